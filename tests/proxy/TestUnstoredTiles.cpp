// Tiles fetched but not stored, kept in memory (proxy/src/tiles/UnstoredTiles.hpp): bounded in
// bytes, least recently used out, never served past their expiry, one try to store them per
// retry interval. tests/proxy/TestFullDisk.cpp drives them through tellus serve on a full disk.

#include "../../proxy/src/tiles/UnstoredTiles.hpp"

#include <gtest/gtest.h>

namespace tellus {
namespace {

std::vector<std::byte> bytesOf(std::size_t n, int v) {
  return std::vector<std::byte>(n, static_cast<std::byte>(v));
}

TileMeta meta(std::optional<UnixMillis> expiresAt = std::nullopt) {
  TileMeta m;
  m.contentType = "image/jpeg";
  m.fetchedAt = 1000;
  m.expiresAt = expiresAt;
  return m;
}

TEST(UnstoredTiles, KeepsWithinItsBytesLeastRecentlyUsedOut) {
  UnstoredTiles kept(300, 1000);
  kept.keep("a/b", {1, 0, 0}, bytesOf(100, 1), meta(), 0);
  kept.keep("a/b", {1, 0, 1}, bytesOf(100, 2), meta(), 0);
  kept.keep("c/d", {1, 0, 0}, bytesOf(100, 3), meta(), 0); // another folder, the same key
  ASSERT_TRUE(kept.find("a/b", {1, 0, 0}, 0));             // used: the most recent now
  kept.keep("a/b", {1, 0, 2}, bytesOf(100, 4), meta(), 0); // 400 bytes: one goes
  EXPECT_FALSE(kept.find("a/b", {1, 0, 1}, 0)) << "the least recently used stays";
  const auto first = kept.find("a/b", {1, 0, 0}, 0);
  ASSERT_TRUE(first);
  EXPECT_EQ(first->bytes, bytesOf(100, 1));
  EXPECT_EQ(kept.find("c/d", {1, 0, 0}, 0)->bytes, bytesOf(100, 3));
  EXPECT_EQ(kept.stats().tiles, 3u);
  EXPECT_EQ(kept.stats().bytes, 300u);
  kept.keep("a/b", {1, 0, 0}, bytesOf(50, 5), meta(), 0); // replaced, not added
  EXPECT_EQ(kept.stats().bytes, 250u);
  EXPECT_EQ(kept.find("a/b", {1, 0, 0}, 0)->bytes, bytesOf(50, 5));
  kept.keep("a/b", {2, 0, 0}, bytesOf(301, 6), meta(), 0); // larger than the whole bound
  EXPECT_FALSE(kept.find("a/b", {2, 0, 0}, 0));
  EXPECT_EQ(kept.stats().bytes, 250u);
}

TEST(UnstoredTiles, AnExpiredTileIsDroppedNotServed) {
  UnstoredTiles kept(1000, 1000);
  kept.keep("a/b", {0, 0, 0}, bytesOf(10, 1), meta(5000), 0);
  EXPECT_TRUE(kept.find("a/b", {0, 0, 0}, 4999));
  EXPECT_FALSE(kept.find("a/b", {0, 0, 0}, 5000));
  EXPECT_EQ(kept.stats().tiles, 0u);
}

TEST(UnstoredTiles, OneTryToStoreEachPerRetryIntervalAndAStoredTileIsDropped) {
  UnstoredTiles kept(1000, 1000);
  kept.keep("a/b", {0, 0, 0}, bytesOf(10, 1), meta(), 100);
  EXPECT_FALSE(kept.find("a/b", {0, 0, 0}, 500)->storeNow) << "just refused: not yet";
  EXPECT_TRUE(kept.find("a/b", {0, 0, 0}, 1100)->storeNow);
  EXPECT_FALSE(kept.find("a/b", {0, 0, 0}, 1200)->storeNow) << "one caller per interval";
  EXPECT_TRUE(kept.find("a/b", {0, 0, 0}, 2100)->storeNow);
  kept.stored("a/b", {0, 0, 0}, true);
  EXPECT_FALSE(kept.find("a/b", {0, 0, 0}, 2200));
  const auto s = kept.stats();
  EXPECT_EQ(s.served, 4u);
  EXPECT_EQ(s.storedLater, 1u);
  kept.stored("a/b", {0, 0, 0}, true); // nothing kept: nothing counted
  EXPECT_EQ(kept.stats().storedLater, 1u);
}

TEST(UnstoredTiles, NoneKeptWithABoundOfZero) {
  UnstoredTiles kept(0, 1000);
  kept.keep("a/b", {0, 0, 0}, bytesOf(10, 1), meta(), 0);
  EXPECT_FALSE(kept.find("a/b", {0, 0, 0}, 0));
}

} // namespace
} // namespace tellus
