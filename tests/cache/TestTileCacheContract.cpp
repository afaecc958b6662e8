// The tile cache's behaviour on every implementation of its index and store (CacheBackends.hpp):
// lookups, puts, removals, datasets, statistics, eviction, prune, verify and rebuild, reopening,
// read-only use, many threads. What is about the SQLite file or the file tree itself is in
// TestTileCache.cpp and TestTileCacheIntegration.cpp.

#include "CacheBackends.hpp"

#include <tellus/cache/CacheMaintenance.hpp>
#include <tellus/cache/TilePath.hpp>

#include <atomic>
#include <chrono>
#include <thread>

using namespace tellus;
using namespace std::chrono_literals;
using tellus::test::payload;

namespace {

DatasetSpec imagery(const std::string& name = "bluemarble") {
  return test::imagerySpec(name);
}

class TileCacheContract : public test::CacheBackendTest {};

} // namespace

#ifdef TELLUS_CONTRACT_S3
// tellus_cache_s3_tests: the same contract on the S3 store, alone and behind the file tree (a
// real server, tests/cache_s3).
INSTANTIATE_TEST_SUITE_P(Backends,
                         TileCacheContract,
                         ::testing::Values(test::Backend::S3, test::Backend::S3Tiered),
                         test::backendName);
#else
INSTANTIATE_TEST_SUITE_P(Backends,
                         TileCacheContract,
                         ::testing::ValuesIn(test::contractBackends()),
                         test::backendName);
#endif

TEST_P(TileCacheContract, PutGetRoundTrip) {
  auto cache = open();
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
  EXPECT_EQ(got->meta.fetchedAt, clock->now());
  EXPECT_FALSE(got->stale);
  const auto info = *cache->dataset(*id);
  const auto stored = store().stat(at(info, k));
  ASSERT_TRUE(stored);
  EXPECT_EQ(stored->size, static_cast<std::int64_t>(payload(k).size()));
  EXPECT_EQ(store().readDescriptor(info.folder), serializeDatasetSpec(imagery()));
}

TEST_P(TileCacheContract, MissAbsentEraseAndStale) {
  auto cache = open();
  const auto id = *cache->registerDataset(imagery());
  const TileKey k{1, 3, 4};
  EXPECT_EQ(cache->get(id, k)->kind, CacheLookup::Kind::Miss);
  ASSERT_TRUE(cache->putAbsent(id, k, 12345));
  auto a = cache->get(id, k);
  EXPECT_EQ(a->kind, CacheLookup::Kind::Absent);
  EXPECT_EQ(a->retryAfter, 12345);
  TileMeta expired;
  expired.expiresAt = clock->now() + 1000;
  ASSERT_TRUE(cache->put(id, k, payload(k), expired));
  EXPECT_FALSE(cache->get(id, k)->stale);
  clock->advance(1s); // the expiry is now
  auto s = cache->get(id, k);
  EXPECT_EQ(s->kind, CacheLookup::Kind::Hit);
  EXPECT_TRUE(s->stale);
  TileMeta fresh;
  fresh.expiresAt = clock->now() + 60000;
  fresh.etag = "\"v2\"";
  ASSERT_TRUE(cache->revalidated(id, k, fresh));
  auto r = cache->get(id, k);
  EXPECT_FALSE(r->stale);
  EXPECT_EQ(r->meta.etag, "\"v2\"");
  EXPECT_EQ(r->meta.fetchedAt, clock->now());
  EXPECT_EQ(r->bytes, payload(k));
  ASSERT_TRUE(cache->erase(id, k));
  EXPECT_EQ(cache->get(id, k)->kind, CacheLookup::Kind::Miss);
  EXPECT_TRUE(cache->revalidated(id, k, fresh)); // nothing there: nothing to update
  EXPECT_FALSE(store().stat(at(*cache->dataset(id), k)));
  EXPECT_TRUE(cache->erase(id, k)); // erasing nothing is fine
}

TEST_P(TileCacheContract, RegisterIsIdempotentAndVariantsAreSeparate) {
  auto cache = open();
  auto spec = imagery();
  const auto a = *cache->registerDataset(spec);
  EXPECT_EQ(*cache->registerDataset(spec), a);
  EXPECT_EQ(cache->dataset(a)->createdAt, clock->now());
  spec.time = "2024-01-02";
  const auto b = *cache->registerDataset(spec);
  EXPECT_NE(a, b);
  const TileKey k{0, 0, 0};
  ASSERT_TRUE(cache->put(a, k, payload(k, 10), {}));
  ASSERT_TRUE(cache->put(b, k, payload(k, 20), {}));
  EXPECT_EQ(cache->get(a, k)->bytes.size(), payload(k, 10).size());
  EXPECT_EQ(cache->get(b, k)->bytes.size(), payload(k, 20).size());
  EXPECT_EQ(cache->datasets().size(), 2u);
  ASSERT_TRUE(cache->setPinned(b, true));
  EXPECT_TRUE(cache->dataset(b)->spec.pinned);
  EXPECT_FALSE(cache->setPinned(b + 100, true));
}

TEST_P(TileCacheContract, PersistsAcrossReopen) {
  DatasetId id = 0;
  {
    auto cache = open();
    id = *cache->registerDataset(imagery());
    for (std::int64_t c = 0; c < 10; ++c)
      ASSERT_TRUE(cache->put(id, TileKey{1, 2, c}, payload({1, 2, c}), {}));
  }
  auto cache = open();
  EXPECT_FALSE(cache->wasRebuiltAtOpen());
  ASSERT_TRUE(cache->dataset(id));
  for (std::int64_t c = 0; c < 10; ++c)
    EXPECT_EQ(cache->get(id, TileKey{1, 2, c})->bytes, payload({1, 2, c}));
}

TEST_P(TileCacheContract, StatsPerDatasetAndLevel) {
  auto cache = open();
  const auto a = *cache->registerDataset(imagery("a"));
  const auto b = *cache->registerDataset(imagery("b"));
  std::int64_t bytesA0 = 0;
  for (std::int64_t c = 0; c < 10; ++c) {
    ASSERT_TRUE(cache->put(a, TileKey{0, 0, c}, payload({0, 0, c}), {}));
    bytesA0 += static_cast<std::int64_t>(payload({0, 0, c}).size());
  }
  ASSERT_TRUE(cache->put(a, TileKey{1, 0, 0}, payload({1, 0, 0}), {}));
  ASSERT_TRUE(cache->putAbsent(b, TileKey{2, 0, 0}, 0));
  auto st = CacheMaintenance(*cache).stats();
  ASSERT_TRUE(st);
  ASSERT_EQ(st->size(), 2u);
  EXPECT_EQ((*st)[0].dataset.spec.name, "a");
  EXPECT_EQ((*st)[0].tiles, 11);
  ASSERT_EQ((*st)[0].levels.size(), 2u);
  EXPECT_EQ((*st)[0].levels[0].tiles, 10);
  EXPECT_EQ((*st)[0].levels[0].bytes, bytesA0);
  EXPECT_EQ((*st)[1].levels[0].absent, 1);
  EXPECT_EQ((*st)[1].bytes, 0);
  EXPECT_EQ(*cache->totalBytes(), bytesA0 + static_cast<std::int64_t>(payload({1, 0, 0}).size()));
  std::vector<TileKey> listed;
  ASSERT_TRUE(cache->forEachTile(a, 0, 0, [&](const TileKey& k, std::int64_t n) {
    EXPECT_EQ(n, static_cast<std::int64_t>(payload(k).size()));
    listed.push_back(k);
    return listed.size() < 4;
  }));
  EXPECT_EQ(listed, (std::vector<TileKey>{{0, 0, 0}, {0, 0, 1}, {0, 0, 2}, {0, 0, 3}}));
}

TEST_P(TileCacheContract, LruEvictionKeepsRecentAndPinned) {
  auto cache = open(20000);
  auto pinnedSpec = imagery("show");
  pinnedSpec.pinned = true;
  const auto pinned = *cache->registerDataset(pinnedSpec);
  const auto id = *cache->registerDataset(imagery());
  const std::vector<std::byte> kb(1000, std::byte{7});
  for (std::int64_t c = 0; c < 8; ++c)
    ASSERT_TRUE(cache->put(pinned, TileKey{1, 0, c}, kb, {}));
  for (std::int64_t c = 0; c < 10; ++c)
    ASSERT_TRUE(cache->put(id, TileKey{1, 1, c}, kb, {}));
  // Touch tiles 0..4 later, so that 5..9 are the least recently used.
  clock->advance(5ms);
  for (std::int64_t c = 0; c < 5; ++c)
    ASSERT_EQ(cache->get(id, TileKey{1, 1, c})->kind, CacheLookup::Kind::Hit);
  cache->flush();
  clock->advance(5ms);
  for (std::int64_t c = 0; c < 6; ++c)
    ASSERT_TRUE(cache->put(id, TileKey{1, 2, c}, kb, {}));
  cache->flush();
  EXPECT_LE(*cache->totalBytes(), 20000);
  for (std::int64_t c = 0; c < 8; ++c)
    EXPECT_EQ(cache->peek(pinned, TileKey{1, 0, c})->kind, CacheLookup::Kind::Hit);
  for (std::int64_t c = 0; c < 5; ++c)
    EXPECT_EQ(cache->peek(id, TileKey{1, 1, c})->kind, CacheLookup::Kind::Hit) << c;
  int evicted = 0;
  for (std::int64_t c = 5; c < 10; ++c)
    evicted += cache->peek(id, TileKey{1, 1, c})->kind == CacheLookup::Kind::Miss;
  EXPECT_GE(evicted, 4);
  // Only pinned data over the limit: it stays.
  auto o = options(dir.path() / "small");
  o.sizeLimitBytes = 1000;
  auto small = open(o);
  const auto p2 = *small->registerDataset(pinnedSpec);
  for (std::int64_t c = 0; c < 3; ++c)
    ASSERT_TRUE(small->put(p2, TileKey{1, 0, c}, kb, {}));
  EXPECT_EQ(*CacheMaintenance(*small).evictToLimit(), 0);
  EXPECT_EQ(*small->totalBytes(), 3000);
}

TEST_P(TileCacheContract, PruneByAgeAndLayer) {
  auto cache = open();
  const auto a = *cache->registerDataset(imagery("a"));
  const auto b = *cache->registerDataset(imagery("b"));
  TileMeta old;
  old.fetchedAt = clock->now() - 10 * 86400 * 1000LL;
  ASSERT_TRUE(cache->put(a, TileKey{0, 0, 0}, payload({}), old));
  ASSERT_TRUE(cache->put(a, TileKey{0, 0, 1}, payload({}), {}));
  ASSERT_TRUE(cache->put(b, TileKey{0, 0, 0}, payload({}), old));
  PruneOptions p;
  p.olderThan = std::chrono::hours(24 * 5);
  p.datasetName = "a";
  const auto doomed = CacheMaintenance(*cache).prunable(p);
  ASSERT_TRUE(doomed);
  ASSERT_EQ(doomed->size(), 1u);
  EXPECT_EQ((*doomed)[0].dataset.id, a);
  EXPECT_EQ((*doomed)[0].tiles, 1);
  EXPECT_EQ(*CacheMaintenance(*cache).prune(p), 1);
  EXPECT_EQ(cache->get(a, TileKey{0, 0, 0})->kind, CacheLookup::Kind::Miss);
  EXPECT_EQ(cache->get(a, TileKey{0, 0, 1})->kind, CacheLookup::Kind::Hit);
  EXPECT_EQ(cache->get(b, TileKey{0, 0, 0})->kind, CacheLookup::Kind::Hit);
  EXPECT_FALSE(store().stat(at(*cache->dataset(a), TileKey{0, 0, 0})));
  p.datasetName.reset();
  EXPECT_EQ(*cache->prune(p), 1);
  EXPECT_EQ(cache->get(b, TileKey{0, 0, 0})->kind, CacheLookup::Kind::Miss);
  // Six days on, the tile stored at the start is older than five days too.
  clock->advance(std::chrono::hours(24 * 6));
  EXPECT_EQ(*cache->prune(p), 1);
  EXPECT_EQ(cache->get(a, TileKey{0, 0, 1})->kind, CacheLookup::Kind::Miss);
}

TEST_P(TileCacheContract, VerifyFindsTilesWithoutRowsAndRowsWithoutTilesAndRebuildAdoptsThem) {
  auto cache = open();
  const auto id = *cache->registerDataset(imagery());
  for (std::int64_t c = 0; c < 4; ++c)
    ASSERT_TRUE(cache->put(id, TileKey{1, 0, c}, payload({1, 0, c}), {}));
  auto report = CacheMaintenance(*cache).verify();
  ASSERT_TRUE(report);
  EXPECT_TRUE(report->ok()) << report->integrity;
  // Behind the cache's back: one tile gone, one stored without a row.
  const auto info = *cache->dataset(id);
  store().remove(at(info, TileKey{1, 0, 1}));
  const TileKey orphan{3, 7, 9};
  auto staged = store().stage(at(info, orphan), payload(orphan));
  ASSERT_TRUE(staged);
  ASSERT_TRUE((*staged)->install());
  (*staged)->finish(true);
  report = CacheMaintenance(*cache).verify();
  ASSERT_TRUE(report);
  EXPECT_FALSE(report->ok());
  ASSERT_EQ(report->rowsWithoutFiles.size(), 1u);
  EXPECT_EQ(report->rowsWithoutFiles[0], info.folder + "/1/0/0_1.jpg");
  ASSERT_EQ(report->filesWithoutRows.size(), 1u);
  EXPECT_EQ(report->filesWithoutRows[0], info.folder + "/3/7/7_9.jpg");
  EXPECT_EQ(*CacheMaintenance(*cache).rebuild(), 4); // 3 survivors + the orphan
  EXPECT_TRUE(CacheMaintenance(*cache).verify()->ok());
  const auto all = cache->datasets();
  ASSERT_EQ(all.size(), 1u);
  EXPECT_EQ(all[0].folder, info.folder);
  EXPECT_EQ(cache->get(all[0].id, orphan)->bytes, payload(orphan));
  EXPECT_EQ(cache->get(all[0].id, TileKey{1, 0, 1})->kind, CacheLookup::Kind::Miss);
}

TEST_P(TileCacheContract, VanishedTileIsAMissAndHealsTheRow) {
  auto cache = open();
  const auto id = *cache->registerDataset(imagery());
  const TileKey k{1, 1, 1};
  ASSERT_TRUE(cache->put(id, k, payload(k), {}));
  store().remove(at(*cache->dataset(id), k));
  EXPECT_EQ(cache->get(id, k)->kind, CacheLookup::Kind::Miss);
  cache->flush();
  EXPECT_EQ(cache->peek(id, k)->kind, CacheLookup::Kind::Miss);
}

TEST_P(TileCacheContract, ReadOnlyCacheServesButRefusesWrites) {
  DatasetId id = 0;
  {
    auto cache = open();
    id = *cache->registerDataset(imagery());
    ASSERT_TRUE(cache->put(id, TileKey{0, 1, 1}, payload({0, 1, 1}), {}));
  }
  auto o = options();
  o.readOnly = true;
  auto ro = open(o);
  ASSERT_TRUE(ro);
  EXPECT_EQ(ro->get(id, TileKey{0, 1, 1})->bytes, payload({0, 1, 1}));
  auto w = ro->put(id, TileKey{0, 1, 2}, payload({}), {});
  ASSERT_FALSE(w);
  EXPECT_EQ(w.error().code, CacheErrc::ReadOnly);
  EXPECT_EQ(ro->erase(id, TileKey{0, 1, 1}).error().code, CacheErrc::ReadOnly);
  EXPECT_EQ(ro->rebuild().error().code, CacheErrc::ReadOnly);
}

TEST_P(TileCacheContract, ManyThreadsReadAndWriteWithoutErrors) {
  auto cache = open();
  const auto id = *cache->registerDataset(imagery());
  std::atomic<int> failures{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&, t] {
      for (std::int64_t i = 0; i < 100; ++i) {
        const TileKey k{4, t, i};
        if (!cache->put(id, k, payload(k), {})) ++failures;
      }
    });
  }
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&, t] {
      for (std::int64_t i = 0; i < 200; ++i) {
        const TileKey k{4, t, i % 100};
        auto r = cache->get(id, k);
        if (!r)
          ++failures;
        else if (r->kind == CacheLookup::Kind::Hit && r->bytes != payload(k))
          ++failures;
      }
    });
  }
  for (auto& th : threads)
    th.join();
  EXPECT_EQ(failures.load(), 0);
  for (int t = 0; t < 4; ++t) {
    for (std::int64_t i = 0; i < 100; ++i)
      EXPECT_EQ(cache->peek(id, TileKey{4, t, i})->kind, CacheLookup::Kind::Hit);
  }
}

TEST_P(TileCacheContract, PutsErasesAbsentMarkersAndPrunesOnTheSameTilesKeepRowsAndTilesTogether) {
  // Threads of one process store, erase, mark absent and prune the same few tiles at once, so
  // that the writer's batches hold several operations on one tile: whatever order they commit
  // in, each tile must be the one its row describes. A fixed amount of work, no timing.
  auto cache = open();
  const auto id = *cache->registerDataset(imagery());
  constexpr std::int64_t kTiles = 6;
  std::atomic<bool> stop{false};
  std::atomic<int> failures{0};
  std::atomic<int> prunes{0};
  std::vector<std::thread> workers;
  for (int t = 0; t < 4; ++t) {
    workers.emplace_back([&, t] {
      for (std::size_t i = 0; i < 150; ++i) {
        const TileKey k{5, 2, static_cast<std::int64_t>(i) % kTiles};
        if (!cache->put(id, k, payload(k, 300 + ((i + static_cast<std::size_t>(t)) % 7) * 100), {}))
          ++failures;
      }
    });
  }
  workers.emplace_back([&] {
    for (std::int64_t i = 0; i < 150; ++i) {
      const TileKey k{5, 2, (i * 5) % kTiles};
      if (!(i % 2 ? cache->erase(id, k) : cache->putAbsent(id, k, clock->now() + 60000)))
        ++failures;
    }
  });
  std::thread pruner([&] {
    PruneOptions all;
    all.olderThan = std::chrono::milliseconds(0);
    all.includePinned = true;
    do {
      if (!cache->prune(all)) ++failures;
      ++prunes;
    } while (!stop);
  });
  for (auto& th : workers)
    th.join();
  stop = true;
  pruner.join();
  cache->flush();
  EXPECT_EQ(failures.load(), 0);
  EXPECT_GT(prunes.load(), 0);
  const auto report = cache->verify();
  ASSERT_TRUE(report);
  EXPECT_TRUE(report->rowsWithoutFiles.empty()) << report->rowsWithoutFiles.size();
  EXPECT_TRUE(report->filesWithoutRows.empty()) << report->filesWithoutRows.size();
  EXPECT_TRUE(report->sizeMismatches.empty()) << report->sizeMismatches.size();
  EXPECT_TRUE(report->ok());
  for (std::int64_t c = 0; c < kTiles; ++c) {
    const TileKey k{5, 2, c};
    const auto g = cache->get(id, k);
    ASSERT_TRUE(g);
    if (g->kind == CacheLookup::Kind::Hit) {
      EXPECT_EQ(static_cast<std::int64_t>(g->bytes.size()), g->size);
    }
  }
}

// A metatile's tiles stored together (TileCache::putMany: the file store flushes them together,
// the S3 store PUTs them in parallel), read back one by one, and replaced together.
TEST_P(TileCacheContract, PutManyStoresEveryTileOfAMetatile) {
  auto cache = open();
  const auto id = *cache->registerDataset(imagery());
  std::vector<std::vector<std::byte>> bytes;
  std::vector<TileCache::TileBytes> tiles;
  bytes.reserve(16);
  for (std::int64_t r = 4; r < 8; ++r) {
    for (std::int64_t c = 8; c < 12; ++c) {
      const TileKey k{4, r, c};
      bytes.push_back(payload(k));
      tiles.push_back(TileCache::TileBytes{k, bytes.back()});
    }
  }
  TileMeta meta;
  meta.etag = "\"metatile\"";
  auto put = cache->putMany(id, tiles, meta);
  ASSERT_TRUE(put) << put.error().message;
  for (std::size_t i = 0; i < tiles.size(); ++i) {
    const auto got = cache->get(id, tiles[i].key);
    ASSERT_TRUE(got);
    ASSERT_EQ(got->kind, CacheLookup::Kind::Hit) << i;
    EXPECT_EQ(got->bytes, bytes[i]);
    EXPECT_EQ(got->meta.etag, meta.etag);
  }
  for (auto& b : bytes)
    b.back() = static_cast<std::byte>(0x5A); // a refresh: new bytes for every tile
  ASSERT_TRUE(cache->putMany(id, tiles, {}));
  for (std::size_t i = 0; i < tiles.size(); ++i)
    EXPECT_EQ(cache->get(id, tiles[i].key)->bytes, bytes[i]) << i;
  EXPECT_EQ(cache->stats()->at(0).tiles, 16);
  EXPECT_TRUE(cache->verify()->ok());
}

TEST_P(TileCacheContract, WriteBehindIsVisibleAtOnceAndCommittedSoon) {
  DatasetId id = 0;
  {
    auto o = options();
    o.indexWriteBehind = true;
    auto cache = open(o);
    id = *cache->registerDataset(imagery());
    for (std::int64_t c = 0; c < 50; ++c) {
      const TileKey k{3, 3, c};
      auto put = cache->put(id, k, payload(k), {});
      ASSERT_TRUE(put) << put.error().message;
      auto got = cache->get(id, k); // before any commit is guaranteed
      ASSERT_EQ(got->kind, CacheLookup::Kind::Hit);
      EXPECT_EQ(got->bytes, payload(k));
      EXPECT_EQ(cache->peek(id, k)->kind, CacheLookup::Kind::Hit);
    }
    ASSERT_TRUE(cache->erase(id, TileKey{3, 3, 0}));
    EXPECT_EQ(cache->peek(id, TileKey{3, 3, 0})->kind, CacheLookup::Kind::Miss);
  } // closing commits whatever is queued
  auto cache = open();
  EXPECT_EQ(cache->peek(id, TileKey{3, 3, 0})->kind, CacheLookup::Kind::Miss);
  for (std::int64_t c = 1; c < 50; ++c)
    EXPECT_EQ(cache->get(id, TileKey{3, 3, c})->bytes, payload({3, 3, c}));
  EXPECT_TRUE(cache->verify()->ok());
  EXPECT_EQ(cache->storeStatus().dropped, 0u);
}

TEST_P(TileCacheContract, OpenTilesAndPeekManyAnswerEachTileAsOpenTileAndPeekDo) {
  for (const bool writeBehind : {false, true}) {
    SCOPED_TRACE(writeBehind ? "write-behind" : "committed");
    auto o = options();
    o.indexWriteBehind = writeBehind;
    auto cache = open(o);
    const auto id = *cache->registerDataset(imagery(writeBehind ? "wb" : "direct"));
    // A metatile's block with every kind of row: stored, absent, expired, vanished, unknown.
    TileMeta expired;
    expired.expiresAt = clock->now() - 1;
    ASSERT_TRUE(cache->put(id, TileKey{5, 8, 12}, payload({5, 8, 12}), {}));
    ASSERT_TRUE(cache->put(id, TileKey{5, 9, 15}, payload({5, 9, 15}), expired));
    ASSERT_TRUE(cache->put(id, TileKey{5, 11, 13}, payload({5, 11, 13}), {}));
    ASSERT_TRUE(cache->putAbsent(id, TileKey{5, 10, 14}, clock->now() + 5000));
    cache->flush();
    store().remove(at(*cache->dataset(id), TileKey{5, 11, 13}));
    ASSERT_TRUE(cache->put(id, TileKey{5, 8, 13}, payload({5, 8, 13}), {})); // maybe pending
    // The block's tiles out of order, a tile far away and one of another level (each a lookup
    // of its own on a block-scanning index), and a tile outside the block's rows but in range.
    const std::vector<std::vector<TileKey>> sets = {
        {{5, 9, 15}, {5, 8, 12}, {5, 10, 14}, {5, 11, 13}, {5, 8, 13}, {5, 9, 12}},
        {{5, 8, 12}, {5, 20, 31}, {5, 10, 14}},
        {{5, 8, 12}, {4, 4, 6}, {5, 9, 15}},
        {{5, 8, 13}},
        {}};
    for (const auto& keys : sets) {
      auto peeked = cache->peekMany(id, keys);
      ASSERT_TRUE(peeked) << peeked.error().message;
      ASSERT_EQ(peeked->size(), keys.size());
      for (std::size_t i = 0; i < keys.size(); ++i) {
        const auto one = cache->peek(id, keys[i]);
        ASSERT_TRUE(one);
        EXPECT_EQ((*peeked)[i].kind, one->kind) << i;
        EXPECT_EQ((*peeked)[i].stale, one->stale) << i;
        EXPECT_EQ((*peeked)[i].retryAfter, one->retryAfter) << i;
        EXPECT_EQ((*peeked)[i].meta.fetchedAt, one->meta.fetchedAt) << i;
      }
      auto opened = cache->openTiles(id, keys);
      ASSERT_TRUE(opened) << opened.error().message;
      ASSERT_EQ(opened->size(), keys.size());
      for (std::size_t i = 0; i < keys.size(); ++i) {
        const auto one = cache->openTile(id, keys[i]);
        ASSERT_TRUE(one);
        const CacheLookup& many = (*opened)[i];
        EXPECT_EQ(many.kind, one->kind) << i;
        EXPECT_EQ(many.stale, one->stale) << i;
        if (many.kind != CacheLookup::Kind::Hit) continue;
        ASSERT_TRUE(many.file) << i;
        EXPECT_EQ(many.file->readAll().value(), payload(keys[i])) << i;
      }
    }
    const auto kinds = *cache->openTiles(id, sets[0]);
    EXPECT_EQ(kinds[0].kind, CacheLookup::Kind::Hit);
    EXPECT_TRUE(kinds[0].stale);
    EXPECT_EQ(kinds[1].kind, CacheLookup::Kind::Hit);
    EXPECT_EQ(kinds[2].kind, CacheLookup::Kind::Absent);
    EXPECT_EQ(kinds[3].kind, CacheLookup::Kind::Miss) << "its file vanished";
    EXPECT_EQ(kinds[4].kind, CacheLookup::Kind::Hit);
    EXPECT_EQ(kinds[5].kind, CacheLookup::Kind::Miss);
    // A dataset the cache does not know is an error, as for one tile.
    EXPECT_FALSE(cache->peekMany(id + 1000, sets[3]));
    EXPECT_FALSE(cache->openTiles(id + 1000, sets[3]));
  }
}
