#pragma once
/**
 * @file Config.hpp
 * @brief The typed configuration of tellus: the cache, and the layers with their grids and sources.
 *
 * The embedded default serves the bundled public-domain data (data/): Blue Marble imagery and ETOPO
 * 20' heights. Reading YAML files into this structure comes with `tellus serve` (issue #3).
 */

#include <tellus/cache/Dataset.hpp>

#include <cstdint>
#include <expected>
#include <filesystem>
#include <string>
#include <vector>

namespace tellus {

struct CacheSettings {
  std::filesystem::path root;       ///< cache root (index.sqlite + the tile tree)
  std::uint64_t sizeLimitBytes = 0; ///< 0 = unlimited
};

/** A layer whose upstream is a georeferenced file read with OpenImageIO. */
struct LocalRasterUpstream {
  std::filesystem::path path;
};

enum class LayerKind { Imagery, Elevation };

struct LayerConfig {
  std::string name; ///< WMS layer / World Wind dataset name
  std::string title;
  LayerKind kind = LayerKind::Imagery;
  DatasetSpec dataset; ///< server, grid, format; dataset.name == name
  LocalRasterUpstream upstream;
};

struct Config {
  CacheSettings cache;
  std::vector<LayerConfig> layers;

  /** The layer with this name, or nullptr. */
  const LayerConfig* layer(std::string_view name) const noexcept;
};

/** The embedded default over the bundled data in dataDir, with the cache at cacheRoot. */
Config embeddedDefault(const std::filesystem::path& dataDir,
                       const std::filesystem::path& cacheRoot);

/** Checks a configuration: unique layer names, valid grids, known formats, existing upstream
 * files. The message names the layer and the field. */
std::expected<void, std::string> validate(const Config& config);

/** The default cache root: $TELLUS_CACHE, else $XDG_CACHE_HOME/tellus, else ~/.cache/tellus. */
std::filesystem::path defaultCacheRoot();

} // namespace tellus
