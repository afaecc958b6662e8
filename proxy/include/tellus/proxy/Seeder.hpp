#pragma once
/**
 * @file Seeder.hpp
 * @brief Fills the cache with the tiles of a layer over a range of levels from a tile renderer.
 *
 * Resumable by construction: a tile the index already holds (present or absent) is skipped without
 * touching the file system. Honest about a full disk: `written` counts the tiles the cache really
 * kept (write-behind rows that could not be committed are taken back at the end), and once the
 * cache refuses a tile for lack of space nothing more is fetched (`stoppedBecause`).
 */

#include <tellus/cache/TileCache.hpp>
#include <tellus/cache/TileGrid.hpp>

#include <cstdint>
#include <expected>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace tellus {

class LocalRasterSource;
class TileService;

struct SeedOptions {
  std::int32_t fromLevel = 0;
  std::int32_t toLevel = 0;
  std::optional<Sector> box; ///< default: the dataset's sector
  bool dryRun = false;       ///< count only
  /// seedFromRaster, heights and values formats: the no-data sample of the tiles and of the
  /// source (LocalRasterSource::renderTile); the layer's (LayerSpec::noData).
  std::int16_t noData = -32768;
};

struct SeedReport {
  std::int64_t planned = 0; ///< tiles in the levels and box
  std::int64_t skipped = 0; ///< already in the index
  std::int64_t written = 0; ///< stored in the cache (its rows committed)
  std::int64_t absent = 0;  ///< the upstream has no tile there (remembered, not a failure)
  std::int64_t retried = 0; ///< extra attempts for tiles that failed
  std::int64_t failed = 0;
  std::int64_t notStored = 0;        ///< fetched or rendered, then refused by a full cache
  std::int64_t bytes = 0;            ///< bytes written
  std::vector<std::string> failures; ///< first few failure messages
  /// Non-empty when seeding stopped early because the cache refused a tile for lack of space (the
  /// message names the cache root and its free bytes and inodes); the tiles not started then were
  /// neither fetched nor counted.
  std::string stoppedBecause;
};

/** Seeding through the tile service: any upstream (WMS, World Wind, local), with its caps,
 * single-flight and validation; `tellus serve` may run on the same cache at the same time. */
struct ServiceSeedOptions {
  SeedOptions range;
  std::string time;     ///< a validated TIME value, "" for none
  int concurrency = 4;  ///< tiles in flight at once (>= 1)
  double rate = 0;      ///< tiles started per second; 0 = unlimited
  int retries = 2;      ///< further attempts for a tile that failed (errors, not absent)
  bool refresh = false; ///< also fetch again tiles whose expiry has passed
  std::int64_t estimateBytesPerTile = 0; ///< dry run: bytes per tile for the estimate
};

/** Progress of a seeding run: the report so far and the seconds since it began. */
using SeedProgress = std::function<void(const SeedReport&, double seconds)>;

/** Seeds a layer through the service. Fails only for bad options or too large a range; tile
 * failures are counted and listed in the report, and a full cache stops it (stoppedBecause). */
std::expected<SeedReport, std::string> seedThroughService(TileService& tiles,
                                                          TileCache& cache,
                                                          const std::string& layer,
                                                          const ServiceSeedOptions& options,
                                                          const SeedProgress& progress = {});

/** Seeds one registered dataset from a local raster. Stops early only for a full disk
 * (stoppedBecause). */
std::expected<SeedReport, CacheError>
seedFromRaster(TileCache& cache,
               DatasetId dataset,
               const LocalRasterSource& source,
               const SeedOptions& options,
               const std::function<void(const SeedReport&)>& progress = {});

} // namespace tellus
