// The cache on a real full disk: a small tmpfs in a mount namespace (tests/support/Tmpfs.hpp), with
// no bytes left, no inodes left, or room for a tile but none for the index.

#include "../support/CacheFixtures.hpp"
#include "../support/TempDir.hpp"
#include "../support/Tmpfs.hpp"

#include <tellus/cache/TileCache.hpp>
#include <tellus/cache/TilePath.hpp>

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <chrono>
#include <filesystem>
#include <unistd.h>

using namespace tellus;
using namespace std::chrono_literals;
namespace fs = std::filesystem;

namespace {

std::size_t countTempFiles(const fs::path& root) {
  std::size_t n = 0;
  for (const auto& e : fs::recursive_directory_iterator(root)) {
    const auto name = e.path().filename().string();
    n += e.is_regular_file() && name.starts_with(".") && name.ends_with(".tmp");
  }
  return n;
}

std::unique_ptr<TileCache> openOn(const fs::path& root,
                                  std::shared_ptr<ManualClock> clock = nullptr,
                                  std::chrono::milliseconds fullRecheck = 10s) {
  TileCache::Options o;
  o.root = root;
  o.fsyncTiles = false;
  o.fullRecheck = fullRecheck;
  o.clock = std::move(clock);
  auto c = TileCache::open(o);
  EXPECT_TRUE(c) << (c ? "" : c.error().message);
  return c ? std::move(*c) : nullptr;
}

} // namespace

TEST(CacheFullDiskIntegration, ARestartOnAFullDiskServesWhatItHasAndStoresAgainWhenRoomReturns) {
  TELLUS_ON_TMPFS(1 << 20, 1000, [&](const fs::path& mnt) {
    const fs::path root = mnt / "cache";
    {
      auto cache = openOn(root);
      ASSERT_TRUE(cache);
      const auto id = *cache->registerDataset(test::imagerySpec());
      for (std::int64_t c = 0; c < 4; ++c) {
        const TileKey k{3, 1, c};
        ASSERT_TRUE(cache->put(id, k, test::payload(k, 20000), {}));
      }
    }
    const fs::path filler = test::fillDisk(mnt);

    // The restart: open, register the same dataset (nothing to write) and read every tile.
    auto clock = std::make_shared<ManualClock>();
    auto cache = openOn(root, clock, 30s);
    ASSERT_TRUE(cache) << "a cache on a full disk must open";
    const auto id = cache->registerDataset(test::imagerySpec());
    ASSERT_TRUE(id) << id.error().message;
    for (std::int64_t c = 0; c < 4; ++c) {
      const TileKey k{3, 1, c};
      const auto g = cache->get(*id, k);
      ASSERT_TRUE(g) << g.error().message;
      EXPECT_EQ(g->bytes, test::payload(k, 20000)) << tileRelativePath(k, "jpg");
    }
    EXPECT_TRUE(cache->storeStatus().writable);

    // A new tile is refused with the root and what is left on its disk.
    const TileKey fresh{3, 2, 0};
    auto p = cache->put(*id, fresh, test::payload(fresh, 20000), {});
    ASSERT_FALSE(p);
    EXPECT_EQ(p.error().code, CacheErrc::DiskFull);
    EXPECT_NE(p.error().message.find("the cache at " + root.string() + " is full ("),
              std::string::npos)
        << p.error().message;
    EXPECT_NE(p.error().message.find("inodes free"), std::string::npos) << p.error().message;
    EXPECT_FALSE(cache->storeStatus().writable);
    EXPECT_EQ(cache->storeStatus().refused, 1u);

    // Room again: refused at once until fullRecheck has passed, then stored.
    fs::remove(filler);
    p = cache->put(*id, fresh, test::payload(fresh, 20000), {});
    ASSERT_FALSE(p);
    EXPECT_EQ(p.error().code, CacheErrc::DiskFull);
    EXPECT_EQ(cache->storeStatus().refused, 2u);
    clock->advance(31s);
    p = cache->put(*id, fresh, test::payload(fresh, 20000), {});
    ASSERT_TRUE(p) << p.error().message;
    EXPECT_TRUE(cache->storeStatus().writable);
    EXPECT_EQ(cache->get(*id, fresh)->bytes, test::payload(fresh, 20000));
    EXPECT_EQ(countTempFiles(root), 0u);
    const auto report = cache->verify();
    ASSERT_TRUE(report);
    EXPECT_TRUE(report->ok());
  });
}

TEST(CacheFullDiskIntegration, ACommitRefusedAfterTheRenameKeepsTheTileItWouldHaveReplaced) {
  TELLUS_ON_TMPFS(2 << 20, 1000, [&](const fs::path& mnt) {
    const fs::path root = mnt / "cache";
    auto cache = openOn(root, nullptr, 0ms); // no pause after a refusal: every put tries
    ASSERT_TRUE(cache);
    const auto id = *cache->registerDataset(test::imagerySpec());
    const TileKey k{4, 2, 3};
    const auto v1 = test::payload(k, 100); // one page: replacing it frees too little for the WAL
    ASSERT_TRUE(cache->put(id, k, v1, {}));
    // A reader's snapshot keeps the WAL from starting over: the next commit must grow it.
    sqlite3* reader = nullptr;
    ASSERT_EQ(
        sqlite3_open_v2((root / "index.sqlite").c_str(), &reader, SQLITE_OPEN_READONLY, nullptr),
        SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(reader, "BEGIN; SELECT count(*) FROM tiles;", nullptr, nullptr, nullptr),
              SQLITE_OK);
    // Room for the new version's file and none for the index.
    const auto v2 = test::payload(k, 33000);
    const fs::path filler = test::fillDisk(mnt);
    const auto pages = (v2.size() + 4095) / 4096;
    fs::resize_file(filler, fs::file_size(filler) - pages * 4096);

    auto p = cache->put(id, k, v2, {});
    ASSERT_FALSE(p) << "the commit should have found no room";
    EXPECT_EQ(p.error().code, CacheErrc::DiskFull) << p.error().message;
    const auto g = cache->get(id, k);
    ASSERT_TRUE(g);
    ASSERT_EQ(g->kind, CacheLookup::Kind::Hit) << "the tile being replaced was lost";
    EXPECT_EQ(g->bytes, v1);

    // A new tile whose commit fails leaves neither a file nor a row.
    const TileKey fresh{4, 2, 4};
    p = cache->put(id, fresh, test::payload(fresh, 33000), {});
    ASSERT_FALSE(p);
    EXPECT_EQ(p.error().code, CacheErrc::DiskFull) << p.error().message;
    EXPECT_FALSE(
        fs::exists(root / cache->datasets().at(0).folder / tileRelativePath(fresh, "jpg")));
    EXPECT_EQ(cache->get(id, fresh)->kind, CacheLookup::Kind::Miss);
    EXPECT_EQ(countTempFiles(root), 0u);

    sqlite3_exec(reader, "COMMIT", nullptr, nullptr, nullptr);
    sqlite3_close(reader);
    const auto report = cache->verify();
    ASSERT_TRUE(report);
    EXPECT_TRUE(report->ok()) << report->rowsWithoutFiles.size() << " rows without files, "
                              << report->filesWithoutRows.size() << " files without rows, "
                              << report->sizeMismatches.size() << " size mismatches";
  });
}

TEST(CacheFullDiskIntegration, NoInodesLeftIsADiskFullThatNamesTheInodes) {
  TELLUS_ON_TMPFS(8 << 20, 48, [&](const fs::path& mnt) {
    const fs::path root = mnt / "cache";
    auto cache = openOn(root, nullptr, 0ms);
    ASSERT_TRUE(cache);
    const auto id = *cache->registerDataset(test::imagerySpec());
    std::int64_t stored = 0;
    std::optional<CacheError> refusal;
    for (std::int64_t r = 0; r < 40 && !refusal; ++r) {
      const TileKey k{5, r, 0}; // a row folder per tile: two inodes each
      if (auto p = cache->put(id, k, test::payload(k, 1000), {}))
        ++stored;
      else
        refusal = p.error();
    }
    ASSERT_TRUE(refusal) << "48 inodes should not hold 40 tiles in their own folders";
    EXPECT_EQ(refusal->code, CacheErrc::DiskFull) << refusal->message;
    EXPECT_NE(refusal->message.find(" 0 inodes free"), std::string::npos) << refusal->message;
    EXPECT_FALSE(cache->storeStatus().writable);
    EXPECT_GT(stored, 0);
    EXPECT_EQ(countTempFiles(root), 0u);
    const auto st = cache->stats();
    ASSERT_TRUE(st);
    EXPECT_EQ(st->at(0).tiles, stored);
    const auto report = cache->verify();
    ASSERT_TRUE(report);
    EXPECT_TRUE(report->ok());
  });
}

// A metatile's tiles stored together (putMany): when some of its files do not fit, none is kept,
// no temp file is left, and the whole fits once there is room again.
TEST(CacheFullDiskIntegration, AMetatileThatDoesNotFitKeepsNoneOfItsTiles) {
  TELLUS_ON_TMPFS(1 << 20, 1000, [&](const fs::path& mnt) {
    const fs::path root = mnt / "cache";
    auto cache = openOn(root, nullptr, 0ms);
    ASSERT_TRUE(cache);
    const auto id = *cache->registerDataset(test::imagerySpec());
    std::vector<std::vector<std::byte>> bytes;
    std::vector<TileCache::TileBytes> tiles;
    bytes.reserve(16);
    for (std::int64_t c = 0; c < 16; ++c) {
      const TileKey k{4, 2, c};
      bytes.push_back(test::payload(k, 20000));
      tiles.push_back(TileCache::TileBytes{k, bytes.back()});
    }
    ASSERT_TRUE(cache->put(id, tiles[0].key, test::payload(tiles[0].key, 100), {}));
    const fs::path filler = test::fillDisk(mnt);
    fs::resize_file(filler, fs::file_size(filler) - 6 * 5 * 4096); // room for 6 of the 16

    auto p = cache->putMany(id, tiles, {});
    ASSERT_FALSE(p);
    EXPECT_EQ(p.error().code, CacheErrc::DiskFull) << p.error().message;
    EXPECT_EQ(cache->get(id, tiles[0].key)->bytes, test::payload(tiles[0].key, 100)); // kept
    for (std::size_t i = 1; i < tiles.size(); ++i) {
      EXPECT_EQ(cache->get(id, tiles[i].key)->kind, CacheLookup::Kind::Miss) << i;
      EXPECT_FALSE(fs::exists(root / cache->datasets().at(0).folder /
                              tileRelativePath(tiles[i].key, "jpg")));
    }
    EXPECT_EQ(countTempFiles(root), 0u);
    EXPECT_FALSE(cache->storeStatus().writable);

    fs::remove(filler);
    ASSERT_TRUE(cache->putMany(id, tiles, {}));
    for (std::size_t i = 0; i < tiles.size(); ++i)
      EXPECT_EQ(cache->get(id, tiles[i].key)->bytes, bytes[i]) << i;
    EXPECT_EQ(countTempFiles(root), 0u);
    const auto report = cache->verify();
    ASSERT_TRUE(report);
    EXPECT_TRUE(report->ok());
  });
}

// Room for every file and none for the index: the one transaction of their rows fails, and every
// tile it put into place is taken back out.
TEST(CacheFullDiskIntegration, AMetatileWhoseRowsCannotBeCommittedLeavesNoFileAndNoRow) {
  TELLUS_ON_TMPFS(2 << 20, 1000, [&](const fs::path& mnt) {
    const fs::path root = mnt / "cache";
    auto cache = openOn(root, nullptr, 0ms);
    ASSERT_TRUE(cache);
    const auto id = *cache->registerDataset(test::imagerySpec());
    const TileKey first{4, 2, 3};
    ASSERT_TRUE(cache->put(id, first, test::payload(first, 100), {}));
    sqlite3* reader = nullptr; // its snapshot keeps the WAL from starting over
    ASSERT_EQ(
        sqlite3_open_v2((root / "index.sqlite").c_str(), &reader, SQLITE_OPEN_READONLY, nullptr),
        SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(reader, "BEGIN; SELECT count(*) FROM tiles;", nullptr, nullptr, nullptr),
              SQLITE_OK);
    std::vector<std::vector<std::byte>> bytes;
    std::vector<TileCache::TileBytes> tiles;
    bytes.reserve(16);
    for (std::int64_t c = 4; c < 20; ++c) {
      const TileKey k{4, 2, c};
      bytes.push_back(test::payload(k, 33000)); // 9 pages each
      tiles.push_back(TileCache::TileBytes{k, bytes.back()});
    }
    const fs::path filler = test::fillDisk(mnt);
    fs::resize_file(filler, fs::file_size(filler) - 16 * 9 * 4096);

    auto p = cache->putMany(id, tiles, {});
    ASSERT_FALSE(p) << "the commit should have found no room";
    EXPECT_EQ(p.error().code, CacheErrc::DiskFull) << p.error().message;
    for (const auto& t : tiles) {
      EXPECT_EQ(cache->get(id, t.key)->kind, CacheLookup::Kind::Miss);
      EXPECT_FALSE(
          fs::exists(root / cache->datasets().at(0).folder / tileRelativePath(t.key, "jpg")));
    }
    EXPECT_EQ(cache->get(id, first)->bytes, test::payload(first, 100));
    EXPECT_EQ(countTempFiles(root), 0u);

    sqlite3_exec(reader, "COMMIT", nullptr, nullptr, nullptr);
    sqlite3_close(reader);
    const auto report = cache->verify();
    ASSERT_TRUE(report);
    EXPECT_TRUE(report->ok());
  });
}
