#pragma once
/**
 * @file PgTileIndex.hpp
 * @brief PgTileIndex: ITileIndex over libpq (the public side is tellus/cache_pg/PgTileIndex.hpp).
 *
 * - Reads borrow a pooled connection (autocommit, so committed state only; at most
 *   maxReadConnections at once, the rest wait); one found broken is dropped and the next read
 *   connects anew, so a restarted server costs the reads in flight only.
 * - Writes use one connection; begin() reconnects it when the server went away in between.
 * - Selections (prune, eviction) stream through a cursor in a read-only transaction, 1000 rows a
 *   fetch, so a selection of millions of rows is never held in memory.
 * - changedByOthers(): each open index has a row in `tellus_writers` counting its write
 *   transactions (its own row: writers never contend for it); the others' sum moving is a change.
 */

#include "Pg.hpp"

#include <tellus/cache/TileIndex.hpp>

#include <condition_variable>
#include <mutex>
#include <vector>

namespace tellus {

class PgTileIndex final : public ITileIndex {
public:
  static std::expected<std::unique_ptr<PgTileIndex>, CacheError>
  open(const PgTileIndexOptions& options);

  bool damagedAtOpen() const noexcept override { return false; }

  // reads (PgTileIndex.cpp)
  std::expected<std::optional<TileRow>, CacheError> lookup(DatasetId id,
                                                           const TileKey& key) override;
  std::expected<std::vector<std::optional<TileRow>>, CacheError>
  lookupMany(DatasetId id, std::span<const TileKey> keys) override;
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
  std::string integrity() override;

  // writes (PgIndexWrites.cpp)
  Result begin() override;
  Result commit() override;
  void rollback() override;
  void savepoint() override;
  void releaseSavepoint() override;
  void rollbackToSavepoint() override;
  Result putRow(DatasetId id, const TileKey& key, const TileRow& row) override;
  Result putRows(DatasetId id, std::span<const std::pair<TileKey, TileRow>> rows) override;
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
  bool changedByOthers() override;

private:
  /** A read connection borrowed from the pool, given back (if still good) when this ends. */
  class Reader {
  public:
    Reader(PgTileIndex* index, pg::ConnPtr conn) : index_(index), conn_(std::move(conn)) {}
    Reader(Reader&&) noexcept = default;
    Reader& operator=(Reader&&) = delete;
    ~Reader();
    PGconn* get() const { return conn_.get(); }

  private:
    PgTileIndex* index_;
    pg::ConnPtr conn_;
  };

  explicit PgTileIndex(const PgTileIndexOptions& options) : options_(options) {}
  std::expected<Reader, CacheError> reader();
  /** Runs a read statement on a pooled connection. */
  std::expected<pg::ResultPtr, CacheError>
  read(const char* sql, const pg::Params& params, const char* what);
  /** Runs a statement on the write connection. */
  std::expected<pg::ResultPtr, CacheError>
  write(const char* sql, const pg::Params& params, const char* what);
  Result
  visitSelected(const std::string& selectSql, const pg::Params& params, const RowVisitor& visit);

  PgTileIndexOptions options_;

  std::mutex readMutex_;
  std::condition_variable readerFreed_;
  std::vector<pg::ConnPtr> idleReaders_;
  int openReaders_ = 0; ///< idle + borrowed

  // The writer's (one thread at a time).
  pg::ConnPtr writer_;
  std::int64_t writerId_ = 0;       ///< this index's row in tellus_writers
  std::int64_t othersCommits_ = -1; ///< the other writers' commits at the last look
};

namespace pg {

/** The tiles table's state column: a stored tile, or one its upstream said is absent. */
inline constexpr int kStatePresent = 1;
inline constexpr int kStateAbsent = 2;
/** Binds $1..$4 = dataset, level, row, col. */
inline Params keyParams(DatasetId id, const TileKey& k) {
  Params p;
  p.add(std::int64_t{id}).add(std::int64_t{k.level}).add(k.row).add(k.col);
  return p;
}
/** Binds $1 = fetched before, $2 = dataset name or NULL, $3 = include pinned (0/1). */
inline Params pruneParams(const PruneSelection& s) {
  Params p;
  p.add(s.fetchedBefore);
  if (s.datasetName)
    p.add(std::string_view(*s.datasetName));
  else
    p.addNull();
  p.add(std::int64_t{s.includePinned ? 1 : 0});
  return p;
}
/** The WHERE clause of prune's selection (tiles t JOIN datasets d). */
inline constexpr const char* kPruneWhere =
    "t.fetched_at < $1 AND ($2::text IS NULL OR d.name = $2::text) AND "
    "($3::int = 1 OR d.pinned = 0)";
} // namespace pg

} // namespace tellus
