// PgTileIndex: opening and the read side.

#include "PgTileIndex.hpp"

#include "PgSchema.hpp"

#include <algorithm>
#include <random>

namespace tellus {

namespace {

using Result = std::expected<void, CacheError>;

constexpr const char* kDatasetColumns =
    "SELECT id, server, name, folder, west, south, east, north, level_zero_delta, tile_width, "
    "tile_height, num_levels, mime_type, extension, style, time, pinned, created_at, body "
    "FROM datasets ";

DatasetInfo datasetFromRow(const PGresult* r, int i) {
  using namespace pg;
  DatasetInfo d;
  d.id = i64(r, i, 0);
  DatasetSpec& s = d.spec;
  s.server = text(r, i, 1);
  s.name = text(r, i, 2);
  d.folder = text(r, i, 3);
  s.grid.sector = Sector{f64(r, i, 4), f64(r, i, 5), f64(r, i, 6), f64(r, i, 7)};
  s.grid.levelZeroDeltaDeg = f64(r, i, 8);
  s.grid.tileWidth = static_cast<std::int32_t>(i64(r, i, 9));
  s.grid.tileHeight = static_cast<std::int32_t>(i64(r, i, 10));
  s.grid.numLevels = static_cast<std::int32_t>(i64(r, i, 11));
  s.mimeType = text(r, i, 12);
  s.extension = text(r, i, 13);
  s.style = text(r, i, 14);
  s.time = text(r, i, 15);
  s.pinned = i64(r, i, 16) != 0;
  d.createdAt = i64(r, i, 17);
  s.body = text(r, i, 18);
  return d;
}

} // namespace

std::expected<std::unique_ptr<PgTileIndex>, CacheError>
PgTileIndex::open(const PgTileIndexOptions& options) {
  std::unique_ptr<PgTileIndex> index(new PgTileIndex(options));
  auto conn = pg::connect(options.connect);
  if (!conn) return std::unexpected(conn.error());
  if (auto s = pg::ensureSchema(conn->get(), options.readOnly); !s) {
    return std::unexpected(CacheError{
        s.error().code, s.error().message + " (" + redactConninfo(options.connect.conninfo) + ")"});
  }
  index->writer_ = std::move(*conn);
  if (!options.readOnly) {
    // A random id for this writer's row (collisions of 63 random bits are not a concern).
    std::random_device rd;
    index->writerId_ =
        static_cast<std::int64_t>(((std::uint64_t{rd()} << 32) ^ rd()) & 0x7fffffffffffffffULL);
    pg::Params me;
    me.add(index->writerId_);
    if (auto w = index->write("INSERT INTO tellus_writers(id) VALUES ($1)", me, "registering"); !w)
      return std::unexpected(w.error());
  }
  (void)index->changedByOthers(); // the first count
  return index;
}

std::expected<std::unique_ptr<ITileIndex>, CacheError>
openPgTileIndex(const PgTileIndexOptions& options) {
  auto index = PgTileIndex::open(options);
  if (!index) return std::unexpected(index.error());
  return std::unique_ptr<ITileIndex>(std::move(*index));
}

// ---------------------------------------------------------------------------------- readers

PgTileIndex::Reader::~Reader() {
  if (!conn_) return; // moved from
  std::lock_guard lock(index_->readMutex_);
  if (!pg::broken(conn_.get()) &&
      index_->idleReaders_.size() <
          static_cast<std::size_t>(std::max(1, index_->options_.readConnections))) {
    index_->idleReaders_.push_back(std::move(conn_));
  } else {
    conn_.reset();
    --index_->openReaders_;
  }
  index_->readerFreed_.notify_one();
}

std::expected<PgTileIndex::Reader, CacheError> PgTileIndex::reader() {
  {
    std::unique_lock lock(readMutex_);
    // At most maxReadConnections at once: a burst waits for a connection rather than opening
    // one per request (each costs the server a process).
    readerFreed_.wait(lock, [this] {
      return !idleReaders_.empty() || openReaders_ < std::max(1, options_.maxReadConnections);
    });
    if (!idleReaders_.empty()) {
      auto c = std::move(idleReaders_.back());
      idleReaders_.pop_back();
      return Reader{this, std::move(c)};
    }
    ++openReaders_;
  }
  auto c = pg::connect(options_.connect);
  if (!c) {
    std::lock_guard lock(readMutex_);
    --openReaders_;
    readerFreed_.notify_one();
    return std::unexpected(c.error());
  }
  return Reader{this, std::move(*c)};
}

std::expected<pg::ResultPtr, CacheError>
PgTileIndex::read(const char* sql, const pg::Params& params, const char* what) {
  auto r = reader();
  if (!r) return std::unexpected(r.error());
  return pg::exec(r->get(), sql, params, what);
}

// ---------------------------------------------------------------------------------- reads

namespace {

constexpr const char* kRowColumns =
    "SELECT state, bytes, content_type, etag, last_modified, expires, fetched_at, retry_after";

/** The row at `i` of a result whose columns are kRowColumns's. */
TileRow rowAt(const PGresult* r, int i) {
  TileRow row;
  row.bytes = pg::i64(r, i, 1);
  if (pg::i64(r, i, 0) == pg::kStateAbsent) {
    row.present = false;
    row.retryAfter = pg::optI64(r, i, 7);
    return row;
  }
  row.meta.contentType = pg::text(r, i, 2);
  row.meta.etag = pg::text(r, i, 3);
  row.meta.lastModified = pg::text(r, i, 4);
  row.meta.expiresAt = pg::optI64(r, i, 5);
  row.meta.fetchedAt = pg::i64(r, i, 6);
  return row;
}

} // namespace

std::expected<std::optional<TileRow>, CacheError> PgTileIndex::lookup(DatasetId id,
                                                                      const TileKey& key) {
  static const std::string sql = std::string(kRowColumns) +
                                 " FROM tiles WHERE dataset = $1 AND level = $2 AND row = $3 AND "
                                 "col = $4";
  auto res = read(sql.c_str(), pg::keyParams(id, key), "looking up tile");
  if (!res) return std::unexpected(res.error());
  if (PQntuples(res->get()) == 0) return std::nullopt;
  return rowAt(res->get(), 0);
}

std::expected<std::vector<std::optional<TileRow>>, CacheError>
PgTileIndex::lookupMany(DatasetId id, std::span<const TileKey> keys) {
  std::vector<std::optional<TileRow>> rows(keys.size());
  if (keys.empty()) return rows;
  if (keys.size() == 1) {
    auto one = lookup(id, keys.front());
    if (!one) return std::unexpected(one.error());
    rows.front() = std::move(*one);
    return rows;
  }
  // The tiles of a metatile (one level, a small block): one range scan of the primary key for
  // their bounding block, where a lookup each cost a round trip each (16 a metatile, several
  // times over in a burst of misses; bench/RESULTS.md, issue 27).
  const std::int32_t level = keys.front().level;
  std::int64_t r0 = keys.front().row, r1 = r0, c0 = keys.front().col, c1 = c0;
  for (const TileKey& k : keys) {
    if (k.level != level) return ITileIndex::lookupMany(id, keys);
    r0 = std::min(r0, k.row);
    r1 = std::max(r1, k.row);
    c0 = std::min(c0, k.col);
    c1 = std::max(c1, k.col);
  }
  if ((r1 - r0 + 1) * (c1 - c0 + 1) > 4 * static_cast<std::int64_t>(keys.size()) + 64)
    return ITileIndex::lookupMany(id, keys); // scattered keys: a block scan would read too much
  pg::Params p;
  p.add(std::int64_t{id}).add(std::int64_t{level}).add(r0).add(r1).add(c0).add(c1);
  static const std::string sql = std::string(kRowColumns) +
                                 ", row, col FROM tiles WHERE dataset = $1 AND level = $2 AND row "
                                 "BETWEEN $3 AND $4 AND col BETWEEN $5 AND $6";
  auto res = read(sql.c_str(), p, "looking up tiles");
  if (!res) return std::unexpected(res.error());
  const PGresult* r = res->get();
  for (int i = 0; i < PQntuples(r); ++i) {
    const std::int64_t row = pg::i64(r, i, 8), col = pg::i64(r, i, 9);
    for (std::size_t j = 0; j < keys.size(); ++j)
      if (keys[j].row == row && keys[j].col == col) rows[j] = rowAt(r, i);
  }
  return rows;
}

std::expected<std::vector<DatasetInfo>, CacheError> PgTileIndex::datasets() {
  auto res = read((std::string(kDatasetColumns) + "ORDER BY id").c_str(), {}, "reading datasets");
  if (!res) return std::unexpected(res.error());
  std::vector<DatasetInfo> out;
  for (int i = 0; i < PQntuples(res->get()); ++i)
    out.push_back(datasetFromRow(res->get(), i));
  return out;
}

std::expected<std::optional<DatasetInfo>, CacheError>
PgTileIndex::datasetInFolder(std::string_view folder) {
  pg::Params p;
  p.add(folder);
  auto res =
      read((std::string(kDatasetColumns) + "WHERE folder = $1").c_str(), p, "finding dataset");
  if (!res) return std::unexpected(res.error());
  if (PQntuples(res->get()) == 0) return std::nullopt;
  return datasetFromRow(res->get(), 0);
}

Result PgTileIndex::forEachTile(DatasetId id,
                                std::int32_t fromLevel,
                                std::int32_t toLevel,
                                const TileVisitor& visit) {
  pg::Params p;
  p.add(std::int64_t{id}).add(std::int64_t{fromLevel}).add(std::int64_t{toLevel});
  auto res = read("SELECT level, row, col, bytes FROM tiles WHERE dataset = $1 AND state = 1 "
                  "AND level BETWEEN $2 AND $3 ORDER BY level, row, col",
                  p,
                  "listing tiles");
  if (!res) return std::unexpected(res.error());
  const PGresult* r = res->get();
  for (int i = 0; i < PQntuples(r); ++i) {
    const TileKey k{
        static_cast<std::int32_t>(pg::i64(r, i, 0)), pg::i64(r, i, 1), pg::i64(r, i, 2)};
    if (!visit(k, pg::i64(r, i, 3))) return {};
  }
  return {};
}

std::expected<std::int64_t, CacheError> PgTileIndex::totalBytes() {
  auto res = read("SELECT coalesce(sum(bytes), 0) FROM usage", {}, "reading totals");
  if (!res) return std::unexpected(res.error());
  return pg::i64(res->get(), 0, 0);
}

std::expected<std::vector<IndexLevelCount>, CacheError> PgTileIndex::levelCounts() {
  auto res = read("SELECT dataset, level, count(*), count(*) FILTER (WHERE state = 2), "
                  "sum(bytes) FROM tiles GROUP BY dataset, level ORDER BY dataset, level",
                  {},
                  "reading stats");
  if (!res) return std::unexpected(res.error());
  const PGresult* r = res->get();
  std::vector<IndexLevelCount> out;
  for (int i = 0; i < PQntuples(r); ++i) {
    out.push_back(IndexLevelCount{pg::i64(r, i, 0),
                                  LevelStats{static_cast<std::int32_t>(pg::i64(r, i, 1)),
                                             pg::i64(r, i, 2),
                                             pg::i64(r, i, 3),
                                             pg::i64(r, i, 4)}});
  }
  return out;
}

std::expected<std::vector<IndexSelectionCount>, CacheError>
PgTileIndex::countPrunable(const PruneSelection& selection) {
  const std::string sql =
      std::string("SELECT t.dataset, count(*), sum(t.bytes) FROM tiles t JOIN datasets d ON "
                  "d.id = t.dataset WHERE ") +
      pg::kPruneWhere + " GROUP BY t.dataset ORDER BY t.dataset";
  auto res = read(sql.c_str(), pg::pruneParams(selection), "reading the index");
  if (!res) return std::unexpected(res.error());
  const PGresult* r = res->get();
  std::vector<IndexSelectionCount> out;
  for (int i = 0; i < PQntuples(r); ++i)
    out.push_back(IndexSelectionCount{pg::i64(r, i, 0), pg::i64(r, i, 1), pg::i64(r, i, 2)});
  return out;
}

std::string PgTileIndex::integrity() {
  // The server keeps its own pages consistent; what tellus can break is the counters.
  auto res = read("SELECT count(*) FROM usage u, LATERAL (SELECT count(*) AS n, "
                  "coalesce(sum(t.bytes), 0) AS b FROM tiles t WHERE t.dataset = u.dataset) s "
                  "WHERE u.tiles <> s.n OR u.bytes <> s.b",
                  {},
                  "checking the index");
  if (!res) return res.error().message;
  const std::int64_t wrong = pg::i64(res->get(), 0, 0);
  return wrong == 0 ? "ok" : std::to_string(wrong) + " datasets' counters disagree with their rows";
}

} // namespace tellus
