// TileService: construction, the accessors and the ITileSource queue. The rest of its work is in
// the files TileServiceImpl.hpp names.

#include "tiles/TileServiceImpl.hpp"

#include <tellus/proxy/BodyCrs.hpp>
#include <tellus/proxy/Log.hpp>

#include <numbers>

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

void TileService::Impl::pump() {
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
  for (const auto& l : impl->layers)
    if (auto c = Impl::wholeRowLayer(l, impl->upstreams.at(l.upstream))) {
      impl->capIndex.emplace(c->name, impl->capLayers.size());
      impl->capGrids.push_back(*TileGrid::create(c->dataset.grid));
      impl->capLayers.push_back(std::move(*c));
      // Its merged rows' nodes whole too: `<layer>@span<k>` for every span a row of its levels
      // may have (a node never spans more than one level-zero column).
      const TileGrid& g = impl->grids[impl->layerIndex.at(l.name)];
      for (std::int64_t k = 2; k <= (std::int64_t{1} << (g.numLevels() - 1)) && k <= kMaxWholeSpan;
           k *= 2) {
        LayerSpec s = l;
        s.name = wholeSpanLayer(l.name, k);
        s.dataset.name = s.name;
        impl->capIndex.emplace(s.name, impl->capLayers.size());
        impl->capGrids.push_back(g);
        impl->capLayers.push_back(std::move(s));
      }
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
  const auto kept = impl_->unstored.stats();
  h.keptUnstoredTiles = kept.tiles;
  h.keptUnstoredBytes = kept.bytes;
  h.servedKeptUnstored = kept.served;
  h.storedLater = kept.storedLater;
  if (impl_->options.leases) {
    h.sharedIndexUp = impl_->options.leases->healthy() && !impl_->indexDown.load();
    h.leaseWaits = impl_->leaseWaits.load(std::memory_order_relaxed);
    h.servedWithoutIndex = impl_->servedWithoutIndex.load(std::memory_order_relaxed);
  }
  if (const auto space = impl_->cache.diskSpace()) {
    h.freeBytes = space->freeBytes;
    h.freeInodes = space->freeInodes;
  }
  if (impl_->options.localTier) h.localTier = impl_->options.localTier();
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

} // namespace tellus
