// CacheMaintenance: statistics, verify, rebuild, prune, eviction; and TileCache's methods of the
// same names, which are these.

#include "CacheCore.hpp"
#include "RowRemoval.hpp"

#include <tellus/cache/CacheMaintenance.hpp>
#include <tellus/cache/TilePath.hpp>

#include <algorithm>
#include <limits>
#include <map>

namespace tellus {

namespace {

using Result = std::expected<void, CacheError>;

PruneSelection selectionFor(const PruneOptions& options, UnixMillis now) {
  PruneSelection s;
  if (options.olderThan) s.fetchedBefore = now - options.olderThan->count();
  s.datasetName = options.datasetName;
  s.includePinned = options.includePinned;
  return s;
}

/** A tile's path relative to the cache root, as verify reports it. */
std::string reportPath(const DatasetInfo& info, const TileKey& key) {
  return info.folder + "/" + tileRelativePath(key, info.spec.extension);
}

/** Rows -> tiles: every present row's tile is there with its size. */
Result checkRows(TileCache::Impl& im, const DatasetInfo& info, VerifyReport& report) {
  return im.index->forEachTile(
      info.id, 0, std::numeric_limits<std::int32_t>::max(), [&](const TileKey& k, std::int64_t n) {
        const auto stored = im.store->stat(TileLocation{info.folder, info.spec.extension, k});
        if (!stored)
          report.rowsWithoutFiles.push_back(reportPath(info, k));
        else if (stored->size != n)
          report.sizeMismatches.push_back(reportPath(info, k));
        return true;
      });
}

/** Tiles -> rows: every stored tile is named like one and has a present row; temp files. */
void checkStored(TileCache::Impl& im, const DatasetInfo& info, VerifyReport& report) {
  im.store->scan(info.folder, [&](const StoreEntry& e) {
    const std::string path = info.folder + "/" + e.path;
    if (e.kind == StoreEntry::Kind::Temp) {
      // A running writer's (a tile on its way, a replaced tile kept until its commit) is fine.
      if (e.tempOwnerAlive)
        ++report.tempFilesInUse;
      else
        report.strayTempFiles.push_back(path);
      return;
    }
    if (e.kind == StoreEntry::Kind::Descriptor) return;
    std::string ext;
    const auto key = parseTileRelativePath(e.path, &ext);
    if (!key || ext != info.spec.extension) {
      report.filesWithoutRows.push_back(path);
      return;
    }
    const auto row = im.index->lookup(info.id, *key);
    if (!row || !*row || !(*row)->present) report.filesWithoutRows.push_back(path);
  });
}

/** Indexes one dataset folder of the store; returns the tiles indexed. Writer, in a transaction. */
std::expected<std::int64_t, CacheError> rebuildDataset(TileCache::Impl& im,
                                                       const std::string& folder) {
  const auto text = im.store->readDescriptor(folder);
  if (!text) return 0;
  const auto spec = parseDatasetSpec(*text);
  if (!spec) return 0;
  auto grid = TileGrid::create(spec->grid);
  if (!grid) return 0;
  auto info = im.index->upsertDataset(*spec, folder, im.clock->now());
  if (!info) return std::unexpected(info.error());
  std::int64_t indexed = 0;
  Result failed;
  im.store->scan(folder, [&](const StoreEntry& e) {
    if (!failed) return;
    if (e.kind == StoreEntry::Kind::Temp) {
      // An interrupted write is never a valid tile; a running writer's is left to it.
      if (!e.tempOwnerAlive) im.store->removeEntry(folder, e.path);
      return;
    }
    if (e.kind != StoreEntry::Kind::Tile) return;
    std::string ext;
    const auto key = parseTileRelativePath(e.path, &ext);
    if (!key || ext != spec->extension || !grid->isValid(*key)) return;
    TileMeta m;
    m.contentType = spec->mimeType;
    m.fetchedAt = e.modified;
    failed = im.writeRow(info->id, *key, TileRow{true, e.size, m, std::nullopt});
    if (failed) ++indexed;
  });
  if (!failed) return std::unexpected(failed.error());
  return indexed;
}

} // namespace

CacheMaintenance::CacheMaintenance(TileCache& cache) noexcept : impl_(cache.impl_.get()) {}

std::expected<std::int64_t, CacheError> CacheMaintenance::totalBytes() const {
  return impl_->index->totalBytes();
}

std::expected<std::vector<DatasetStats>, CacheError> CacheMaintenance::stats() const {
  TileCache::Impl& im = *impl_;
  const auto infos = im.datasets.all();
  std::map<DatasetId, DatasetStats> byId;
  for (const auto& info : infos)
    byId[info.id].dataset = info;
  auto counts = im.index->levelCounts();
  if (!counts) return std::unexpected(counts.error());
  for (const auto& c : *counts) {
    auto it = byId.find(c.dataset);
    if (it == byId.end()) continue;
    it->second.tiles += c.level.tiles;
    it->second.bytes += c.level.bytes;
    it->second.levels.push_back(c.level);
  }
  std::vector<DatasetStats> out;
  for (auto& [id, st] : byId)
    out.push_back(std::move(st));
  return out;
}

std::expected<std::vector<DatasetStats>, CacheError>
CacheMaintenance::prunable(const PruneOptions& options) const {
  TileCache::Impl& im = *impl_;
  const PruneSelection selection = selectionFor(options, im.clock->now());
  const auto infos = im.datasets.all();
  auto counts = im.index->countPrunable(selection);
  if (!counts) return std::unexpected(counts.error());
  std::vector<DatasetStats> out;
  for (const auto& c : *counts) {
    const auto info = std::find_if(
        infos.begin(), infos.end(), [&](const DatasetInfo& d) { return d.id == c.dataset; });
    if (info == infos.end()) continue;
    out.push_back(DatasetStats{*info, c.tiles, c.bytes, {}});
  }
  return out;
}

std::expected<VerifyReport, CacheError> CacheMaintenance::verify() const {
  TileCache::Impl& im = *impl_;
  VerifyReport report;
  const auto infos = im.datasets.all();
  report.integrity = im.index->integrity();
  for (const auto& info : infos) {
    if (auto r = checkRows(im, info, report); !r) return std::unexpected(r.error());
  }
  // Temp files beside the index (a damage marker being written).
  im.store->scan("", [&](const StoreEntry& e) {
    if (e.kind != StoreEntry::Kind::Temp) return;
    if (e.tempOwnerAlive)
      ++report.tempFilesInUse;
    else
      report.strayTempFiles.push_back(e.path);
  });
  for (const auto& info : infos)
    checkStored(im, info, report);
  return report;
}

std::expected<std::int64_t, CacheError> CacheMaintenance::rebuild() {
  TileCache::Impl& im = *impl_;
  if (im.options.readOnly)
    return std::unexpected(CacheError{CacheErrc::ReadOnly, "the cache is read-only"});
  std::int64_t indexed = 0;
  auto r = im.writer.submit([&]() -> Result {
    im.writer.allRowsChanged();
    if (auto c = im.index->clear(); !c) return c;
    im.store->removeDeadTemps("");
    for (const auto& folder : im.store->datasetFolders()) {
      auto n = rebuildDataset(im, folder);
      if (!n) return std::unexpected(n.error());
      indexed += *n;
    }
    return {};
  });
  // After the commit (or the rollback): the datasets as the index has them now.
  (void)im.datasets.load();
  if (!r) return std::unexpected(r.error());
  return indexed;
}

std::expected<std::int64_t, CacheError> CacheMaintenance::prune(const PruneOptions& options) {
  TileCache::Impl& im = *impl_;
  const PruneSelection selection = selectionFor(options, im.clock->now());
  std::expected<std::int64_t, CacheError> removed = 0;
  auto r = im.writer.submit(
      [&]() -> Result {
        removed = detail::removeSelected(
            im,
            [&](const ITileIndex::RowVisitor& visit) {
              return im.index->forEachPrunable(selection, visit);
            },
            std::numeric_limits<std::int64_t>::max(),
            std::nullopt);
        return {};
      },
      {},
      true);
  if (!r) return std::unexpected(r.error());
  return removed;
}

std::expected<std::int64_t, CacheError> CacheMaintenance::evictToLimit() {
  TileCache::Impl& im = *impl_;
  std::expected<std::int64_t, CacheError> evicted = 0;
  auto r = im.writer.submit(
      [&]() -> Result {
        evicted = detail::evictOverLimit(im);
        return {};
      },
      {},
      true);
  if (!r) return std::unexpected(r.error());
  return evicted;
}

// ---------------------------------------------------------------------------------- TileCache

std::expected<std::vector<DatasetStats>, CacheError> TileCache::stats() const {
  return CacheMaintenance(*impl_).stats();
}
std::expected<std::vector<DatasetStats>, CacheError>
TileCache::prunable(const PruneOptions& options) const {
  return CacheMaintenance(*impl_).prunable(options);
}
std::expected<VerifyReport, CacheError> TileCache::verify() const {
  return CacheMaintenance(*impl_).verify();
}
std::expected<std::int64_t, CacheError> TileCache::rebuild() {
  return CacheMaintenance(*impl_).rebuild();
}
std::expected<std::int64_t, CacheError> TileCache::prune(const PruneOptions& options) {
  return CacheMaintenance(*impl_).prune(options);
}
std::expected<std::int64_t, CacheError> TileCache::evictToLimit() {
  return CacheMaintenance(*impl_).evictToLimit();
}
std::expected<std::int64_t, CacheError> TileCache::totalBytes() const {
  return CacheMaintenance(*impl_).totalBytes();
}

} // namespace tellus
