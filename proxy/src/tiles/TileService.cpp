#include "tiles/MetaTile.hpp"
#include "tiles/WorkerPool.hpp"
#include "upstream/WmtsCompose.hpp"

#include <tellus/cache/RequestQueue.hpp>
#include <tellus/cache/TilePath.hpp>
#include <tellus/proxy/BodyCrs.hpp>
#include <tellus/proxy/LocalRasterSource.hpp>
#include <tellus/proxy/Log.hpp>
#include <tellus/proxy/TileService.hpp>
#include <tellus/proxy/TileValidation.hpp>

#include <atomic>
#include <charconv>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <map>
#include <mutex>
#include <numbers>
#include <thread>
#include <unordered_map>

namespace tellus {

const char* toString(TileOrigin origin) noexcept {
  switch (origin) {
  case TileOrigin::Hit:
    return "HIT";
  case TileOrigin::Miss:
    return "MISS";
  case TileOrigin::Stale:
    return "STALE";
  case TileOrigin::Offline:
    return "OFFLINE";
  }
  return "MISS";
}

namespace {

std::string formatNumber(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

std::string urlEncode(std::string_view s) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string out;
  for (const char ch : s) {
    const auto c = static_cast<unsigned char>(ch);
    if ((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-' ||
        c == '_' || c == '.' || c == '~' || c == ':' || c == ',') {
      out.push_back(ch);
    } else {
      out.push_back('%');
      out.push_back(kHex[c >> 4]);
      out.push_back(kHex[c & 15]);
    }
  }
  return out;
}

std::string
strongEtag(const std::string& folder, const TileKey& k, UnixMillis fetchedAt, std::size_t size) {
  char buf[80];
  std::snprintf(
      buf,
      sizeof buf,
      "\"%016llx-%llx-%zx\"",
      static_cast<unsigned long long>(stableHash64(folder + "/" + tileRelativePath(k, ""))),
      static_cast<unsigned long long>(fetchedAt),
      size);
  return buf;
}

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

} // namespace

struct TileService::Impl : std::enable_shared_from_this<TileService::Impl> {
  TileCache& cache;
  Fetcher& fetcher;
  TileServiceOptions options;
  std::vector<LayerSpec> layers;
  std::map<std::string, std::size_t, std::less<>> layerIndex;
  std::vector<UnixMillis> layerSince; // per layer: its dataset's registration time
  std::vector<std::pair<DatasetId, std::string>> defaultDatasets; // per layer: time "" (id, folder)
  std::vector<TileGrid> grids;                                    // parallel to layers
  std::map<std::string, UpstreamSpec, std::less<>> upstreams;
  std::map<std::string, LocalRasterSource, std::less<>> rasters; // by upstream name
  std::atomic<bool> forcedOffline{false};
  std::atomic<std::uint64_t> fetches{0};
  std::atomic<std::uint64_t> metaFetches{0};
  // Fetched tiles served but not kept for lack of space, and whether the log last said "storing".
  std::atomic<std::uint64_t> refusedStores{0};
  std::atomic<bool> storingLogged{true};

  // (layer, time) -> dataset id, registered on first use.
  std::mutex datasetsMutex;
  std::map<std::pair<std::string, std::string>, std::pair<DatasetId, std::string>> datasets;

  std::mutex flightsMutex;
  std::unordered_map<FlightKey, std::vector<Done>, FlightKeyHash> flights;

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

  Impl(TileCache& c, Fetcher& f, TileServiceOptions o) : cache(c), fetcher(f), options(o) {}

  /** A stand-in id for a dataset the cache could not register (a full disk): negative, never a
   * real id, and one per folder so that flights of different datasets stay apart. Its tiles are
   * fetched and served, never looked up or stored. */
  static DatasetId unregisteredId(const std::string& folder) {
    return -1 - static_cast<DatasetId>(stableHash64(folder) >> 2);
  }

  std::expected<std::pair<DatasetId, std::string>, std::string> dataset(const LayerSpec& l,
                                                                        std::string_view time) {
    std::lock_guard lock(datasetsMutex);
    const auto key = std::make_pair(l.name, std::string(time));
    if (const auto it = datasets.find(key); it != datasets.end()) return it->second;
    DatasetSpec spec = l.dataset;
    spec.time = std::string(time);
    auto id = cache.registerDataset(spec);
    if (!id && id.error().code == CacheErrc::DiskFull) {
      // Served from the upstream, not stored; registered by a later request once there is room.
      noticeStoreState(&id.error());
      const std::string folder = datasetFolder(spec);
      return std::make_pair(unregisteredId(folder), folder);
    }
    if (!id) return std::unexpected("cache: " + id.error().message);
    const auto value = std::make_pair(*id, datasetFolder(spec));
    datasets.emplace(key, value);
    return value;
  }

  /** Logs the cache's change between storing and refusing (a full disk), once per change: the
   * state is the cache's, looked at after each store. */
  void noticeStoreState(const CacheError* refusal) {
    const bool writable = refusal == nullptr && cache.storeStatus().writable;
    if (storingLogged.exchange(writable) == writable) return;
    const std::string root = cache.root().string();
    const auto space = cache.diskSpace();
    const std::string freeBytes = space ? std::to_string(space->freeBytes) : "?";
    const std::string freeInodes = space ? std::to_string(space->freeInodes) : "?";
    if (!writable) {
      logger().log(LogLevel::Error,
                   "cache",
                   "the cache is full: tiles are served but not stored until there is room",
                   {{"root", root},
                    {"free_bytes", freeBytes},
                    {"free_inodes", freeInodes},
                    {"error", refusal ? std::string_view(refusal->message) : "disk full"}});
    } else {
      logger().log(LogLevel::Warn,
                   "cache",
                   "the cache stores tiles again",
                   {{"root", root}, {"free_bytes", freeBytes}, {"free_inodes", freeInodes}});
    }
  }

  bool remoteReachable(const UpstreamSpec& u) const {
    return u.type == UpstreamSpec::Type::Local || fetcher.reachable(u.name);
  }

  /** Joins a flight; true when the caller is the first and must start the work. */
  bool join(const FlightKey& k, Done done) {
    std::lock_guard lock(flightsMutex);
    auto [it, inserted] = flights.try_emplace(k);
    it->second.push_back(std::move(done));
    return inserted;
  }

  struct Joined {
    bool first = false;                               ///< the caller starts the work
    std::optional<std::chrono::milliseconds> refused; ///< the gate's budget said no (done kept)
  };
  /** join() for a client's request: joining a flight under way costs nothing; starting one asks
   * the gate's budget first (under the flights' lock, so that the check and the start are one
   * step). `done` is taken unless refused. */
  Joined joinGated(const FlightKey& k, Done& done, FetchGate gate) {
    std::lock_guard lock(flightsMutex);
    if (const auto it = flights.find(k); it != flights.end()) {
      it->second.push_back(std::move(done));
      return {};
    }
    if (gate.budget) {
      if (auto wait = gate.budget->take(gate.client)) return {false, wait};
    }
    flights[k].push_back(std::move(done));
    return {true, std::nullopt};
  }

  /** For the owner of a new flight: the cache lookup before the join and the join are two steps,
   * and a flight that landed between them has stored the tile; fetching it again would be a
   * second upstream request for one tile. Lands the flight with the cached tile when it is
   * there and fresh now. */
  bool landIfCachedNow(const FlightKey& fk, const std::string& folder) {
    if (fk.dataset < 0) return false;
    auto again = cache.openTile(fk.dataset, fk.key);
    if (!again || again->kind != CacheLookup::Kind::Hit || again->stale) return false;
    land(fk,
         tile(TileOrigin::Hit,
              {},
              std::move(again->meta.contentType),
              again->meta.fetchedAt,
              folder,
              fk.key,
              std::move(again->file)));
    return true;
  }

  void land(const FlightKey& k, TileAnswer&& answer) {
    std::vector<Done> waiters;
    {
      std::lock_guard lock(flightsMutex);
      const auto it = flights.find(k);
      if (it == flights.end()) return;
      waiters = std::move(it->second);
      flights.erase(it);
    }
    for (std::size_t i = 0; i + 1 < waiters.size(); ++i) {
      TileAnswer copy = answer;
      waiters[i](std::move(copy));
    }
    if (!waiters.empty()) waiters.back()(std::move(answer));
  }

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
  TileAnswer unavailable(const std::string& upstream, std::string message) const {
    TileAnswer a = error(std::move(message));
    a.failure = TileAnswer::Failure::Unavailable;
    const auto wait = std::chrono::ceil<std::chrono::seconds>(fetcher.unavailableFor(upstream));
    a.retryAfterSeconds = std::max<std::int64_t>(kMinRetryAfterSeconds, wait.count());
    return a;
  }

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
  TileAnswer fetchFailure(const std::string& upstream, const FetchError& e) const {
    const std::string what = e.code == FetchErrc::HttpError && e.httpStatus > 0
                                 ? "HTTP " + std::to_string(e.httpStatus)
                                 : std::string(toString(e.code));
    switch (e.code) {
    case FetchErrc::Timeout:
    case FetchErrc::Connect:
    case FetchErrc::CircuitOpen:
    case FetchErrc::Truncated:
    case FetchErrc::Throttled:
    case FetchErrc::Cancelled:
      return unavailable(upstream, "the upstream is unavailable (" + what + ")");
    case FetchErrc::HttpError:
      if (e.httpStatus >= 500 || e.httpStatus == 429)
        return unavailable(upstream, "the upstream is unavailable (" + what + ")");
      break;
    default:
      break;
    }
    return error("the upstream failed (" + what + ")");
  }

  /** The upstream says there is no tile there: 404, or 204 No Content. */
  static bool noSuchTile(int status) noexcept { return status == 404 || status == 204; }
  static TileAnswer tile(TileOrigin origin,
                         std::vector<std::byte> bytes,
                         std::string contentType,
                         UnixMillis fetchedAt,
                         const std::string& folder,
                         const TileKey& key,
                         std::shared_ptr<const TileFile> file = nullptr) {
    TileAnswer a;
    a.kind = TileAnswer::Kind::Tile;
    a.origin = origin;
    a.etag = strongEtag(
        folder, key, fetchedAt, file ? static_cast<std::size_t>(file->size()) : bytes.size());
    a.bytes = std::move(bytes);
    a.file = std::move(file);
    a.contentType = std::move(contentType);
    a.fetchedAt = fetchedAt;
    return a;
  }

  /** The answer for an expired tile served because no fresh one could be had. */
  static TileAnswer staleTile(CacheLookup&& old, const std::string& folder, const TileKey& key) {
    return tile(TileOrigin::Stale,
                std::move(old.bytes),
                std::move(old.meta.contentType),
                old.meta.fetchedAt,
                folder,
                key,
                std::move(old.file));
  }

  /** Stores a good tile and lands the flight (worker thread). A tile the cache does not keep is
   * still served: a full disk never fails a client (the answer says it was not stored). */
  void store(const FlightKey& fk,
             const std::string& folder,
             std::vector<std::byte> bytes,
             TileMeta meta) {
    std::optional<CacheError> notStored;
    if (fk.dataset < 0) {
      notStored = CacheError{CacheErrc::DiskFull,
                             "the cache is full: the layer's dataset could not be registered"};
    } else if (auto put = cache.put(fk.dataset, fk.key, bytes, meta); !put) {
      notStored = std::move(put.error());
    }
    if (notStored && notStored->code == CacheErrc::DiskFull) {
      refusedStores.fetch_add(1, std::memory_order_relaxed);
      noticeStoreState(&*notStored); // logged once per change, not once per tile
    } else if (notStored) {
      logger().log(LogLevel::Error,
                   "cache",
                   "cannot cache a tile; it is served but not kept",
                   {{"error", notStored->message}});
    } else {
      noticeStoreState(nullptr);
    }
    TileAnswer a =
        tile(TileOrigin::Miss, std::move(bytes), meta.contentType, meta.fetchedAt, folder, fk.key);
    a.notStored = std::move(notStored);
    land(fk, std::move(a));
  }

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
                   std::optional<CacheLookup> stale) {
    workers->post([this, fk, &l, &g, folder, stale = std::move(stale)]() mutable {
      const auto& src = rasters.at(l.upstream);
      auto bytes = src.renderTile(g.sectorOf(fk.key),
                                  g.spec().tileWidth,
                                  g.spec().tileHeight,
                                  l.dataset.mimeType,
                                  l.noData);
      if (!bytes) {
        if (stale) {
          land(fk, staleTile(std::move(*stale), folder, fk.key));
        } else {
          land(fk, error("cannot render the tile: " + bytes.error()));
        }
        return;
      }
      store(fk, folder, std::move(*bytes), freshMeta(l));
    });
  }

  void fetchRemote(const FlightKey& fk,
                   const LayerSpec& l,
                   const UpstreamSpec& u,
                   const TileGrid& g,
                   const std::string& folder,
                   std::string time,
                   std::optional<CacheLookup> stale) {
    if (l.wmts && wmtsComposed(*l.wmts, fk.key)) {
      composeRemote(fk, l, u, g, folder, time, std::move(stale));
      return;
    }
    FetchRequest req;
    req.upstream = u.name;
    req.url = upstreamUrl(u, l, g.sectorOf(fk.key), fk.key, time);
    if (req.url.empty()) { // a WMTS tile outside the upstream's matrix: there is none to fetch
      land(fk, absent(TileOrigin::Miss, "the upstream has no tile here"));
      return;
    }
    if (stale) {
      req.ifNoneMatch = stale->meta.etag;
      req.ifModifiedSince = stale->meta.lastModified;
    }
    fetches.fetch_add(1);
    fetcher.fetch(std::move(req),
                  [weak = weak_from_this(), fk, &l, &g, folder, stale = std::move(stale)](
                      FetchResult&& r) mutable {
                    // The fetcher thread only hands over: validation and the cache write run on a
                    // worker. A service already destroyed has no one left to answer.
                    const auto self = weak.lock();
                    if (!self) return;
                    self->workers->post([im = self.get(),
                                         fk,
                                         &l,
                                         &g,
                                         folder,
                                         stale = std::move(stale),
                                         r = std::move(r)]() mutable {
                      im->onFetched(fk, l, g, folder, std::move(stale), std::move(r));
                    });
                  });
  }

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
                     std::optional<CacheLookup> stale) {
    const Sector sector = g.sectorOf(fk.key);
    const auto sources =
        wmtsSourceTiles(*l.wmts, fk.key, sector, g.spec().tileWidth, g.spec().tileHeight, time);
    if (sources.empty()) {
      land(fk, absent(TileOrigin::Miss, "the upstream has no tile here"));
      return;
    }
    auto gather = std::make_shared<WmtsGather>();
    gather->left = sources.size();
    gather->stale = std::move(stale);
    for (const auto& src : sources)
      gather->tiles.push_back(WmtsFetchedTile{src, {}});
    fetches.fetch_add(sources.size());
    for (std::size_t i = 0; i < sources.size(); ++i) {
      FetchRequest req;
      req.upstream = u.name;
      req.url = sources[i].url;
      fetcher.fetch(
          std::move(req),
          [weak = weak_from_this(), gather, i, fk, &l, &g, folder, sector](FetchResult&& r) {
            {
              std::lock_guard lock(gather->mutex);
              if (r && r->status == 200)
                gather->tiles[i].bytes = std::move(r->body);
              else if (!(r && noSuchTile(r->status)) && !gather->failure)
                gather->failure = std::move(r);
              if (--gather->left > 0) return;
            }
            const auto self = weak.lock();
            if (!self) return;
            self->workers->post([im = self.get(), gather, fk, &l, &g, folder, sector] {
              im->onComposedFetched(fk, l, g, folder, sector, *gather);
            });
          });
    }
  }

  void onComposedFetched(const FlightKey& fk,
                         const LayerSpec& l,
                         const TileGrid& g,
                         const std::string& folder,
                         const Sector& sector,
                         WmtsGather& gather) {
    if (gather.failure)
      return onFetched(fk, l, g, folder, std::move(gather.stale), std::move(*gather.failure));
    FetchResponse resp;
    const bool none = std::all_of(
        gather.tiles.begin(), gather.tiles.end(), [](const auto& t) { return t.bytes.empty(); });
    if (none) {
      resp.status = 404;
      return onFetched(fk, l, g, folder, std::move(gather.stale), FetchResult(std::move(resp)));
    }
    auto composed = composeWmtsTile(*l.wmts,
                                    fk.key,
                                    sector,
                                    g.spec().tileWidth,
                                    g.spec().tileHeight,
                                    gather.tiles,
                                    l.dataset.mimeType);
    if (!composed) {
      land(fk, error("the upstream's tiles could not be composed: " + composed.error()));
      return;
    }
    resp.status = 200;
    resp.contentType = l.dataset.mimeType;
    resp.body = std::move(*composed);
    onFetched(fk, l, g, folder, std::move(gather.stale), FetchResult(std::move(resp)));
  }

  void onFetched(const FlightKey& fk,
                 const LayerSpec& l,
                 const TileGrid& g,
                 const std::string& folder,
                 std::optional<CacheLookup> stale,
                 FetchResult&& r) {
    auto serveStale = [&] {
      if (!stale) return false;
      land(fk, staleTile(std::move(*stale), folder, fk.key));
      return true;
    };
    if (!r) {
      if (serveStale()) return;
      land(fk, fetchFailure(l.upstream, r.error()));
      return;
    }
    FetchResponse& resp = *r;
    if (resp.status == 304 && stale) {
      TileMeta m = freshMeta(l);
      m.etag = resp.etag.empty() ? stale->meta.etag : resp.etag;
      m.lastModified = resp.lastModified.empty() ? stale->meta.lastModified : resp.lastModified;
      (void)cache.revalidated(fk.dataset, fk.key, m);
      land(fk,
           tile(TileOrigin::Hit,
                std::move(stale->bytes),
                stale->meta.contentType,
                m.fetchedAt,
                folder,
                fk.key,
                std::move(stale->file)));
      return;
    }
    if (noSuchTile(resp.status)) {
      (void)cache.putAbsent(fk.dataset, fk.key, nowMillis() + options.absentRetry.count());
      land(fk, absent(TileOrigin::Miss, "the upstream has no tile here"));
      return;
    }
    if (resp.status != 200) {
      if (serveStale()) return;
      land(fk, error("the upstream answered HTTP " + std::to_string(resp.status)));
      return;
    }
    if (auto ok = validateTile(resp, l.dataset.mimeType, g.spec().tileWidth, g.spec().tileHeight);
        !ok) {
      // Never cached: an error page, a ServiceException, a truncated or wrong-sized image.
      if (serveStale()) return;
      land(fk, error("the upstream did not send a tile: " + ok.error()));
      return;
    }
    TileMeta m = freshMeta(l);
    m.etag = resp.etag;
    m.lastModified = resp.lastModified;
    store(fk, folder, std::move(resp.body), std::move(m));
  }

  void getTile(std::string_view layerName,
               std::string_view time,
               const TileKey& key,
               Done done,
               FetchGate gate = {}) {
    const auto li = layerIndex.find(layerName);
    if (li == layerIndex.end()) return done(error("no layer '" + std::string(layerName) + "'"));
    const LayerSpec& l = layers[li->second];
    const TileGrid& g = grids[li->second];
    if (key.level < 0 || key.level >= g.numLevels() || !g.isValid(key)) {
      return done(absent(TileOrigin::Hit, "outside the layer's coverage"));
    }
    // Layers without TIME (most requests) use the dataset registered at start: no lock, no copy.
    std::pair<DatasetId, std::string> timed;
    const std::pair<DatasetId, std::string>* ds = &defaultDatasets[li->second];
    if (!time.empty()) {
      auto found = dataset(l, time);
      if (!found) return done(error(found.error()));
      timed = std::move(*found);
      ds = &timed;
    }
    if (time.empty() && ds->first < 0) { // not registered for lack of space: room now?
      auto again = dataset(l, time);
      if (!again) return done(error(again.error()));
      timed = std::move(*again);
      ds = &timed;
    }
    const auto& [id, folder] = *ds;
    // The file held open, not read: the HTTP server sends it with sendfile(2). A dataset the
    // cache could not register has nothing cached.
    auto found =
        id < 0 ? std::expected<CacheLookup, CacheError>(CacheLookup{}) : cache.openTile(id, key);
    if (!found) return done(error("cache: " + std::string(toString(found.error().code))));
    const UnixMillis now = nowMillis();
    if (found->kind == CacheLookup::Kind::Hit && !found->stale) {
      return done(tile(TileOrigin::Hit,
                       {},
                       std::move(found->meta.contentType),
                       found->meta.fetchedAt,
                       folder,
                       key,
                       std::move(found->file)));
    }
    if (found->kind == CacheLookup::Kind::Absent && found->retryAfter > now) {
      return done(absent(TileOrigin::Hit, "the upstream has no tile here"));
    }
    const UpstreamSpec& u = upstreams.at(l.upstream);
    const bool forced = forcedOffline.load();
    std::optional<CacheLookup> stale;
    if (found->kind == CacheLookup::Kind::Hit) stale = std::move(*found);
    if (forced || !remoteReachable(u)) {
      if (stale) {
        return done(staleTile(std::move(*stale), folder, key));
      }
      // Offline by choice: there is no tile to be had. An open breaker is a temporary failure.
      if (forced) return done(absent(TileOrigin::Offline, "offline: the tile is not cached"));
      TileAnswer a = unavailable(
          u.name, "the upstream is unreachable (circuit open) and the tile is not cached");
      a.origin = TileOrigin::Offline;
      return done(std::move(a));
    }
    const FlightKey fk{id, key};
    // Local rasters are rendered here, not fetched: the budget counts upstream fetches.
    const auto joined =
        joinGated(fk, done, u.type == UpstreamSpec::Type::Local ? FetchGate{} : gate);
    if (joined.refused) {
      // Over the client's budget: what the cache has is still served.
      if (stale) return done(staleTile(std::move(*stale), folder, key));
      return done(overBudget(*joined.refused));
    }
    if (!joined.first) return; // someone is already fetching it
    if (landIfCachedNow(fk, folder)) return;
    if (u.type == UpstreamSpec::Type::Local) {
      renderLocal(fk, l, g, folder, std::move(stale));
    } else {
      fetchRemote(fk, l, u, g, folder, std::string(time), std::move(stale));
    }
  }

  // ------------------------------------------------------------------ metatiles (getTiles)

  using TilesDone = std::function<void(const TileKey&, TileAnswer&&)>;

  /** Whether tiles of this layer can be fetched as one GetMap of a block and split. */
  static bool metaCapable(const LayerSpec& l, const UpstreamSpec& u) {
    return u.type == UpstreamSpec::Type::Wms && u.metaTiles > 1 && !l.elevation &&
           (l.dataset.mimeType == "image/jpeg" || l.dataset.mimeType == "image/png");
  }

  void getTiles(std::string_view layerName,
                std::string_view time,
                std::span<const TileKey> keys,
                TilesDone doneFn) {
    if (keys.empty()) return;
    const auto done = std::make_shared<TilesDone>(std::move(doneFn));
    auto waiter = [done](const TileKey& k) {
      return [done, k](TileAnswer&& a) { (*done)(k, std::move(a)); };
    };
    auto oneByOne = [&](std::span<const TileKey> ks) {
      for (const TileKey& k : ks)
        getTile(layerName, time, k, waiter(k));
    };
    const auto li = layerIndex.find(layerName);
    if (li == layerIndex.end()) return oneByOne(keys); // each answers "no layer"
    const LayerSpec& l = layers[li->second];
    const TileGrid& g = grids[li->second];
    const UpstreamSpec& u = upstreams.at(l.upstream);
    const bool oneLevel = std::all_of(
        keys.begin(), keys.end(), [&](const TileKey& k) { return k.level == keys[0].level; });
    if (keys.size() < 2 || !metaCapable(l, u) || !oneLevel || forcedOffline.load() ||
        !remoteReachable(u))
      return oneByOne(keys);
    std::pair<DatasetId, std::string> ds = defaultDatasets[li->second];
    if (!time.empty()) {
      auto found = dataset(l, time);
      if (!found) return oneByOne(keys); // each reports the error
      ds = std::move(*found);
    }
    const auto& [id, folder] = ds;
    std::vector<TileKey> owned = claimMissing(layerName, time, keys, g, id, folder, done);
    if (owned.empty()) return;
    fetchBlock(std::move(owned), l, u, g, id, folder, time);
  }

  /** The keys of `keys` that are ours to fetch (missing or expired, and no flight out for them:
   * their flights are joined with `done`); the others are answered by getTile or their flight. */
  std::vector<TileKey> claimMissing(std::string_view layerName,
                                    std::string_view time,
                                    std::span<const TileKey> keys,
                                    const TileGrid& g,
                                    DatasetId id,
                                    const std::string& folder,
                                    const std::shared_ptr<TilesDone>& done) {
    auto waiter = [done](const TileKey& k) {
      return [done, k](TileAnswer&& a) { (*done)(k, std::move(a)); };
    };
    const UnixMillis now = nowMillis();
    std::vector<TileKey> owned;
    for (const TileKey& k : keys) {
      if (k.level < 0 || k.level >= g.numLevels() || !g.isValid(k)) {
        getTile(layerName, time, k, waiter(k)); // answers "outside the layer's coverage"
        continue;
      }
      const auto known = cache.peek(id, k);
      const bool fromCache = !known || (known->kind == CacheLookup::Kind::Hit && !known->stale) ||
                             (known->kind == CacheLookup::Kind::Absent && known->retryAfter > now);
      if (fromCache) { // a hit, a remembered absence, or an index error: getTile answers
        getTile(layerName, time, k, waiter(k));
        continue;
      }
      // Missing or expired: ours to fetch unless a flight for it is already out (it answers).
      if (join(FlightKey{id, k}, waiter(k)) && !landIfCachedNow(FlightKey{id, k}, folder))
        owned.push_back(k);
    }
    return owned;
  }

  /** One GetMap of the smallest block holding `owned` (tile by tile when it is one tile or the
   * block is too large an image); its answer is split on a worker (onBlockFetched). */
  void fetchBlock(std::vector<TileKey> owned,
                  const LayerSpec& l,
                  const UpstreamSpec& u,
                  const TileGrid& g,
                  DatasetId id,
                  const std::string& folder,
                  std::string_view time) {
    const TileBlock block = boundingBlock(owned);
    const auto& spec = g.spec();
    const bool tooBig = static_cast<std::int64_t>(block.cols) * spec.tileWidth > 8192 ||
                        static_cast<std::int64_t>(block.rows) * spec.tileHeight > 8192;
    if (owned.size() == 1 || tooBig) {
      for (const TileKey& k : owned)
        fetchRemote(FlightKey{id, k}, l, u, g, folder, std::string(time), std::nullopt);
      return;
    }
    FetchRequest req;
    req.upstream = u.name;
    req.url = wmsUrl(u,
                     l,
                     blockSector(g, block),
                     block.cols * spec.tileWidth,
                     block.rows * spec.tileHeight,
                     time);
    fetches.fetch_add(1);
    metaFetches.fetch_add(1);
    fetcher.fetch(std::move(req),
                  [weak = weak_from_this(), owned = std::move(owned), block, &l, &g, id, folder](
                      FetchResult&& r) mutable {
                    const auto self = weak.lock();
                    if (!self) return;
                    self->workers->post([im = self.get(),
                                         owned = std::move(owned),
                                         block,
                                         &l,
                                         &g,
                                         id,
                                         folder,
                                         r = std::move(r)]() mutable {
                      im->onBlockFetched(owned, block, l, g, id, folder, std::move(r));
                    });
                  });
  }

  /** A metatile's answer (worker thread): validated and split once; its tiles are stored (each
   * on a worker, so that their fsyncs overlap) or, when anything is wrong, none is. */
  void onBlockFetched(const std::vector<TileKey>& owned,
                      const TileBlock& block,
                      const LayerSpec& l,
                      const TileGrid& g,
                      DatasetId id,
                      const std::string& folder,
                      FetchResult&& r) {
    auto landAll = [&](const TileAnswer& a) {
      for (const TileKey& k : owned) {
        TileAnswer copy = a;
        land(FlightKey{id, k}, std::move(copy));
      }
    };
    if (!r) {
      landAll(fetchFailure(l.upstream, r.error()));
      return;
    }
    FetchResponse& resp = *r;
    if (noSuchTile(resp.status)) {
      for (const TileKey& k : owned)
        (void)cache.putAbsent(id, k, nowMillis() + options.absentRetry.count());
      landAll(absent(TileOrigin::Miss, "the upstream has no tile here"));
      return;
    }
    if (resp.status != 200) {
      landAll(error("the upstream answered HTTP " + std::to_string(resp.status)));
      return;
    }
    auto kind = validateImageResponse(resp, l.dataset.mimeType);
    if (!kind) {
      landAll(error("the upstream did not send a tile: " + kind.error()));
      return;
    }
    auto split = splitMetaTile(
        resp.body, *kind, block.cols, block.rows, g.spec().tileWidth, g.spec().tileHeight);
    if (!split) {
      landAll(error("the upstream did not send a tile: " + split.error()));
      return;
    }
    resp.body = {}; // the metatile's bytes are no longer needed
    TileMeta m = freshMeta(l);
    // The metatile's ETag names another resource than any tile's GetMap: not kept. Its
    // Last-Modified is true of every tile in it.
    m.lastModified = resp.lastModified;
    for (const TileKey& k : owned) {
      workers->post([this,
                     fk = FlightKey{id, k},
                     folder,
                     m,
                     bytes = std::move(split->tiles[block.imageIndex(k)])]() mutable {
        store(fk, folder, std::move(bytes), std::move(m));
      });
    }
  }

  // ITileSource dispatch: start queued requests while fewer than kMaxInFlight run.
  void pump() {
    for (;;) {
      std::optional<std::pair<TileRequestId, Queued>> next;
      {
        std::lock_guard lock(queueMutex);
        if (inFlight >= kMaxInFlight) return;
        next = queue.pop();
        if (!next) return;
        ++inFlight;
      }
      Queued job = std::move(next->second);
      getTile(job.address.layer,
              job.address.time,
              job.address.key,
              [this, done = std::move(job.done)](TileAnswer&& a) {
                TileResult r;
                r.status = a.kind == TileAnswer::Kind::Tile     ? TileStatus::Ok
                           : a.kind == TileAnswer::Kind::Absent ? TileStatus::Absent
                                                                : TileStatus::Failed;
                r.bytes = std::move(a.bytes);
                if (a.file && r.bytes.empty()) {
                  if (auto b = a.file->readAll()) {
                    r.bytes = std::move(*b);
                  } else {
                    r.status = TileStatus::Failed;
                    a.message = "cannot read the cached tile";
                  }
                }
                r.contentType = std::move(a.contentType);
                r.message = std::move(a.message);
                done(std::move(r));
                {
                  std::lock_guard lock(queueMutex);
                  --inFlight;
                }
                pump();
              });
    }
  }
};

std::expected<std::unique_ptr<TileService>, std::string>
TileService::create(TileCache& cache,
                    Fetcher& fetcher,
                    std::vector<UpstreamSpec> upstreams,
                    std::vector<LayerSpec> layers,
                    TileServiceOptions options) {
  auto impl = std::make_shared<Impl>(cache, fetcher, options);
  std::map<std::string, WmtsCapabilities, std::less<>> wmtsCaps;
  for (auto& u : upstreams) {
    if (u.type == UpstreamSpec::Type::Local) {
      auto src = LocalRasterSource::open(u.path);
      if (!src) return std::unexpected("upstream '" + u.name + "': " + src.error());
      impl->rasters.emplace(u.name, std::move(*src));
    } else {
      fetcher.setPolicy(u.name, u.policy);
    }
    if (u.type == UpstreamSpec::Type::Wmts) {
      const auto root =
          options.wmtsCapabilitiesRoot.empty() ? cache.root() : options.wmtsCapabilitiesRoot;
      std::string note;
      auto caps = loadWmtsCapabilities(fetcher,
                                       u.name,
                                       u.url,
                                       root.empty() ? root : wmtsCapabilitiesFile(root, u.name),
                                       options.offline,
                                       &note);
      if (!caps) return std::unexpected("upstream '" + u.name + "': " + caps.error());
      if (!note.empty()) logger().log(LogLevel::Warn, "upstream", note, {{"upstream", u.name}});
      wmtsCaps.emplace(u.name, std::move(*caps));
    }
    const std::string name = u.name;
    impl->upstreams.emplace(name, std::move(u));
  }
  for (auto& l : layers) {
    if (!impl->upstreams.contains(l.upstream)) {
      return std::unexpected("layer '" + l.name + "': no upstream '" + l.upstream + "'");
    }
    auto grid = TileGrid::create(l.dataset.grid);
    if (!grid) return std::unexpected("layer '" + l.name + "': " + grid.error());
    if (impl->layerIndex.contains(l.name)) return std::unexpected("layer '" + l.name + "' twice");
    if (l.upstreamLayer.empty()) l.upstreamLayer = l.name;
    if (const auto caps = wmtsCaps.find(l.upstream); caps != wmtsCaps.end()) {
      const UpstreamSpec& u = impl->upstreams.at(l.upstream);
      WmtsChoice choice{l.upstreamLayer,
                        l.dataset.style,
                        l.dataset.mimeType,
                        l.tileMatrixSet,
                        u.wmtsEncoding,
                        wmtsCapabilitiesUrl(u.url)};
      if (const auto body = bodyCrs(l.dataset.body); body && !isEarthBody(l.dataset.body))
        choice.bodyMetresPerDegree = body->meanRadiusM * std::numbers::pi / 180.0;
      auto bound = bindWmtsLayer(caps->second, choice, l.dataset.grid);
      if (!bound) return std::unexpected("layer '" + l.name + "': " + bound.error());
      l.wmts = std::make_shared<const WmtsTiles>(std::move(*bound));
    }
    l.dataset.name = l.name;
    l.dataset.server = l.upstream;
    l.dataset.time.clear();
    if (l.dataset.extension.empty()) l.dataset.extension = extensionForMimeType(l.dataset.mimeType);
    impl->layerIndex.emplace(l.name, impl->layers.size());
    impl->grids.push_back(*grid);
    impl->layers.push_back(std::move(l));
  }
  for (const auto& l : impl->layers) {
    // On a full disk a new layer starts unregistered: served from its upstream, not kept.
    auto ds = impl->dataset(l, "");
    if (!ds) return std::unexpected("layer '" + l.name + "': " + ds.error());
    const auto info = ds->first < 0 ? std::nullopt : cache.dataset(ds->first);
    impl->layerSince.push_back(info ? info->createdAt : 0);
    impl->defaultDatasets.push_back(*ds);
  }
  impl->forcedOffline = options.offline;
  impl->workers = std::make_unique<WorkerPool>(options.renderThreads, options.workerNice);
  return std::unique_ptr<TileService>(new TileService(std::move(impl)));
}

TileService::TileService(std::shared_ptr<Impl> impl) : impl_(std::move(impl)) {}

// The workers are Impl's last member: they finish what they hold (landing flights) before anything
// they use goes away, whichever thread drops the last reference.
TileService::~TileService() = default;

const std::vector<LayerSpec>& TileService::layers() const noexcept {
  return impl_->layers;
}

const LayerSpec* TileService::layer(std::string_view name) const noexcept {
  const auto it = impl_->layerIndex.find(name);
  return it == impl_->layerIndex.end() ? nullptr : &impl_->layers[it->second];
}

std::vector<UpstreamMetrics> TileService::upstreamMetrics() const {
  std::vector<UpstreamMetrics> out;
  for (const auto& [name, u] : impl_->upstreams) {
    if (u.type == UpstreamSpec::Type::Local) continue;
    out.push_back(UpstreamMetrics{name, impl_->fetcher.stats(name)});
  }
  return out;
}

std::optional<std::int64_t> TileService::cachedBytes() const {
  auto b = impl_->cache.totalBytes();
  if (!b) return std::nullopt;
  return *b;
}

UnixMillis TileService::layerSince(std::string_view name) const noexcept {
  const auto it = impl_->layerIndex.find(name);
  return it == impl_->layerIndex.end() ? 0 : impl_->layerSince[it->second];
}

const TileGrid* TileService::grid(std::string_view name) const noexcept {
  const auto it = impl_->layerIndex.find(name);
  return it == impl_->layerIndex.end() ? nullptr : &impl_->grids[it->second];
}

TileCache& TileService::cache() const noexcept {
  return impl_->cache;
}

void TileService::getTile(std::string_view layer,
                          std::string_view time,
                          const TileKey& key,
                          std::function<void(TileAnswer&&)> done,
                          FetchGate gate) {
  impl_->getTile(layer, time, key, std::move(done), gate);
}

void TileService::getTiles(std::string_view layer,
                           std::string_view time,
                           std::span<const TileKey> keys,
                           std::function<void(const TileKey&, TileAnswer&&)> done) {
  impl_->getTiles(layer, time, keys, std::move(done));
}

std::int32_t TileService::metaTileSize(std::string_view layer) const noexcept {
  const LayerSpec* l = this->layer(layer);
  if (!l) return 1;
  const auto u = impl_->upstreams.find(l->upstream);
  if (u == impl_->upstreams.end() || !Impl::metaCapable(*l, u->second)) return 1;
  return u->second.metaTiles;
}

std::uint64_t TileService::metaTileFetches() const noexcept {
  return impl_->metaFetches.load();
}

std::optional<TileAnswer>
TileService::cachedTile(std::string_view layer, std::string_view time, const TileKey& key) {
  const auto li = impl_->layerIndex.find(layer);
  if (li == impl_->layerIndex.end()) return std::nullopt;
  const TileGrid& g = impl_->grids[li->second];
  if (key.level < 0 || key.level >= g.numLevels() || !g.isValid(key)) return std::nullopt;
  auto ds = time.empty() ? impl_->defaultDatasets[li->second]
                         : impl_->dataset(impl_->layers[li->second], time)
                               .value_or(std::pair<DatasetId, std::string>{-1, {}});
  if (ds.first < 0) return std::nullopt;
  auto found = impl_->cache.openTile(ds.first, key);
  if (!found || found->kind != CacheLookup::Kind::Hit) return std::nullopt;
  const bool stale = found->stale;
  auto a = Impl::tile(stale ? TileOrigin::Stale : TileOrigin::Hit,
                      {},
                      std::move(found->meta.contentType),
                      found->meta.fetchedAt,
                      ds.second,
                      key,
                      std::move(found->file));
  return a;
}

void TileService::setOffline(bool offline) noexcept {
  impl_->forcedOffline = offline;
}

bool TileService::offline() const noexcept {
  if (impl_->forcedOffline) return true;
  bool anyRemote = false;
  for (const auto& [name, u] : impl_->upstreams) {
    if (u.type == UpstreamSpec::Type::Local) continue;
    anyRemote = true;
    if (impl_->fetcher.reachable(name)) return false;
  }
  return anyRemote;
}

std::uint64_t TileService::upstreamFetches() const noexcept {
  return impl_->fetches.load();
}

CacheHealthMetrics TileService::cacheHealth() const {
  CacheHealthMetrics h;
  h.writable = impl_->cache.storeStatus().writable;
  h.refusedStores = impl_->refusedStores.load(std::memory_order_relaxed);
  if (const auto space = impl_->cache.diskSpace()) {
    h.freeBytes = space->freeBytes;
    h.freeInodes = space->freeInodes;
  }
  return h;
}

std::optional<DatasetSpec> TileService::describe(std::string_view layer,
                                                 std::string_view time) const {
  const LayerSpec* l = this->layer(layer);
  if (!l) return std::nullopt;
  DatasetSpec s = l->dataset;
  s.time = std::string(time);
  return s;
}

TileRequestId TileService::request(const TileAddress& address, double priority, Callback done) {
  TileRequestId id = 0;
  {
    std::lock_guard lock(impl_->queueMutex);
    id = impl_->queue.push(priority, Impl::Queued{address, std::move(done)});
  }
  impl_->pump();
  return id;
}

void TileService::reprioritize(TileRequestId id, double priority) {
  std::lock_guard lock(impl_->queueMutex);
  impl_->queue.reprioritize(id, priority);
}

bool TileService::cancel(TileRequestId id) {
  std::lock_guard lock(impl_->queueMutex);
  return impl_->queue.cancel(id);
}

std::string TileService::upstreamUrl(const UpstreamSpec& u,
                                     const LayerSpec& l,
                                     const Sector& s,
                                     const TileKey& key,
                                     std::string_view time) {
  if (u.type == UpstreamSpec::Type::Wmts)
    return l.wmts ? wmtsTileUrl(*l.wmts, key, time).value_or(std::string()) : std::string();
  if (u.type == UpstreamSpec::Type::WorldWind) {
    std::string url = u.url;
    if (url.find('?') == std::string::npos) {
      url += '?';
    } else if (url.back() != '?' && url.back() != '&') {
      url += '&';
    }
    url += "T=" + urlEncode(l.upstreamLayer) + "&L=" + std::to_string(key.level + l.firstLevel) +
           "&X=" + std::to_string(key.col) + "&Y=" + std::to_string(key.row);
    return url;
  }
  return wmsUrl(u, l, s, l.dataset.grid.tileWidth, l.dataset.grid.tileHeight, time);
}

std::string TileService::wmsUrl(const UpstreamSpec& u,
                                const LayerSpec& l,
                                const Sector& s,
                                std::int32_t width,
                                std::int32_t height,
                                std::string_view time) {
  std::string url = u.url;
  if (url.find('?') == std::string::npos) {
    url += '?';
  } else if (url.back() != '?' && url.back() != '&') {
    url += '&';
  }
  const bool v111 = u.wmsVersion == "1.1.1";
  const bool latLon = !v111 && u.crs == "EPSG:4326"; // WMS 1.3.0 EPSG:4326 is lat/lon
  url += "SERVICE=WMS&REQUEST=GetMap&VERSION=" + u.wmsVersion;
  url += "&LAYERS=" + urlEncode(l.upstreamLayer) + "&STYLES=" + urlEncode(l.dataset.style);
  url += "&FORMAT=" + urlEncode(l.dataset.mimeType);
  url += "&WIDTH=" + std::to_string(width) + "&HEIGHT=" + std::to_string(height);
  url += v111 ? "&SRS=EPSG:4326" : "&CRS=" + urlEncode(u.crs);
  url += "&BBOX=";
  url += latLon ? formatNumber(s.south) + "," + formatNumber(s.west) + "," + formatNumber(s.north) +
                      "," + formatNumber(s.east)
                : formatNumber(s.west) + "," + formatNumber(s.south) + "," + formatNumber(s.east) +
                      "," + formatNumber(s.north);
  url += l.dataset.mimeType == "image/png" ? "&TRANSPARENT=TRUE" : "&TRANSPARENT=FALSE";
  if (!time.empty()) url += "&TIME=" + urlEncode(time);
  return url;
}

} // namespace tellus
