#pragma once
/** @file Dataset.hpp @brief What a cached dataset is: a grid, a format and what makes tiles differ.
 */

#include <tellus/cache/TileGrid.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace tellus {

/**
 * @brief Everything that identifies one set of cached tiles.
 *
 * Two specs with the same server and name but a different grid, format, style or time are different
 * datasets stored side by side: the folder name is the encoded name plus a short hash of those
 * fields (as the thesis adds bbox and tile size to the folder name).
 */
struct DatasetSpec {
  std::string server;    ///< upstream identity, e.g. "local" or "gibs.earthdata.nasa.gov"
  std::string name;      ///< dataset (layer) name, e.g. "bluemarble"
  GridSpec grid;         ///< the lat/long grid
  std::string mimeType;  ///< e.g. "image/jpeg", "application/bil16"
  std::string extension; ///< file suffix without dot, e.g. "jpg", "bil"
  std::string style;     ///< WMS STYLES value ("" = default)
  std::string time;      ///< WMS TIME value ("" = none)
  bool pinned = false;   ///< never evicted by the size limit (shows that must run offline)
  /// the body the grid's latitudes and longitudes lie on (issue 26): "earth", "moon", "mars" or a
  /// configured body's name; its datasets are kept apart from another body's of the same name
  std::string body = "earth";
};

/** The body of every dataset written before bodies existed. */
inline constexpr std::string_view kEarthBody = "earth";

/** Whether `body` names the Earth: such a dataset's hash and descriptor are those of a cache
 * written before bodies existed (the body enters the hash and `dataset.txt` only otherwise). */
bool isEarthBody(std::string_view body);

/** The folder of a dataset below the cache root: "<encoded server>/<encoded name>-<8 hex hash>". */
std::string datasetFolder(const DatasetSpec& spec);

/** The variant hash alone (8 hex digits) of the fields that make tiles differ: the grid, the
 * format, the style, the time and, when it is not the Earth, the body. */
std::string datasetVariant(const DatasetSpec& spec);

/** Serialises a spec as the small `dataset.txt` descriptor kept in each dataset folder (so that an
 * index can be rebuilt from the tree alone), and parses it back. */
std::string serializeDatasetSpec(const DatasetSpec& spec);
std::optional<DatasetSpec> parseDatasetSpec(std::string_view text);

/** Identifier of a registered dataset inside one cache (stable for the cache's life). */
using DatasetId = std::int64_t;

} // namespace tellus
