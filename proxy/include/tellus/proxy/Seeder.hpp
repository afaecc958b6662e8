#pragma once
/**
 * @file Seeder.hpp
 * @brief Fills the cache with the tiles of a layer over a range of levels from a tile renderer.
 *
 * Resumable by construction: a tile the index already holds (present or absent) is skipped without
 * touching the file system.
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

struct SeedOptions {
  std::int32_t fromLevel = 0;
  std::int32_t toLevel = 0;
  std::optional<Sector> box; ///< default: the dataset's sector
  bool dryRun = false;       ///< count only
};

struct SeedReport {
  std::int64_t planned = 0; ///< tiles in the levels and box
  std::int64_t skipped = 0; ///< already in the index
  std::int64_t written = 0;
  std::int64_t failed = 0;
  std::int64_t bytes = 0;            ///< bytes written
  std::vector<std::string> failures; ///< first few failure messages
};

/** Seeds one registered dataset from a local raster. Stops early only for a full disk. */
std::expected<SeedReport, CacheError>
seedFromRaster(TileCache& cache,
               DatasetId dataset,
               const LocalRasterSource& source,
               const SeedOptions& options,
               const std::function<void(const SeedReport&)>& progress = {});

} // namespace tellus
