#include "../support/CacheFixtures.hpp"
#include "../support/TempDir.hpp"

#include <tellus/cache/GeoPackage.hpp>

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <fstream>
#include <unistd.h>

using namespace tellus;
namespace fs = std::filesystem;

namespace {

/** JPEG magic followed by a pattern that depends on the key. */
std::vector<std::byte> jpegLike(const TileKey& k) {
  auto v = test::payload(k, 200);
  v[0] = std::byte{0xFF};
  v[1] = std::byte{0xD8};
  v[2] = std::byte{0xFF};
  return v;
}

std::int64_t scalar(const fs::path& db, const std::string& sqlText) {
  sqlite3* raw = nullptr;
  sqlite3_open_v2(db.c_str(), &raw, SQLITE_OPEN_READONLY, nullptr);
  sqlite3_stmt* s = nullptr;
  std::int64_t v = -1;
  if (sqlite3_prepare_v2(raw, sqlText.c_str(), -1, &s, nullptr) == SQLITE_OK &&
      sqlite3_step(s) == SQLITE_ROW)
    v = sqlite3_column_int64(s, 0);
  sqlite3_finalize(s);
  sqlite3_close(raw);
  return v;
}

} // namespace

TEST(GeoPackage, ExportFlipsRowsAndImportRestoresTheSameTiles) {
  test::TempDir dir("gpkg");
  auto cache = test::openTestCache(dir.path() / "a");
  const auto id = *cache->registerDataset(test::imagerySpec());
  const std::vector<TileKey> keys{{0, 0, 0}, {0, 4, 9}, {1, 0, 3}, {1, 9, 19}, {2, 7, 11}};
  for (const auto& k : keys)
    ASSERT_TRUE(cache->put(id, k, jpegLike(k), {}));
  const fs::path file = dir.path() / "out.gpkg";
  auto r = exportGeoPackage(*cache, id, file, 0, 1);
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(r->tiles, 4); // level 2 is outside the range
  EXPECT_EQ(r->minLevel, 0);
  EXPECT_EQ(r->maxLevel, 1);
  EXPECT_EQ(scalar(file, "PRAGMA application_id"), 1196444487);
  EXPECT_EQ(scalar(file, "SELECT matrix_width FROM gpkg_tile_matrix WHERE zoom_level = 1"), 20);
  EXPECT_EQ(scalar(file, "SELECT matrix_height FROM gpkg_tile_matrix WHERE zoom_level = 1"), 10);
  // World Wind row 0 is the southernmost; GeoPackage row 0 the northernmost.
  EXPECT_EQ(
      scalar(file, "SELECT tile_row FROM bluemarble WHERE zoom_level = 1 AND tile_column = 3"), 9);
  EXPECT_EQ(
      scalar(file, "SELECT tile_row FROM bluemarble WHERE zoom_level = 0 AND tile_column = 9"), 0);
  EXPECT_FALSE(fs::exists(file.string() + ".tmp-" + std::to_string(::getpid())));

  auto other = test::openTestCache(dir.path() / "b");
  const auto id2 = *other->registerDataset(test::imagerySpec());
  auto back = importGeoPackage(*other, id2, file);
  ASSERT_TRUE(back) << back.error().message;
  EXPECT_EQ(back->tiles, 4);
  for (const auto& k : keys) {
    const auto got = other->get(id2, k);
    ASSERT_TRUE(got);
    if (k.level <= 1) {
      ASSERT_EQ(got->kind, CacheLookup::Kind::Hit) << k.level << "/" << k.row << "/" << k.col;
      EXPECT_EQ(got->bytes, jpegLike(k));
    } else {
      EXPECT_EQ(got->kind, CacheLookup::Kind::Miss);
    }
  }
}

TEST(GeoPackage, RefusesWhatItCannotHoldOrMatch) {
  test::TempDir dir("gpkg");
  auto cache = test::openTestCache(dir.path() / "a");
  DatasetSpec heights = test::imagerySpec("etopo");
  heights.mimeType = "application/bil16";
  heights.extension = "bil";
  const auto hid = *cache->registerDataset(heights);
  const fs::path file = dir.path() / "x.gpkg";
  auto e = exportGeoPackage(*cache, hid, file);
  ASSERT_FALSE(e);
  EXPECT_EQ(e.error().code, CacheErrc::InvalidArgument);
  EXPECT_NE(e.error().message.find("JPEG or PNG"), std::string::npos) << e.error().message;
  EXPECT_FALSE(fs::exists(file));

  const auto id = *cache->registerDataset(test::imagerySpec());
  ASSERT_TRUE(cache->put(id, TileKey{0, 1, 1}, jpegLike({0, 1, 1}), {}));
  ASSERT_TRUE(exportGeoPackage(*cache, id, file));
  // Another grid: 256-pixel tiles.
  DatasetSpec small = test::imagerySpec("small");
  small.grid.tileWidth = small.grid.tileHeight = 256;
  const auto sid = *cache->registerDataset(small);
  auto m = importGeoPackage(*cache, sid, file);
  ASSERT_FALSE(m);
  EXPECT_NE(m.error().message.find("512x512 px"), std::string::npos) << m.error().message;
  // Not a GeoPackage at all.
  const fs::path junk = dir.path() / "junk.gpkg";
  std::ofstream(junk) << "not sqlite";
  EXPECT_FALSE(importGeoPackage(*cache, id, junk));
}

TEST(GeoPackage, RefusesADatasetOnAnotherBody) {
  test::TempDir dir("gpkg");
  auto cache = test::openTestCache(dir.path() / "a");
  DatasetSpec moon = test::imagerySpec("lroc");
  moon.body = "moon";
  const auto id = *cache->registerDataset(moon);
  ASSERT_TRUE(cache->put(id, TileKey{0, 1, 1}, jpegLike({0, 1, 1}), {}));
  const fs::path file = dir.path() / "moon.gpkg";
  auto e = exportGeoPackage(*cache, id, file);
  ASSERT_FALSE(e);
  EXPECT_EQ(e.error().code, CacheErrc::InvalidArgument);
  EXPECT_NE(e.error().message.find("moon"), std::string::npos) << e.error().message;
  EXPECT_FALSE(fs::exists(file));
  // An Earth GeoPackage is not read into the Moon's dataset either.
  const auto earth = *cache->registerDataset(test::imagerySpec());
  ASSERT_TRUE(cache->put(earth, TileKey{0, 1, 1}, jpegLike({0, 1, 1}), {}));
  ASSERT_TRUE(exportGeoPackage(*cache, earth, file));
  auto m = importGeoPackage(*cache, id, file);
  ASSERT_FALSE(m);
  EXPECT_NE(m.error().message.find("moon"), std::string::npos) << m.error().message;
}

// A renderer's whole polar rows and spans (issue 29) are boxes no tile of their grid is: neither
// exported nor imported as a GeoPackage, with a message that says why.
TEST(GeoPackage, RefusesWholeRowsAndSpans) {
  test::TempDir dir("gpkg");
  auto cache = test::openTestCache(dir.path() / "a");
  const fs::path file = dir.path() / "x.gpkg";
  const auto earth = *cache->registerDataset(test::imagerySpec());
  ASSERT_TRUE(cache->put(earth, TileKey{0, 1, 1}, jpegLike({0, 1, 1}), {}));
  ASSERT_TRUE(exportGeoPackage(*cache, earth, file));
  for (const char* name : {"bluemarble@caps", "bluemarble@span4"}) {
    SCOPED_TRACE(name);
    const auto id = *cache->registerDataset(test::imagerySpec(name));
    ASSERT_TRUE(cache->put(id, TileKey{0, 4, 0}, jpegLike({0, 4, 0}), {}));
    const fs::path out = dir.path() / "whole.gpkg";
    auto e = exportGeoPackage(*cache, id, out);
    ASSERT_FALSE(e);
    EXPECT_EQ(e.error().code, CacheErrc::InvalidArgument);
    EXPECT_NE(e.error().message.find("not a tile pyramid"), std::string::npos) << e.error().message;
    EXPECT_FALSE(fs::exists(out));
    auto m = importGeoPackage(*cache, id, file);
    ASSERT_FALSE(m);
    EXPECT_NE(m.error().message.find("not a tile pyramid"), std::string::npos) << m.error().message;
  }
}
