// PgTileIndex: the write side (one thread at a time, on the write connection).

#include "PgTileIndex.hpp"

#include <algorithm>
#include <string>

namespace tellus {

namespace {

using Result = std::expected<void, CacheError>;

constexpr int kFetchRows = 1000;
/** Rows per INSERT of putRows (12 parameters each, far below PostgreSQL's 65,535). */
constexpr std::size_t kMaxRowsPerStatement = 256;

Result done(const std::expected<pg::ResultPtr, CacheError>& r) {
  if (!r) return std::unexpected(r.error());
  return {};
}

} // namespace

std::expected<pg::ResultPtr, CacheError>
PgTileIndex::write(const char* sql, const pg::Params& params, const char* what) {
  return pg::exec(writer_.get(), sql, params, what);
}

// ---------------------------------------------------------------------------------- transactions

Result PgTileIndex::begin() {
  // A server restarted since the last write: connect again (ITileIndex's callers retry later).
  if (pg::broken(writer_.get())) {
    PQreset(writer_.get());
    if (pg::broken(writer_.get())) {
      return std::unexpected(pg::errorFrom(writer_.get(), nullptr, "starting a write"));
    }
  }
  return done(write("BEGIN", {}, "starting a write"));
}

Result PgTileIndex::commit() {
  // Counted for the others' changedByOthers(), when the transaction wrote anything.
  pg::Params me;
  me.add(writerId_);
  (void)write("UPDATE tellus_writers SET commits = commits + 1 WHERE id = $1 AND "
              "txid_current_if_assigned() IS NOT NULL",
              me,
              "committing");
  auto c = write("COMMIT", {}, "committing");
  if (!c || (PQcmdStatus(c->get()) == std::string_view("ROLLBACK"))) {
    rollback();
    return std::unexpected(
        c ? CacheError{CacheErrc::Io, "PostgreSQL: committing: the transaction was rolled back"}
          : c.error());
  }
  return {};
}

void PgTileIndex::rollback() {
  (void)write("ROLLBACK", {}, "rolling back");
}
void PgTileIndex::savepoint() {
  (void)write("SAVEPOINT op", {}, "savepoint");
}
void PgTileIndex::releaseSavepoint() {
  (void)write("RELEASE SAVEPOINT op", {}, "savepoint");
}
void PgTileIndex::rollbackToSavepoint() {
  (void)write("ROLLBACK TO SAVEPOINT op", {}, "savepoint");
}

// ---------------------------------------------------------------------------------- rows

namespace {

constexpr int kRowParams = 12;

/** Binds one row's twelve values (dataset, key, state, bytes, validators, times). */
void addRow(pg::Params& p, DatasetId id, const TileKey& key, const TileRow& row) {
  p.add(std::int64_t{id}).add(std::int64_t{key.level}).add(key.row).add(key.col);
  p.add(std::int64_t{row.present ? pg::kStatePresent : pg::kStateAbsent}).add(row.bytes);
  p.add(std::string_view(row.meta.contentType)).add(std::string_view(row.meta.etag));
  p.add(std::string_view(row.meta.lastModified)).add(row.meta.expiresAt);
  p.add(row.meta.fetchedAt).add(row.retryAfter);
}

/** INSERT ... ON CONFLICT of `n` rows bound by addRow, in one statement. */
std::string putRowsSql(std::size_t n) {
  std::string sql = "INSERT INTO tiles(dataset, level, row, col, state, bytes, content_type, etag, "
                    "last_modified, expires, fetched_at, last_access, retry_after) VALUES ";
  for (std::size_t i = 0; i < n; ++i) {
    const int b = static_cast<int>(i) * kRowParams;
    auto at = [b](int k) { return "$" + std::to_string(b + k); };
    sql += (i ? ", (" : "(") + at(1) + ", " + at(2) + ", " + at(3) + ", " + at(4) + ", " + at(5) +
           ", " + at(6) + ", " + at(7) + ", " + at(8) + ", " + at(9) + ", " + at(10) + ", " +
           at(11) + ", " + at(11) + ", " + at(12) + ")";
  }
  sql += " ON CONFLICT (dataset, level, row, col) DO UPDATE SET "
         "state = excluded.state, bytes = excluded.bytes, "
         "content_type = excluded.content_type, etag = excluded.etag, "
         "last_modified = excluded.last_modified, expires = excluded.expires, "
         "fetched_at = excluded.fetched_at, last_access = excluded.last_access, "
         "retry_after = excluded.retry_after";
  return sql;
}

} // namespace

Result PgTileIndex::putRow(DatasetId id, const TileKey& key, const TileRow& row) {
  pg::Params p;
  addRow(p, id, key, row);
  static const std::string sql = putRowsSql(1);
  return done(write(sql.c_str(), p, "indexing tile"));
}

Result PgTileIndex::putRows(DatasetId id, std::span<const std::pair<TileKey, TileRow>> rows) {
  // A metatile's rows in one statement, where one each cost a round trip each (15 of them in
  // the transaction that a burst's waiters wait for; bench/RESULTS.md, issue 27). One statement
  // may not touch a row twice: a key given twice is written row by row, the last one winning.
  for (std::size_t i = 0; i < rows.size(); ++i)
    for (std::size_t j = i + 1; j < rows.size(); ++j)
      if (rows[i].first == rows[j].first) return ITileIndex::putRows(id, rows);
  for (std::size_t from = 0; from < rows.size(); from += kMaxRowsPerStatement) {
    const std::size_t n = std::min(kMaxRowsPerStatement, rows.size() - from);
    pg::Params p;
    for (std::size_t i = from; i < from + n; ++i)
      addRow(p, id, rows[i].first, rows[i].second);
    if (auto r = done(write(putRowsSql(n).c_str(), p, "indexing tiles")); !r) return r;
  }
  return {};
}

Result PgTileIndex::deleteRow(DatasetId id, const TileKey& key) {
  return done(write("DELETE FROM tiles WHERE dataset = $1 AND level = $2 AND row = $3 AND col = $4",
                    pg::keyParams(id, key),
                    "removing tile"));
}

Result PgTileIndex::revalidate(DatasetId id, const TileKey& key, const TileMeta& meta) {
  auto p = pg::keyParams(id, key);
  p.add(meta.expiresAt).add(std::string_view(meta.etag)).add(std::string_view(meta.lastModified));
  p.add(meta.fetchedAt);
  return done(write("UPDATE tiles SET expires = $5, etag = $6, last_modified = $7, fetched_at = $8 "
                    "WHERE dataset = $1 AND level = $2 AND row = $3 AND col = $4 AND state = 1",
                    p,
                    "revalidating"));
}

void PgTileIndex::touch(DatasetId id, const TileKey& key, UnixMillis when) {
  auto p = pg::keyParams(id, key);
  p.add(when);
  // Last-access times are advisory: a row another transaction holds is skipped, never waited
  // for. Three instances touching the same hot tiles in their own orders deadlocked, and each
  // writer thread (its tiles' stores behind the touches) stood still for PostgreSQL's
  // deadlock_timeout, a second (bench/RESULTS.md, issue 27's bursts).
  (void)write("UPDATE tiles t SET last_access = $5 FROM (SELECT 1 FROM tiles WHERE dataset = $1 "
              "AND level = $2 AND row = $3 AND col = $4 AND last_access < $5 "
              "FOR UPDATE SKIP LOCKED) free WHERE t.dataset = $1 AND t.level = $2 AND t.row = $3 "
              "AND t.col = $4",
              p,
              "touching");
}

std::expected<std::optional<std::int64_t>, CacheError>
PgTileIndex::presentBytes(DatasetId id, const TileKey& key) {
  auto r = write("SELECT state, bytes FROM tiles WHERE dataset = $1 AND level = $2 AND row = $3 "
                 "AND col = $4",
                 pg::keyParams(id, key),
                 "checking a tile");
  if (!r) return std::unexpected(r.error());
  if (PQntuples(r->get()) == 1 && pg::i64(r->get(), 0, 0) == pg::kStatePresent)
    return pg::i64(r->get(), 0, 1);
  return std::nullopt;
}

// ---------------------------------------------------------------------------------- datasets

std::expected<DatasetInfo, CacheError>
PgTileIndex::upsertDataset(const DatasetSpec& spec, std::string_view folder, UnixMillis createdAt) {
  // One statement: instances registering the same dataset at once get the same row.
  pg::Params p;
  const GridSpec& g = spec.grid;
  p.add(std::string_view(spec.server)).add(std::string_view(spec.name)).add(folder);
  p.add(g.sector.west).add(g.sector.south).add(g.sector.east).add(g.sector.north);
  p.add(g.levelZeroDeltaDeg).add(std::int64_t{g.tileWidth}).add(std::int64_t{g.tileHeight});
  p.add(std::int64_t{g.numLevels}).add(std::string_view(spec.mimeType));
  p.add(std::string_view(spec.extension)).add(std::string_view(spec.style));
  p.add(std::string_view(spec.time)).add(std::int64_t{spec.pinned ? 1 : 0});
  p.add(createdAt).add(std::string_view(spec.body));
  auto r = write("INSERT INTO datasets(server, name, folder, west, south, east, north, "
                 "level_zero_delta, tile_width, tile_height, num_levels, mime_type, extension, "
                 "style, time, pinned, created_at, body) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, "
                 "$9, $10, $11, $12, $13, $14, $15, $16, $17, $18) ON CONFLICT (folder) DO UPDATE "
                 "SET pinned = excluded.pinned RETURNING id, created_at",
                 p,
                 "registering dataset");
  if (!r) return std::unexpected(r.error());
  DatasetInfo info{pg::i64(r->get(), 0, 0), spec, std::string(folder), pg::i64(r->get(), 0, 1)};
  return info;
}

Result PgTileIndex::setPinned(DatasetId id, bool pinned) {
  pg::Params p;
  p.add(std::int64_t{id}).add(std::int64_t{pinned ? 1 : 0});
  return done(write("UPDATE datasets SET pinned = $2 WHERE id = $1", p, "pinning"));
}

Result PgTileIndex::clear() {
  return done(pg::exec(writer_.get(),
                       "DELETE FROM tiles; DELETE FROM datasets; DELETE FROM usage;",
                       "clearing index"));
}

// ---------------------------------------------------------------------------------- selections

/** Streams a query of (dataset, level, row, col, folder, extension, bytes) rows into `visit`
 * through a cursor, kFetchRows at a time, in a read-only transaction of its own. */
Result PgTileIndex::visitSelected(const std::string& selectSql,
                                  const pg::Params& params,
                                  const RowVisitor& visit) {
  if (pg::broken(writer_.get())) PQreset(writer_.get());
  if (auto b = write("BEGIN READ ONLY", {}, "selecting tiles"); !b)
    return std::unexpected(b.error());
  const std::string declare = "DECLARE tellus_sel NO SCROLL CURSOR FOR " + selectSql;
  Result result;
  if (auto d = write(declare.c_str(), params, "selecting tiles"); !d) {
    result = std::unexpected(d.error());
  } else {
    const std::string fetch = "FETCH " + std::to_string(kFetchRows) + " FROM tellus_sel";
    bool more = true;
    while (more) {
      auto f = write(fetch.c_str(), {}, "selecting tiles");
      if (!f) {
        result = std::unexpected(f.error());
        break;
      }
      const PGresult* r = f->get();
      const int n = PQntuples(r);
      for (int i = 0; i < n && more; ++i) {
        const SelectedRow row{pg::i64(r, i, 0),
                              TileKey{static_cast<std::int32_t>(pg::i64(r, i, 1)),
                                      pg::i64(r, i, 2),
                                      pg::i64(r, i, 3)},
                              pg::text(r, i, 4),
                              pg::text(r, i, 5),
                              pg::i64(r, i, 6)};
        more = visit(row);
      }
      if (n < kFetchRows) more = false;
    }
  }
  (void)write(result ? "COMMIT" : "ROLLBACK", {}, "selecting tiles");
  return result;
}

Result PgTileIndex::forEachPrunable(const PruneSelection& selection, const RowVisitor& visit) {
  return visitSelected(
      std::string("SELECT t.dataset, t.level, t.row, t.col, d.folder, d.extension, t.bytes FROM "
                  "tiles t JOIN datasets d ON d.id = t.dataset WHERE ") +
          pg::kPruneWhere,
      pg::pruneParams(selection),
      visit);
}

Result PgTileIndex::forEachEvictable(const RowVisitor& visit) {
  return visitSelected(
      "SELECT t.dataset, t.level, t.row, t.col, d.folder, d.extension, t.bytes FROM tiles t "
      "JOIN datasets d ON d.id = t.dataset WHERE d.pinned = 0 AND t.state = 1 "
      "ORDER BY t.last_access",
      {},
      visit);
}

// ---------------------------------------------------------------------------------- others

bool PgTileIndex::changedByOthers() {
  if (pg::broken(writer_.get())) PQreset(writer_.get());
  pg::Params me;
  me.add(writerId_);
  auto r =
      write("SELECT coalesce(sum(commits), 0) FROM tellus_writers WHERE id <> $1", me, "polling");
  if (!r) return true;
  const std::int64_t others = pg::i64(r->get(), 0, 0);
  const bool changed = others != othersCommits_;
  othersCommits_ = others;
  return changed;
}

} // namespace tellus
