#include <tellus/cache/CacheTileSource.hpp>
#include <tellus/cache/RequestQueue.hpp>

#include <condition_variable>
#include <map>
#include <mutex>
#include <thread>

namespace tellus {

struct CacheTileSource::Impl {
  struct Pending {
    TileAddress address;
    Callback done;
  };

  TileCache& cache;
  int workerCount;
  mutable std::mutex mutex;
  std::condition_variable cv;
  RequestQueue<Pending> queue;
  bool started = false;
  bool stopping = false;
  std::vector<std::thread> workers;

  Impl(TileCache& c, int n) : cache(c), workerCount(n < 1 ? 1 : n) {}

  void startLocked() {
    if (started) return;
    started = true;
    for (int i = 0; i < workerCount; ++i)
      workers.emplace_back([this] { loop(); });
  }

  // Layer lookups are remembered: a dataset id never changes for the life of a cache.
  mutable std::mutex layersMutex;
  mutable std::map<std::pair<std::string, std::string>, DatasetInfo, std::less<>> layers;

  /** The dataset for a layer and time: the most recently registered one with that name and time. */
  std::optional<DatasetInfo> find(std::string_view layer, std::string_view time) const {
    const std::pair<std::string, std::string> key{layer, time};
    {
      std::lock_guard lock(layersMutex);
      if (const auto it = layers.find(key); it != layers.end()) return it->second;
    }
    std::optional<DatasetInfo> best;
    for (auto& d : cache.datasets()) {
      if (d.spec.name == layer && d.spec.time == time && (!best || d.id > best->id))
        best = std::move(d);
    }
    if (best) {
      std::lock_guard lock(layersMutex);
      layers.insert_or_assign(key, *best);
    }
    return best;
  }

  TileResult fetch(const TileAddress& a) const {
    TileResult r;
    const auto d = find(a.layer, a.time);
    if (!d) {
      r.status = TileStatus::Failed;
      r.message =
          "no cached layer '" + a.layer + "'" + (a.time.empty() ? "" : " at time " + a.time);
      return r;
    }
    auto got = cache.get(d->id, a.key);
    if (!got) {
      // A key outside the grid has no tile; anything else is an error worth retrying.
      r.status =
          got.error().code == CacheErrc::InvalidArgument ? TileStatus::Absent : TileStatus::Failed;
      r.message = got.error().message;
      return r;
    }
    switch (got->kind) {
    case CacheLookup::Kind::Hit:
      r.status = TileStatus::Ok;
      r.bytes = std::move(got->bytes);
      r.contentType = std::move(got->meta.contentType);
      break;
    case CacheLookup::Kind::Absent:
      r.status = TileStatus::Absent;
      r.message = "upstream has no tile here";
      break;
    case CacheLookup::Kind::Miss:
      r.status = TileStatus::Absent;
      r.message = "not cached (offline)";
      break;
    }
    return r;
  }

  void loop() {
    for (;;) {
      Pending job;
      {
        std::unique_lock lock(mutex);
        cv.wait(lock, [this] { return stopping || !queue.empty(); });
        if (stopping) return;
        job = std::move(queue.pop()->second);
      }
      TileResult result = fetch(job.address);
      job.done(std::move(result));
    }
  }
};

CacheTileSource::CacheTileSource(TileCache& cache, int workers, bool startPaused)
    : impl_(std::make_unique<Impl>(cache, workers)) {
  if (!startPaused) start();
}

CacheTileSource::~CacheTileSource() {
  {
    std::lock_guard lock(impl_->mutex);
    impl_->stopping = true;
    impl_->queue.clear();
  }
  impl_->cv.notify_all();
  for (auto& t : impl_->workers)
    t.join();
}

void CacheTileSource::start() {
  std::lock_guard lock(impl_->mutex);
  impl_->startLocked();
}

bool CacheTileSource::wholePolarRows(std::string_view layer) const {
  return impl_->find(std::string(layer) + std::string(kWholeRowLayerSuffix), "").has_value();
}

std::optional<DatasetSpec> CacheTileSource::describe(std::string_view layer,
                                                     std::string_view time) const {
  auto d = impl_->find(layer, time);
  if (!d) return std::nullopt;
  return d->spec;
}

TileRequestId CacheTileSource::request(const TileAddress& address, double priority, Callback done) {
  TileRequestId id = 0;
  {
    std::lock_guard lock(impl_->mutex);
    id = impl_->queue.push(priority, Impl::Pending{address, std::move(done)});
  }
  impl_->cv.notify_one();
  return id;
}

void CacheTileSource::reprioritize(TileRequestId id, double priority) {
  std::lock_guard lock(impl_->mutex);
  impl_->queue.reprioritize(id, priority);
}

bool CacheTileSource::cancel(TileRequestId id) {
  std::lock_guard lock(impl_->mutex);
  return impl_->queue.cancel(id);
}

std::size_t CacheTileSource::queued() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->queue.size();
}

} // namespace tellus
