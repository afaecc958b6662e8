#include <tellus/proxy/LocalRasterSource.hpp>
#include <tellus/proxy/Seeder.hpp>
#include <tellus/proxy/TileService.hpp>

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <thread>

namespace tellus {

namespace {

/** Why seeding stops when the cache said "not writable" without a message of its own (a
 * write-behind row that could not be committed). */
std::string cacheFullMessage(const TileCache& cache) {
  std::string m = "the cache at " + cache.root().string() + " is full";
  if (const auto space = cache.diskSpace()) {
    m += " (" + std::to_string(space->freeBytes) + " bytes and " +
         std::to_string(space->freeInodes) + " inodes free)";
  }
  return m + ": it refused to store a tile";
}

/** At the end of a run: waits for write-behind rows and takes back the tiles whose rows could not
 * be committed (they were counted written when their bytes went to disk). */
void settleWriteBehind(TileCache& cache, const StoreStatus& before, SeedReport& report) {
  cache.flush();
  const StoreStatus after = cache.storeStatus();
  const auto dropped = static_cast<std::int64_t>(after.dropped - before.dropped);
  if (dropped <= 0) return;
  report.written -= dropped;
  report.notStored += dropped;
  if (report.stoppedBecause.empty()) report.stoppedBecause = cacheFullMessage(cache);
}

} // namespace

std::expected<SeedReport, CacheError>
seedFromRaster(TileCache& cache,
               DatasetId dataset,
               const LocalRasterSource& source,
               const SeedOptions& options,
               const std::function<void(const SeedReport&)>& progress) {
  const auto info = cache.dataset(dataset);
  if (!info) return std::unexpected(CacheError{CacheErrc::InvalidArgument, "unknown dataset"});
  const auto grid = TileGrid::create(info->spec.grid);
  if (!grid) return std::unexpected(CacheError{CacheErrc::InvalidArgument, grid.error()});
  const Sector box = options.box.value_or(info->spec.grid.sector);
  SeedReport report;
  const StoreStatus before = cache.storeStatus();
  for (std::int32_t level = std::max(0, options.fromLevel);
       level <= std::min(options.toLevel, grid->numLevels() - 1) && report.stoppedBecause.empty();
       ++level) {
    const auto keys = grid->keysCovering(box, level);
    if (!keys) {
      return std::unexpected(
          CacheError{CacheErrc::InvalidArgument,
                     "level " + std::to_string(level) + " has too many tiles to seed at once"});
    }
    report.planned += static_cast<std::int64_t>(keys->size());
    if (options.dryRun) continue;
    for (const TileKey& key : *keys) {
      if (!report.stoppedBecause.empty()) break;
      auto known = cache.peek(dataset, key);
      if (known && known->kind != CacheLookup::Kind::Miss) {
        ++report.skipped;
        continue;
      }
      auto bytes = source.renderTile(grid->sectorOf(key),
                                     grid->spec().tileWidth,
                                     grid->spec().tileHeight,
                                     info->spec.mimeType,
                                     options.noData);
      if (!bytes) {
        ++report.failed;
        if (report.failures.size() < 10) report.failures.push_back(bytes.error());
        continue;
      }
      auto put = cache.put(dataset, key, *bytes, TileMeta{});
      if (!put) {
        if (put.error().code == CacheErrc::DiskFull) {
          // Nothing more fits: rendering on would only waste the time.
          ++report.notStored;
          report.stoppedBecause = put.error().message;
          break;
        }
        ++report.failed;
        if (report.failures.size() < 10) report.failures.push_back(put.error().message);
        continue;
      }
      ++report.written;
      report.bytes += static_cast<std::int64_t>(bytes->size());
      // A write-behind row the index refused (its put had returned) stops the run as well.
      if (!cache.storeStatus().writable) report.stoppedBecause = cacheFullMessage(cache);
      if (progress && report.written % 64 == 0) progress(report);
    }
  }
  settleWriteBehind(cache, before, report);
  if (progress) progress(report);
  return report;
}

} // namespace tellus

// ------------------------------------------------------------------------------ through the
// service

namespace tellus {

namespace {

using Steady = std::chrono::steady_clock;

/**
 * One run of seedThroughService: the work list (every key of the range, per level), then the
 * tiles the index does not hold yet asked of the tile service, a tile or a metatile's missing
 * tiles per unit of work, at most `concurrency` units at once and paced by `rate`; the failed ones
 * retried tile by tile after the pass. A tile the cache refuses for lack of space stops it.
 */
class ServiceSeeder {
public:
  ServiceSeeder(TileService& tiles,
                TileCache& cache,
                const std::string& layer,
                const ServiceSeedOptions& options,
                const SeedProgress& progress)
      : tiles_(tiles), cache_(cache), layer_(layer), options_(options), progress_(progress),
        started_(Steady::now()) {}

  /** Every key of `box` at each level of the range, counted as planned. */
  std::expected<std::vector<std::vector<TileKey>>, std::string> plan(const TileGrid& grid,
                                                                     const Sector& box) {
    std::vector<std::vector<TileKey>> levels;
    for (std::int32_t level = std::max(0, options_.range.fromLevel);
         level <= std::min(options_.range.toLevel, grid.numLevels() - 1);
         ++level) {
      auto keys = grid.keysCovering(box, level);
      if (!keys)
        return std::unexpected("level " + std::to_string(level) +
                               " has too many tiles to seed at once: narrow --bbox");
      report_.planned += static_cast<std::int64_t>(keys->size());
      levels.push_back(std::move(*keys));
    }
    return levels;
  }

  SeedReport dryRun() {
    report_.bytes = report_.planned * options_.estimateBytesPerTile;
    if (progress_) progress_(report_, elapsed());
    return report_;
  }

  SeedReport noRoom(std::string why) {
    report_.stoppedBecause = std::move(why);
    return report_;
  }

  SeedReport run(DatasetId dataset, const std::vector<std::vector<TileKey>>& levels) {
    storeBefore_ = cache_.storeStatus();
    lastProgress_ = Steady::now();
    interval_ = options_.rate > 0 ? std::chrono::duration<double>(1.0 / options_.rate)
                                  : std::chrono::duration<double>(0);
    nextStart_ = Steady::now();
    // Metatile order: each level's missing tiles grouped by the n x n block they belong to,
    // blocks from the south-west, one request per block (n = 1: tile by tile, row-major).
    const std::int32_t n = std::max<std::int32_t>(1, tiles_.metaTileSize(layer_));
    for (const auto& keys : levels) {
      if (isStopped()) break;
      seedLevel(dataset, keys, n);
    }
    retryFailed();
    waitForAll();
    settleWriteBehind(cache_, storeBefore_, report_);
    if (progress_) progress_(report_, elapsed());
    return report_;
  }

private:
  double elapsed() const { return std::chrono::duration<double>(Steady::now() - started_).count(); }

  void seedLevel(DatasetId dataset, const std::vector<TileKey>& keys, std::int32_t n) {
    std::map<std::pair<std::int64_t, std::int64_t>, std::vector<TileKey>> blocks;
    for (const TileKey& key : keys) {
      if (n == 1 && isStopped()) break;
      if (held(dataset, key)) {
        std::lock_guard lock(mutex_);
        ++report_.skipped;
        continue;
      }
      if (n == 1) {
        start({key}, 0);
      } else {
        blocks[{key.row - key.row % n, key.col - key.col % n}].push_back(key);
      }
    }
    for (auto& [origin, missing] : blocks) {
      if (isStopped()) break;
      start(std::move(missing), 0);
    }
  }

  /** Whether the index holds the tile already (resumable without a file-system scan): a tile, or
   * an absent marker; an expired tile too, unless `refresh`. */
  bool held(DatasetId dataset, const TileKey& key) const {
    const auto known = cache_.peek(dataset, key);
    return known && known->kind != CacheLookup::Kind::Miss &&
           !(options_.refresh && known->kind == CacheLookup::Kind::Hit && known->stale);
  }

  /** Retries, after the first pass, with a pause that grows per round. */
  void retryFailed() {
    for (int round = 1;; ++round) {
      std::deque<std::pair<TileKey, int>> batch;
      {
        std::unique_lock lock(mutex_);
        cv_.wait(lock, [&] { return inFlight_ == 0; });
        batch.swap(retryQueue_);
      }
      if (batch.empty() || isStopped()) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(250) * round);
      for (const auto& [key, attempt] : batch) {
        {
          std::lock_guard lock(mutex_);
          if (stopped_) break;
          ++report_.retried;
        }
        start({key}, attempt);
      }
    }
  }

  void waitForAll() {
    std::unique_lock lock(mutex_);
    cv_.wait(lock, [&] { return inFlight_ == 0; });
  }

  /** One unit of work: a tile, or the missing tiles of one metatile (one upstream request); the
   * window (`concurrency`) counts units. Retries go tile by tile: an upstream that cannot answer
   * a metatile (too large an image, a timeout) still gets its tiles asked one at a time. */
  void start(std::vector<TileKey> keys, int attempt) {
    pace(keys.size());
    {
      std::unique_lock lock(mutex_);
      cv_.wait(lock, [&] { return inFlight_ < options_.concurrency; });
      if (stopped_) return; // the cache is full: fetching more would only be thrown away
      ++inFlight_;
    }
    if (keys.size() == 1) {
      const TileKey key = keys.front();
      tiles_.getTile(layer_, options_.time, key, [this, key, attempt](TileAnswer&& a) {
        std::lock_guard lock(mutex_);
        count(key, attempt, a);
        --inFlight_;
        cv_.notify_all();
      });
    } else {
      auto remaining = std::make_shared<std::size_t>(keys.size()); // guarded by `mutex_`
      tiles_.getTiles(layer_,
                      options_.time,
                      keys,
                      [this, remaining, attempt](const TileKey& k, TileAnswer&& a) {
                        std::lock_guard lock(mutex_);
                        count(k, attempt, a);
                        if (--*remaining == 0) {
                          --inFlight_;
                          cv_.notify_all();
                        }
                      });
    }
    reportProgress();
  }

  /** Paces starts evenly, in tiles per second (`rate`). */
  void pace(std::size_t tiles) {
    if (options_.rate <= 0) return;
    std::this_thread::sleep_until(nextStart_);
    nextStart_ = std::max(nextStart_, Steady::now()) +
                 std::chrono::duration_cast<Steady::duration>(interval_ * tiles);
  }

  void reportProgress() {
    if (!progress_) return;
    std::lock_guard lock(mutex_);
    if (Steady::now() - lastProgress_ >= std::chrono::milliseconds(200)) {
      lastProgress_ = Steady::now();
      progress_(report_, elapsed());
    }
  }

  /** One answer for one tile (under `mutex_`). */
  void count(const TileKey& key, int attempt, const TileAnswer& a) {
    const bool full = a.notStored && a.notStored->code == CacheErrc::DiskFull;
    if (a.kind == TileAnswer::Kind::Tile && !a.notStored) {
      ++report_.written;
      report_.bytes += a.file ? a.file->size() : static_cast<std::int64_t>(a.bytes.size());
      // A write-behind row the index refused (its put had returned): stop as for a refusal.
      if (!cache_.storeStatus().writable) stop(cacheFullMessage(cache_));
    } else if (a.kind == TileAnswer::Kind::Tile && full) {
      ++report_.notStored;
      stop(a.notStored->message);
    } else if (a.kind == TileAnswer::Kind::Absent && a.origin != TileOrigin::Offline) {
      ++report_.absent;
    } else if (attempt < options_.retries && !stopped_) {
      retryQueue_.emplace_back(key, attempt + 1);
    } else {
      ++report_.failed;
      if (report_.failures.size() < 20) {
        const std::string why = a.notStored ? "not stored: " + a.notStored->message : a.message;
        report_.failures.push_back("L" + std::to_string(key.level) + " R" +
                                   std::to_string(key.row) + " C" + std::to_string(key.col) + ": " +
                                   why);
      }
    }
  }

  /** Nothing more is started (under `mutex_`). */
  void stop(std::string why) {
    if (stopped_) return;
    stopped_ = true;
    report_.stoppedBecause = std::move(why);
  }

  bool isStopped() {
    std::lock_guard lock(mutex_);
    return stopped_;
  }

  TileService& tiles_;
  TileCache& cache_;
  const std::string& layer_;
  const ServiceSeedOptions& options_;
  const SeedProgress& progress_;
  const Steady::time_point started_;

  std::mutex mutex_;
  std::condition_variable cv_;
  // Guarded by mutex_.
  SeedReport report_;
  int inFlight_ = 0;
  /// Set once the cache refuses a tile for lack of space: nothing more is started.
  bool stopped_ = false;
  std::deque<std::pair<TileKey, int>> retryQueue_; // key, attempts so far
  Steady::time_point lastProgress_{};
  // The calling thread's.
  StoreStatus storeBefore_{};
  std::chrono::duration<double> interval_{0};
  Steady::time_point nextStart_{};
};

} // namespace

std::expected<SeedReport, std::string> seedThroughService(TileService& tiles,
                                                          TileCache& cache,
                                                          const std::string& layerName,
                                                          const ServiceSeedOptions& options,
                                                          const SeedProgress& progress) {
  const LayerSpec* layer = tiles.layer(layerName);
  const TileGrid* grid = tiles.grid(layerName);
  if (!layer || !grid) return std::unexpected("no layer '" + layerName + "'");
  if (options.concurrency < 1) return std::unexpected("concurrency must be at least 1");
  if (!(options.rate >= 0) || !std::isfinite(options.rate))
    return std::unexpected("rate must be a finite number >= 0");
  const auto spec = tiles.describe(layerName, options.time);
  if (!spec) return std::unexpected("layer '" + layerName + "' has no dataset");
  auto dataset = cache.registerDataset(*spec);
  // A cache too full to register the dataset stops the run (below, after a dry run's count).
  const bool noRoom = !dataset && dataset.error().code == CacheErrc::DiskFull;
  if (!dataset && !noRoom) return std::unexpected("cache: " + dataset.error().message);

  ServiceSeeder seeder(tiles, cache, layerName, options, progress);
  const auto levels = seeder.plan(*grid, options.range.box.value_or(spec->grid.sector));
  if (!levels) return std::unexpected(levels.error());
  if (options.range.dryRun) return seeder.dryRun();
  if (noRoom) return seeder.noRoom(dataset.error().message);
  return seeder.run(*dataset, *levels);
}

} // namespace tellus
