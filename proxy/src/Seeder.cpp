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
                                     info->spec.mimeType);
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

std::expected<SeedReport, std::string> seedThroughService(TileService& tiles,
                                                          TileCache& cache,
                                                          const std::string& layerName,
                                                          const ServiceSeedOptions& options,
                                                          const SeedProgress& progress) {
  using Steady = std::chrono::steady_clock;
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
  const Sector box = options.range.box.value_or(spec->grid.sector);

  SeedReport report;
  const auto started = Steady::now();
  auto elapsed = [&] { return std::chrono::duration<double>(Steady::now() - started).count(); };

  // Work list: every key of the range the index does not hold yet (resumable from the index).
  std::vector<std::vector<TileKey>> levels;
  for (std::int32_t level = std::max(0, options.range.fromLevel);
       level <= std::min(options.range.toLevel, grid->numLevels() - 1);
       ++level) {
    auto keys = grid->keysCovering(box, level);
    if (!keys)
      return std::unexpected("level " + std::to_string(level) +
                             " has too many tiles to seed at once: narrow --bbox");
    report.planned += static_cast<std::int64_t>(keys->size());
    levels.push_back(std::move(*keys));
  }
  if (options.range.dryRun) {
    report.bytes = report.planned * options.estimateBytesPerTile;
    if (progress) progress(report, elapsed());
    return report;
  }
  if (noRoom) {
    report.stoppedBecause = dataset.error().message;
    return report;
  }

  std::mutex mutex;
  std::condition_variable cv;
  int inFlight = 0;
  const StoreStatus storeBefore = cache.storeStatus();
  // Set (under `mutex`) once the cache refuses a tile for lack of space: nothing more is started.
  bool stopped = false;
  auto stop = [&](std::string why) {
    if (stopped) return;
    stopped = true;
    report.stoppedBecause = std::move(why);
  };
  std::deque<std::pair<TileKey, int>> retryQueue; // key, attempts so far
  std::vector<std::pair<TileKey, std::string>> lastErrors;
  auto lastProgress = Steady::now();

  const auto interval = options.rate > 0 ? std::chrono::duration<double>(1.0 / options.rate)
                                         : std::chrono::duration<double>(0);
  auto nextStart = Steady::now();

  // One answer for one tile (under `mutex`).
  auto count = [&](const TileKey& key, int attempt, const TileAnswer& a) {
    const bool full = a.notStored && a.notStored->code == CacheErrc::DiskFull;
    if (a.kind == TileAnswer::Kind::Tile && !a.notStored) {
      ++report.written;
      report.bytes += a.file ? a.file->size() : static_cast<std::int64_t>(a.bytes.size());
      // A write-behind row the index refused (its put had returned): stop as for a refusal.
      if (!cache.storeStatus().writable) stop(cacheFullMessage(cache));
    } else if (a.kind == TileAnswer::Kind::Tile && full) {
      ++report.notStored;
      stop(a.notStored->message);
    } else if (a.kind == TileAnswer::Kind::Absent && a.origin != TileOrigin::Offline) {
      ++report.absent;
    } else if (attempt < options.retries && !stopped) {
      retryQueue.emplace_back(key, attempt + 1);
    } else {
      ++report.failed;
      if (report.failures.size() < 20) {
        const std::string why = a.notStored ? "not stored: " + a.notStored->message : a.message;
        report.failures.push_back("L" + std::to_string(key.level) + " R" + std::to_string(key.row) +
                                  " C" + std::to_string(key.col) + ": " + why);
      }
    }
  };

  // One unit of work: a tile, or the missing tiles of one metatile (one upstream request); the
  // window (`concurrency`) counts units. Retries go tile by tile: an upstream that cannot answer
  // a metatile (too large an image, a timeout) still gets its tiles asked one at a time.
  auto start = [&](std::vector<TileKey> keys, int attempt) {
    if (options.rate > 0) { // pace starts evenly, in tiles per second
      std::this_thread::sleep_until(nextStart);
      nextStart = std::max(nextStart, Steady::now()) +
                  std::chrono::duration_cast<Steady::duration>(interval * keys.size());
    }
    {
      std::unique_lock lock(mutex);
      cv.wait(lock, [&] { return inFlight < options.concurrency; });
      if (stopped) return; // the cache is full: fetching more would only be thrown away
      ++inFlight;
    }
    if (keys.size() == 1) {
      const TileKey key = keys.front();
      tiles.getTile(layerName, options.time, key, [&, key, attempt](TileAnswer&& a) {
        std::lock_guard lock(mutex);
        count(key, attempt, a);
        --inFlight;
        cv.notify_all();
      });
    } else {
      auto remaining = std::make_shared<std::size_t>(keys.size()); // guarded by `mutex`
      tiles.getTiles(
          layerName, options.time, keys, [&, remaining, attempt](const TileKey& k, TileAnswer&& a) {
            std::lock_guard lock(mutex);
            count(k, attempt, a);
            if (--*remaining == 0) {
              --inFlight;
              cv.notify_all();
            }
          });
    }
    if (progress) {
      std::lock_guard lock(mutex);
      if (Steady::now() - lastProgress >= std::chrono::milliseconds(200)) {
        lastProgress = Steady::now();
        progress(report, elapsed());
      }
    }
  };

  // Metatile order: each level's missing tiles grouped by the n x n block they belong to, blocks
  // from the south-west, one request per block (n = 1: tile by tile, row-major).
  const std::int32_t n = std::max<std::int32_t>(1, tiles.metaTileSize(layerName));
  auto isStopped = [&] {
    std::lock_guard lock(mutex);
    return stopped;
  };
  for (const auto& keys : levels) {
    if (isStopped()) break;
    std::map<std::pair<std::int64_t, std::int64_t>, std::vector<TileKey>> blocks;
    for (const TileKey& key : keys) {
      if (n == 1 && isStopped()) break;
      const auto known = cache.peek(*dataset, key);
      const bool have = known && known->kind != CacheLookup::Kind::Miss &&
                        !(options.refresh && known->kind == CacheLookup::Kind::Hit && known->stale);
      if (have) {
        std::lock_guard lock(mutex);
        ++report.skipped;
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
  // Retries, after the first pass, with a pause that grows per round.
  for (int round = 1;; ++round) {
    std::deque<std::pair<TileKey, int>> batch;
    {
      std::unique_lock lock(mutex);
      cv.wait(lock, [&] { return inFlight == 0; });
      batch.swap(retryQueue);
    }
    if (batch.empty() || isStopped()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(250) * round);
    for (const auto& [key, attempt] : batch) {
      {
        std::lock_guard lock(mutex);
        if (stopped) break;
        ++report.retried;
      }
      start({key}, attempt);
    }
  }
  {
    std::unique_lock lock(mutex);
    cv.wait(lock, [&] { return inFlight == 0; });
  }
  settleWriteBehind(cache, storeBefore, report);
  if (progress) progress(report, elapsed());
  return report;
}

} // namespace tellus
