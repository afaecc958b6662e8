#include "../support/CacheFixtures.hpp"
#include "../support/TempDir.hpp"

#include <tellus/cache/TileCache.hpp>
#include <tellus/cache/TilePath.hpp>

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <sys/resource.h>
#include <thread>

using namespace tellus;
using tellus::test::payload;
namespace fs = std::filesystem;

namespace {

DatasetSpec imagery(const std::string& name = "bluemarble") {
  return test::imagerySpec(name);
}

std::unique_ptr<TileCache> openCache(const fs::path& root, std::uint64_t limit = 0) {
  return test::openTestCache(root, limit);
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
}

TEST(TileCache, MissAbsentEraseAndStale) {
  test::TempDir dir("cache");
  auto cache = openCache(dir.path());
  const auto id = *cache->registerDataset(imagery());
  const TileKey k{1, 3, 4};
  EXPECT_EQ(cache->get(id, k)->kind, CacheLookup::Kind::Miss);
  ASSERT_TRUE(cache->putAbsent(id, k, 12345));
  auto a = cache->get(id, k);
  EXPECT_EQ(a->kind, CacheLookup::Kind::Absent);
  EXPECT_EQ(a->retryAfter, 12345);
  TileMeta expired;
  expired.expiresAt = unixMillisNow() - 1000;
  ASSERT_TRUE(cache->put(id, k, payload(k), expired));
  auto s = cache->get(id, k);
  EXPECT_EQ(s->kind, CacheLookup::Kind::Hit);
  EXPECT_TRUE(s->stale);
  TileMeta fresh;
  fresh.expiresAt = unixMillisNow() + 60000;
  fresh.etag = "\"v2\"";
  ASSERT_TRUE(cache->revalidated(id, k, fresh));
  auto r = cache->get(id, k);
  EXPECT_FALSE(r->stale);
  EXPECT_EQ(r->meta.etag, "\"v2\"");
  EXPECT_EQ(r->bytes, payload(k));
  ASSERT_TRUE(cache->erase(id, k));
  EXPECT_EQ(cache->get(id, k)->kind, CacheLookup::Kind::Miss);
  EXPECT_TRUE(cache->revalidated(id, k, fresh)); // nothing there: nothing to update
  EXPECT_FALSE(fs::exists(dir.path() / datasetFolder(imagery()) / tileRelativePath(k, "jpg")));
  EXPECT_TRUE(cache->erase(id, k)); // erasing nothing is fine
}

TEST(TileCache, RegisterIsIdempotentAndVariantsAreSeparate) {
  test::TempDir dir("cache");
  auto cache = openCache(dir.path());
  auto spec = imagery();
  const auto a = *cache->registerDataset(spec);
  EXPECT_EQ(*cache->registerDataset(spec), a);
  spec.time = "2024-01-02";
  const auto b = *cache->registerDataset(spec);
  EXPECT_NE(a, b);
  const TileKey k{0, 0, 0};
  ASSERT_TRUE(cache->put(a, k, payload(k, 10), {}));
  ASSERT_TRUE(cache->put(b, k, payload(k, 20), {}));
  EXPECT_EQ(cache->get(a, k)->bytes.size(), payload(k, 10).size());
  EXPECT_EQ(cache->get(b, k)->bytes.size(), payload(k, 20).size());
  EXPECT_EQ(cache->datasets().size(), 2u);
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

TEST(TileCache, PersistsAcrossReopen) {
  test::TempDir dir("cache");
  DatasetId id = 0;
  {
    auto cache = openCache(dir.path());
    id = *cache->registerDataset(imagery());
    for (std::int64_t c = 0; c < 10; ++c)
      ASSERT_TRUE(cache->put(id, TileKey{1, 2, c}, payload({1, 2, c}), {}));
  }
  auto cache = openCache(dir.path());
  EXPECT_FALSE(cache->wasRebuiltAtOpen());
  ASSERT_TRUE(cache->dataset(id));
  for (std::int64_t c = 0; c < 10; ++c)
    EXPECT_EQ(cache->get(id, TileKey{1, 2, c})->bytes, payload({1, 2, c}));
  EXPECT_EQ(userVersion(dir.path() / "index.sqlite"), 2);
}

TEST(TileCache, StatsPerDatasetAndLevel) {
  test::TempDir dir("cache");
  auto cache = openCache(dir.path());
  const auto a = *cache->registerDataset(imagery("a"));
  const auto b = *cache->registerDataset(imagery("b"));
  std::int64_t bytesA0 = 0;
  for (std::int64_t c = 0; c < 10; ++c) {
    ASSERT_TRUE(cache->put(a, TileKey{0, 0, c}, payload({0, 0, c}), {}));
    bytesA0 += static_cast<std::int64_t>(payload({0, 0, c}).size());
  }
  ASSERT_TRUE(cache->put(a, TileKey{1, 0, 0}, payload({1, 0, 0}), {}));
  ASSERT_TRUE(cache->putAbsent(b, TileKey{2, 0, 0}, 0));
  auto st = cache->stats();
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
}

TEST(TileCache, LruEvictionKeepsRecentAndPinned) {
  test::TempDir dir("cache");
  auto cache = openCache(dir.path(), 20000);
  auto pinnedSpec = imagery("show");
  pinnedSpec.pinned = true;
  const auto pinned = *cache->registerDataset(pinnedSpec);
  const auto id = *cache->registerDataset(imagery());
  const std::vector<std::byte> kb(1000, std::byte{7});
  for (std::int64_t c = 0; c < 8; ++c)
    ASSERT_TRUE(cache->put(pinned, TileKey{1, 0, c}, kb, {}));
  for (std::int64_t c = 0; c < 10; ++c)
    ASSERT_TRUE(cache->put(id, TileKey{1, 1, c}, kb, {}));
  // Touch tiles 0..4 so that 5..9 are the least recently used.
  std::this_thread::sleep_for(std::chrono::milliseconds(5));
  for (std::int64_t c = 0; c < 5; ++c)
    ASSERT_EQ(cache->get(id, TileKey{1, 1, c})->kind, CacheLookup::Kind::Hit);
  cache->flush();
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
  auto small = openCache(dir.path() / "small", 1000);
  const auto p2 = *small->registerDataset(pinnedSpec);
  for (std::int64_t c = 0; c < 3; ++c)
    ASSERT_TRUE(small->put(p2, TileKey{1, 0, c}, kb, {}));
  EXPECT_EQ(*small->evictToLimit(), 0);
  EXPECT_EQ(*small->totalBytes(), 3000);
}

TEST(TileCache, PruneByAgeAndLayer) {
  test::TempDir dir("cache");
  auto cache = openCache(dir.path());
  const auto a = *cache->registerDataset(imagery("a"));
  const auto b = *cache->registerDataset(imagery("b"));
  TileMeta old;
  old.fetchedAt = unixMillisNow() - 10 * 86400 * 1000LL;
  ASSERT_TRUE(cache->put(a, TileKey{0, 0, 0}, payload({}), old));
  ASSERT_TRUE(cache->put(a, TileKey{0, 0, 1}, payload({}), {}));
  ASSERT_TRUE(cache->put(b, TileKey{0, 0, 0}, payload({}), old));
  PruneOptions p;
  p.olderThan = std::chrono::hours(24 * 5);
  p.datasetName = "a";
  EXPECT_EQ(*cache->prune(p), 1);
  EXPECT_EQ(cache->get(a, TileKey{0, 0, 0})->kind, CacheLookup::Kind::Miss);
  EXPECT_EQ(cache->get(a, TileKey{0, 0, 1})->kind, CacheLookup::Kind::Hit);
  EXPECT_EQ(cache->get(b, TileKey{0, 0, 0})->kind, CacheLookup::Kind::Hit);
  p.datasetName.reset();
  EXPECT_EQ(*cache->prune(p), 1);
  EXPECT_EQ(cache->get(b, TileKey{0, 0, 0})->kind, CacheLookup::Kind::Miss);
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
  std::ofstream(ds / "1/0/.0_2.jpg.999.0.tmp") << "partial";
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

TEST(TileCache, VanishedFileIsAMissAndHealsTheRow) {
  test::TempDir dir("cache");
  auto cache = openCache(dir.path());
  const auto id = *cache->registerDataset(imagery());
  const TileKey k{1, 1, 1};
  ASSERT_TRUE(cache->put(id, k, payload(k), {}));
  fs::remove(dir.path() / datasetFolder(imagery()) / tileRelativePath(k, "jpg"));
  EXPECT_EQ(cache->get(id, k)->kind, CacheLookup::Kind::Miss);
  cache->flush();
  EXPECT_EQ(cache->peek(id, k)->kind, CacheLookup::Kind::Miss);
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
  EXPECT_EQ(userVersion(dir.path() / "index.sqlite"), 2);
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

TEST(TileCache, ReadOnlyCacheServesButRefusesWrites) {
  test::TempDir dir("cache");
  DatasetId id = 0;
  {
    auto cache = openCache(dir.path());
    id = *cache->registerDataset(imagery());
    ASSERT_TRUE(cache->put(id, TileKey{0, 1, 1}, payload({0, 1, 1}), {}));
  }
  TileCache::Options o;
  o.root = dir.path();
  o.readOnly = true;
  auto ro = TileCache::open(o);
  ASSERT_TRUE(ro) << ro.error().message;
  EXPECT_EQ((*ro)->get(id, TileKey{0, 1, 1})->bytes, payload({0, 1, 1}));
  auto w = (*ro)->put(id, TileKey{0, 1, 2}, payload({}), {});
  ASSERT_FALSE(w);
  EXPECT_EQ(w.error().code, CacheErrc::ReadOnly);
}

TEST(TileCache, ManyThreadsReadAndWriteWithoutErrors) {
  test::TempDir dir("cache");
  auto cache = openCache(dir.path());
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

TEST(TileCache, PutsErasesAbsentMarkersAndPrunesOnTheSameTilesKeepRowsAndFilesTogether) {
  // Threads of one process store, erase, mark absent and prune the same few tiles at once, so
  // that the writer's batches hold several operations on one tile: whatever order they commit
  // in, each file must be the one its row describes.
  test::TempDir dir("cache");
  auto cache = openCache(dir.path());
  const auto id = *cache->registerDataset(imagery());
  constexpr std::int64_t kTiles = 6;
  std::atomic<bool> stop{false};
  std::atomic<int> failures{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&, t] {
      for (std::size_t i = 0; !stop; ++i) {
        const TileKey k{5, 2, static_cast<std::int64_t>(i) % kTiles};
        if (!cache->put(id, k, payload(k, 300 + ((i + static_cast<std::size_t>(t)) % 7) * 100), {}))
          ++failures;
      }
    });
  }
  threads.emplace_back([&] {
    for (std::int64_t i = 0; !stop; ++i) {
      const TileKey k{5, 2, (i * 5) % kTiles};
      if (!(i % 2 ? cache->erase(id, k) : cache->putAbsent(id, k, unixMillisNow() + 60000)))
        ++failures;
    }
  });
  threads.emplace_back([&] {
    PruneOptions all;
    all.olderThan = std::chrono::milliseconds(0);
    all.includePinned = true;
    while (!stop) {
      if (!cache->prune(all)) ++failures;
    }
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(700));
  stop = true;
  for (auto& th : threads)
    th.join();
  cache->flush();
  EXPECT_EQ(failures.load(), 0);
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

TEST(TileCache, WriteBehindIsVisibleAtOnceAndCommittedSoon) {
  test::TempDir dir("cache");
  DatasetId id = 0;
  {
    TileCache::Options o;
    o.root = dir.path();
    o.fsyncTiles = false;
    o.indexWriteBehind = true;
    auto cache = std::move(*TileCache::open(o));
    id = *cache->registerDataset(imagery());
    for (std::int64_t c = 0; c < 50; ++c) {
      const TileKey k{3, 3, c};
      auto put = cache->put(id, k, payload(k), {});
      ASSERT_TRUE(put) << put.error().message;
      auto got = cache->get(id, k); // before any commit is guaranteed
      ASSERT_EQ(got->kind, CacheLookup::Kind::Hit);
      EXPECT_EQ(got->bytes, payload(k));
    }
    ASSERT_TRUE(cache->erase(id, TileKey{3, 3, 0}));
    EXPECT_EQ(cache->peek(id, TileKey{3, 3, 0})->kind, CacheLookup::Kind::Miss);
  } // closing commits whatever is queued
  auto cache = openCache(dir.path());
  EXPECT_EQ(cache->peek(id, TileKey{3, 3, 0})->kind, CacheLookup::Kind::Miss);
  for (std::int64_t c = 1; c < 50; ++c)
    EXPECT_EQ(cache->get(id, TileKey{3, 3, c})->bytes, payload({3, 3, c}));
  EXPECT_TRUE(cache->verify()->ok());
}

// ------------------------------------------------------------------ remembered rows and open files

namespace {

std::vector<std::byte> filled(std::size_t n, unsigned char value) {
  return std::vector<std::byte>(n, static_cast<std::byte>(value));
}

std::unique_ptr<TileCache> openWith(const fs::path& root,
                                    std::chrono::milliseconds otherWritersCheck,
                                    std::chrono::milliseconds fileRecheck) {
  TileCache::Options o;
  o.root = root;
  o.fsyncTiles = false;
  o.otherWritersCheck = otherWritersCheck;
  o.fileRecheck = fileRecheck;
  auto c = TileCache::open(o);
  EXPECT_TRUE(c) << (c ? "" : c.error().message);
  return c ? std::move(*c) : nullptr;
}

} // namespace

TEST(TileCache, OwnReplacementIsSeenByTheNextGet) {
  test::TempDir dir("cache");
  auto cache = openWith(dir.path(), std::chrono::hours(1), std::chrono::hours(1));
  const auto id = *cache->registerDataset(imagery());
  const TileKey k{1, 0, 1};
  ASSERT_TRUE(cache->put(id, k, filled(300, 1), {}));
  ASSERT_EQ(cache->get(id, k)->bytes, filled(300, 1)); // now remembered, file held open
  ASSERT_TRUE(cache->put(id, k, filled(300, 2), {}));  // same size, new bytes
  EXPECT_EQ(cache->get(id, k)->bytes, filled(300, 2));
  ASSERT_TRUE(cache->put(id, k, filled(120, 3), {})); // new size
  EXPECT_EQ(cache->openTile(id, k)->file->size(), 120);
  EXPECT_EQ(cache->get(id, k)->bytes, filled(120, 3));
  ASSERT_TRUE(cache->erase(id, k));
  EXPECT_EQ(cache->get(id, k)->kind, CacheLookup::Kind::Miss);
  ASSERT_TRUE(cache->putAbsent(id, k, unixMillisNow() + 60000));
  EXPECT_EQ(cache->openTile(id, k)->kind, CacheLookup::Kind::Absent);
}

TEST(TileCache, OpenTileKeepsItsBytesWhileTheTileIsReplaced) {
  test::TempDir dir("cache");
  auto cache = openCache(dir.path());
  const auto id = *cache->registerDataset(imagery());
  const TileKey k{2, 1, 1};
  ASSERT_TRUE(cache->put(id, k, filled(500, 7), {}));
  auto held = cache->openTile(id, k);
  ASSERT_TRUE(held && held->file);
  ASSERT_TRUE(cache->put(id, k, filled(200, 8), {}));
  ASSERT_TRUE(cache->erase(id, k));
  // A response being sent from the old descriptor is never torn.
  EXPECT_EQ(held->file->readAll(), filled(500, 7));
}

TEST(TileCache, AnotherWritersChangesAreSeenWithinTheCheckInterval) {
  test::TempDir dir("cache");
  // Two caches on one root: as two processes, each with its own connections.
  auto writer = openWith(dir.path(), std::chrono::milliseconds(20), std::chrono::hours(1));
  auto reader = openWith(dir.path(), std::chrono::milliseconds(20), std::chrono::hours(1));
  const auto id = *writer->registerDataset(imagery());
  const TileKey k{1, 0, 0};
  ASSERT_TRUE(writer->put(id, k, filled(256, 1), {}));
  ASSERT_EQ(reader->get(id, k)->bytes, filled(256, 1));
  ASSERT_TRUE(writer->put(id, k, filled(256, 9), {}));
  std::this_thread::sleep_for(std::chrono::milliseconds(80));
  EXPECT_EQ(reader->get(id, k)->bytes, filled(256, 9));
  ASSERT_TRUE(writer->erase(id, k));
  std::this_thread::sleep_for(std::chrono::milliseconds(80));
  EXPECT_EQ(reader->get(id, k)->kind, CacheLookup::Kind::Miss);
}

TEST(TileCache, FileReplacedOrRemovedBehindTheIndexIsNoticed) {
  test::TempDir dir("cache");
  auto cache = openWith(dir.path(), std::chrono::hours(1), std::chrono::milliseconds(0));
  const auto id = *cache->registerDataset(imagery());
  const TileKey k{1, 1, 0};
  ASSERT_TRUE(cache->put(id, k, filled(64, 1), {}));
  ASSERT_EQ(cache->get(id, k)->bytes, filled(64, 1));
  const fs::path file = dir.path() / datasetFolder(imagery()) / tileRelativePath(k, "jpg");
  {
    std::ofstream out(file.string() + ".new", std::ios::binary);
    const auto b = filled(64, 5);
    out.write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
  }
  fs::rename(file.string() + ".new", file);
  EXPECT_EQ(cache->get(id, k)->bytes, filled(64, 5));
  fs::remove(file);
  EXPECT_EQ(cache->get(id, k)->kind, CacheLookup::Kind::Miss);
}

TEST(TileCache, HeldOpenFilesStayWithinTheirLimit) {
  test::TempDir dir("cache");
  TileCache::Options o;
  o.root = dir.path();
  o.fsyncTiles = false;
  o.openFiles = 8;
  auto cache = std::move(*TileCache::open(o));
  const auto id = *cache->registerDataset(imagery());
  auto openFds = [] {
    std::size_t n = 0;
    for ([[maybe_unused]] const auto& e : fs::directory_iterator("/proc/self/fd"))
      ++n;
    return n;
  };
  const std::size_t before = openFds();
  for (std::int64_t c = 0; c < 32; ++c) {
    const TileKey k{3, 2, c};
    ASSERT_TRUE(cache->put(id, k, payload(k), {}));
    ASSERT_EQ(cache->get(id, k)->bytes, payload(k));
  }
  // Read connections may open as well; the tiles themselves add at most `openFiles`.
  EXPECT_LE(openFds(), before + 8 + 4);
}
