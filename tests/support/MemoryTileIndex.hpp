#pragma once
/**
 * @file MemoryTileIndex.hpp
 * @brief An ITileIndex in memory, for tests: built on the public interface alone, it is what shows
 * that the seam is complete (the cache's own suite runs against it and against SQLite alike).
 *
 * Committed state is read under a shared lock; a transaction works on a copy of it (begin() copies
 * every row, so transactions cost O(rows): fine for tests, not for a server) that commit() puts in
 * place at once, so readers see committed state only, as with a database. Savepoints are copies of
 * the working state. One process only: changedByOthers() is always false.
 */

#include <tellus/cache/TileIndex.hpp>

#include <atomic>
#include <map>
#include <optional>
#include <shared_mutex>
#include <tuple>
#include <vector>

namespace tellus::test {

class MemoryTileIndex final : public ITileIndex {
public:
  bool damagedAtOpen() const noexcept override { return false; }

  std::expected<std::optional<TileRow>, CacheError> lookup(DatasetId id,
                                                           const TileKey& key) override;
  std::expected<std::vector<DatasetInfo>, CacheError> datasets() override;
  std::expected<std::optional<DatasetInfo>, CacheError>
  datasetInFolder(std::string_view folder) override;
  Result forEachTile(DatasetId id,
                     std::int32_t fromLevel,
                     std::int32_t toLevel,
                     const TileVisitor& visit) override;
  std::expected<std::int64_t, CacheError> totalBytes() override;
  std::expected<std::vector<IndexLevelCount>, CacheError> levelCounts() override;
  std::expected<std::vector<IndexSelectionCount>, CacheError>
  countPrunable(const PruneSelection& selection) override;
  std::string integrity() override { return "ok"; }

  Result begin() override;
  Result commit() override;
  void rollback() override;
  void savepoint() override;
  void releaseSavepoint() override;
  void rollbackToSavepoint() override;
  Result putRow(DatasetId id, const TileKey& key, const TileRow& row) override;
  Result deleteRow(DatasetId id, const TileKey& key) override;
  Result revalidate(DatasetId id, const TileKey& key, const TileMeta& meta) override;
  void touch(DatasetId id, const TileKey& key, UnixMillis when) override;
  std::expected<std::optional<std::int64_t>, CacheError> presentBytes(DatasetId id,
                                                                      const TileKey& key) override;
  std::expected<DatasetInfo, CacheError>
  upsertDataset(const DatasetSpec& spec, std::string_view folder, UnixMillis createdAt) override;
  Result setPinned(DatasetId id, bool pinned) override;
  Result clear() override;
  Result forEachPrunable(const PruneSelection& selection, const RowVisitor& visit) override;
  Result forEachEvictable(const RowVisitor& visit) override;
  bool changedByOthers() override { return false; }

  /** Makes the next commits fail with `error` (a full index, ...) until cleared with nullopt. */
  void failCommits(std::optional<CacheError> error);
  /** Makes lookups fail with `error` (a database out of reach) until cleared with nullopt. */
  void failLookups(std::optional<CacheError> error);
  /** How many rows were looked up so far (what a database would be asked). */
  std::int64_t lookups() const { return lookups_.load(); }

private:
  using RowId = std::tuple<DatasetId, std::int32_t, std::int64_t, std::int64_t>;
  struct Row {
    TileRow row;
    UnixMillis lastAccess = 0;
  };
  struct Tables {
    std::map<RowId, Row> tiles;
    std::map<DatasetId, DatasetInfo> datasets;
    DatasetId nextId = 1;
  };

  std::optional<CacheError> failLookups_; // under mutex_
  std::atomic<std::int64_t> lookups_{0};
  static RowId idOf(DatasetId id, const TileKey& key) { return {id, key.level, key.row, key.col}; }
  static TileKey keyOf(const RowId& id) {
    return TileKey{std::get<1>(id), std::get<2>(id), std::get<3>(id)};
  }
  static bool prunable(const Tables& t, const PruneSelection& s, const RowId& id, const Row& r);
  /** What a write sees: the transaction's copy. */
  Tables& working();
  Result visitSelected(std::vector<SelectedRow> rows, const RowVisitor& visit);

  mutable std::shared_mutex mutex_; // guards committed_
  Tables committed_;
  // The writer's (one thread at a time).
  std::optional<Tables> working_;
  std::vector<Tables> savepoints_;
  std::optional<CacheError> failCommits_;
};

} // namespace tellus::test
