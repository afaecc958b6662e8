// SqliteTileIndex: the write side (one thread at a time, on the write connection).

#include "SqliteTileIndex.hpp"

namespace tellus {

namespace {

using Result = std::expected<void, CacheError>;

int run(const sql::Stmt& s) {
  sql::Stmt::Use u(s);
  return u.step();
}

/** Inserts a dataset row (the usage row follows by trigger); returns its id. */
std::expected<DatasetId, CacheError>
insertDataset(sqlite3* db, const DatasetSpec& spec, std::string_view folder, UnixMillis createdAt) {
  sql::Stmt ins(
      db,
      "INSERT INTO datasets(server, name, folder, west, south, east, north, "
      "level_zero_delta, tile_width, tile_height, num_levels, mime_type, extension, "
      "style, time, pinned, created_at, body) VALUES "
      "(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16, ?17, ?18)");
  if (!ins.ok()) return std::unexpected(sql::errorFrom(db, ins.prepareRc(), "registering dataset"));
  sql::Stmt::Use u(ins);
  const GridSpec& g = spec.grid;
  u.bind(1, std::string_view(spec.server)).bind(2, std::string_view(spec.name)).bind(3, folder);
  u.bind(4, g.sector.west).bind(5, g.sector.south).bind(6, g.sector.east).bind(7, g.sector.north);
  u.bind(8, g.levelZeroDeltaDeg)
      .bind(9, std::int64_t{g.tileWidth})
      .bind(10, std::int64_t{g.tileHeight});
  u.bind(11, std::int64_t{g.numLevels}).bind(12, std::string_view(spec.mimeType));
  u.bind(13, std::string_view(spec.extension)).bind(14, std::string_view(spec.style));
  u.bind(15, std::string_view(spec.time)).bind(16, std::int64_t{spec.pinned ? 1 : 0});
  u.bind(17, createdAt).bind(18, std::string_view(spec.body));
  const int rc = u.step();
  if (rc != SQLITE_DONE) return std::unexpected(sql::errorFrom(db, rc, "registering dataset"));
  return sqlite3_last_insert_rowid(db);
}

} // namespace

Result SqliteTileIndex::prepareWriter() {
  sqlite3* db = writeDb_.get();
  upsertTile_ = sql::Stmt(db,
                          "INSERT INTO tiles(dataset, level, row, col, state, bytes, content_type, "
                          "etag, last_modified, expires, fetched_at, last_access, retry_after) "
                          "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?11, ?12) "
                          "ON CONFLICT(dataset, level, row, col) DO UPDATE SET "
                          "state = excluded.state, bytes = excluded.bytes, "
                          "content_type = excluded.content_type, etag = excluded.etag, "
                          "last_modified = excluded.last_modified, expires = excluded.expires, "
                          "fetched_at = excluded.fetched_at, last_access = excluded.last_access, "
                          "retry_after = excluded.retry_after");
  deleteTile_ = sql::Stmt(db,
                          "DELETE FROM tiles WHERE dataset = ?1 AND level = ?2 AND row = ?3 "
                          "AND col = ?4");
  touchTile_ = sql::Stmt(db,
                         "UPDATE tiles SET last_access = max(last_access, ?5) WHERE "
                         "dataset = ?1 AND level = ?2 AND row = ?3 AND col = ?4");
  rowBytes_ = sql::Stmt(db,
                        "SELECT state, bytes FROM tiles WHERE dataset = ?1 AND level = ?2 "
                        "AND row = ?3 AND col = ?4");
  revalidate_ =
      sql::Stmt(db,
                "UPDATE tiles SET expires = ?5, etag = ?6, last_modified = ?7, fetched_at = ?8 "
                "WHERE dataset = ?1 AND level = ?2 AND row = ?3 AND col = ?4 AND state = 1");
  begin_ = sql::Stmt(db, "BEGIN IMMEDIATE");
  commit_ = sql::Stmt(db, "COMMIT");
  rollback_ = sql::Stmt(db, "ROLLBACK");
  savepoint_ = sql::Stmt(db, "SAVEPOINT op");
  release_ = sql::Stmt(db, "RELEASE op");
  rollbackTo_ = sql::Stmt(db, "ROLLBACK TO op");
  for (const sql::Stmt* s : {&upsertTile_,
                             &deleteTile_,
                             &touchTile_,
                             &rowBytes_,
                             &revalidate_,
                             &begin_,
                             &commit_,
                             &rollback_,
                             &savepoint_,
                             &release_,
                             &rollbackTo_}) {
    if (!s->ok()) return std::unexpected(sql::errorFrom(db, s->prepareRc(), "preparing writer"));
  }
  return {};
}

// ---------------------------------------------------------------------------------- transactions

Result SqliteTileIndex::begin() {
  const int rc = run(begin_);
  if (rc != SQLITE_DONE)
    return std::unexpected(sql::errorFrom(writeDb_.get(), rc, "starting a write"));
  return {};
}

Result SqliteTileIndex::commit() {
  const int rc = run(commit_);
  if (rc != SQLITE_DONE) {
    run(rollback_);
    return std::unexpected(sql::errorFrom(writeDb_.get(), rc, "committing"));
  }
  return {};
}

void SqliteTileIndex::rollback() {
  run(rollback_);
}
void SqliteTileIndex::savepoint() {
  run(savepoint_);
}
void SqliteTileIndex::releaseSavepoint() {
  run(release_);
}
void SqliteTileIndex::rollbackToSavepoint() {
  run(rollbackTo_);
}

// ---------------------------------------------------------------------------------- rows

Result SqliteTileIndex::putRow(DatasetId id, const TileKey& key, const TileRow& row) {
  sql::Stmt::Use u(upsertTile_);
  sql::bindKey(u, id, key);
  u.bind(5, std::int64_t{row.present ? sql::kStatePresent : sql::kStateAbsent}).bind(6, row.bytes);
  u.bind(7, std::string_view(row.meta.contentType)).bind(8, std::string_view(row.meta.etag));
  u.bind(9, std::string_view(row.meta.lastModified)).bind(10, row.meta.expiresAt);
  u.bind(11, row.meta.fetchedAt).bind(12, row.retryAfter);
  const int rc = u.step();
  if (rc != SQLITE_DONE)
    return std::unexpected(sql::errorFrom(writeDb_.get(), rc, "indexing tile"));
  return {};
}

Result SqliteTileIndex::deleteRow(DatasetId id, const TileKey& key) {
  sql::Stmt::Use u(deleteTile_);
  sql::bindKey(u, id, key);
  const int rc = u.step();
  if (rc != SQLITE_DONE)
    return std::unexpected(sql::errorFrom(writeDb_.get(), rc, "removing tile"));
  return {};
}

Result SqliteTileIndex::revalidate(DatasetId id, const TileKey& key, const TileMeta& meta) {
  sql::Stmt::Use u(revalidate_);
  sql::bindKey(u, id, key);
  u.bind(5, meta.expiresAt)
      .bind(6, std::string_view(meta.etag))
      .bind(7, std::string_view(meta.lastModified))
      .bind(8, meta.fetchedAt);
  const int rc = u.step();
  if (rc != SQLITE_DONE) return std::unexpected(sql::errorFrom(writeDb_.get(), rc, "revalidating"));
  return {};
}

void SqliteTileIndex::touch(DatasetId id, const TileKey& key, UnixMillis when) {
  sql::Stmt::Use u(touchTile_);
  sql::bindKey(u, id, key);
  u.bind(5, when);
  u.step();
}

std::expected<std::optional<std::int64_t>, CacheError>
SqliteTileIndex::presentBytes(DatasetId id, const TileKey& key) {
  sql::Stmt::Use u(rowBytes_);
  sql::bindKey(u, id, key);
  const int rc = u.step();
  if (rc == SQLITE_ROW && u.i64(0) == sql::kStatePresent) return u.i64(1);
  if (rc != SQLITE_ROW && rc != SQLITE_DONE)
    return std::unexpected(sql::errorFrom(writeDb_.get(), rc, "checking a tile"));
  return std::nullopt;
}

// ---------------------------------------------------------------------------------- datasets

std::expected<DatasetInfo, CacheError> SqliteTileIndex::upsertDataset(const DatasetSpec& spec,
                                                                      std::string_view folder,
                                                                      UnixMillis createdAt) {
  sqlite3* db = writeDb_.get();
  DatasetInfo info{0, spec, std::string(folder), createdAt};
  sql::Stmt find(db, "SELECT id, created_at FROM datasets WHERE folder = ?1");
  {
    sql::Stmt::Use u(find);
    u.bind(1, folder);
    const int rc = u.step();
    if (rc == SQLITE_ROW) {
      info.id = u.i64(0);
      info.createdAt = u.i64(1);
    } else if (rc != SQLITE_DONE) {
      return std::unexpected(sql::errorFrom(db, rc, "finding dataset"));
    }
  }
  if (info.id != 0) {
    if (auto r = setPinned(info.id, spec.pinned); !r) return std::unexpected(r.error());
    return info;
  }
  auto inserted = insertDataset(db, spec, folder, createdAt);
  if (!inserted) return std::unexpected(inserted.error());
  info.id = *inserted;
  return info;
}

Result SqliteTileIndex::setPinned(DatasetId id, bool pinned) {
  sql::Stmt upd(writeDb_.get(), "UPDATE datasets SET pinned = ?2 WHERE id = ?1");
  sql::Stmt::Use u(upd);
  u.bind(1, id).bind(2, std::int64_t{pinned ? 1 : 0});
  const int rc = u.step();
  if (rc != SQLITE_DONE) return std::unexpected(sql::errorFrom(writeDb_.get(), rc, "pinning"));
  return {};
}

Result SqliteTileIndex::clear() {
  sqlite3* db = writeDb_.get();
  if (sql::exec(db, "DELETE FROM tiles; DELETE FROM datasets; DELETE FROM usage;") != SQLITE_OK) {
    return std::unexpected(sql::errorFrom(db, sqlite3_errcode(db), "clearing index"));
  }
  return {};
}

// ---------------------------------------------------------------------------------- selections

/** Steps a query of (dataset, level, row, col, folder, extension, bytes) rows into `visit`. */
Result SqliteTileIndex::visitSelected(const char* selectSql,
                                      const std::function<void(sql::Stmt::Use&)>& bind,
                                      const RowVisitor& visit) {
  sqlite3* db = writeDb_.get();
  sql::Stmt sel(db, selectSql);
  if (!sel.ok()) return std::unexpected(sql::errorFrom(db, sel.prepareRc(), "selecting tiles"));
  sql::Stmt::Use u(sel);
  bind(u);
  int rc = 0;
  while ((rc = u.step()) == SQLITE_ROW) {
    const SelectedRow row{u.i64(0),
                          TileKey{static_cast<std::int32_t>(u.i64(1)), u.i64(2), u.i64(3)},
                          u.text(4),
                          u.text(5),
                          u.i64(6)};
    if (!visit(row)) return {};
  }
  if (rc != SQLITE_DONE) return std::unexpected(sql::errorFrom(db, rc, "selecting tiles"));
  return {};
}

Result SqliteTileIndex::forEachPrunable(const PruneSelection& selection, const RowVisitor& visit) {
  return visitSelected(
      "SELECT t.dataset, t.level, t.row, t.col, d.folder, d.extension, t.bytes FROM tiles t "
      "JOIN datasets d ON d.id = t.dataset WHERE t.fetched_at < ?1 "
      "AND (?2 IS NULL OR d.name = ?2) AND (?3 = 1 OR d.pinned = 0)",
      [&](sql::Stmt::Use& u) { sql::bindPrune(u, selection); },
      visit);
}

Result SqliteTileIndex::forEachEvictable(const RowVisitor& visit) {
  return visitSelected(
      "SELECT t.dataset, t.level, t.row, t.col, d.folder, d.extension, t.bytes FROM tiles t "
      "JOIN datasets d ON d.id = t.dataset WHERE d.pinned = 0 AND t.state = 1 "
      "ORDER BY t.last_access",
      [](sql::Stmt::Use&) {},
      visit);
}

// ---------------------------------------------------------------------------------- others

bool SqliteTileIndex::changedByOthers() {
  if (!dataVersion_.ok()) return true;
  sql::Stmt::Use u(dataVersion_);
  if (u.step() != SQLITE_ROW) return true;
  const std::int64_t v = u.i64(0);
  if (v == lastDataVersion_) return false;
  lastDataVersion_ = v;
  return true;
}

} // namespace tellus
