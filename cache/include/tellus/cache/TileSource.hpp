#pragma once
/**
 * @file TileSource.hpp
 * @brief How the planet renderer gets tiles: request a key with a priority, receive the bytes
 * asynchronously, cancel, observe "absent".
 *
 * Implemented in-process by the proxy's tile service (cache-through with upstream fetches), by an
 * HTTP client of a remote `tellus serve`, and here by CacheTileSource (the cache alone: offline
 * browsing of what is cached).
 */

#include <tellus/cache/Dataset.hpp>
#include <tellus/cache/TileKey.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <numbers>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace tellus {

/** A tile of a layer at a time ("" = the layer's default time). */
struct TileAddress {
  std::string layer;
  std::string time;
  TileKey key;
  friend bool operator==(const TileAddress&, const TileAddress&) = default;
};

enum class TileStatus {
  Ok,     ///< bytes hold the encoded tile
  Absent, ///< there is no tile here (upstream said so, outside coverage, or offline and not cached)
  Failed, ///< an error; message says which. The caller may ask again later
};

struct TileResult {
  TileStatus status = TileStatus::Failed;
  std::vector<std::byte> bytes;
  std::string contentType;
  std::string message;
};

using TileRequestId = std::uint64_t;

/**
 * A polar row fetched whole (issue 29, docs/design/poles.md): a source that can fetch any box
 * (a WMS upstream, a local raster) answers the layer `<layer>@caps` ('@' is never in a layer's
 * name) at key (level, row, 0), row the level's first or last, with ONE image of that whole row:
 * every longitude, the row's latitudes, kWholeRowWidthFactor tiles wide and one tile tall. It is
 * cached as the tile (level, row, 0) of a dataset of its own, `<layer>@caps` on the layer's grid
 * with kWholeRowWidthFactor times its tile width, so it can never be taken for a grid tile.
 */
inline constexpr std::string_view kWholeRowLayerSuffix = "@caps";
inline constexpr std::int32_t kWholeRowWidthFactor = 8;

/**
 * A merged polar row's node fetched whole (issue 29, docs/design/poles.md): where polar rows are
 * given whole, the layer `<layer>@span<k>` (k a power of two, at least 2) at key (level, row,
 * col), col a multiple of k, answers ONE image of the box of the k tiles from col, one tile in
 * size (its texels k times as wide east-west), instead of the k tiles (up to 16 of them) the
 * renderer would shrink into one. Cached as the tile (level, row, col) of a dataset of its own,
 * `<layer>@span<k>` on the layer's grid. wholeSpanLayer() names one; parseWholeSpanLayer() reads
 * one back (only the canonical spelling: no sign, no leading zero).
 */
inline constexpr std::string_view kWholeSpanLayerMark = "@span";
inline constexpr std::int64_t kMaxWholeSpan = std::int64_t{1} << 40;

inline std::string wholeSpanLayer(std::string_view layer, std::int64_t span) {
  return std::string(layer) + std::string(kWholeSpanLayerMark) + std::to_string(span);
}

struct WholeSpanName {
  std::string_view layer;
  std::int64_t span = 0;
};

inline std::optional<WholeSpanName> parseWholeSpanLayer(std::string_view name) {
  const auto at = name.rfind(kWholeSpanLayerMark);
  if (at == std::string_view::npos || at == 0) return std::nullopt;
  const std::string_view digits = name.substr(at + kWholeSpanLayerMark.size());
  if (digits.empty() || digits.size() > 13 || digits.front() == '0') return std::nullopt;
  std::int64_t span = 0;
  for (const char c : digits) {
    if (c < '0' || c > '9') return std::nullopt;
    span = span * 10 + (c - '0');
  }
  if (span < 2 || span > kMaxWholeSpan || (span & (span - 1)) != 0) return std::nullopt;
  return WholeSpanName{name.substr(0, at), span};
}

/**
 * The texels east-west a merged node's image needs (issue 29, docs/design/poles.md): enough that
 * along its equatorward parallel, its widest, a texel is no longer east-west in metres than its
 * rows are tall; at most the tile width (a node widened past that keeps the tile's texels, as the
 * LOD expects). `box` is the node's (k tiles), the image tileWidth x tileHeight in full. A source
 * that makes any box fetches this many and stretches them to tileWidth; the renderer's LOD
 * measures a merged node's texels by it (Quadtree::lodFor), whatever its source.
 */
inline int wholeSpanTexelWidth(const Sector& box, int tileWidth, int tileHeight) {
  const double equatorward = box.south > 0.0 ? box.south : box.north < 0.0 ? -box.north : 0.0;
  const double need = tileHeight * (box.east - box.west) *
                      std::cos(equatorward * std::numbers::pi / 180.0) / (box.north - box.south);
  if (!(need < tileWidth)) return tileWidth;
  return std::clamp(static_cast<int>(std::ceil(need - 1e-9)), 1, tileWidth);
}

/** The layer whose whole row or span `name` is (`<layer>@caps`, `<layer>@span<k>`), else nullopt.
 */
inline std::optional<std::string_view> wholeBoxLayer(std::string_view name) {
  if (name.size() > kWholeRowLayerSuffix.size() && name.ends_with(kWholeRowLayerSuffix))
    return name.substr(0, name.size() - kWholeRowLayerSuffix.size());
  if (const auto span = parseWholeSpanLayer(name)) return span->layer;
  return std::nullopt;
}

/**
 * @brief The asynchronous tile interface. Thread safety: every method may be called from any
 * thread.
 *
 * `done` is called exactly once per request, on a worker thread, unless cancel() returned true. It
 * must not throw and should only hand the result over (e.g. push it into a queue the main thread
 * drains). Destroying a source drops queued requests without calling them and waits for running
 * callbacks.
 */
class ITileSource {
public:
  using Callback = std::function<void(TileResult&&)>;

  virtual ~ITileSource() = default;

  /** The dataset behind a layer (grid, format), or nullopt for an unknown layer. */
  virtual std::optional<DatasetSpec> describe(std::string_view layer,
                                              std::string_view time = {}) const = 0;
  /** Queues a request; higher priority runs first, equal priorities in request order. */
  virtual TileRequestId request(const TileAddress& address, double priority, Callback done) = 0;
  /** Changes the priority of a queued request (no effect once it runs). */
  virtual void reprioritize(TileRequestId id, double priority) = 0;
  /** Removes a queued request; true when its callback will never be called. */
  virtual bool cancel(TileRequestId id) = 0;
  /** Whether `layer + kWholeRowLayerSuffix` gives its polar rows whole, and
   * wholeSpanLayer(layer, k) its merged rows' nodes (see there). Sources that serve only a tile
   * grid say no: the renderer then composes caps and merged nodes from the row's tiles. */
  virtual bool wholePolarRows(std::string_view /*layer*/) const { return false; }
};

} // namespace tellus
