#include "PgSchema.hpp"

#include <string>

namespace tellus::pg {

namespace {

// The SQLite index's version 3 (cache/src/sqlite/Schema.cpp) in PostgreSQL's types. The counters
// in `usage` are kept by triggers as there; a row per dataset, so writers of different datasets
// never wait for each other.
constexpr const char* kV1 = R"sql(
CREATE TABLE tellus_meta(key text PRIMARY KEY, value text NOT NULL);
-- One row per open index (process): its count of write transactions, which only it updates, so
-- that another process sees "something changed" without all writers contending for one row.
CREATE TABLE tellus_writers(id bigint PRIMARY KEY, commits bigint NOT NULL DEFAULT 0);
CREATE TABLE datasets(
  id bigserial PRIMARY KEY,
  server text NOT NULL,
  name text NOT NULL,
  folder text NOT NULL UNIQUE,
  west double precision NOT NULL, south double precision NOT NULL,
  east double precision NOT NULL, north double precision NOT NULL,
  level_zero_delta double precision NOT NULL,
  tile_width integer NOT NULL, tile_height integer NOT NULL, num_levels integer NOT NULL,
  mime_type text NOT NULL, extension text NOT NULL, style text NOT NULL, time text NOT NULL,
  pinned integer NOT NULL DEFAULT 0,
  created_at bigint NOT NULL,
  body text NOT NULL DEFAULT 'earth');
CREATE TABLE tiles(
  dataset bigint NOT NULL,
  level integer NOT NULL, row bigint NOT NULL, col bigint NOT NULL,
  state smallint NOT NULL,            -- 1 present, 2 absent upstream
  bytes bigint NOT NULL,
  content_type text, etag text, last_modified text,
  expires bigint,                     -- unix ms, NULL = never
  fetched_at bigint NOT NULL,         -- unix ms
  last_access bigint NOT NULL,        -- unix ms
  retry_after bigint,                 -- absent: unix ms after which upstream is asked again
  PRIMARY KEY(dataset, level, row, col));
CREATE INDEX tiles_by_access ON tiles(last_access);
CREATE TABLE usage(dataset bigint PRIMARY KEY, tiles bigint NOT NULL DEFAULT 0,
                   bytes bigint NOT NULL DEFAULT 0);
CREATE FUNCTION tellus_usage() RETURNS trigger LANGUAGE plpgsql AS $$
BEGIN
  IF TG_TABLE_NAME = 'datasets' THEN
    IF TG_OP = 'INSERT' THEN INSERT INTO usage(dataset) VALUES (NEW.id);
    ELSE DELETE FROM usage WHERE dataset = OLD.id; END IF;
  ELSIF TG_OP = 'INSERT' THEN
    UPDATE usage SET tiles = tiles + 1, bytes = bytes + NEW.bytes WHERE dataset = NEW.dataset;
  ELSIF TG_OP = 'DELETE' THEN
    UPDATE usage SET tiles = tiles - 1, bytes = bytes - OLD.bytes WHERE dataset = OLD.dataset;
  ELSIF NEW.bytes <> OLD.bytes THEN
    UPDATE usage SET bytes = bytes - OLD.bytes + NEW.bytes WHERE dataset = NEW.dataset;
  END IF;
  RETURN NULL;
END $$;
CREATE TRIGGER datasets_usage AFTER INSERT OR DELETE ON datasets
  FOR EACH ROW EXECUTE FUNCTION tellus_usage();
CREATE TRIGGER tiles_usage AFTER INSERT OR DELETE OR UPDATE OF bytes ON tiles
  FOR EACH ROW EXECUTE FUNCTION tellus_usage();
-- Seeding jobs shared by several `tellus seed` (PgSeedJob.hpp): a row per band of a job.
CREATE TABLE seed_bands(job text NOT NULL, level integer NOT NULL, row bigint NOT NULL,
                        done boolean NOT NULL DEFAULT false, PRIMARY KEY(job, level, row));
INSERT INTO tellus_meta VALUES ('schema_version', '1');
)sql";

// Any constant: the advisory lock that one creator of the schema holds. A session lock, taken
// before the transaction that looks again: a backend that waited for it inside a transaction kept
// its catalog cache's "no tellus_meta" from before the wait (invalidations are read when a
// transaction starts), and created the schema a second time ("relation already exists").
constexpr const char* kLock = "SELECT pg_advisory_lock(7227001)";
constexpr const char* kUnlock = "SELECT pg_advisory_unlock(7227001)";

std::expected<std::optional<int>, CacheError> version(PGconn* conn) {
  auto t = exec(conn, "SELECT to_regclass('tellus_meta') IS NOT NULL", "reading schema");
  if (!t) return std::unexpected(t.error());
  if (text(t->get(), 0, 0) != "t") return std::optional<int>{};
  auto v =
      exec(conn, "SELECT value FROM tellus_meta WHERE key = 'schema_version'", "reading schema");
  if (!v) return std::unexpected(v.error());
  if (PQntuples(v->get()) != 1)
    return std::unexpected(CacheError{CacheErrc::Schema, "the index has no schema version"});
  return std::optional<int>{std::stoi(text(v->get(), 0, 0))};
}

std::expected<void, CacheError> check(int v) {
  if (v > kSchemaVersion) {
    return std::unexpected(CacheError{CacheErrc::Schema,
                                      "the index has schema version " + std::to_string(v) +
                                          ", newer than this tellus understands (" +
                                          std::to_string(kSchemaVersion) + "); upgrade tellus"});
  }
  return {};
}

} // namespace

std::expected<void, CacheError> ensureSchema(PGconn* conn, bool readOnly) {
  auto v = version(conn);
  if (!v) return std::unexpected(v.error());
  if (*v) return check(**v);
  if (readOnly) {
    return std::unexpected(CacheError{CacheErrc::Io, "the database holds no tellus index"});
  }
  if (auto l = exec(conn, kLock, "creating schema"); !l) return std::unexpected(l.error());
  auto fail = [conn](CacheError e, bool rollback) -> std::expected<void, CacheError> {
    if (rollback) (void)exec(conn, "ROLLBACK", "rolling back");
    (void)exec(conn, kUnlock, "creating schema");
    return std::unexpected(std::move(e));
  };
  if (auto b = exec(conn, "BEGIN", "creating schema"); !b) return fail(b.error(), false);
  v = version(conn); // another instance may have created it meanwhile
  if (!v) return fail(v.error(), true);
  if (!*v) {
    if (auto c = exec(conn, kV1, "creating schema"); !c) return fail(c.error(), true);
  }
  if (auto c = exec(conn, "COMMIT", "creating schema"); !c) return fail(c.error(), false);
  (void)exec(conn, kUnlock, "creating schema");
  return *v ? check(**v) : std::expected<void, CacheError>{};
}

} // namespace tellus::pg
