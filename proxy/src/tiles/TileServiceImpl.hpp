#pragma once
// TileService's state and steps, shared by the files of proxy/src/tiles/ that implement them:
// TileService.cpp (construction, accessors, the ITileSource queue), TileFlights.cpp (the
// cache-through lookup, single flight, answers, stores), TileFetch.cpp (fetching, rendering and
// revalidating one tile), TileWmtsCompose.cpp (WMTS tiles composed of several upstream tiles),
// TileMetaFetch.cpp (metatiles: getTiles) and UpstreamUrls.cpp (the upstream request URLs).

#include "tiles/CapBands.hpp"
#include "tiles/MetaTile.hpp"
#include "tiles/UnstoredTiles.hpp"
#include "tiles/WorkerPool.hpp"
#include "upstream/WmtsCompose.hpp"

#include <tellus/cache/RequestQueue.hpp>
#include <tellus/cache/TileLeases.hpp>
#include <tellus/cache/TilePath.hpp>
#include <tellus/proxy/LocalRasterSource.hpp>
#include <tellus/proxy/TileService.hpp>

#include <atomic>
#include <functional>
#include <map>
#include <mutex>
#include <unordered_map>

namespace tellus {

struct TileService::Impl : std::enable_shared_from_this<TileService::Impl> {
  struct FlightKey {
    DatasetId dataset;
    TileKey key;
    bool operator==(const FlightKey&) const = default;
  };
  struct FlightKeyHash {
    std::size_t operator()(const FlightKey& f) const noexcept {
      return TileKeyHash{}(f.key) ^ static_cast<std::size_t>(f.dataset) * 0x9E3779B97F4A7C15u;
    }
  };
  using Done = std::function<void(TileAnswer&&)>;
  /** A lease taken here, given back when the last flight holding it lands (a metatile's lease is
   * held by the flights of every tile fetched with it). */
  struct LeaseHold {
    std::shared_ptr<ITileLeases> leases;
    LeaseKey key;
    std::atomic<bool> announced{false}; ///< a tile landed under it was announced (progress)
    LeaseHold(std::shared_ptr<ITileLeases> l, LeaseKey k)
        : leases(std::move(l)), key(std::move(k)) {}
    LeaseHold(const LeaseHold&) = delete;
    LeaseHold& operator=(const LeaseHold&) = delete;
    ~LeaseHold() { leases->release(key); }
  };

  TileCache& cache;
  Fetcher& fetcher;
  TileServiceOptions options;
  std::vector<LayerSpec> layers;
  std::map<std::string, std::size_t, std::less<>> layerIndex;
  std::vector<UnixMillis> layerSince; // per layer: its dataset's registration time
  std::vector<std::pair<DatasetId, std::string>> defaultDatasets; // per layer: time "" (id, folder)
  std::vector<TileGrid> grids;                                    // parallel to layers
  // Whole polar rows (TileSource.hpp, kWholeRowLayerSuffix): `<layer>@caps` of each layer that
  // has them, on its grid kWholeRowWidthFactor tiles wide; not in `layers` (no client sees them),
  // their datasets registered on first use.
  std::vector<LayerSpec> capLayers;
  std::vector<TileGrid> capGrids; // parallel to capLayers
  std::map<std::string, std::size_t, std::less<>> capIndex;
  std::map<std::string, UpstreamSpec, std::less<>> upstreams;
  std::map<std::string, LocalRasterSource, std::less<>> rasters; // by upstream name
  std::atomic<bool> forcedOffline{false};
  std::atomic<std::uint64_t> fetches{0};
  std::atomic<std::uint64_t> metaFetches{0};
  // Fetched tiles served but not kept for lack of space, and whether the log last said "storing".
  std::atomic<std::uint64_t> refusedStores{0};
  std::atomic<bool> storingLogged{true};
  // What could not be stored (full disk, store unreachable), kept in memory (options.keepUnstored).
  UnstoredTiles unstored;
  static constexpr UnixMillis kStoreKeptEveryMs = 1000; // a kept tile's next try to be stored

  // (layer, time) -> dataset id, registered on first use.
  std::mutex datasetsMutex;
  std::map<std::pair<std::string, std::string>, std::pair<DatasetId, std::string>> datasets;

  std::mutex flightsMutex;
  std::unordered_map<FlightKey, std::vector<Done>, FlightKeyHash> flights;
  // flights.size(), read without the lock: a hit skips the lock while nothing is in flight.
  std::atomic<std::size_t> openFlights{0};
  // Leases held by flights of this process (options.leases), given back when the last flight
  // holding one lands.
  std::unordered_map<FlightKey, std::shared_ptr<LeaseHold>, FlightKeyHash> heldLeases;
  std::atomic<std::uint64_t> leaseWaits{0}; // misses that waited for another process's fetch
  // A shared index (options.leases) that failed its last lookup: answers come from the store.
  std::atomic<bool> indexDown{false};
  std::atomic<std::uint64_t> servedWithoutIndex{0};

  // ITileSource: a bounded number of tiles in flight, the rest queued by priority.
  struct Queued {
    TileAddress address;
    Callback done;
  };
  std::mutex queueMutex;
  RequestQueue<Queued> queue;
  int inFlight = 0;
  static constexpr int kMaxInFlight = 32;

  std::unique_ptr<WorkerPool> workers; // last member: destroyed first, while the rest still lives

  Impl(TileCache& c, Fetcher& f, TileServiceOptions o)
      : cache(c), fetcher(f), options(o), unstored(o.keepUnstoredBytes, kStoreKeptEveryMs) {}

  /** A stand-in id for a dataset the cache could not register (a full disk): negative, never a
   * real id, and one per folder so that flights of different datasets stay apart. Its tiles are
   * fetched and served, never looked up or stored. */
  static DatasetId unregisteredId(const std::string& folder) {
    return -1 - static_cast<DatasetId>(stableHash64(folder) >> 2);
  }

  /** Answers from a tile kept unstored (UnstoredTiles), and tries to store it when due. */
  void serveKept(DatasetId id,
                 const std::string& folder,
                 const TileKey& key,
                 UnstoredTiles::Kept& kept,
                 const Done& done);
  std::expected<std::pair<DatasetId, std::string>, std::string> dataset(const LayerSpec& l,
                                                                        std::string_view time);

  /** Logs the cache's change between storing and refusing (a full disk), once per change: the
   * state is the cache's, looked at after each store. */
  void noticeStoreState(const CacheError* refusal);

  bool remoteReachable(const UpstreamSpec& u) const {
    return u.type == UpstreamSpec::Type::Local || fetcher.reachable(u.name);
  }

  /** The `<layer>@caps` of a layer that has whole polar rows (wholeRowLayer), if it may. */
  static std::optional<LayerSpec> wholeRowLayer(const LayerSpec& l, const UpstreamSpec& u);
  static bool isWholeRow(const LayerSpec& l) noexcept {
    return l.name.ends_with(kWholeRowLayerSuffix);
  }
  /** A whole span's k (`<layer>@span<k>`), 0 for any other layer. */
  static std::int64_t wholeSpanOf(const LayerSpec& l) noexcept {
    const auto s = parseWholeSpanLayer(l.name);
    return s ? s->span : 0;
  }
  /** Whether a layer is made of boxes no grid tile is: whole rows and spans (no metatiles). */
  static bool isWholeBox(const LayerSpec& l) noexcept {
    return isWholeRow(l) || wholeSpanOf(l) > 0;
  }
  /** The box a tile's request asks for: a whole polar row's is every longitude of its row, a
   * whole span's the k tiles from its key. */
  static Sector requestSector(const LayerSpec& l, const TileGrid& g, const TileKey& k) {
    Sector s = g.sectorOf(k);
    if (isWholeRow(l)) {
      s.west = -180.0;
      s.east = 180.0;
    } else if (const std::int64_t span = wholeSpanOf(l); span > 0) {
      s.east = g.sectorOf({k.level, k.row, k.col + span - 1}).east;
    }
    return s;
  }
  /** Whether a key of a whole-row layer is its level's first or last row, at column 0, and on
   * the pole. */
  static bool isPolarRowKey(const TileGrid& g, const TileKey& k) noexcept;
  /** Whether a key of a whole-span layer starts an aligned run of k tiles of the grid. */
  static bool isSpanKey(const TileGrid& g, const TileKey& k, std::int64_t span) noexcept;

  /** Joins a flight; true when the caller is the first and must start the work. */
  bool join(const FlightKey& k, Done done);
  /** Joins the flight of `k` if one is under way (taking `done`); false, with `done` kept, if
   * none is. */
  bool joinUnderWay(const FlightKey& k, Done& done);

  struct Joined {
    bool first = false;                               ///< the caller starts the work
    std::optional<std::chrono::milliseconds> refused; ///< the gate's budget said no (done kept)
  };
  /** join() for a client's request: joining a flight under way costs nothing; starting one asks
   * the gate's budget first (under the flights' lock, so that the check and the start are one
   * step). `done` is taken unless refused. */
  Joined joinGated(const FlightKey& k, Done& done, FetchGate gate);

  /** For the owner of a new flight: the cache lookup before the join and the join are two steps,
   * and a flight that landed between them has stored the tile; fetching it again would be a
   * second upstream request for one tile. Lands the flight with the cached tile when it is
   * there and fresh now. */
  bool landIfCachedNow(const FlightKey& fk, const std::string& folder);
  /** landIfCachedNow() for tiles of one dataset, with one index round trip for those not stored
   * (TileCache::openTiles): removes those landed from `keys`. */
  void landCachedNow(std::vector<TileKey>& keys, DatasetId id, const std::string& folder);

  /** Drops the lease shares of these flights (given back if no other flight holds them), so that
   * the processes waiting for them wake before this one answers its own clients. */
  void releaseLeasesOf(std::span<const FlightKey> fks);
  /** Answers a flight's waiters; gives its lease back (after the tile was stored: the waiters of
   * other processes find it). */
  void land(const FlightKey& k, TileAnswer&& answer);

  /** A lookup in a shared index that failed: the store's tile, or 503 (read-only meanwhile). */
  void serveWithoutIndex(DatasetId id, const std::string& folder, const TileKey& key, Done done);

  /** Takes options.leases' lease, or waits for it: nullopt while another process holds it (then
   * `again` runs on a worker once the holder lets go, to look at the cache and try again); else
   * the hold, or null when the lease service is down (each instance fetches alone). */
  std::optional<std::shared_ptr<LeaseHold>> takeLease(const LeaseKey& lease,
                                                      std::function<void(Impl&)> again);

  /** A remote miss under options.leases: fetches when the lease is taken (or the lease service is
   * down), or waits for the holder's release and then looks at the cache again. */
  void fetchUnderLease(const FlightKey& fk,
                       const LayerSpec& l,
                       const UpstreamSpec& u,
                       const TileGrid& g,
                       const std::string& folder,
                       const std::string& time,
                       std::optional<CacheLookup> stale);

  /** A plain miss of a metatile-capable layer with options.metaTilesOnMiss: the tile's whole
   * metatile is fetched with one GetMap under the metatile's lease (with options.leases), so that
   * instances missing different tiles of it cause one upstream request. `fk`'s flight is ours;
   * every missing tile of the metatile is fetched (one without a flight gets one with no waiter).
   */
  void missUnderMetaLease(const FlightKey& fk,
                          const LayerSpec& l,
                          const UpstreamSpec& u,
                          const TileGrid& g,
                          const std::string& folder,
                          const std::string& time);

  /** fetchBlock under the lease of the metatile holding owned's first tile (options.leases):
   * fetched when the lease is taken (or the lease service is down), the lease held until every
   * owned tile has landed; or, while another process holds it, waited for, then the cache looked
   * at again and what is still missing fetched under the lease. Without leases: fetchBlock. */
  void fetchBlockUnderLease(std::vector<TileKey> owned,
                            const LayerSpec& l,
                            const UpstreamSpec& u,
                            const TileGrid& g,
                            DatasetId id,
                            const std::string& folder,
                            const std::string& time);

  static TileAnswer absent(TileOrigin origin, std::string message) {
    TileAnswer a;
    a.kind = TileAnswer::Kind::Absent;
    a.origin = origin;
    a.message = std::move(message);
    return a;
  }
  static TileAnswer error(std::string message) {
    TileAnswer a;
    a.kind = TileAnswer::Kind::Error;
    a.message = std::move(message);
    return a;
  }

  /// The least Retry-After of a temporary failure: the fetch has been retried already.
  static constexpr std::int64_t kMinRetryAfterSeconds = 5;

  /** A temporary failure of this upstream: try again once its breaker or pause would let a fetch
   * through, and not before kMinRetryAfterSeconds. */
  TileAnswer unavailable(const std::string& upstream, std::string message) const;

  static TileAnswer overBudget(std::chrono::milliseconds wait) {
    TileAnswer a = error("too many upstream fetches from this client; try again later");
    a.failure = TileAnswer::Failure::OverBudget;
    a.retryAfterSeconds =
        std::max<std::int64_t>(1, std::chrono::ceil<std::chrono::seconds>(wait).count());
    return a;
  }

  /** What a failed fetch is to a client: temporary (the upstream could not be reached, reset or
   * closed the connection, timed out, failed with 5xx or asked for a pause) or not (its answer
   * was too large, a redirect was refused, the URL is bad). Never "absent". */
  TileAnswer fetchFailure(const std::string& upstream, const FetchError& e) const;

  /** The upstream says there is no tile there: 404, or 204 No Content. */
  static bool noSuchTile(int status) noexcept { return status == 404 || status == 204; }
  static TileAnswer tile(TileOrigin origin,
                         std::vector<std::byte> bytes,
                         std::string contentType,
                         UnixMillis fetchedAt,
                         const std::string& folder,
                         const TileKey& key,
                         std::shared_ptr<const TileFile> file = nullptr);

  /** The answer for an expired tile served because no fresh one could be had. */
  static TileAnswer staleTile(CacheLookup&& old, const std::string& folder, const TileKey& key);

  /** Stores a good tile and lands the flight (worker thread). A tile the cache does not keep is
   * still served: a full disk never fails a client (the answer says it was not stored). */
  void store(const FlightKey& fk,
             const std::string& folder,
             std::vector<std::byte> bytes,
             TileMeta meta);
  /** The cache's put of store(), without landing: why the tile was not stored, if it was not. */
  std::optional<CacheError>
  put(const FlightKey& fk, std::span<const std::byte> bytes, const TileMeta& meta);
  /** store() for tiles of one dataset fetched together (a metatile's), all or none: their files
   * flushed together and their rows in one transaction (TileCache::putMany); their lease given
   * back (if no other flight holds it), then each flight landed. */
  void storeMany(const std::vector<FlightKey>& fks,
                 const std::string& folder,
                 std::vector<std::vector<std::byte>> bytes,
                 const TileMeta& meta);
  /** After store()'s put: kept in memory when not stored, and the flight landed. */
  void landStored(const FlightKey& fk,
                  const std::string& folder,
                  std::vector<std::byte> bytes,
                  TileMeta meta,
                  std::optional<CacheError> notStored);

  /** Wall time in Unix milliseconds, by the injected clock (TileServiceOptions::clock). */
  UnixMillis nowMillis() const { return (options.clock ? *options.clock : Clock::system()).now(); }

  TileMeta freshMeta(const LayerSpec& l) const {
    TileMeta m;
    m.contentType = l.dataset.mimeType;
    m.fetchedAt = nowMillis();
    if (l.ttl.count() > 0) m.expiresAt = m.fetchedAt + l.ttl.count();
    return m;
  }

  void renderLocal(const FlightKey& fk,
                   const LayerSpec& l,
                   const TileGrid& g,
                   const std::string& folder,
                   std::optional<CacheLookup> stale);

  void fetchRemote(const FlightKey& fk,
                   const LayerSpec& l,
                   const UpstreamSpec& u,
                   const TileGrid& g,
                   const std::string& folder,
                   std::string time,
                   std::optional<CacheLookup> stale);

  /** The answers gathered for one composed WMTS tile. */
  struct WmtsGather {
    std::mutex mutex;
    std::vector<WmtsFetchedTile> tiles;
    std::optional<FetchResult> failure; ///< the first answer that is neither a tile nor a 404
    std::size_t left = 0;
    std::optional<CacheLookup> stale;
  };

  /** A WMTS tile of a level no matrix lines up with (WmtsCompose.hpp): the upstream tiles that
   * cover it are fetched, then composed on a worker and handed to onFetched as the upstream's
   * answer (validated and stored as any fetched tile). */
  void composeRemote(const FlightKey& fk,
                     const LayerSpec& l,
                     const UpstreamSpec& u,
                     const TileGrid& g,
                     const std::string& folder,
                     const std::string& time,
                     std::optional<CacheLookup> stale);

  /** The answers gathered for a cap fetched in bands, or a merged node at its own width. */
  struct BandGather {
    std::mutex mutex;
    std::vector<CapBand> bands;
    std::vector<std::optional<FetchResult>> answers;
    std::size_t left = 0;
    std::optional<CacheLookup> stale;
  };

  /** A WMS's whole polar row in bands, or a merged node's box at the texels east-west it needs
   * (CapBands.hpp): the bands fetched at once, then checked, stretched to the image's width
   * (wrapping around a cap's parallels) and stacked on a worker (onBandsFetched), and stored as
   * the tile; the first band that is not an image of its size answers for the tile
   * (onFetched: a stale tile, an absence or an error), and nothing is stored. */
  void fetchBands(const FlightKey& fk,
                  const LayerSpec& l,
                  const UpstreamSpec& u,
                  const TileGrid& g,
                  const std::string& folder,
                  const std::string& time,
                  std::optional<CacheLookup> stale,
                  std::vector<CapBand> bands);

  void onBandsFetched(const FlightKey& fk,
                      const LayerSpec& l,
                      const TileGrid& g,
                      const std::string& folder,
                      BandGather& gather);

  void onComposedFetched(const FlightKey& fk,
                         const LayerSpec& l,
                         const TileGrid& g,
                         const std::string& folder,
                         const Sector& sector,
                         WmtsGather& gather);

  void onFetched(const FlightKey& fk,
                 const LayerSpec& l,
                 const TileGrid& g,
                 const std::string& folder,
                 std::optional<CacheLookup> stale,
                 FetchResult&& r);

  void getTile(std::string_view layerName,
               std::string_view time,
               const TileKey& key,
               Done done,
               FetchGate gate = {});

  // ------------------------------------------------------------------ metatiles (getTiles)

  using TilesDone = std::function<void(const TileKey&, TileAnswer&&)>;

  /** Whether tiles of this layer can be fetched as one GetMap of a block and split. */
  static bool metaCapable(const LayerSpec& l, const UpstreamSpec& u) {
    return u.type == UpstreamSpec::Type::Wms && u.metaTiles > 1 && !l.elevation && !isWholeBox(l) &&
           (l.dataset.mimeType == "image/jpeg" || l.dataset.mimeType == "image/png");
  }

  void getTiles(std::string_view layerName,
                std::string_view time,
                std::span<const TileKey> keys,
                TilesDone doneFn);

  /** The keys of `keys` that are ours to fetch (missing or expired, and no flight out for them:
   * their flights are joined with `done`); the others are answered by getTile or their flight. */
  std::vector<TileKey> claimMissing(std::string_view layerName,
                                    std::string_view time,
                                    std::span<const TileKey> keys,
                                    const TileGrid& g,
                                    DatasetId id,
                                    const std::string& folder,
                                    const std::shared_ptr<TilesDone>& done);

  /** One GetMap of the smallest block holding `owned` (tile by tile when it is one tile or the
   * block is too large an image); its answer is split on a worker (onBlockFetched). */
  void fetchBlock(std::vector<TileKey> owned,
                  const LayerSpec& l,
                  const UpstreamSpec& u,
                  const TileGrid& g,
                  DatasetId id,
                  const std::string& folder,
                  std::string_view time);

  /** A metatile's answer (worker thread): validated and split once; its tiles are stored (the
   * asked-for one first, the others with one putMany) or, when anything is wrong, none is. */
  void onBlockFetched(const std::vector<TileKey>& owned,
                      const TileBlock& block,
                      const LayerSpec& l,
                      const TileGrid& g,
                      DatasetId id,
                      const std::string& folder,
                      FetchResult&& r);

  // ITileSource dispatch: start queued requests while fewer than kMaxInFlight run.
  void pump();
};

} // namespace tellus
