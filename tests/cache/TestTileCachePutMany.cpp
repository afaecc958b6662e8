// TileCache::putMany, a metatile's tiles stored together (their files flushed together, their rows
// in one transaction), on a real folder and SQLite index: every tile or none. The full disk's cases
// are in TestTileCacheFullDisk.cpp.

#include "../support/CacheFixtures.hpp"
#include "../support/TempDir.hpp"

#include <tellus/cache/TileCache.hpp>
#include <tellus/cache/TilePath.hpp>

#include <gtest/gtest.h>

#include <filesystem>
#include <vector>

using namespace tellus;
namespace fs = std::filesystem;

namespace {

/** The 16 tiles of the 4x4 metatile at level 4 whose top-left tile is (row 4, column 8). */
std::vector<TileKey> metatile() {
  std::vector<TileKey> keys;
  for (std::int64_t r = 4; r < 8; ++r)
    for (std::int64_t c = 8; c < 12; ++c)
      keys.push_back(TileKey{4, r, c});
  return keys;
}

std::vector<TileCache::TileBytes> tilesOf(const std::vector<TileKey>& keys,
                                          std::vector<std::vector<std::byte>>& bytes) {
  std::vector<TileCache::TileBytes> tiles;
  for (const TileKey& k : keys) {
    bytes.push_back(test::payload(k, 3000));
    tiles.push_back(TileCache::TileBytes{k, bytes.back()});
  }
  return tiles;
}

std::size_t filesUnder(const fs::path& root, bool temps) {
  std::size_t n = 0;
  for (const auto& e : fs::recursive_directory_iterator(root)) {
    const auto name = e.path().filename().string();
    const bool temp = name.starts_with(".") && name.ends_with(".tmp");
    n += e.is_regular_file() && temp == temps && (temps || name.ends_with(".jpg"));
  }
  return n;
}

} // namespace

TEST(PutMany, EveryTileIsStoredWithItsRowAndReadsBackItsOwnBytes) {
  test::TempDir dir("putmany");
  auto cache = test::openTestCache(dir.path(), 0, /*fsyncTiles=*/true);
  ASSERT_TRUE(cache);
  const auto id = *cache->registerDataset(test::imagerySpec());
  const auto keys = metatile();
  std::vector<std::vector<std::byte>> bytes;
  bytes.reserve(keys.size());
  const auto tiles = tilesOf(keys, bytes);
  TileMeta meta;
  meta.lastModified = "Tue, 01 Dec 2026 10:00:00 GMT";
  ASSERT_TRUE(cache->putMany(id, tiles, meta));

  for (std::size_t i = 0; i < keys.size(); ++i) {
    const auto g = cache->get(id, keys[i]);
    ASSERT_TRUE(g) << g.error().message;
    ASSERT_EQ(g->kind, CacheLookup::Kind::Hit) << tileRelativePath(keys[i], "jpg");
    EXPECT_EQ(g->bytes, bytes[i]) << tileRelativePath(keys[i], "jpg");
    EXPECT_EQ(g->meta.contentType, "image/jpeg"); // the dataset's, as put() fills it
    EXPECT_EQ(g->meta.lastModified, meta.lastModified);
  }
  const auto st = cache->stats();
  ASSERT_TRUE(st);
  EXPECT_EQ(st->at(0).tiles, 16);
  EXPECT_EQ(filesUnder(dir.path(), false), 16u);
  EXPECT_EQ(filesUnder(dir.path(), true), 0u); // every temp renamed into place
  const auto report = cache->verify();
  ASSERT_TRUE(report);
  EXPECT_TRUE(report->ok());
}

TEST(PutMany, OneKeyOutsideTheGridStoresNoneOfThem) {
  test::TempDir dir("putmany");
  auto cache = test::openTestCache(dir.path());
  ASSERT_TRUE(cache);
  const auto id = *cache->registerDataset(test::imagerySpec());
  auto keys = metatile();
  keys.back() = TileKey{4, 4, 160}; // level 4 has columns 0 to 159
  std::vector<std::vector<std::byte>> bytes;
  bytes.reserve(keys.size());
  const auto r = cache->putMany(id, tilesOf(keys, bytes), {});
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, CacheErrc::InvalidArgument) << r.error().message;
  for (std::size_t i = 0; i + 1 < keys.size(); ++i)
    EXPECT_EQ(cache->get(id, keys[i])->kind, CacheLookup::Kind::Miss);
  EXPECT_EQ(filesUnder(dir.path(), false), 0u);
  EXPECT_EQ(filesUnder(dir.path(), true), 0u);
}

TEST(PutMany, ReplacesTilesThereAndAnEmptyListIsNothing) {
  test::TempDir dir("putmany");
  auto cache = test::openTestCache(dir.path());
  ASSERT_TRUE(cache);
  const auto id = *cache->registerDataset(test::imagerySpec());
  const auto keys = metatile();
  ASSERT_TRUE(cache->put(id, keys[5], test::payload(keys[5], 10), {}));
  ASSERT_TRUE(cache->putMany(id, {}, {}));
  std::vector<std::vector<std::byte>> bytes;
  bytes.reserve(keys.size());
  ASSERT_TRUE(cache->putMany(id, tilesOf(keys, bytes), {}));
  EXPECT_EQ(cache->get(id, keys[5])->bytes, bytes[5]);
  EXPECT_EQ(cache->stats()->at(0).tiles, 16);
  EXPECT_EQ(filesUnder(dir.path(), true), 0u); // the replaced tile's backup gone too
}

TEST(PutMany, WriteBehindTilesAreReadableAtOnceAndCommittedByTheWriter) {
  test::TempDir dir("putmany");
  const auto keys = metatile();
  std::vector<std::vector<std::byte>> bytes;
  bytes.reserve(keys.size());
  {
    TileCache::Options o;
    o.root = dir.path();
    o.fsyncTiles = false;
    o.indexWriteBehind = true;
    auto cache = TileCache::open(o);
    ASSERT_TRUE(cache) << cache.error().message;
    const auto id = *(*cache)->registerDataset(test::imagerySpec());
    ASSERT_TRUE((*cache)->putMany(id, tilesOf(keys, bytes), {}));
    for (std::size_t i = 0; i < keys.size(); ++i)
      EXPECT_EQ((*cache)->get(id, keys[i])->bytes, bytes[i]);
  } // closed: what was queued is committed
  auto again = test::openTestCache(dir.path());
  ASSERT_TRUE(again);
  const auto id = *again->registerDataset(test::imagerySpec());
  for (std::size_t i = 0; i < keys.size(); ++i)
    EXPECT_EQ(again->get(id, keys[i])->bytes, bytes[i]);
  EXPECT_EQ(filesUnder(dir.path(), true), 0u);
}
