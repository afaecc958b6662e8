#include "../support/CacheFixtures.hpp"
#include "../support/TempDir.hpp"

#include <tellus/cache/CacheTileSource.hpp>

#include <gtest/gtest.h>

#include <atomic>
#include <condition_variable>
#include <mutex>
#include <thread>

using namespace tellus;

namespace {

struct Fixture {
  test::TempDir dir{"source"};
  std::unique_ptr<TileCache> cache;
  DatasetId id = 0;
  Fixture() {
    cache = test::openTestCache(dir.path());
    id = *cache->registerDataset(test::imagerySpec());
  }
};

/** Collects results; waits for a count. */
struct Sink {
  std::mutex m;
  std::condition_variable cv;
  std::vector<std::pair<TileKey, TileResult>> got;
  ITileSource::Callback callback(TileKey k) {
    return [this, k](TileResult&& r) {
      std::lock_guard lock(m);
      got.emplace_back(k, std::move(r));
      cv.notify_all();
    };
  }
  void waitFor(std::size_t n) {
    std::unique_lock lock(m);
    ASSERT_TRUE(cv.wait_for(lock, std::chrono::seconds(10), [&] { return got.size() >= n; }));
  }
};

} // namespace

TEST(CacheTileSource, DeliversCachedTilesAndAbsence) {
  Fixture f;
  const std::vector<std::byte> bytes(300, std::byte{9});
  ASSERT_TRUE(f.cache->put(f.id, TileKey{1, 2, 3}, bytes, {}));
  ASSERT_TRUE(f.cache->putAbsent(f.id, TileKey{1, 2, 4}, 0));
  CacheTileSource src(*f.cache, 2);
  ASSERT_TRUE(src.describe("bluemarble"));
  EXPECT_EQ(src.describe("bluemarble")->grid.levelZeroDeltaDeg, 36.0);
  EXPECT_FALSE(src.describe("nope"));
  EXPECT_FALSE(src.describe("bluemarble", "2024-01-01"));
  Sink sink;
  src.request({"bluemarble", "", {1, 2, 3}}, 1.0, sink.callback({1, 2, 3}));
  src.request({"bluemarble", "", {1, 2, 4}}, 1.0, sink.callback({1, 2, 4}));
  src.request({"bluemarble", "", {1, 2, 5}}, 1.0, sink.callback({1, 2, 5}));
  src.request({"bluemarble", "", {0, 9, 0}}, 1.0, sink.callback({0, 9, 0}));
  src.request({"nope", "", {0, 0, 0}}, 1.0, sink.callback({0, 0, 0}));
  sink.waitFor(5);
  std::map<TileKey, TileStatus> status;
  for (auto& [k, r] : sink.got) {
    status[k] = r.status;
    if (r.status == TileStatus::Ok) {
      EXPECT_EQ(r.bytes, bytes);
      EXPECT_EQ(r.contentType, "image/jpeg");
    }
  }
  EXPECT_EQ(status[TileKey({1, 2, 3})], TileStatus::Ok);
  EXPECT_EQ(status[TileKey({1, 2, 4})], TileStatus::Absent); // upstream said none
  EXPECT_EQ(status[TileKey({1, 2, 5})], TileStatus::Absent); // offline, not cached
  EXPECT_EQ(status[TileKey({0, 9, 0})], TileStatus::Absent); // outside the grid
  EXPECT_EQ(status[TileKey({0, 0, 0})], TileStatus::Failed); // unknown layer
}

TEST(CacheTileSource, HighestPriorityFirstCancelAndReprioritize) {
  Fixture f;
  CacheTileSource src(*f.cache, 1, /*startPaused=*/true);
  Sink sink;
  std::vector<TileRequestId> ids;
  for (std::int64_t c = 0; c < 6; ++c) {
    ids.push_back(src.request(
        {"bluemarble", "", {2, 0, c}}, static_cast<double>(c % 3), sink.callback({2, 0, c})));
  }
  EXPECT_TRUE(src.cancel(ids[4]));
  EXPECT_FALSE(src.cancel(ids[4]));
  src.reprioritize(ids[0], 10.0);
  EXPECT_EQ(src.queued(), 5u);
  src.start();
  sink.waitFor(5);
  std::vector<std::int64_t> order;
  for (auto& [k, r] : sink.got)
    order.push_back(k.col);
  // c=0 raised to 10; then priority 2 (c=5; c=2 before it), then 1 (c=1; c=4 cancelled), then 0
  // (c=3).
  EXPECT_EQ(order, (std::vector<std::int64_t>{0, 2, 5, 1, 3}));
  EXPECT_FALSE(src.cancel(ids[0])); // already delivered
}

TEST(CacheTileSource, ManyClientsEveryCallbackOnce) {
  Fixture f;
  const std::vector<std::byte> bytes(64, std::byte{1});
  for (std::int64_t c = 0; c < 20; ++c)
    ASSERT_TRUE(f.cache->put(f.id, TileKey{3, 1, c}, bytes, {}));
  std::mutex m;
  std::condition_variable cv;
  int calls = 0;
  int ok = 0;
  {
    CacheTileSource src(*f.cache, 3);
    std::vector<std::thread> clients;
    for (int t = 0; t < 4; ++t) {
      clients.emplace_back([&] {
        for (std::int64_t i = 0; i < 100; ++i) {
          src.request(
              {"bluemarble", "", {3, 1, i % 40}}, static_cast<double>(i), [&](TileResult&& r) {
                std::lock_guard lock(m);
                ++calls;
                ok += r.status == TileStatus::Ok;
                cv.notify_all();
              });
        }
      });
    }
    for (auto& c : clients)
      c.join();
    // Every callback has come (the bound only keeps a broken source from hanging the suite).
    std::unique_lock lock(m);
    EXPECT_TRUE(cv.wait_for(lock, std::chrono::seconds(60), [&] { return calls == 400; }));
  } // destruction waits for running callbacks
  std::lock_guard lock(m);
  EXPECT_EQ(calls, 400);
  EXPECT_EQ(ok, 4 * 60); // columns 0..19 of i % 40 over i < 100
}

// A cache a tile service filled with whole polar rows (`<layer>@caps`, issue 29) gives them to an
// offline renderer; without that dataset it has none (caps are composed of the rows' tiles).
TEST(CacheTileSource, WholeRowsWhereTheCacheHasThem) {
  Fixture f;
  CacheTileSource src(*f.cache, 1);
  EXPECT_FALSE(src.wholePolarRows("bluemarble"));
  DatasetSpec caps = test::imagerySpec("bluemarble@caps");
  caps.grid.tileWidth *= kWholeRowWidthFactor;
  const DatasetId id = *f.cache->registerDataset(caps);
  const std::vector<std::byte> bytes(500, std::byte{7});
  ASSERT_TRUE(f.cache->put(id, TileKey{0, 4, 0}, bytes, {}));
  EXPECT_TRUE(src.wholePolarRows("bluemarble"));
  Sink sink;
  src.request({"bluemarble@caps", "", {0, 4, 0}}, 1.0, sink.callback({0, 4, 0}));
  src.request({"bluemarble@caps", "", {1, 9, 0}}, 1.0, sink.callback({1, 9, 0}));
  sink.waitFor(2);
  for (auto& [k, r] : sink.got) {
    if (k.level == 0) {
      EXPECT_EQ(r.status, TileStatus::Ok);
      EXPECT_EQ(r.bytes, bytes);
    } else {
      EXPECT_EQ(r.status, TileStatus::Absent); // not cached: the renderer composes that cap
    }
  }
}
