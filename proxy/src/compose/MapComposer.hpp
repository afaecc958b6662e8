#pragma once
// GetMap for any box: fetches the tiles a map needs through the tile service (cache first,
// single-flight, upstream on a miss), then decodes, samples (Compose.hpp) and encodes the map on
// its own worker threads, so the HTTP loops never decode or encode.

#include <tellus/cache/TileGrid.hpp>
#include <tellus/proxy/TileService.hpp>
#include <tellus/proxy/Wms.hpp>

#include <cstddef>
#include <cstdint>
#include <expected>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace tellus {

struct ComposeLayer {
  const LayerSpec* layer = nullptr;
  std::string time; ///< validated ("" = none)
  double opacity = 1.0;
  /** A value layer drawn coloured (its WMS style): values decoded, sampled and coloured by the
   * layer's scale (ValueLayer.hpp); nullptr = drawn as before (imagery, heights). */
  const values::ColourMap* colourMap = nullptr;
};

struct ComposeRequest {
  /** Drawn in order, imagery and elevation layers alike: into a picture, heights as grey
   * (drawHeightsAsGrey); into heights, imagery as its luminance (drawLuminanceAsHeights). */
  std::vector<ComposeLayer> layers;
  /** lon/lat, west < east, south < north; rows evenly in latitude, or in Web Mercator y
   * (mercatorBox): each layer composed in bands of rows (composeBands). */
  MapBox bbox{};
  std::int32_t width = 0;
  std::int32_t height = 0;
  MapFormat format = MapFormat::Png;
  /** The map is heights (mapIsHeights): BIL16, Int16 TIFF or 16-bit PNG, else a picture. */
  bool heights = false;
  std::int16_t noData = -32768; ///< of a heights map: where no layer has data
  /** The map is values (application/bil32): every layer a value layer, its values sampled as
   * composeValues does (later layers win where they have data), `valueNoData` where none has. */
  bool values = false;
  float valueNoData = kNoValue;
  bool transparent = false;
  std::optional<std::uint32_t> bgcolor;
  std::string ifNoneMatch; ///< the client's If-None-Match ("" = none)
  /// Asked before a tile of this map starts an upstream fetch (TileService::getTile); the client
  /// it is charged to.
  FetchBudget* fetchBudget = nullptr;
  std::string client;
};

struct ComposedMap {
  enum class Kind { Map, NotModified, Error } kind = Kind::Error;
  std::vector<std::byte> bytes;
  std::string contentType;
  TileOrigin origin = TileOrigin::Hit; ///< the least fresh of the tiles used
  std::string etag;                    ///< quoted; from the tiles' validators and the request
  std::int64_t maxAgeSeconds = 0;
  std::string message; ///< Error: why (safe to show)
  /// Error: of a tile that failed (TileAnswer::Failure; Unavailable wins over OverBudget, which
  /// wins over Bad) and the longest Retry-After of those tiles.
  TileAnswer::Failure failure = TileAnswer::Failure::Bad;
  std::int64_t retryAfterSeconds = 0;
  std::size_t tiles = 0;        ///< tiles sampled (all layers, fallbacks included)
  std::size_t decodedTiles = 0; ///< of those, decoded for this map (the rest came decoded)
  std::size_t fallbackPixels = 0;
  /// Texels of the tiles asked for the map (all layers): fetched from the upstream for it
  /// (TileOrigin::Miss), found in the cache, or fetched for another answer whose fetch this map
  /// joined in flight (issue 29: its upstream cost against its pixels, each fetch counted once).
  std::uint64_t upstreamTexels = 0;
  std::uint64_t cachedTexels = 0;
  std::uint64_t joinedTexels = 0;
  std::uint64_t outputTexels = 0; ///< width x height of a Map, else 0
};

class DecodedTileCache; // MapJob.hpp

class MapComposer {
public:
  /** `decodedCacheBytes`: decoded tiles kept between maps, a tile admitted when it is used often
   * enough (AdmittingLru; 0: none, and only the part of each JPEG tile a map samples is decoded).
   * `jpegQuality`: of JPEG maps (the encoders clamp it to 1-100). */
  MapComposer(TileService& tiles,
              int threads,
              std::size_t maxTiles,
              std::size_t decodedCacheBytes,
              int jpegQuality = 90);
  ~MapComposer();

  /** The tiles of every layer, or an error (for InvalidParameterValue) when they are more than
   * the limit. Then `onTile` sees each tile answer (for metrics) and `done` the map, once, on a
   * worker thread or the caller's. */
  std::expected<void, std::string>
  compose(ComposeRequest request,
          std::function<void(const LayerSpec&, const TileAnswer&)> onTile,
          std::function<void(ComposedMap&&)> done);

  /** Bytes of decoded tiles kept between maps now. */
  std::size_t decodedCacheBytes() const;

  struct Job;

private:
  void finish(const std::shared_ptr<Job>& job);

  TileService& tiles_;
  std::size_t maxTiles_;
  int jpegQuality_;
  bool yccDisabled_ = false; ///< TELLUS_COMPOSE_YCC=0: JPEG maps on the RGB path (for comparisons)
  std::unique_ptr<DecodedTileCache> decodedCache_;
  struct Pool;
  /** Where the last tile answer of a map posts its job; null once the composer is going away. */
  struct Gate {
    std::mutex mutex;
    class WorkerPool* pool = nullptr;
  };
  std::shared_ptr<Gate> gate_;
  std::unique_ptr<Pool> pool_; // last: destroyed first
};

} // namespace tellus
