// Bad input, a full disk, two processes on one cache and a crash in the middle of writing.

#include "../support/CacheFixtures.hpp"
#include "../support/TempDir.hpp"

#include <tellus/cache/TileCache.hpp>
#include <tellus/cache/TilePath.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <fstream>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

using namespace tellus;
namespace fs = std::filesystem;

namespace {

DatasetSpec imagery() {
  return test::imagerySpec();
}

std::vector<std::byte> payload(const TileKey& k, std::size_t base = 2000) {
  return test::payload(k, base);
}

std::unique_ptr<TileCache> openCache(const fs::path& root, bool fsyncTiles = false) {
  return test::openTestCache(root, 0, fsyncTiles);
}

std::size_t countTempFiles(const fs::path& root) {
  std::size_t n = 0;
  for (const auto& e : fs::recursive_directory_iterator(root)) {
    const auto name = e.path().filename().string();
    n += e.is_regular_file() && name.starts_with(".") && name.ends_with(".tmp");
  }
  return n;
}

/** Runs fn in a child process (before this process opens anything), returns its exit code. */
template <class Fn> pid_t spawn(Fn fn) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    int rc = 1;
    try {
      rc = fn();
    } catch (...) {
      rc = 2;
    }
    ::_exit(rc);
  }
  return pid;
}

int waitExit(pid_t pid) {
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

} // namespace

TEST(TileCacheExtremes, FullDiskIsReportedAndLosesNothing) {
  test::TempDir dir("full");
  auto cache = openCache(dir.path());
  const auto id = *cache->registerDataset(imagery());
  const TileKey k{3, 1, 2};
  ASSERT_TRUE(cache->put(id, k, payload(k), {}));
  cache->flush();
  const auto before = *cache->totalBytes();

  // Simulate a full disk for files: a file-size limit below the tile (EFBIG, SIGXFSZ ignored).
  rlimit old{};
  ::getrlimit(RLIMIT_FSIZE, &old);
  rlimit lim = old;
  lim.rlim_cur = 64 * 1024;
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &lim), 0);
  const std::vector<std::byte> big(256 * 1024, std::byte{0x5A});
  auto r = cache->put(id, k, big, {});
  auto r2 = cache->put(id, TileKey{3, 1, 3}, big, {});
  ::setrlimit(RLIMIT_FSIZE, &old);

  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, CacheErrc::DiskFull) << r.error().message;
  EXPECT_NE(r.error().message.find("3/1/1_2.jpg"), std::string::npos) << r.error().message;
  ASSERT_FALSE(r2);
  EXPECT_EQ(r2.error().code, CacheErrc::DiskFull);
  EXPECT_EQ(countTempFiles(dir.path()), 0u);
  EXPECT_EQ(*cache->totalBytes(), before);
  EXPECT_EQ(cache->get(id, k)->bytes, payload(k)); // the old tile is intact
  EXPECT_EQ(cache->get(id, TileKey{3, 1, 3})->kind, CacheLookup::Kind::Miss);
  EXPECT_TRUE(cache->verify()->ok());
}

TEST(TileCacheIntegration, TwoProcessesShareOneCache) {
  test::TempDir dir("two");
  {
    auto setup = openCache(dir.path());
    ASSERT_TRUE(setup->registerDataset(imagery()));
  }
  constexpr int kTiles = 300;
  // Two writers (a "server" and a "seeder") plus reads, at once, in separate processes.
  auto worker = [&](std::int64_t row) {
    return spawn([&, row] {
      auto cache = openCache(dir.path());
      if (!cache) return 3;
      const auto id = cache->datasets().at(0).id;
      for (std::int64_t c = 0; c < kTiles; ++c) {
        const TileKey k{9, row, c};
        auto p = cache->put(id, k, payload(k, 200), {});
        if (!p) {
          std::fprintf(stderr, "put failed: %s\n", p.error().message.c_str());
          return 4;
        }
        auto g = cache->get(id, TileKey{9, 1 - row, c});
        if (!g) {
          std::fprintf(stderr, "get failed: %s\n", g.error().message.c_str());
          return 5;
        }
      }
      return 0;
    });
  };
  const pid_t a = worker(0);
  const pid_t b = worker(1);
  EXPECT_EQ(waitExit(a), 0);
  EXPECT_EQ(waitExit(b), 0);
  auto cache = openCache(dir.path());
  const auto id = cache->datasets().at(0).id;
  for (std::int64_t row = 0; row < 2; ++row) {
    for (std::int64_t c = 0; c < kTiles; ++c) {
      const TileKey k{9, row, c};
      EXPECT_EQ(cache->get(id, k)->bytes, payload(k, 200));
    }
  }
  EXPECT_TRUE(cache->verify()->ok());
}

TEST(TileCacheIntegration, ProcessesOpeningOneFreshCacheAtOnceAllOpenIt) {
  // Six processes (a cluster's ranks, servers started together) creating one cache in the same
  // instant: SQLite answers the first switch to WAL with "database is locked" without waiting.
  for (int round = 0; round < 10; ++round) {
    test::TempDir dir("fresh");
    std::vector<pid_t> kids;
    for (int i = 0; i < 6; ++i) {
      kids.push_back(spawn([&] {
        auto cache = openCache(dir.path());
        return cache ? 0 : 3;
      }));
    }
    for (const pid_t k : kids)
      EXPECT_EQ(waitExit(k), 0) << "round " << round;
  }
}

TEST(TileCacheIntegration, CrashMidWriteNeverLeavesACorruptTile) {
  test::TempDir dir("crash");
  {
    auto setup = openCache(dir.path());
    ASSERT_TRUE(setup->registerDataset(imagery()));
  }
  for (int round = 0; round < 3; ++round) {
    // The child says after each put that it has stored one; it is killed once it has stored a
    // number that differs per round, in the middle of whatever it is doing then (no timing).
    int done[2];
    ASSERT_EQ(::pipe(done), 0);
    const pid_t child = spawn([&] {
      ::close(done[0]);
      auto cache = openCache(dir.path(), /*fsyncTiles=*/true);
      if (!cache) return 3;
      const auto id = cache->datasets().at(0).id;
      // Overwrite the same keys again and again with content of different lengths.
      for (std::int64_t i = 0;; ++i) {
        const TileKey k{8, i % 7, (i * 5) % 11};
        (void)cache->put(id, k, payload(k, 1000 + static_cast<std::size_t>(i % 3) * 40000), {});
        const char one = 1;
        if (::write(done[1], &one, 1) != 1) return 4;
      }
    });
    ::close(done[1]);
    const int puts = 20 + round * 15;
    int seen = 0;
    char buf[64];
    while (seen < puts) {
      const ssize_t n =
          ::read(done[0], buf, std::min(sizeof buf, static_cast<std::size_t>(puts - seen)));
      if (n <= 0) break;
      seen += static_cast<int>(n);
    }
    ::kill(child, SIGKILL);
    ::close(done[0]);
    EXPECT_EQ(seen, puts) << "the writer stopped before it was killed";
    EXPECT_EQ(waitExit(child), 128 + SIGKILL);
  }
  auto cache = openCache(dir.path());
  ASSERT_TRUE(cache);
  EXPECT_FALSE(cache->wasRebuiltAtOpen());
  const auto id = cache->datasets().at(0).id;
  int hits = 0;
  for (std::int64_t r = 0; r < 7; ++r) {
    for (std::int64_t c = 0; c < 11; ++c) {
      const TileKey k{8, r, c};
      auto g = cache->get(id, k);
      ASSERT_TRUE(g);
      if (g->kind != CacheLookup::Kind::Hit) continue;
      ++hits;
      // Whatever version is there is one of the complete versions, never a torn one.
      bool complete = false;
      for (std::size_t v = 0; v < 3; ++v)
        complete |= g->bytes == payload(k, 1000 + v * 40000);
      EXPECT_TRUE(complete) << "torn tile " << tileRelativePath(k, "jpg") << " size "
                            << g->bytes.size();
    }
  }
  EXPECT_GT(hits, 0);
  auto report = cache->verify();
  ASSERT_TRUE(report);
  EXPECT_EQ(report->integrity, "ok");
  EXPECT_TRUE(report->rowsWithoutFiles.empty());
}

TEST(TileCacheIntegration, PruneRacingPutsNeverLeavesARowWithoutItsFile) {
  // `tellus cache prune` in one process while another (a server, a seeder) stores the same tiles
  // again and again: a tile stored between the prune's row delete and its unlink must keep its
  // file. The putter checks after each put: a tile whose file is gone must have no row either
  // (only this process stores; the pruner removes the row before the file).
  test::TempDir dir("race");
  std::string folder;
  {
    auto setup = openCache(dir.path());
    ASSERT_TRUE(setup->registerDataset(imagery()));
    folder = setup->datasets().at(0).folder;
  }
  const fs::path stop = dir.path() / "stop";
  constexpr auto kRun = std::chrono::milliseconds(1500);
  const pid_t putter = spawn([&] {
    auto cache = openCache(dir.path());
    if (!cache) return 3;
    const auto id = cache->datasets().at(0).id;
    const auto until = std::chrono::steady_clock::now() + kRun;
    int lost = 0;
    for (std::int64_t round = 0; std::chrono::steady_clock::now() < until && lost == 0; ++round) {
      for (std::int64_t c = 0; c < 16; ++c) {
        const TileKey k{6, 3, c};
        if (!cache->put(id, k, payload(k, 500 + static_cast<std::size_t>(round % 5) * 300), {}))
          continue;
        const fs::path file = dir.path() / folder / tileRelativePath(k, "jpg");
        if (fs::exists(file)) continue;
        const auto row = cache->peek(id, k);
        if (row && row->kind == CacheLookup::Kind::Hit) {
          std::fprintf(stderr,
                       "round %lld: %s has an index row but its file is gone\n",
                       static_cast<long long>(round),
                       tileRelativePath(k, "jpg").c_str());
          ++lost;
        }
      }
    }
    return lost == 0 ? 0 : 10;
  });
  const pid_t pruner = spawn([&] {
    auto cache = openCache(dir.path());
    if (!cache) return 3;
    PruneOptions all;
    all.olderThan = std::chrono::milliseconds(0);
    all.includePinned = true;
    while (!fs::exists(stop)) {
      if (!cache->prune(all)) return 4;
    }
    return 0;
  });
  EXPECT_EQ(waitExit(putter), 0) << "a prune removed the file of a tile stored after its row";
  { std::ofstream(stop).put('x'); }
  EXPECT_EQ(waitExit(pruner), 0);
  auto cache = openCache(dir.path());
  const auto report = cache->verify();
  ASSERT_TRUE(report);
  EXPECT_TRUE(report->rowsWithoutFiles.empty()) << report->rowsWithoutFiles.size() << " rows";
  EXPECT_TRUE(report->filesWithoutRows.empty()) << report->filesWithoutRows.size() << " files";
  EXPECT_TRUE(report->ok());
}

TEST(TileCacheIntegration, TempFilesOfWritersThatAreGoneAreRemovedAtOpenAndFailVerify) {
  test::TempDir dir("temps");
  std::string folder;
  {
    auto cache = openCache(dir.path());
    const auto id = *cache->registerDataset(imagery());
    ASSERT_TRUE(cache->put(id, TileKey{3, 1, 2}, payload({3, 1, 2}), {}));
    folder = cache->datasets().at(0).folder;
  }
  // A writer that is gone: a child that has exited (its pid names no process any more).
  const pid_t gone = spawn([] { return 0; });
  ASSERT_EQ(waitExit(gone), 0);
  const std::string deadPid = std::to_string(gone);
  const std::string livePid = std::to_string(::getpid());
  const fs::path ds = dir.path() / folder;
  auto touch = [](const fs::path& p) {
    fs::create_directories(p.parent_path());
    std::ofstream(p) << "partial";
    return p;
  };
  // Where writers put their temp files, owned by the dead writer (pid and start time), by a
  // process that reuses this process's pid but started at another time, and by this process.
  const auto deadInTmp = touch(ds / ".tmp" / (".1_3.jpg." + deadPid + "-12345.0.tmp"));
  const auto reusedPid = touch(ds / ".tmp" / (".1_4.jpg." + livePid + "-1.0.tmp"));
  const auto liveInTmp = touch(ds / ".tmp" / (".1_5.jpg." + livePid + ".1.tmp"));
  // Beside the tiles, where earlier versions wrote them (left to verify and rebuild).
  const auto deadBeside = touch(ds / "3" / "1" / (".1_6.jpg." + deadPid + ".7.tmp"));
  const auto liveBeside = touch(ds / "3" / "1" / (".1_7.jpg." + livePid + ".8.tmp"));

  auto cache = openCache(dir.path());
  EXPECT_FALSE(fs::exists(deadInTmp)) << "a dead writer's temp file survived the open";
  EXPECT_FALSE(fs::exists(reusedPid)) << "a temp file of a reused pid survived the open";
  EXPECT_TRUE(fs::exists(liveInTmp)) << "a running writer's temp file was removed";
  EXPECT_TRUE(fs::exists(deadBeside)); // no scan of the tree at open
  EXPECT_TRUE(fs::exists(liveBeside));
  EXPECT_EQ(cache->tempFilesRemovedAtOpen(), 2u);

  auto report = cache->verify();
  ASSERT_TRUE(report);
  ASSERT_EQ(report->strayTempFiles.size(), 1u);
  EXPECT_EQ(report->strayTempFiles[0], folder + "/3/1/.1_6.jpg." + deadPid + ".7.tmp");
  EXPECT_EQ(report->tempFilesInUse, 2);
  EXPECT_FALSE(report->ok()) << "a stray temp file must fail verify";

  ASSERT_TRUE(cache->rebuild());
  EXPECT_FALSE(fs::exists(deadBeside));
  EXPECT_TRUE(fs::exists(liveBeside)) << "rebuild removed a running writer's temp file";
  EXPECT_TRUE(fs::exists(liveInTmp));
  report = cache->verify();
  ASSERT_TRUE(report);
  EXPECT_TRUE(report->strayTempFiles.empty());
  EXPECT_TRUE(report->ok());
}
