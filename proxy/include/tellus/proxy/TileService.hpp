#pragma once
/**
 * @file TileService.hpp
 * @brief Cache-through tiles: look in the cache, fetch a miss from the layer's upstream once
 * (single-flight), keep only real tiles, remember "absent", revalidate expired tiles and serve them
 * stale when the refresh fails, and answer at once while offline.
 *
 * It is also an ITileSource, so the planet renderer can use it in-process.
 */

#include <tellus/cache/Clock.hpp>
#include <tellus/cache/TileCache.hpp>
#include <tellus/cache/TileGrid.hpp>
#include <tellus/cache/TileLeases.hpp>
#include <tellus/cache/TileSource.hpp>
#include <tellus/proxy/FetchBudget.hpp>
#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/Metrics.hpp>
#include <tellus/proxy/ValueLayer.hpp>
#include <tellus/proxy/WmtsUpstream.hpp>

#include <chrono>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace tellus {

/** An upstream as the proxy uses it (the composition root maps the configuration onto this). */
struct UpstreamSpec {
  enum class Type { Local, Wms, WorldWind, Wmts };
  std::string name;
  Type type = Type::Local;
  std::filesystem::path path; ///< Local: a georeferenced image
  std::string url; ///< Wms / WorldWind: base URL (may hold a query); Wmts: its capabilities
  std::string wmsVersion = "1.3.0";
  std::string crs = "EPSG:4326"; ///< EPSG:4326 or CRS:84
  /// Wms: seeding asks for up to metaTiles x metaTiles tiles of a level with one GetMap (getTiles);
  /// 1 = one GetMap per tile. The configuration's default is 4 (docs/CONFIG.md).
  int metaTiles = 1;
  UpstreamPolicy policy;
  WmtsEncoding wmtsEncoding = WmtsEncoding::Auto; ///< Wmts: how tiles are asked for
};

/** A layer as the proxy serves it. */
struct LayerSpec {
  std::string name;
  std::string title;
  std::string abstract;
  DatasetSpec dataset; ///< server = upstream name, name = layer name, time = "" (per request)
  std::string upstream;
  std::string upstreamLayer; ///< WMS LAYERS / World Wind T= / WMTS LAYER (default: name)
  std::int32_t firstLevel = 0;
  bool elevation = false;
  std::int16_t noData = -32768;
  std::chrono::milliseconds ttl{0}; ///< 0: tiles never expire
  std::chrono::seconds maxAge{86400};
  double opacity = 1.0;                ///< when composed with other layers in one GetMap (0..1)
  std::vector<std::string> timeValues; ///< empty: no TIME dimension (or a period, see timePeriod)
  std::string timePeriod;
  std::string timeDefault;
  /** Value and elevation layers: samples, colour-map styles, queryable (ValueLayer.hpp). */
  std::optional<ValueLayerSpec> values;
  std::string tileMatrixSet; ///< Wmts: the upstream's set ("" = the layer's only one)
  /// Wmts: the upstream layer bound to this layer's grid (TileService::create fills it in)
  std::shared_ptr<const WmtsTiles> wmts;
};

/** Whether two layers serve the same upstream data (upstream, upstream layer, style, body, kind,
 * times) on two grids: a map of one may be made of the other's tiles (issue 29: coarser rows from
 * an overview, a GetMap that is exactly one of the other's tiles). Value layers never are. */
inline bool sameUpstreamData(const LayerSpec& a, const LayerSpec& b) noexcept {
  return a.name != b.name && a.upstream == b.upstream && a.upstreamLayer == b.upstreamLayer &&
         a.dataset.style == b.dataset.style && a.dataset.body == b.dataset.body &&
         a.elevation == b.elevation && !a.values && !b.values && a.timeValues == b.timeValues &&
         a.timePeriod == b.timePeriod;
}

/** Where an answer came from (the X-Cache header). */
enum class TileOrigin { Hit, Miss, Stale, Offline };

struct TileAnswer {
  /// Absent is only ever "there is no such tile": the upstream said so (404 or 204), the key lies
  /// outside the layer's grid, or the proxy runs offline (`--offline`). A failure to get a tile,
  /// however temporary, is an Error.
  enum class Kind { Tile, Absent, Error };
  /// Why an Error (what the front end answers): Bad, the upstream's answer is not a tile or a tile
  /// could not be made (502); Unavailable, the upstream could not be reached, reset or closed the
  /// connection, timed out, failed with 5xx or asked for a pause, or its circuit breaker is open
  /// (503); OverBudget, the client's budget of upstream fetches is spent and no upstream was asked
  /// (429).
  enum class Failure : std::uint8_t { Bad, Unavailable, OverBudget };
  Kind kind = Kind::Error;
  Failure failure = Failure::Bad;
  std::int64_t retryAfterSeconds = 0; ///< Unavailable, OverBudget: when to try again (>= 1)
  TileOrigin origin = TileOrigin::Miss;
  std::vector<std::byte> bytes;         ///< Tile: the bytes, unless `file` holds them
  std::shared_ptr<const TileFile> file; ///< Tile from the cache: its open file (bytes empty)
  std::string contentType;
  UnixMillis fetchedAt = 0; ///< Last-Modified
  std::string etag;         ///< strong validator of these bytes, quoted
  std::string message;      ///< Absent/Error: why (safe to show a client)
  /// Tile fetched or rendered now that the cache did not keep (why: DiskFull for lack of space).
  std::optional<CacheError> notStored;
  /// The answer of a fetch another request started: this request joined it in flight (its
  /// upstream cost is the first request's; composed maps count it apart, issue 29).
  bool joinedInFlight = false;
};

struct TileServiceOptions {
  bool offline = false;                           ///< never contact upstreams
  std::chrono::milliseconds absentRetry{3600000}; ///< how long "no tile here" is believed
  int renderThreads = 2;                          ///< workers for local rasters
  /** Added to the workers' nice value (the planet renderer's commands: tiles made in the
   * background give the CPU up to the frame being drawn). */
  int workerNice = 0;
  /// Wall time of fetched tiles (fetched-at, so expiry) and of absent markers' retry times; null:
  /// the system's (tests inject a ManualClock, which outlives the service).
  const Clock* clock = nullptr;
  /// Where WMTS upstreams' capabilities are kept (wmtsCapabilitiesFile); empty: the cache's root.
  std::filesystem::path wmtsCapabilitiesRoot;
  /// Single flight across processes sharing one index (issue 27, TileLeases.hpp): a miss of a
  /// remote upstream takes the tile's lease before it is fetched, or waits for another process's
  /// fetch and reads the tile it stored. Null: this process alone (its own flights only).
  std::shared_ptr<ITileLeases> leases;
  /// How long a waiter waits for a release before it tries the lease again (a holder that died
  /// releases nothing; its lease is free as soon as its connection is gone).
  std::chrono::milliseconds leaseRecheck{1000};
  /// A plain miss (nothing cached) of a layer whose WMS upstream has metaTiles > 1 fetches the
  /// tile's whole metatile with one GetMap and stores its missing tiles, under the metatile's lease
  /// when `leases` is set: what `serve` does on a shared index (issue 27), so that instances
  /// missing different tiles of one metatile cause one upstream request. False: one GetMap per
  /// missed tile (the embedded default; an expired tile is always refreshed alone).
  bool metaTilesOnMiss = false;
  /// The bounded local tier's figures for /metrics (issue 27, `cache.s3.local_tier_limit`); empty:
  /// none.
  std::function<LocalTierMetrics()> localTier;
  /// Tiles fetched that the cache could not store (a full disk, a shared store that cannot be
  /// reached) are kept in memory up to this many bytes, least recently used out: the next request
  /// for one is answered from there instead of the upstream, and it is stored from there once the
  /// cache takes tiles again. 0: none kept (each request fetches again).
  std::size_t keepUnstoredBytes = 64u << 20;
};

class TileService final : public ITileSource {
public:
  /** Registers every layer's dataset (time "") and opens local rasters; reads each WMTS upstream's
   * capabilities (fetched, or the saved copy when offline or unreachable: loadWmtsCapabilities;
   * blocks meanwhile) and binds its layers (bindWmtsLayer); fails with a message naming the layer
   * or upstream. The cache and fetcher must outlive the service. */
  static std::expected<std::unique_ptr<TileService>, std::string>
  create(TileCache& cache,
         Fetcher& fetcher,
         std::vector<UpstreamSpec> upstreams,
         std::vector<LayerSpec> layers,
         TileServiceOptions options);
  ~TileService() override;

  const std::vector<LayerSpec>& layers() const noexcept;
  const LayerSpec* layer(std::string_view name) const noexcept;
  /** The layer whose whole polar rows or spans `name` is (`<layer>@caps`, `<layer>@span<k>`,
   * wholePolarRows), or null: what `/tiles/` serves them as (issue 29). */
  const LayerSpec* wholeBoxBase(std::string_view name) const noexcept;
  /** When the layer's dataset (as now defined) was first registered in the cache: stable across
   * restarts, new when the definition changes (the capabilities' LastUpdate). 0 if unknown. */
  UnixMillis layerSince(std::string_view layer) const noexcept;
  /** The grid of a layer (nullptr for an unknown layer). */
  const TileGrid* grid(std::string_view layer) const noexcept;

  /** The cache the layers' tiles are kept in (WMTS keeps its composed tile matrix sets there,
   * each a dataset of its own). */
  TileCache& cache() const noexcept;

  /** One tile; `done` runs exactly once, possibly on another thread, possibly before return.
   * `time` must already be validated ("" = no time). When the request would start a fetch from a
   * remote upstream (a miss or an expired tile that no flight is fetching yet), `gate`'s budget is
   * asked first: a refusal answers an expired tile stale, anything else an Error with
   * Failure::OverBudget. */
  void getTile(std::string_view layer,
               std::string_view time,
               const TileKey& key,
               std::function<void(TileAnswer&&)> done,
               FetchGate gate = {});

  /**
   * Several tiles (normally of one metatile: one level, close together), each answered
   * through `done(key, answer)` exactly once, possibly on another thread, possibly before return.
   * Tiles that are cached (fresh) or known absent are answered from the cache; tiles already in
   * flight (a `getTile` or another `getTiles`) wait for that flight; the rest are fetched with ONE
   * GetMap of their bounding block when the layer's upstream is WMS with metaTiles > 1 and the
   * format is JPEG or PNG imagery (else, and for keys of several levels or a block over 8192
   * pixels, one request per tile, as getTile). The answer is
   * validated once, whole, and split (a JPEG in the DCT domain when its iMCUs allow); a failing
   * or invalid answer stores nothing and fails every tile it was fetched for. While it is in
   * flight, getTile for any of its tiles joins it instead of fetching.
   */
  void getTiles(std::string_view layer,
                std::string_view time,
                std::span<const TileKey> keys,
                std::function<void(const TileKey&, TileAnswer&&)> done);

  /** A tile from the cache alone (fresh or expired), never fetched: what fills in a composed
   * map where a finer tile is missing. std::nullopt when it is not cached. */
  std::optional<TileAnswer>
  cachedTile(std::string_view layer, std::string_view time, const TileKey& key);

  void setOffline(bool offline) noexcept;
  /** Explicitly offline, or every remote upstream's breaker open. */
  bool offline() const noexcept;

  /** The remote upstreams' fetch statistics, for /metrics. */
  std::vector<UpstreamMetrics> upstreamMetrics() const;
  /** Bytes of all cached tiles (the index's counters, no scan); nullopt if the index fails. */
  std::optional<std::int64_t> cachedBytes() const;

  /** Upstream requests started for tiles (not counting revalidations), for tests and metrics. */
  std::uint64_t upstreamFetches() const noexcept;
  /** Whether the cache stores tiles, how many fetched tiles it refused for lack of space (served
   * all the same) and the free space under its root, for /metrics. */
  CacheHealthMetrics cacheHealth() const;

  // ITileSource
  std::optional<DatasetSpec> describe(std::string_view layer,
                                      std::string_view time = {}) const override;
  TileRequestId request(const TileAddress& address, double priority, Callback done) override;
  void reprioritize(TileRequestId id, double priority) override;
  bool cancel(TileRequestId id) override;
  /** True for an imagery layer (JPEG or PNG) of a WMS or local upstream whose grid spans every
   * longitude and reaches a pole: `<layer>@caps` is then ONE image of the polar row's box at
   * kWholeRowWidthFactor x 1 tiles (a render of it; from a WMS, GetMaps of its bands stretched
   * and stacked: proxy/src/tiles/CapBands.hpp), and `<layer>@span<k>` ONE of the box of k tiles
   * at one tile's size (from a WMS, one GetMap at wholeSpanTexelWidth, stretched; TileSource.hpp).
   */
  bool wholePolarRows(std::string_view layer) const override;

  /** The WMS, World Wind or WMTS URL that fetches a tile from a remote upstream (for tests and
   * logs); "" for a WMTS tile outside the upstream's matrix (there is no such tile). */
  static std::string upstreamUrl(const UpstreamSpec& upstream,
                                 const LayerSpec& layer,
                                 const Sector& sector,
                                 const TileKey& key,
                                 std::string_view time);
  /** A WMS GetMap of `sector` at width x height pixels (a metatile; upstreamUrl for one tile). */
  static std::string wmsUrl(const UpstreamSpec& upstream,
                            const LayerSpec& layer,
                            const Sector& sector,
                            std::int32_t width,
                            std::int32_t height,
                            std::string_view time);

  /** n when getTiles fetches this layer's tiles in blocks of up to n x n (its upstream is WMS
   * with metaTiles = n > 1, imagery in JPEG or PNG), else 1. */
  std::int32_t metaTileSize(std::string_view layer) const noexcept;
  /** Upstream requests that fetched a metatile (a block of more than one tile), for tests. */
  std::uint64_t metaTileFetches() const noexcept;

  struct Impl;

private:
  explicit TileService(std::shared_ptr<Impl> impl);
  std::shared_ptr<Impl> impl_; // shared: fetch callbacks hold it weakly
};

const char* toString(TileOrigin origin) noexcept;

} // namespace tellus
