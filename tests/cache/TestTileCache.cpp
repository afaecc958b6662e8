// The tile cache on its embedded default, SQLite and the file tree: the layout on disk, the index
// file (damage, schema versions), verify of files, two caches on one index. Behaviour common to
// every index and store is in TestTileCacheContract.cpp and TestTileCacheHotPath.cpp.

#include "../support/CacheFixtures.hpp"
#include "../support/TempDir.hpp"

#include <tellus/cache/TileCache.hpp>
#include <tellus/cache/TilePath.hpp>

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <chrono>
#include <fstream>
#include <memory>

using namespace tellus;
using tellus::test::payload;
namespace fs = std::filesystem;

namespace {

DatasetSpec imagery(const std::string& name = "bluemarble") {
  return test::imagerySpec(name);
}

std::unique_ptr<TileCache> openCache(const fs::path& root) {
  return test::openTestCache(root);
}

int userVersion(const fs::path& db) {
  sqlite3* raw = nullptr;
  sqlite3_open(db.c_str(), &raw);
  sqlite3_stmt* s = nullptr;
  sqlite3_prepare_v2(raw, "PRAGMA user_version", -1, &s, nullptr);
  sqlite3_step(s);
  const int v = sqlite3_column_int(s, 0);
  sqlite3_finalize(s);
  sqlite3_close(raw);
  return v;
}

} // namespace

TEST(TileCache, PutGetRoundTripInWorldWindTree) {
  test::TempDir dir("cache");
  auto cache = openCache(dir.path());
  auto id = cache->registerDataset(imagery());
  ASSERT_TRUE(id);
  const TileKey k{2, 13, 35};
  TileMeta meta;
  meta.etag = "\"abc\"";
  meta.lastModified = "Tue, 01 Jun 2004 00:00:00 GMT";
  ASSERT_TRUE(cache->put(*id, k, payload(k), meta));
  auto got = cache->get(*id, k);
  ASSERT_TRUE(got);
  EXPECT_EQ(got->kind, CacheLookup::Kind::Hit);
  EXPECT_EQ(got->bytes, payload(k));
  EXPECT_EQ(got->meta.contentType, "image/jpeg");
  EXPECT_EQ(got->meta.etag, "\"abc\"");
  EXPECT_EQ(got->meta.lastModified, meta.lastModified);
  EXPECT_FALSE(got->stale);
  const fs::path file = dir.path() / datasetFolder(imagery()) / "2/13/13_35.jpg";
  EXPECT_TRUE(fs::exists(file)) << file;
  EXPECT_TRUE(fs::exists(dir.path() / datasetFolder(imagery()) / "dataset.txt"));
  EXPECT_TRUE(fs::exists(dir.path() / "index.sqlite"));
  EXPECT_EQ(userVersion(dir.path() / "index.sqlite"), 3);
}

TEST(TileCache, HostileNamesStayInsideTheRoot) {
  test::TempDir dir("cache");
  auto cache = openCache(dir.path() / "root");
  auto spec = imagery("../../escaped");
  spec.server = "..";
  const auto id = cache->registerDataset(spec);
  ASSERT_TRUE(id);
  ASSERT_TRUE(cache->put(*id, TileKey{0, 0, 0}, payload({}), {}));
  EXPECT_FALSE(fs::exists(dir.path() / "escaped"));
  for (const auto& e : fs::recursive_directory_iterator(dir.path())) {
    const auto rel = fs::relative(e.path(), dir.path() / "root");
    EXPECT_FALSE(rel.string().starts_with("..")) << e.path();
  }
}

TEST(TileCache, VerifyFindsBothKindsOfDriftAndRebuildRepairs) {
  test::TempDir dir("cache");
  auto cache = openCache(dir.path());
  const auto id = *cache->registerDataset(imagery());
  for (std::int64_t c = 0; c < 4; ++c)
    ASSERT_TRUE(cache->put(id, TileKey{1, 0, c}, payload({1, 0, c}), {}));
  auto report = cache->verify();
  ASSERT_TRUE(report);
  EXPECT_TRUE(report->ok()) << report->integrity;
  const fs::path ds = dir.path() / datasetFolder(imagery());
  fs::remove(ds / "1/0/0_1.jpg");
  fs::create_directories(ds / "3/7");
  std::ofstream(ds / "3/7/7_9.jpg") << "orphan";
  // A dead writer's: no pid can be above Linux's PID_MAX_LIMIT (4,194,304); pid 999, used before,
  // ran now and then on a busy machine, and its temp file then counted as in use.
  std::ofstream(ds / "1/0/.0_2.jpg.2147483646.0.tmp") << "partial";
  report = cache->verify();
  ASSERT_TRUE(report);
  EXPECT_FALSE(report->ok());
  ASSERT_EQ(report->rowsWithoutFiles.size(), 1u);
  EXPECT_TRUE(report->rowsWithoutFiles[0].ends_with("1/0/0_1.jpg"));
  ASSERT_EQ(report->filesWithoutRows.size(), 1u);
  EXPECT_TRUE(report->filesWithoutRows[0].ends_with("3/7/7_9.jpg"));
  EXPECT_EQ(report->strayTempFiles.size(), 1u);
  EXPECT_EQ(*cache->rebuild(), 4); // 3 survivors + the orphan
  report = cache->verify();
  EXPECT_TRUE(report->ok());
  EXPECT_TRUE(report->strayTempFiles.empty());
  EXPECT_EQ(cache->get(id, TileKey{3, 7, 9})->kind, CacheLookup::Kind::Hit);
}

// A tile file's mtime is the fetched-at it was stored with (TileLocation::fetchedAt), so an index
// rebuilt from the tree keeps each tile's age (before: the time its file was written).
TEST(TileCache, ARebuiltIndexKeepsEachTilesFetchedAt) {
  test::TempDir dir("cache");
  auto cache = openCache(dir.path());
  const auto id = *cache->registerDataset(imagery());
  constexpr UnixMillis kFetched = 1'600'000'000'000; // 2020: long before the files were written
  for (std::int64_t c = 0; c < 3; ++c) {
    TileMeta m;
    m.fetchedAt = kFetched + 1000 * c + 7;
    ASSERT_TRUE(cache->put(id, TileKey{1, 0, c}, payload({1, 0, c}), m));
  }
  std::vector<TileCache::TileBytes> many;
  const auto a = payload({2, 0, 0}), b = payload({2, 0, 1});
  many.push_back({TileKey{2, 0, 0}, a});
  many.push_back({TileKey{2, 0, 1}, b});
  TileMeta together;
  together.fetchedAt = kFetched + 99;
  ASSERT_TRUE(cache->putMany(id, many, together));
  cache.reset();
  fs::remove(dir.path() / "index.sqlite");
  cache = openCache(dir.path());
  ASSERT_TRUE(cache);
  EXPECT_EQ(*cache->rebuild(), 5);
  const auto all = cache->datasets();
  ASSERT_EQ(all.size(), 1u);
  for (std::int64_t c = 0; c < 3; ++c) {
    const auto got = cache->get(all[0].id, TileKey{1, 0, c});
    ASSERT_TRUE(got);
    EXPECT_EQ(got->meta.fetchedAt, kFetched + 1000 * c + 7) << c;
  }
  for (std::int64_t c = 0; c < 2; ++c)
    EXPECT_EQ(cache->get(all[0].id, TileKey{2, 0, c})->meta.fetchedAt, kFetched + 99) << c;
}

TEST(TileCache, CorruptIndexIsMovedAsideAndRebuilt) {
  test::TempDir dir("cache");
  DatasetId id = 0;
  {
    auto cache = openCache(dir.path());
    id = *cache->registerDataset(imagery());
    for (std::int64_t c = 0; c < 5; ++c)
      ASSERT_TRUE(cache->put(id, TileKey{1, 0, c}, payload({1, 0, c}), {}));
  }
  {
    std::fstream f(dir.path() / "index.sqlite", std::ios::in | std::ios::out | std::ios::binary);
    const std::string garbage(4096, 'Z');
    f.write(garbage.data(), static_cast<std::streamsize>(garbage.size()));
  }
  auto cache = openCache(dir.path());
  ASSERT_TRUE(cache);
  EXPECT_TRUE(cache->wasRebuiltAtOpen());
  const auto all = cache->datasets();
  ASSERT_EQ(all.size(), 1u);
  for (std::int64_t c = 0; c < 5; ++c) {
    EXPECT_EQ(cache->get(all[0].id, TileKey{1, 0, c})->bytes, payload({1, 0, c}));
  }
  bool movedAside = false;
  for (const auto& e : fs::directory_iterator(dir.path())) {
    movedAside |= e.path().filename().string().starts_with("index.sqlite.corrupt-");
  }
  EXPECT_TRUE(movedAside);
}

TEST(TileCache, MigratesSchemaVersion1) {
  test::TempDir dir("cache");
  // The version-1 layout exactly as tellus 0.1 wrote it (frozen here on purpose).
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open((dir.path() / "index.sqlite").c_str(), &db), SQLITE_OK);
    const char* v1 = R"sql(
      CREATE TABLE datasets(id INTEGER PRIMARY KEY, server TEXT NOT NULL, name TEXT NOT NULL,
        folder TEXT NOT NULL UNIQUE, west REAL NOT NULL, south REAL NOT NULL, east REAL NOT NULL,
        north REAL NOT NULL, level_zero_delta REAL NOT NULL, tile_width INTEGER NOT NULL,
        tile_height INTEGER NOT NULL, num_levels INTEGER NOT NULL, mime_type TEXT NOT NULL,
        extension TEXT NOT NULL, style TEXT NOT NULL, time TEXT NOT NULL,
        pinned INTEGER NOT NULL DEFAULT 0, created_at INTEGER NOT NULL);
      CREATE TABLE tiles(dataset INTEGER NOT NULL, level INTEGER NOT NULL, row INTEGER NOT NULL,
        col INTEGER NOT NULL, state INTEGER NOT NULL, bytes INTEGER NOT NULL, content_type TEXT,
        etag TEXT, last_modified TEXT, expires INTEGER, fetched_at INTEGER NOT NULL,
        last_access INTEGER NOT NULL, retry_after INTEGER,
        PRIMARY KEY(dataset, level, row, col)) WITHOUT ROWID;
      CREATE INDEX tiles_by_access ON tiles(last_access);
      PRAGMA user_version = 1;)sql";
    ASSERT_EQ(sqlite3_exec(db, v1, nullptr, nullptr, nullptr), SQLITE_OK);
    const std::string folder = datasetFolder(imagery());
    const std::string ins =
        "INSERT INTO datasets VALUES(7, 'local', 'bluemarble', '" + folder +
        "', -180, -90, 180, 90, 36, 512, 512, 10, 'image/jpeg', 'jpg', '', '', 0, 0);"
        "INSERT INTO tiles VALUES(7, 0, 0, 0, 1, 100, 'image/jpeg', '', '', NULL, 1, 1, NULL);"
        "INSERT INTO tiles VALUES(7, 0, 0, 1, 1, 150, 'image/jpeg', '', '', NULL, 1, 1, NULL);";
    ASSERT_EQ(sqlite3_exec(db, ins.c_str(), nullptr, nullptr, nullptr), SQLITE_OK);
    sqlite3_close(db);
  }
  auto cache = openCache(dir.path());
  ASSERT_TRUE(cache);
  EXPECT_FALSE(cache->wasRebuiltAtOpen());
  EXPECT_EQ(userVersion(dir.path() / "index.sqlite"), 3);
  EXPECT_EQ(*cache->totalBytes(), 250);
  ASSERT_TRUE(cache->dataset(7));
  EXPECT_EQ(cache->peek(7, TileKey{0, 0, 1})->size, 150);
}

TEST(TileCache, RefusesANewerSchema) {
  test::TempDir dir("cache");
  {
    sqlite3* db = nullptr;
    sqlite3_open((dir.path() / "index.sqlite").c_str(), &db);
    sqlite3_exec(db, "CREATE TABLE x(a); PRAGMA user_version = 99;", nullptr, nullptr, nullptr);
    sqlite3_close(db);
  }
  TileCache::Options o;
  o.root = dir.path();
  auto c = TileCache::open(o);
  ASSERT_FALSE(c);
  EXPECT_EQ(c.error().code, CacheErrc::Schema);
  EXPECT_NE(c.error().message.find("99"), std::string::npos);
  EXPECT_EQ(userVersion(dir.path() / "index.sqlite"), 99); // left alone, not "repaired"
}

// ------------------------------------------------------------------ remembered rows, other
// processes

namespace {

std::vector<std::byte> filled(std::size_t n, unsigned char value) {
  return std::vector<std::byte>(n, static_cast<std::byte>(value));
}

std::unique_ptr<TileCache> openWith(const fs::path& root,
                                    const std::shared_ptr<ManualClock>& clock,
                                    std::chrono::milliseconds otherWritersCheck,
                                    std::chrono::milliseconds fileRecheck) {
  TileCache::Options o;
  o.root = root;
  o.fsyncTiles = false;
  o.otherWritersCheck = otherWritersCheck;
  o.fileRecheck = fileRecheck;
  o.clock = clock;
  auto c = TileCache::open(o);
  EXPECT_TRUE(c) << (c ? "" : c.error().message);
  return c ? std::move(*c) : nullptr;
}

} // namespace

TEST(TileCache, AnotherWritersChangesAreSeenWithinTheCheckInterval) {
  test::TempDir dir("cache");
  // Two caches on one root: as two processes, each with its own SQLite connections (another
  // connection's commits move PRAGMA data_version), on one clock.
  auto clock = std::make_shared<ManualClock>();
  auto writer = openWith(dir.path(), clock, std::chrono::milliseconds(20), std::chrono::hours(1));
  auto reader = openWith(dir.path(), clock, std::chrono::milliseconds(20), std::chrono::hours(1));
  const auto id = *writer->registerDataset(imagery());
  const TileKey k{1, 0, 0};
  ASSERT_TRUE(writer->put(id, k, filled(256, 1), {}));
  ASSERT_EQ(reader->get(id, k)->bytes, filled(256, 1));
  ASSERT_TRUE(writer->put(id, k, filled(256, 9), {}));
  // Within the interval the reader answers from the row (and the file) it remembered.
  EXPECT_EQ(reader->get(id, k)->bytes, filled(256, 1));
  clock->advance(std::chrono::milliseconds(20));
  EXPECT_EQ(reader->get(id, k)->bytes, filled(256, 9));
  ASSERT_TRUE(writer->erase(id, k));
  clock->advance(std::chrono::milliseconds(20));
  EXPECT_EQ(reader->get(id, k)->kind, CacheLookup::Kind::Miss);
}
