#include "Schema.hpp"

#include "Sqlite.hpp"

#include <string>

namespace tellus::schema {

namespace {

// Version 1: datasets with their grid, one row per tile (present or absent), an LRU index.
constexpr const char* kV1 = R"sql(
CREATE TABLE datasets(
  id INTEGER PRIMARY KEY,
  server TEXT NOT NULL,
  name TEXT NOT NULL,
  folder TEXT NOT NULL UNIQUE,
  west REAL NOT NULL, south REAL NOT NULL, east REAL NOT NULL, north REAL NOT NULL,
  level_zero_delta REAL NOT NULL,
  tile_width INTEGER NOT NULL, tile_height INTEGER NOT NULL, num_levels INTEGER NOT NULL,
  mime_type TEXT NOT NULL, extension TEXT NOT NULL, style TEXT NOT NULL, time TEXT NOT NULL,
  pinned INTEGER NOT NULL DEFAULT 0,
  created_at INTEGER NOT NULL);
CREATE TABLE tiles(
  dataset INTEGER NOT NULL,
  level INTEGER NOT NULL, row INTEGER NOT NULL, col INTEGER NOT NULL,
  state INTEGER NOT NULL,             -- 1 present, 2 absent upstream
  bytes INTEGER NOT NULL,
  content_type TEXT, etag TEXT, last_modified TEXT,
  expires INTEGER,                    -- unix ms, NULL = never
  fetched_at INTEGER NOT NULL,        -- unix ms
  last_access INTEGER NOT NULL,       -- unix ms
  retry_after INTEGER,                -- absent: unix ms after which upstream is asked again
  PRIMARY KEY(dataset, level, row, col)) WITHOUT ROWID;
CREATE INDEX tiles_by_access ON tiles(last_access);
)sql";

// Version 2: per-dataset counters kept by triggers, so that the size limit and `stats` totals
// never scan the tiles table (opening a cache of millions of tiles costs what an empty one costs).
constexpr const char* kV1toV2 = R"sql(
CREATE TABLE usage(dataset INTEGER PRIMARY KEY, tiles INTEGER NOT NULL DEFAULT 0,
                   bytes INTEGER NOT NULL DEFAULT 0);
INSERT INTO usage(dataset, tiles, bytes)
  SELECT d.id, count(t.dataset), coalesce(sum(t.bytes), 0)
  FROM datasets d LEFT JOIN tiles t ON t.dataset = d.id GROUP BY d.id;
CREATE TRIGGER datasets_ins AFTER INSERT ON datasets BEGIN
  INSERT INTO usage(dataset) VALUES (NEW.id);
END;
CREATE TRIGGER datasets_del AFTER DELETE ON datasets BEGIN
  DELETE FROM usage WHERE dataset = OLD.id;
END;
CREATE TRIGGER tiles_ins AFTER INSERT ON tiles BEGIN
  UPDATE usage SET tiles = tiles + 1, bytes = bytes + NEW.bytes WHERE dataset = NEW.dataset;
END;
CREATE TRIGGER tiles_del AFTER DELETE ON tiles BEGIN
  UPDATE usage SET tiles = tiles - 1, bytes = bytes - OLD.bytes WHERE dataset = OLD.dataset;
END;
CREATE TRIGGER tiles_upd AFTER UPDATE OF bytes ON tiles BEGIN
  UPDATE usage SET bytes = bytes - OLD.bytes + NEW.bytes WHERE dataset = NEW.dataset;
END;
)sql";

// Version 3: the body a dataset lies on (issue 26); every dataset of an older index is the Earth's.
constexpr const char* kV2toV3 = R"sql(
ALTER TABLE datasets ADD COLUMN body TEXT NOT NULL DEFAULT 'earth';
)sql";

std::expected<int, CacheError> userVersion(sqlite3* db) {
  sql::Stmt s(db, "PRAGMA user_version");
  if (!s.ok()) return std::unexpected(sql::errorFrom(db, s.prepareRc(), "reading schema version"));
  sql::Stmt::Use u(s);
  const int rc = u.step();
  if (rc != SQLITE_ROW) return std::unexpected(sql::errorFrom(db, rc, "reading schema version"));
  return static_cast<int>(u.i64(0));
}

std::expected<bool, CacheError> hasTables(sqlite3* db) {
  sql::Stmt s(db, "SELECT count(*) FROM sqlite_master WHERE type = 'table'");
  if (!s.ok()) return std::unexpected(sql::errorFrom(db, s.prepareRc(), "reading schema"));
  sql::Stmt::Use u(s);
  const int rc = u.step();
  if (rc != SQLITE_ROW) return std::unexpected(sql::errorFrom(db, rc, "reading schema"));
  return u.i64(0) > 0;
}

std::expected<void, CacheError> run(sqlite3* db, const char* text, const char* what) {
  const int rc = sql::exec(db, text);
  if (rc != SQLITE_OK) return std::unexpected(sql::errorFrom(db, rc, what));
  return {};
}

} // namespace

std::expected<void, CacheError> ensure(sqlite3* db) {
  auto v = userVersion(db);
  if (!v) return std::unexpected(v.error());
  if (*v == kVersion) return {};
  if (*v > kVersion) {
    return std::unexpected(CacheError{CacheErrc::Schema,
                                      "the index has schema version " + std::to_string(*v) +
                                          ", newer than this tellus understands (" +
                                          std::to_string(kVersion) + "); upgrade tellus"});
  }
  // Another process may be doing the same right now: decide inside the write transaction.
  if (auto r = run(db, "BEGIN IMMEDIATE", "starting schema transaction"); !r) return r;
  auto fail = [db](CacheError e) -> std::expected<void, CacheError> {
    sql::exec(db, "ROLLBACK");
    return std::unexpected(std::move(e));
  };
  v = userVersion(db);
  if (!v) return fail(v.error());
  if (*v == 0) {
    auto tables = hasTables(db);
    if (!tables) return fail(tables.error());
    if (*tables) {
      return fail(CacheError{CacheErrc::Schema,
                             "the index file holds tables but no tellus schema version"});
    }
    if (auto r = run(db, kV1, "creating schema v1"); !r) return fail(r.error());
    *v = 1;
  }
  if (*v == 1) {
    if (auto r = run(db, kV1toV2, "migrating schema v1 -> v2"); !r) return fail(r.error());
    *v = 2;
  }
  if (*v == 2) {
    if (auto r = run(db, kV2toV3, "migrating schema v2 -> v3"); !r) return fail(r.error());
    *v = 3;
  }
  const std::string setVersion = "PRAGMA user_version = " + std::to_string(kVersion);
  if (auto r = run(db, setVersion.c_str(), "writing schema version"); !r) return fail(r.error());
  if (auto r = run(db, "COMMIT", "committing schema"); !r) return fail(r.error());
  return {};
}

} // namespace tellus::schema
