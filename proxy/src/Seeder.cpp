#include <tellus/proxy/LocalRasterSource.hpp>
#include <tellus/proxy/Seeder.hpp>

namespace tellus {

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
  for (std::int32_t level = std::max(0, options.fromLevel);
       level <= std::min(options.toLevel, grid->numLevels() - 1);
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
        if (put.error().code == CacheErrc::DiskFull) return std::unexpected(put.error());
        ++report.failed;
        if (report.failures.size() < 10) report.failures.push_back(put.error().message);
        continue;
      }
      ++report.written;
      report.bytes += static_cast<std::int64_t>(bytes->size());
      if (progress && report.written % 64 == 0) progress(report);
    }
  }
  if (progress) progress(report);
  return report;
}

} // namespace tellus
