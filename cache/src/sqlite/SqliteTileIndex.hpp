#pragma once
/**
 * @file SqliteTileIndex.hpp
 * @brief The tile index in SQLite (`<root>/index.sqlite`, Schema.hpp): the embedded default.
 *
 * - Reads use pooled read-only connections with prepared statements (WAL: they never wait for
 *   the writer), memory-mapped.
 * - Writes use one connection with prepared statements; BEGIN IMMEDIATE and a busy timeout let
 *   two processes (a server and a seeder) share the index without "database is locked".
 * - The WAL and its shared-memory index persist after the last connection closes: a cache whose
 *   disk filled up still opens and reads (creating them needs room), and commits that fit in the
 *   kept WAL still succeed on a full disk.
 * - Opening does no scan: the header, the schema and both edges of the tiles b-tree are probed. A
 *   damaged index, or an `index.corrupt` marker left by a read that met SQLITE_CORRUPT, is moved
 *   aside to `index.sqlite.corrupt-<ms>` and started empty (damagedAtOpen()).
 * - Other processes' commits are noticed through PRAGMA data_version on the write connection (its
 *   own commits do not move it).
 */

#include "Sqlite.hpp"

#include <tellus/cache/TileIndex.hpp>

#include <memory>
#include <mutex>
#include <vector>

namespace tellus {

namespace sql {

/** The tiles table's state column: a stored tile, or one its upstream said is absent. */
inline constexpr int kStatePresent = 1;
inline constexpr int kStateAbsent = 2;

/** Binds ?1..?4 = dataset, level, row, col: the tiles table's primary key. */
inline void bindKey(Stmt::Use& u, DatasetId id, const TileKey& k) {
  u.bind(1, id).bind(2, std::int64_t{k.level}).bind(3, k.row).bind(4, k.col);
}

/** Binds ?1 = fetched before, ?2 = dataset name or NULL, ?3 = include pinned (0/1). */
inline void bindPrune(Stmt::Use& u, const PruneSelection& s) {
  u.bind(1, s.fetchedBefore);
  if (s.datasetName)
    u.bind(2, std::string_view(*s.datasetName));
  else
    u.bindNull(2);
  u.bind(3, std::int64_t{s.includePinned ? 1 : 0});
}

} // namespace sql

class SqliteTileIndex final : public ITileIndex {
public:
  static std::expected<std::unique_ptr<SqliteTileIndex>, CacheError>
  open(const SqliteTileIndexOptions& options);
  ~SqliteTileIndex() override;
  SqliteTileIndex(const SqliteTileIndex&) = delete;
  SqliteTileIndex& operator=(const SqliteTileIndex&) = delete;

  bool damagedAtOpen() const noexcept override { return damaged_; }

  // reads (SqliteTileIndex.cpp)
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
  std::string integrity() override;

  // writes (SqliteIndexWrites.cpp)
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
  bool changedByOthers() override;

private:
  /** One read connection with its prepared lookup. */
  struct ReadConn {
    sql::DbPtr db;
    sql::Stmt lookup;
  };
  /** A read connection borrowed from the pool, given back when the lease ends. */
  class ReaderLease {
  public:
    ReaderLease(SqliteTileIndex* index, std::unique_ptr<ReadConn> conn)
        : index_(index), conn_(std::move(conn)) {}
    ReaderLease(ReaderLease&&) noexcept = default;
    ReaderLease& operator=(ReaderLease&&) = delete;
    ~ReaderLease();
    ReadConn& operator*() const { return *conn_; }
    ReadConn* operator->() const { return conn_.get(); }

  private:
    SqliteTileIndex* index_;
    std::unique_ptr<ReadConn> conn_;
  };

  explicit SqliteTileIndex(const SqliteTileIndexOptions& options);
  Result openWriteConnection();
  Result prepareWriter();
  std::expected<std::unique_ptr<ReadConn>, CacheError> makeReader() const;
  std::expected<ReaderLease, CacheError> acquireReader();
  void markDamaged(const CacheError& error) const;
  Result visitSelected(const char* selectSql,
                       const std::function<void(sql::Stmt::Use&)>& bind,
                       const RowVisitor& visit);

  SqliteTileIndexOptions options_;
  std::filesystem::path path_;
  bool damaged_ = false;

  std::mutex readMutex_;
  std::vector<std::unique_ptr<ReadConn>> idleReaders_;

  // The write connection and its statements (the writer's: one thread at a time).
  sql::DbPtr writeDb_;
  sql::Stmt upsertTile_, deleteTile_, touchTile_, rowBytes_, revalidate_;
  sql::Stmt begin_, commit_, rollback_, savepoint_, release_, rollbackTo_;
  sql::Stmt dataVersion_;
  std::int64_t lastDataVersion_ = -1;
};

} // namespace tellus
