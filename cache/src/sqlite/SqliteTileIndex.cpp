// SqliteTileIndex: opening (damage, schema) and the read side.

#include "SqliteTileIndex.hpp"

#include "../files/FileIo.hpp"
#include "Schema.hpp"

#include <algorithm>

namespace tellus {

namespace fs = std::filesystem;

namespace {

using Result = std::expected<void, CacheError>;

constexpr const char* kIndexName = "index.sqlite";
constexpr const char* kCorruptMarker = "index.corrupt";

sql::DbPtr openDb(const fs::path& path, bool readOnly, bool create, int busyMs, int* rcOut) {
  sqlite3* raw = nullptr;
  int flags = SQLITE_OPEN_NOMUTEX;
  flags |=
      readOnly ? SQLITE_OPEN_READONLY : (SQLITE_OPEN_READWRITE | (create ? SQLITE_OPEN_CREATE : 0));
  const int rc = sqlite3_open_v2(path.c_str(), &raw, flags, nullptr);
  sql::DbPtr db(raw);
  *rcOut = rc;
  if (rc != SQLITE_OK) return nullptr;
  sqlite3_busy_timeout(db.get(), busyMs);
  sqlite3_extended_result_codes(db.get(), 1);
  // The WAL and its shared-memory index stay when the last connection closes: a cache whose disk
  // filled up can still be opened and read (creating them needs room), and commits that fit in
  // the kept WAL still succeed on a full disk.
  int persist = 1;
  (void)sqlite3_file_control(db.get(), "main", SQLITE_FCNTL_PERSIST_WAL, &persist);
  return db;
}

/** Runs statements that return at most rows nobody reads; the first failure is the result. */
Result runAll(sqlite3* db, std::initializer_list<const char*> statements, const char* what) {
  for (const char* q : statements) {
    sql::Stmt s(db, q);
    if (!s.ok()) return std::unexpected(sql::errorFrom(db, s.prepareRc(), what));
    sql::Stmt::Use u(s);
    const int rc = u.step();
    if (rc != SQLITE_ROW && rc != SQLITE_DONE) return std::unexpected(sql::errorFrom(db, rc, what));
  }
  return {};
}

/** Cheap damage checks at open: header, schema, both edges of the tiles b-tree. No scan. */
Result probe(sqlite3* db) {
  return runAll(db,
                {"SELECT count(*) FROM datasets",
                 "SELECT dataset FROM tiles ORDER BY dataset, level, row, col LIMIT 1",
                 "SELECT dataset FROM tiles ORDER BY dataset DESC, level DESC, row DESC, "
                 "col DESC LIMIT 1",
                 "SELECT last_access FROM tiles ORDER BY last_access DESC LIMIT 1",
                 "SELECT count(*) FROM usage"},
                "checking index");
}

/** The switch to WAL. A new database's first switch needs it to itself, and SQLite answers a
 * process opening it in the same instant "database is locked" at once, not through the busy
 * handler: tried again, 10 ms apart, within the busy timeout. */
Result switchToWal(sqlite3* db, int busyMs) {
  for (int waitedMs = 0;; waitedMs += 10) {
    sql::Stmt s(db, "PRAGMA journal_mode = WAL");
    int rc = s.prepareRc();
    if (s.ok()) {
      sql::Stmt::Use u(s);
      rc = u.step();
      if (rc == SQLITE_ROW || rc == SQLITE_DONE) return {};
    }
    if ((rc & 0xff) != SQLITE_BUSY || waitedMs >= busyMs)
      return std::unexpected(sql::errorFrom(db, rc, "configuring index"));
    sqlite3_sleep(10);
  }
}

Result configure(sqlite3* db, bool readOnly, int busyMs) {
  if (readOnly) return {};
  if (Result r = switchToWal(db, busyMs); !r) return r;
  // The WAL persists (openDb); it is cut back to 64 MiB when it is reset, so one huge transaction
  // (a rebuild) does not keep its size forever.
  return runAll(db,
                {"PRAGMA synchronous = NORMAL", "PRAGMA journal_size_limit = 67108864"},
                "configuring index");
}

void moveAside(const fs::path& indexPath, UnixMillis now) {
  const std::string suffix = ".corrupt-" + std::to_string(now);
  std::error_code ec;
  for (const char* extra : {"", "-wal", "-shm"}) {
    const fs::path p = indexPath.string() + extra;
    if (fs::exists(p, ec)) fs::rename(p, indexPath.string() + suffix + extra, ec);
  }
}

/** A datasets row (columns as in kDatasetColumns) as a DatasetInfo. */
DatasetInfo datasetFromRow(const sql::Stmt::Use& u) {
  DatasetInfo d;
  d.id = u.i64(0);
  DatasetSpec& s = d.spec;
  s.server = u.text(1);
  s.name = u.text(2);
  d.folder = u.text(3);
  s.grid.sector = Sector{u.f64(4), u.f64(5), u.f64(6), u.f64(7)};
  s.grid.levelZeroDeltaDeg = u.f64(8);
  s.grid.tileWidth = static_cast<std::int32_t>(u.i64(9));
  s.grid.tileHeight = static_cast<std::int32_t>(u.i64(10));
  s.grid.numLevels = static_cast<std::int32_t>(u.i64(11));
  s.mimeType = u.text(12);
  s.extension = u.text(13);
  s.style = u.text(14);
  s.time = u.text(15);
  s.pinned = u.i64(16) != 0;
  d.createdAt = u.i64(17);
  s.body = u.text(18);
  return d;
}

constexpr const char* kDatasetColumns =
    "SELECT id, server, name, folder, west, south, east, north, level_zero_delta, tile_width, "
    "tile_height, num_levels, mime_type, extension, style, time, pinned, created_at, body "
    "FROM datasets ";

} // namespace

SqliteTileIndex::SqliteTileIndex(const SqliteTileIndexOptions& options)
    : options_(options), path_(options.root / kIndexName) {
  if (!options_.clock) options_.clock = systemClock();
}

SqliteTileIndex::~SqliteTileIndex() {
  // Readers close first: the write connection, last, checkpoints and empties the (kept) WAL, so
  // the next open reads the database file itself.
  std::lock_guard lock(readMutex_);
  idleReaders_.clear();
}

std::expected<std::unique_ptr<SqliteTileIndex>, CacheError>
SqliteTileIndex::open(const SqliteTileIndexOptions& options) {
  std::unique_ptr<SqliteTileIndex> index(new SqliteTileIndex(options));
  std::error_code ec;
  if (options.readOnly && !fs::exists(index->path_, ec)) {
    return std::unexpected(CacheError{CacheErrc::Io, "no cache index at " + index->path_.string()});
  }
  if (auto r = index->openWriteConnection(); !r) return std::unexpected(r.error());
  if (!options.readOnly) {
    if (auto r = index->prepareWriter(); !r) return std::unexpected(r.error());
  }
  index->dataVersion_ = sql::Stmt(index->writeDb_.get(), "PRAGMA data_version");
  return index;
}

/** Opens, configures, creates or migrates and probes the index; a damaged one once more after
 * moving it aside. */
Result SqliteTileIndex::openWriteConnection() {
  const bool readOnly = options_.readOnly;
  const fs::path marker = options_.root / kCorruptMarker;
  std::error_code ec;
  bool damaged = !readOnly && fs::exists(marker, ec);
  for (int attempt = 0; attempt < 2; ++attempt) {
    if (damaged) {
      moveAside(path_, options_.clock->now());
      fs::remove(marker, ec);
      damaged_ = true;
    }
    int rc = 0;
    writeDb_ = openDb(path_, readOnly, true, static_cast<int>(options_.busyTimeout.count()), &rc);
    if (!writeDb_) return std::unexpected(sql::errorFrom(nullptr, rc, "opening " + path_.string()));
    Result r = configure(writeDb_.get(), readOnly, static_cast<int>(options_.busyTimeout.count()));
    if (r && !readOnly) r = schema::ensure(writeDb_.get());
    if (r) r = probe(writeDb_.get());
    if (r) return {};
    if (r.error().code != CacheErrc::Corrupt || readOnly || attempt == 1) return r;
    writeDb_.reset();
    damaged = true;
  }
  return {};
}

// ---------------------------------------------------------------------------------- readers

std::expected<std::unique_ptr<SqliteTileIndex::ReadConn>, CacheError>
SqliteTileIndex::makeReader() const {
  int rc = 0;
  auto db = openDb(path_, true, false, static_cast<int>(options_.busyTimeout.count()), &rc);
  if (!db) return std::unexpected(sql::errorFrom(nullptr, rc, "opening index for reading"));
  auto c = std::make_unique<ReadConn>();
  c->lookup = sql::Stmt(db.get(),
                        "SELECT state, bytes, content_type, etag, last_modified, expires, "
                        "fetched_at, retry_after FROM tiles "
                        "WHERE dataset = ?1 AND level = ?2 AND row = ?3 AND col = ?4");
  // Memory-mapped reads: lookups skip a copy through SQLite's page cache (about 25% at p99).
  (void)sql::exec(db.get(), "PRAGMA mmap_size = 268435456");
  if (!c->lookup.ok()) {
    return std::unexpected(sql::errorFrom(db.get(), c->lookup.prepareRc(), "preparing lookup"));
  }
  c->db = std::move(db);
  return c;
}

SqliteTileIndex::ReaderLease::~ReaderLease() {
  if (!conn_) return;
  std::lock_guard lock(index_->readMutex_);
  if (index_->idleReaders_.size() <
      static_cast<std::size_t>(std::max(1, index_->options_.readConnections))) {
    index_->idleReaders_.push_back(std::move(conn_));
  }
}

std::expected<SqliteTileIndex::ReaderLease, CacheError> SqliteTileIndex::acquireReader() {
  {
    std::lock_guard lock(readMutex_);
    if (!idleReaders_.empty()) {
      auto c = std::move(idleReaders_.back());
      idleReaders_.pop_back();
      return ReaderLease{this, std::move(c)};
    }
  }
  auto c = makeReader();
  if (!c) return std::unexpected(c.error());
  return ReaderLease{this, std::move(*c)};
}

/** Remembers damage met by a read: the next open moves the index aside and rebuilds it. */
void SqliteTileIndex::markDamaged(const CacheError& error) const {
  (void)fileio::writeFileAtomic(
      options_.root / kCorruptMarker,
      std::as_bytes(std::span(error.message.data(), error.message.size())),
      false);
}

// ---------------------------------------------------------------------------------- reads

std::expected<std::optional<TileRow>, CacheError> SqliteTileIndex::lookup(DatasetId id,
                                                                          const TileKey& key) {
  auto lease = acquireReader();
  if (!lease) return std::unexpected(lease.error());
  sql::Stmt::Use u((*lease)->lookup);
  sql::bindKey(u, id, key);
  const int rc = u.step();
  if (rc == SQLITE_DONE) return std::nullopt;
  if (rc != SQLITE_ROW) {
    auto err = sql::errorFrom((*lease)->db.get(), rc, "looking up tile");
    if (err.code == CacheErrc::Corrupt) markDamaged(err);
    return std::unexpected(std::move(err));
  }
  TileRow row;
  row.bytes = u.i64(1);
  if (u.i64(0) == sql::kStateAbsent) {
    row.present = false;
    if (!u.isNull(7)) row.retryAfter = u.i64(7);
    return row;
  }
  row.meta.contentType = u.text(2);
  row.meta.etag = u.text(3);
  row.meta.lastModified = u.text(4);
  if (!u.isNull(5)) row.meta.expiresAt = u.i64(5);
  row.meta.fetchedAt = u.i64(6);
  return row;
}

std::expected<std::vector<DatasetInfo>, CacheError> SqliteTileIndex::datasets() {
  auto lease = acquireReader();
  if (!lease) return std::unexpected(lease.error());
  sqlite3* db = (*lease)->db.get();
  sql::Stmt s(db, (std::string(kDatasetColumns) + "ORDER BY id").c_str());
  if (!s.ok()) return std::unexpected(sql::errorFrom(db, s.prepareRc(), "reading datasets"));
  std::vector<DatasetInfo> out;
  sql::Stmt::Use u(s);
  int rc = 0;
  while ((rc = u.step()) == SQLITE_ROW)
    out.push_back(datasetFromRow(u));
  if (rc != SQLITE_DONE) return std::unexpected(sql::errorFrom(db, rc, "reading datasets"));
  return out;
}

std::expected<std::optional<DatasetInfo>, CacheError>
SqliteTileIndex::datasetInFolder(std::string_view folder) {
  auto lease = acquireReader();
  if (!lease) return std::unexpected(lease.error());
  sqlite3* db = (*lease)->db.get();
  sql::Stmt s(db, (std::string(kDatasetColumns) + "WHERE folder = ?1").c_str());
  if (!s.ok()) return std::unexpected(sql::errorFrom(db, s.prepareRc(), "finding dataset"));
  sql::Stmt::Use u(s);
  u.bind(1, folder);
  const int rc = u.step();
  if (rc == SQLITE_ROW) return datasetFromRow(u);
  if (rc != SQLITE_DONE) return std::unexpected(sql::errorFrom(db, rc, "finding dataset"));
  return std::nullopt;
}

Result SqliteTileIndex::forEachTile(DatasetId id,
                                    std::int32_t fromLevel,
                                    std::int32_t toLevel,
                                    const TileVisitor& visit) {
  auto lease = acquireReader();
  if (!lease) return std::unexpected(lease.error());
  sqlite3* db = (*lease)->db.get();
  sql::Stmt s(db,
              "SELECT level, row, col, bytes FROM tiles WHERE dataset = ?1 AND state = 1 "
              "AND level BETWEEN ?2 AND ?3 ORDER BY level, row, col");
  if (!s.ok()) return std::unexpected(sql::errorFrom(db, s.prepareRc(), "listing tiles"));
  sql::Stmt::Use u(s);
  u.bind(1, id).bind(2, std::int64_t{fromLevel}).bind(3, std::int64_t{toLevel});
  int rc = 0;
  while ((rc = u.step()) == SQLITE_ROW) {
    const TileKey k{static_cast<std::int32_t>(u.i64(0)), u.i64(1), u.i64(2)};
    if (!visit(k, u.i64(3))) return {};
  }
  if (rc != SQLITE_DONE) return std::unexpected(sql::errorFrom(db, rc, "listing tiles"));
  return {};
}

std::expected<std::int64_t, CacheError> SqliteTileIndex::totalBytes() {
  auto lease = acquireReader();
  if (!lease) return std::unexpected(lease.error());
  sql::Stmt s((*lease)->db.get(), "SELECT coalesce(sum(bytes), 0) FROM usage");
  sql::Stmt::Use u(s);
  const int rc = u.step();
  if (rc != SQLITE_ROW)
    return std::unexpected(sql::errorFrom((*lease)->db.get(), rc, "reading totals"));
  return u.i64(0);
}

std::expected<std::vector<IndexLevelCount>, CacheError> SqliteTileIndex::levelCounts() {
  auto lease = acquireReader();
  if (!lease) return std::unexpected(lease.error());
  sqlite3* db = (*lease)->db.get();
  sql::Stmt s(db,
              "SELECT dataset, level, count(*), sum(state = 2), sum(bytes) FROM tiles "
              "GROUP BY dataset, level ORDER BY dataset, level");
  if (!s.ok()) return std::unexpected(sql::errorFrom(db, s.prepareRc(), "reading stats"));
  sql::Stmt::Use u(s);
  std::vector<IndexLevelCount> out;
  int rc = 0;
  while ((rc = u.step()) == SQLITE_ROW) {
    out.push_back(IndexLevelCount{
        u.i64(0), LevelStats{static_cast<std::int32_t>(u.i64(1)), u.i64(2), u.i64(3), u.i64(4)}});
  }
  if (rc != SQLITE_DONE) return std::unexpected(sql::errorFrom(db, rc, "reading stats"));
  return out;
}

std::expected<std::vector<IndexSelectionCount>, CacheError>
SqliteTileIndex::countPrunable(const PruneSelection& selection) {
  auto lease = acquireReader();
  if (!lease) return std::unexpected(lease.error());
  sqlite3* db = (*lease)->db.get();
  // The same selection as forEachPrunable's.
  sql::Stmt s(db,
              "SELECT t.dataset, count(*), sum(t.bytes) FROM tiles t "
              "JOIN datasets d ON d.id = t.dataset WHERE t.fetched_at < ?1 "
              "AND (?2 IS NULL OR d.name = ?2) AND (?3 = 1 OR d.pinned = 0) "
              "GROUP BY t.dataset ORDER BY t.dataset");
  if (!s.ok()) return std::unexpected(sql::errorFrom(db, s.prepareRc(), "reading the index"));
  sql::Stmt::Use u(s);
  sql::bindPrune(u, selection);
  std::vector<IndexSelectionCount> out;
  int rc = 0;
  while ((rc = u.step()) == SQLITE_ROW)
    out.push_back(IndexSelectionCount{u.i64(0), u.i64(1), u.i64(2)});
  if (rc != SQLITE_DONE) return std::unexpected(sql::errorFrom(db, rc, "reading the index"));
  return out;
}

std::string SqliteTileIndex::integrity() {
  auto lease = acquireReader();
  if (!lease) return lease.error().message;
  sqlite3* db = (*lease)->db.get();
  sql::Stmt q(db, "PRAGMA quick_check");
  sql::Stmt::Use u(q);
  const int rc = u.step();
  return rc == SQLITE_ROW ? u.text(0) : std::string(sqlite3_errmsg(db));
}

std::expected<std::unique_ptr<ITileIndex>, CacheError>
openSqliteTileIndex(const SqliteTileIndexOptions& options) {
  auto index = SqliteTileIndex::open(options);
  if (!index) return std::unexpected(index.error());
  return std::unique_ptr<ITileIndex>(std::move(*index));
}

} // namespace tellus
