#include "MemoryTileIndex.hpp"

#include <algorithm>
#include <mutex>

namespace tellus::test {

namespace {

CacheError noTransaction() {
  return CacheError{CacheErrc::Io, "memory index: a write outside a transaction"};
}

} // namespace

// ---------------------------------------------------------------------------------- reads

std::expected<std::optional<TileRow>, CacheError> MemoryTileIndex::lookup(DatasetId id,
                                                                          const TileKey& key) {
  ++lookups_;
  std::shared_lock lock(mutex_);
  if (failLookups_) return std::unexpected(*failLookups_);
  const auto it = committed_.tiles.find(idOf(id, key));
  if (it == committed_.tiles.end()) return std::nullopt;
  return it->second.row;
}

std::expected<std::vector<DatasetInfo>, CacheError> MemoryTileIndex::datasets() {
  std::shared_lock lock(mutex_);
  std::vector<DatasetInfo> out;
  for (const auto& [id, d] : committed_.datasets)
    out.push_back(d);
  return out;
}

std::expected<std::optional<DatasetInfo>, CacheError>
MemoryTileIndex::datasetInFolder(std::string_view folder) {
  std::shared_lock lock(mutex_);
  for (const auto& [id, d] : committed_.datasets) {
    if (d.folder == folder) return d;
  }
  return std::nullopt;
}

MemoryTileIndex::Result MemoryTileIndex::forEachTile(DatasetId id,
                                                     std::int32_t fromLevel,
                                                     std::int32_t toLevel,
                                                     const TileVisitor& visit) {
  std::vector<std::pair<TileKey, std::int64_t>> tiles;
  {
    std::shared_lock lock(mutex_);
    const auto from = committed_.tiles.lower_bound(RowId{id, fromLevel, INT64_MIN, INT64_MIN});
    for (auto it = from; it != committed_.tiles.end() && std::get<0>(it->first) == id; ++it) {
      if (std::get<1>(it->first) > toLevel) break;
      if (it->second.row.present) tiles.emplace_back(keyOf(it->first), it->second.row.bytes);
    }
  }
  for (const auto& [key, bytes] : tiles) {
    if (!visit(key, bytes)) break;
  }
  return {};
}

std::expected<std::int64_t, CacheError> MemoryTileIndex::totalBytes() {
  std::shared_lock lock(mutex_);
  std::int64_t total = 0;
  for (const auto& [id, r] : committed_.tiles)
    total += r.row.bytes;
  return total;
}

std::expected<std::vector<IndexLevelCount>, CacheError> MemoryTileIndex::levelCounts() {
  std::shared_lock lock(mutex_);
  std::map<std::pair<DatasetId, std::int32_t>, LevelStats> counts;
  for (const auto& [id, r] : committed_.tiles) {
    LevelStats& l = counts[{std::get<0>(id), std::get<1>(id)}];
    l.level = std::get<1>(id);
    ++l.tiles;
    l.absent += r.row.present ? 0 : 1;
    l.bytes += r.row.bytes;
  }
  std::vector<IndexLevelCount> out;
  for (const auto& [k, l] : counts)
    out.push_back(IndexLevelCount{k.first, l});
  return out;
}

bool MemoryTileIndex::prunable(const Tables& t,
                               const PruneSelection& s,
                               const RowId& id,
                               const Row& r) {
  const auto d = t.datasets.find(std::get<0>(id));
  if (d == t.datasets.end()) return false; // the join finds no dataset
  return r.row.meta.fetchedAt < s.fetchedBefore &&
         (!s.datasetName || d->second.spec.name == *s.datasetName) &&
         (s.includePinned || !d->second.spec.pinned);
}

std::expected<std::vector<IndexSelectionCount>, CacheError>
MemoryTileIndex::countPrunable(const PruneSelection& selection) {
  std::shared_lock lock(mutex_);
  std::map<DatasetId, IndexSelectionCount> counts;
  for (const auto& [id, r] : committed_.tiles) {
    if (!prunable(committed_, selection, id, r)) continue;
    IndexSelectionCount& c = counts[std::get<0>(id)];
    c.dataset = std::get<0>(id);
    ++c.tiles;
    c.bytes += r.row.bytes;
  }
  std::vector<IndexSelectionCount> out;
  for (const auto& [id, c] : counts)
    out.push_back(c);
  return out;
}

// ---------------------------------------------------------------------------------- transactions

MemoryTileIndex::Result MemoryTileIndex::begin() {
  if (working_) return std::unexpected(CacheError{CacheErrc::Io, "memory index: nested begin"});
  std::shared_lock lock(mutex_);
  working_ = committed_;
  return {};
}

MemoryTileIndex::Result MemoryTileIndex::commit() {
  if (!working_) return std::unexpected(noTransaction());
  std::unique_lock lock(mutex_);
  if (failCommits_) {
    const CacheError e = *failCommits_;
    lock.unlock();
    rollback();
    return std::unexpected(e);
  }
  committed_ = std::move(*working_);
  working_.reset();
  savepoints_.clear();
  return {};
}

void MemoryTileIndex::rollback() {
  working_.reset();
  savepoints_.clear();
}

void MemoryTileIndex::savepoint() {
  if (working_) savepoints_.push_back(*working_);
}

void MemoryTileIndex::releaseSavepoint() {
  if (!savepoints_.empty()) savepoints_.pop_back();
}

void MemoryTileIndex::rollbackToSavepoint() {
  if (working_ && !savepoints_.empty()) *working_ = savepoints_.back();
}

void MemoryTileIndex::failCommits(std::optional<CacheError> error) {
  std::unique_lock lock(mutex_);
  failCommits_ = std::move(error);
}

void MemoryTileIndex::failLookups(std::optional<CacheError> error) {
  std::unique_lock lock(mutex_);
  failLookups_ = std::move(error);
}

MemoryTileIndex::Tables& MemoryTileIndex::working() {
  return *working_;
}

// ---------------------------------------------------------------------------------- writes

MemoryTileIndex::Result
MemoryTileIndex::putRow(DatasetId id, const TileKey& key, const TileRow& row) {
  if (!working_) return std::unexpected(noTransaction());
  working().tiles[idOf(id, key)] = Row{row, row.meta.fetchedAt};
  return {};
}

MemoryTileIndex::Result MemoryTileIndex::deleteRow(DatasetId id, const TileKey& key) {
  if (!working_) return std::unexpected(noTransaction());
  working().tiles.erase(idOf(id, key));
  return {};
}

MemoryTileIndex::Result
MemoryTileIndex::revalidate(DatasetId id, const TileKey& key, const TileMeta& meta) {
  if (!working_) return std::unexpected(noTransaction());
  const auto it = working().tiles.find(idOf(id, key));
  if (it == working().tiles.end() || !it->second.row.present) return {};
  TileMeta& m = it->second.row.meta;
  m.expiresAt = meta.expiresAt;
  m.etag = meta.etag;
  m.lastModified = meta.lastModified;
  m.fetchedAt = meta.fetchedAt;
  return {};
}

void MemoryTileIndex::touch(DatasetId id, const TileKey& key, UnixMillis when) {
  if (!working_) return;
  const auto it = working().tiles.find(idOf(id, key));
  if (it != working().tiles.end()) it->second.lastAccess = std::max(it->second.lastAccess, when);
}

std::expected<std::optional<std::int64_t>, CacheError>
MemoryTileIndex::presentBytes(DatasetId id, const TileKey& key) {
  std::shared_lock lock(mutex_, std::defer_lock);
  if (!working_) lock.lock();
  const Tables& t = working_ ? *working_ : committed_;
  const auto it = t.tiles.find(idOf(id, key));
  if (it == t.tiles.end() || !it->second.row.present) return std::nullopt;
  return it->second.row.bytes;
}

std::expected<DatasetInfo, CacheError> MemoryTileIndex::upsertDataset(const DatasetSpec& spec,
                                                                      std::string_view folder,
                                                                      UnixMillis createdAt) {
  if (!working_) return std::unexpected(noTransaction());
  for (auto& [id, d] : working().datasets) {
    if (d.folder != folder) continue;
    d.spec.pinned = spec.pinned;
    return d;
  }
  const DatasetId id = working().nextId++;
  DatasetInfo info{id, spec, std::string(folder), createdAt};
  working().datasets.emplace(id, info);
  return info;
}

MemoryTileIndex::Result MemoryTileIndex::setPinned(DatasetId id, bool pinned) {
  if (!working_) return std::unexpected(noTransaction());
  if (auto it = working().datasets.find(id); it != working().datasets.end())
    it->second.spec.pinned = pinned;
  return {};
}

MemoryTileIndex::Result MemoryTileIndex::clear() {
  if (!working_) return std::unexpected(noTransaction());
  working() = Tables{};
  return {};
}

// ---------------------------------------------------------------------------------- selections

MemoryTileIndex::Result MemoryTileIndex::visitSelected(std::vector<SelectedRow> rows,
                                                       const RowVisitor& visit) {
  for (const auto& r : rows) {
    if (!visit(r)) break;
  }
  return {};
}

MemoryTileIndex::Result MemoryTileIndex::forEachPrunable(const PruneSelection& selection,
                                                         const RowVisitor& visit) {
  std::vector<SelectedRow> rows;
  {
    std::shared_lock lock(mutex_);
    for (const auto& [id, r] : committed_.tiles) {
      if (!prunable(committed_, selection, id, r)) continue;
      const DatasetInfo& d = committed_.datasets.at(std::get<0>(id));
      rows.push_back(SelectedRow{d.id, keyOf(id), d.folder, d.spec.extension, r.row.bytes});
    }
  }
  return visitSelected(std::move(rows), visit);
}

MemoryTileIndex::Result MemoryTileIndex::forEachEvictable(const RowVisitor& visit) {
  std::vector<std::pair<UnixMillis, SelectedRow>> rows;
  {
    std::shared_lock lock(mutex_);
    for (const auto& [id, r] : committed_.tiles) {
      const auto d = committed_.datasets.find(std::get<0>(id));
      if (d == committed_.datasets.end() || d->second.spec.pinned || !r.row.present) continue;
      rows.emplace_back(
          r.lastAccess,
          SelectedRow{
              d->first, keyOf(id), d->second.folder, d->second.spec.extension, r.row.bytes});
    }
  }
  std::stable_sort(
      rows.begin(), rows.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<SelectedRow> ordered;
  for (auto& [when, row] : rows)
    ordered.push_back(std::move(row));
  return visitSelected(std::move(ordered), visit);
}

} // namespace tellus::test
