// The cache keeps each body's datasets apart (issue 26): the body enters the variant hash and the
// descriptor only when it is not the Earth, so every cache written before bodies keeps its folders;
// the index stores it (schema v3) and reads every older row as the Earth's; a rebuild from the tree
// reads it back from dataset.txt.

#include "../support/CacheFixtures.hpp"
#include "../support/TempDir.hpp"

#include <tellus/cache/Dataset.hpp>
#include <tellus/cache/TileCache.hpp>

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

using namespace tellus;
using tellus::test::payload;
namespace fs = std::filesystem;

namespace {

DatasetSpec on(const std::string& body, const std::string& name = "global") {
  DatasetSpec s = test::imagerySpec(name);
  s.server = "planetarymaps.usgs.gov";
  s.body = body;
  return s;
}

std::string readFile(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
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

TEST(DatasetBodies, TheEarthKeepsTheHashOfEveryCacheWrittenBeforeBodies) {
  // The variant of bluemarble as tellus computed it before bodies (main at cbacb98), frozen here.
  const DatasetSpec earth = test::imagerySpec();
  EXPECT_EQ(earth.body, "earth");
  EXPECT_EQ(datasetVariant(earth), "455863c2");
  EXPECT_EQ(serializeDatasetSpec(earth).find("body"), std::string::npos);
}

TEST(DatasetBodies, TheSameNameOnTwoBodiesIsTwoVariants) {
  const auto moon = on("moon"), mars = on("mars"), earth = on("earth");
  EXPECT_NE(datasetVariant(moon), datasetVariant(mars));
  EXPECT_NE(datasetVariant(moon), datasetVariant(earth));
  EXPECT_NE(datasetFolder(moon), datasetFolder(mars));
}

TEST(DatasetBodies, TheDescriptorCarriesTheBodyAndItsAbsenceIsTheEarth) {
  const auto text = serializeDatasetSpec(on("moon"));
  EXPECT_NE(text.find("\nbody=moon\n"), std::string::npos);
  const auto back = parseDatasetSpec(text);
  ASSERT_TRUE(back);
  EXPECT_EQ(back->body, "moon");
  EXPECT_EQ(datasetFolder(*back), datasetFolder(on("moon")));
  const auto old = parseDatasetSpec(serializeDatasetSpec(on("earth")));
  ASSERT_TRUE(old);
  EXPECT_EQ(old->body, "earth");
  EXPECT_FALSE(parseDatasetSpec(text + "body=\n")) << "an empty body is no body";
}

TEST(TileCacheBodies, TheSameNameAndServerOnTwoBodiesAreTwoDatasetsInTwoFolders) {
  test::TempDir dir("bodies");
  auto cache = test::openTestCache(dir.path());
  const auto moon = cache->registerDataset(on("moon"));
  const auto mars = cache->registerDataset(on("mars"));
  ASSERT_TRUE(moon);
  ASSERT_TRUE(mars);
  EXPECT_NE(*moon, *mars);
  const TileKey k{0, 0, 0};
  ASSERT_TRUE(cache->put(*moon, k, payload(k, 100), {}));
  ASSERT_TRUE(cache->put(*mars, k, payload(k, 300), {}));
  EXPECT_EQ(cache->get(*moon, k)->bytes, payload(k, 100));
  EXPECT_EQ(cache->get(*mars, k)->bytes, payload(k, 300));
  const auto mi = *cache->dataset(*moon), ri = *cache->dataset(*mars);
  EXPECT_NE(mi.folder, ri.folder);
  EXPECT_EQ(mi.spec.body, "moon");
  EXPECT_EQ(ri.spec.body, "mars");
  EXPECT_TRUE(fs::exists(dir.path() / mi.folder / "0/0/0_0.jpg"));
  EXPECT_TRUE(fs::exists(dir.path() / ri.folder / "0/0/0_0.jpg"));
  EXPECT_NE(readFile(dir.path() / mi.folder / "dataset.txt").find("body=moon"), std::string::npos);
  // Reopened: the index remembers each body.
  cache.reset();
  cache = test::openTestCache(dir.path());
  EXPECT_EQ(cache->dataset(*moon)->spec.body, "moon");
  EXPECT_EQ(cache->dataset(*mars)->spec.body, "mars");
}

TEST(TileCacheBodies, RefusesAnEmptyBody) {
  test::TempDir dir("bodies");
  auto cache = test::openTestCache(dir.path());
  const auto r = cache->registerDataset(on(""));
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, CacheErrc::InvalidArgument);
  EXPECT_NE(r.error().message.find("body"), std::string::npos);
}

TEST(TileCacheBodies, AnIndexOfSchemaVersion2OpensAndReadsAsTheEarth) {
  test::TempDir dir("bodies");
  // The version-2 layout exactly as tellus wrote it before bodies (frozen here on purpose).
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open((dir.path() / "index.sqlite").c_str(), &db), SQLITE_OK);
    const char* v2 = R"sql(
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
      CREATE TABLE usage(dataset INTEGER PRIMARY KEY, tiles INTEGER NOT NULL DEFAULT 0,
                         bytes INTEGER NOT NULL DEFAULT 0);
      CREATE TRIGGER datasets_ins AFTER INSERT ON datasets BEGIN
        INSERT INTO usage(dataset) VALUES (NEW.id);
      END;
      CREATE TRIGGER tiles_ins AFTER INSERT ON tiles BEGIN
        UPDATE usage SET tiles = tiles + 1, bytes = bytes + NEW.bytes WHERE dataset = NEW.dataset;
      END;
      PRAGMA user_version = 2;)sql";
    ASSERT_EQ(sqlite3_exec(db, v2, nullptr, nullptr, nullptr), SQLITE_OK);
    const std::string folder = datasetFolder(test::imagerySpec());
    const std::string ins =
        "INSERT INTO datasets VALUES(7, 'local', 'bluemarble', '" + folder +
        "', -180, -90, 180, 90, 36, 512, 512, 12, 'image/jpeg', 'jpg', '', '', 0, 0);"
        "INSERT INTO tiles VALUES(7, 0, 0, 1, 1, 150, 'image/jpeg', '', '', NULL, 1, 1, NULL);";
    ASSERT_EQ(sqlite3_exec(db, ins.c_str(), nullptr, nullptr, nullptr), SQLITE_OK);
    sqlite3_close(db);
  }
  auto cache = test::openTestCache(dir.path());
  ASSERT_TRUE(cache);
  EXPECT_FALSE(cache->wasRebuiltAtOpen());
  EXPECT_EQ(userVersion(dir.path() / "index.sqlite"), 3);
  ASSERT_TRUE(cache->dataset(7));
  EXPECT_EQ(cache->dataset(7)->spec.body, "earth");
  EXPECT_EQ(*cache->totalBytes(), 150);
  // Registering the layer as configured today finds the same dataset (same folder, same id).
  EXPECT_EQ(*cache->registerDataset(test::imagerySpec()), 7);
}

TEST(TileCacheBodies, ARebuildFromTheTreeReadsEachDatasetsBody) {
  test::TempDir dir("bodies");
  auto cache = test::openTestCache(dir.path());
  const auto moon = *cache->registerDataset(on("moon"));
  const auto earth = *cache->registerDataset(on("earth"));
  const TileKey k{1, 0, 2};
  ASSERT_TRUE(cache->put(moon, k, payload(k), {}));
  ASSERT_TRUE(cache->put(earth, k, payload(k), {}));
  EXPECT_EQ(*cache->rebuild(), 2);
  std::map<std::string, std::string> bodyOfFolder;
  for (const auto& d : cache->datasets())
    bodyOfFolder[d.folder] = d.spec.body;
  ASSERT_EQ(bodyOfFolder.size(), 2u);
  EXPECT_EQ(bodyOfFolder[datasetFolder(on("moon"))], "moon");
  EXPECT_EQ(bodyOfFolder[datasetFolder(on("earth"))], "earth");
}
