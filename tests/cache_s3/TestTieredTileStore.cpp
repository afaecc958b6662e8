// The local tier's bound (TieredTileStore.hpp, `cache.s3.local_tier_limit`): the local tier a real
// folder (the file store), the shared store one in memory that counts what it is asked. No S3
// server: these are unit tests (the one against the server is in TestS3TileStore.cpp).

#include "../support/MemoryTileStore.hpp"
#include "../support/TempDir.hpp"

#include <tellus/cache/TilePath.hpp>
#include <tellus/cache_s3/TieredTileStore.hpp>

#include <gtest/gtest.h>

#include <atomic>
#include <fcntl.h>
#include <fstream>
#include <future>
#include <sys/stat.h>
#include <thread>

using namespace tellus;
namespace fs = std::filesystem;

namespace {

/** The shared store: tiles in memory; how often it was asked to open and to remove. */
class CountingStore final : public ITileStore {
public:
  test::MemoryTileStore inner;
  std::atomic<int> opens{0};
  std::atomic<int> removals{0};

  Result prepareDataset(std::string_view f) override { return inner.prepareDataset(f); }
  std::optional<std::string> readDescriptor(std::string_view f) override {
    return inner.readDescriptor(f);
  }
  Result writeDescriptor(std::string_view f, std::string_view t) override {
    return inner.writeDescriptor(f, t);
  }
  std::optional<StoredTile> open(const TileLocation& at, std::int64_t size) override {
    ++opens;
    return inner.open(at, size);
  }
  std::optional<TileStat> stat(const TileLocation& at) override { return inner.stat(at); }
  std::expected<std::shared_ptr<StagedTile>, CacheError>
  stage(const TileLocation& at, std::span<const std::byte> bytes) override {
    return inner.stage(at, bytes);
  }
  std::shared_ptr<StagedRemoval> stageRemoval(const TileLocation& at) override {
    ++removals;
    return inner.stageRemoval(at);
  }
  void remove(const TileLocation& at) override {
    ++removals;
    inner.remove(at);
  }
  Result lockChanges(std::chrono::milliseconds t) override { return inner.lockChanges(t); }
  void unlockChanges() override { inner.unlockChanges(); }
  std::optional<DiskSpace> freeSpace() const override { return inner.freeSpace(); }
  std::size_t removeDeadTemps(std::string_view f) override { return inner.removeDeadTemps(f); }
  std::vector<std::string> datasetFolders() override { return inner.datasetFolders(); }
  void scan(std::string_view f, const EntryVisitor& v) override { inner.scan(f, v); }
  void removeEntry(std::string_view f, std::string_view p) override {
    ++removals;
    inner.removeEntry(f, p);
  }
};

constexpr std::string_view kFolder = "srv/ds-0000abcd";

TileLocation tile(int i) {
  return TileLocation{kFolder, "png", TileKey{5, 7, i}};
}

/** `n` bytes, the tile's number in the first. */
std::vector<std::byte> body(int i, std::size_t n = 100) {
  std::vector<std::byte> b(n, std::byte{'x'});
  b[0] = static_cast<std::byte>(i);
  return b;
}

void put(ITileStore& s, const TileLocation& at, const std::vector<std::byte>& bytes) {
  auto staged = s.stage(at, bytes);
  ASSERT_TRUE(staged) << staged.error().message;
  const auto r = (*staged)->install();
  ASSERT_TRUE(r) << r.error().message;
  (*staged)->finish(true);
}

/** Bytes and number of the tile files under a local tree (what is really on disk). */
std::pair<std::uint64_t, int> tilesOnDisk(const fs::path& root) {
  std::uint64_t bytes = 0;
  int files = 0;
  for (auto it = fs::recursive_directory_iterator(root); it != fs::recursive_directory_iterator();
       ++it) {
    const std::string rel = fs::relative(it->path(), root).generic_string();
    const auto slash = rel.find('/', rel.find('/') + 1); // past <server>/<dataset>/
    if (!it->is_regular_file() || slash == std::string::npos) continue;
    if (parseTileRelativePath(std::string_view(rel).substr(slash + 1))) {
      bytes += it->file_size();
      ++files;
    }
  }
  return {bytes, files};
}

class LocalTier : public ::testing::Test {
protected:
  test::TempDir dir{"tier"};
  std::shared_ptr<CountingStore> shared = std::make_shared<CountingStore>();
  std::shared_ptr<ITileStore> local;

  void SetUp() override {
    auto l = openFileTileStore(FileTileStoreOptions{dir.path(), false, false});
    ASSERT_TRUE(l) << l.error().message;
    local = std::move(*l);
  }

  std::unique_ptr<TieredTileStore> tiered(std::uint64_t limit,
                                          std::function<void()> beforeScan = {}) {
    auto t = makeTieredTileStore(
        local, shared, LocalTierOptions{limit, 0.9, dir.path(), std::move(beforeScan)});
    EXPECT_TRUE(t->prepareDataset(kFolder));
    return t;
  }

  bool localHas(int i) { return local->stat(tile(i)).has_value(); }
};

} // namespace

TEST_F(LocalTier, OverTheLimitTheLeastRecentlyUsedLocalCopiesGoDownToTheLowWaterMark) {
  auto t = tiered(1000);
  for (int i = 0; i < 10; ++i)
    put(*t, tile(i), body(i));
  ASSERT_TRUE(t->open(tile(0), 100)); // a local hit: tile 0 is now the most recently used
  t->settle();
  EXPECT_EQ(t->localTier().bytes, 1000U); // at the limit, not over it
  EXPECT_EQ(t->localTier().evictions, 0U);

  put(*t, tile(10), body(10)); // 1,100 bytes: over; down to 900, the two least recently used
  t->settle();
  const auto s = t->localTier();
  EXPECT_EQ(s.bytes, 900U);
  EXPECT_EQ(s.files, 9U);
  EXPECT_EQ(s.evictions, 2U);
  EXPECT_EQ(s.evictedBytes, 200U);
  EXPECT_FALSE(localHas(1));
  EXPECT_FALSE(localHas(2));
  EXPECT_TRUE(localHas(0)); // read recently: it survives
  for (int i = 3; i <= 10; ++i)
    EXPECT_TRUE(localHas(i)) << i;
  EXPECT_EQ(tilesOnDisk(dir.path()), std::make_pair(std::uint64_t{900}, 9));
  // The shared store untouched: asked to remove nothing, holding every tile.
  EXPECT_EQ(shared->removals.load(), 0);
  EXPECT_EQ(shared->inner.usedBytes(), 1100U);
  for (int i = 0; i <= 10; ++i)
    EXPECT_TRUE(shared->inner.stat(tile(i))) << i;
}

TEST_F(LocalTier, AReadAfterEvictionComesFromTheSharedStoreAndIsCopiedBack) {
  auto t = tiered(500);
  for (int i = 0; i < 6; ++i)
    put(*t, tile(i), body(i));
  t->settle();
  ASSERT_FALSE(localHas(0)); // 600 > 500: tiles 0 and 1 went (down to 450 at most)
  ASSERT_FALSE(localHas(1));
  const int before = shared->opens.load();
  for (int i : {0, 1}) {
    const auto read = t->open(tile(i), 100);
    ASSERT_TRUE(read);
    const auto bytes = read->file->readAll();
    ASSERT_TRUE(bytes);
    EXPECT_EQ(*bytes, body(i));
    EXPECT_TRUE(localHas(i)); // copied back
  }
  EXPECT_EQ(shared->opens.load(), before + 2); // from the shared store
  t->settle();                                 // 600 again: the least recently used went
  EXPECT_TRUE(localHas(0));
  EXPECT_TRUE(localHas(1));
  EXPECT_FALSE(localHas(2));
  EXPECT_FALSE(localHas(3));
  ASSERT_TRUE(t->open(tile(0), 100));
  EXPECT_EQ(shared->opens.load(), before + 2); // the next read a local hit
  EXPECT_EQ(t->localTier().bytes, 400U);
  EXPECT_EQ(shared->removals.load(), 0);
}

// A write the start's scan finds installed before its use is recorded (CI saw it once, under ASan):
// the scan put that newest tile at the back of the order, its first victim, and counted it twice.
TEST_F(LocalTier, AWriteFinishingWhileTheScanRunsIsRecordedByTheWriteNotTheScan) {
  std::promise<void> go;
  auto t = tiered(500, [released = go.get_future().share()] { released.wait(); });
  for (int i = 0; i < 5; ++i)
    put(*t, tile(i), body(i)); // 500: at the limit, tile 0 the least recently used
  const auto bytes = body(5);
  auto staged = t->stage(tile(5), bytes);
  ASSERT_TRUE(staged);
  ASSERT_TRUE((*staged)->install()); // on disk, its use not recorded yet
  go.set_value();                    // the scan finds tiles 0 to 5 there
  t->settle();
  EXPECT_EQ(t->localTier().bytes, 500U); // tile 5 is the write's to record, not the scan's
  EXPECT_EQ(t->localTier().evictions, 0U);
  EXPECT_TRUE(localHas(5));
  (*staged)->finish(true); // 600: the least recently used go, down to 400
  t->settle();
  EXPECT_TRUE(localHas(5));
  EXPECT_FALSE(localHas(0));
  EXPECT_FALSE(localHas(1));
  EXPECT_EQ(t->localTier().bytes, 400U);
  EXPECT_EQ(t->localTier().files, 4U);
}

/** The mtime of a tile's local copy, in milliseconds. */
UnixMillis copyModified(ITileStore& local, const TileLocation& at) {
  const auto t = local.open(at, 100); // every tile of these tests is 100 bytes
  struct stat st {};
  if (!t || ::fstat(t->file->fd(), &st) != 0) return -1;
  return static_cast<UnixMillis>(st.st_mtim.tv_sec) * 1000 + st.st_mtim.tv_nsec / 1000000;
}

std::vector<std::byte> bytesOf(const std::optional<StoredTile>& t) {
  if (!t) return {};
  auto b = t->file->readAll();
  return b ? *b : std::vector<std::byte>{};
}

// A tile refreshed by another instance whose clock runs behind this one's (issue 27): a copy's
// mtime is the fetched-at it was written for, and only equality with the row's counts. The first
// rule (a copy older than its row is stale) served the old copy here.
TEST_F(LocalTier, ACopyOfAnotherVersionIsReplacedWhateverTheClocksSay) {
  auto t = tiered(0);
  TileLocation mine = tile(0);
  mine.fetchedAt = 1'900'000'000'123; // this instance's clock
  put(*t, mine, body(1));
  EXPECT_EQ(copyModified(*local, tile(0)), mine.fetchedAt); // the copy names its version
  // Refreshed elsewhere: new bytes of the same size in the shared store, the row's fetched-at two
  // minutes before this copy's (the refreshing machine's clock behind).
  TileLocation row = tile(0);
  row.fetchedAt = mine.fetchedAt - 120'000;
  put(shared->inner, row, body(2));
  const int before = shared->opens.load();
  EXPECT_EQ(bytesOf(t->open(tile(0), 100)), body(1)); // no row to compare (the index down)
  EXPECT_EQ(bytesOf(t->open(mine, 100)), body(1));    // the copy's own version
  EXPECT_EQ(shared->opens.load(), before);
  EXPECT_EQ(bytesOf(t->open(row, 100)), body(2)); // another version: the shared store's
  EXPECT_EQ(shared->opens.load(), before + 1);
  EXPECT_EQ(bytesOf(local->open(tile(0), 100)), body(2)); // the copy replaced, with its version
  EXPECT_EQ(copyModified(*local, tile(0)), row.fetchedAt);
  EXPECT_EQ(bytesOf(t->open(row, 100)), body(2));
  EXPECT_EQ(shared->opens.load(), before + 1); // then a local hit
  // Tiles stored together name their version too (putMany's stageMany).
  std::vector<std::vector<std::byte>> bodies{body(3), body(4)};
  std::vector<TileToStage> many{{tile(3), bodies[0]}, {tile(4), bodies[1]}};
  for (auto& m : many)
    m.at.fetchedAt = 1'800'000'000'456;
  auto staged = t->stageMany(many);
  ASSERT_TRUE(staged);
  for (const auto& s : *staged) {
    ASSERT_TRUE(s->install());
    s->finish(true);
  }
  EXPECT_EQ(copyModified(*local, tile(3)), 1'800'000'000'456);
  EXPECT_EQ(copyModified(*local, tile(4)), 1'800'000'000'456);
}

TEST(TileVersion, AnMtimeNamesTheMillisecondOrOnAWholeSecondFileSystemTheSecond) {
  constexpr UnixMillis v = 1'900'000'000'123;
  EXPECT_TRUE(mtimeNamesVersion(1'900'000'000, 123'000'000, v));
  EXPECT_TRUE(mtimeNamesVersion(1'900'000'000, 123'999'999, v)); // the same millisecond
  EXPECT_FALSE(mtimeNamesVersion(1'900'000'000, 124'000'000, v));
  EXPECT_FALSE(mtimeNamesVersion(1'900'000'000, 122'999'999, v));
  EXPECT_FALSE(mtimeNamesVersion(1'899'999'880, 123'000'000, v)); // two minutes before: another
  EXPECT_TRUE(mtimeNamesVersion(1'900'000'000, 0, v));  // whole seconds kept: the same second
  EXPECT_FALSE(mtimeNamesVersion(1'900'000'001, 0, v)); // another second
  EXPECT_FALSE(mtimeNamesVersion(1'899'999'999, 0, v));
  EXPECT_TRUE(mtimeNamesVersion(1'900'000'000, 0, 1'900'000'000'000));
  EXPECT_FALSE(mtimeNamesVersion(1'900'000'000, 1'000'000, 1'900'000'000'000));
}

TEST_F(LocalTier, TheScanAtStartCountsTheFilesThereOldestFirstAndOnlyTiles) {
  for (int i = 0; i < 5; ++i)
    put(*local, tile(i), body(i, 100 + static_cast<std::size_t>(i)));
  // Modified in the order 3 (oldest), 1, 0, 2, 4: set, not waited for.
  const int order[] = {3, 1, 0, 2, 4};
  for (int k = 0; k < 5; ++k) {
    const fs::path p = dir.path() / kFolder / tileRelativePath(tile(order[k]).key, "png");
    const timespec times[2] = {{1'000'000 + k, 0}, {1'000'000 + k, 0}};
    ASSERT_EQ(::utimensat(AT_FDCWD, p.c_str(), times, 0), 0) << p;
  }
  // What is no tile is neither counted nor ever removed.
  ASSERT_TRUE(local->writeDescriptor(kFolder, std::string(5000, 'd')));
  fs::create_directories(dir.path() / kFolder / ".tmp");
  std::ofstream(dir.path() / kFolder / ".tmp" / ".0_1.png.1-2.3.tmp") << std::string(5000, 't');
  std::ofstream(dir.path() / "index.sqlite") << std::string(5000, 'i');
  std::ofstream(dir.path() / kFolder / "5" / "notes.txt") << std::string(5000, 'n');

  auto t = tiered(600);
  t->settle();
  auto s = t->localTier();
  EXPECT_TRUE(s.scanned);
  EXPECT_EQ(s.files, 5U);
  EXPECT_EQ(s.bytes, 510U); // 100 + 101 + 102 + 103 + 104
  EXPECT_EQ(s.evictions, 0U);

  put(*t, tile(5), body(5)); // 610: over; down to 540 at most, the oldest modified first
  t->settle();
  EXPECT_FALSE(localHas(3));
  EXPECT_TRUE(localHas(1));
  EXPECT_EQ(t->localTier().bytes, 507U);
  put(*t, tile(6), body(6)); // 607: the next oldest
  t->settle();
  EXPECT_FALSE(localHas(1));
  EXPECT_TRUE(localHas(0));
  EXPECT_EQ(local->readDescriptor(kFolder), std::string(5000, 'd'));
  EXPECT_TRUE(fs::exists(dir.path() / kFolder / ".tmp" / ".0_1.png.1-2.3.tmp"));
  EXPECT_TRUE(fs::exists(dir.path() / "index.sqlite"));
  EXPECT_TRUE(fs::exists(dir.path() / kFolder / "5" / "notes.txt"));
}

// A clean stop saves the record's order of use (`<root>/.local-tier-order`); the next start's scan
// takes it over the files' mtimes (a read does not change a file's mtime), reads it once and
// removes it. A file that is not one is ignored: the mtimes decide, as after a crash.
TEST_F(LocalTier, TheOrderOfUseOutlivesACleanRestart) {
  const fs::path order = dir.path() / ".local-tier-order";
  {
    auto t = tiered(600);
    for (int i = 0; i < 5; ++i)
      put(*t, tile(i), body(i)); // modified 0 (oldest) to 4
    t->settle();
    for (const int i : {4, 3, 2, 1, 0}) // read: 0 is now the most recently used, 4 the least
      ASSERT_TRUE(t->open(tile(i), 100));
    ASSERT_FALSE(fs::exists(order));
  }
  ASSERT_TRUE(fs::exists(order));
  // mtimes that say the opposite: 0 the oldest.
  for (int i = 0; i < 5; ++i) {
    const fs::path p = dir.path() / kFolder / tileRelativePath(tile(i).key, "png");
    const timespec times[2] = {{2'000'000 + i, 0}, {2'000'000 + i, 0}};
    ASSERT_EQ(::utimensat(AT_FDCWD, p.c_str(), times, 0), 0) << p;
  }
  {
    auto t = tiered(600);
    t->settle();
    EXPECT_FALSE(fs::exists(order)); // read once
    EXPECT_EQ(t->localTier().files, 5U);
    put(*t, tile(5), body(5)); // 600 -> over at the next: 700 with tile 6
    put(*t, tile(6), body(6));
    t->settle();
    EXPECT_FALSE(localHas(4)); // the least recently used by the record, the newest by mtime
    EXPECT_FALSE(localHas(3));
    EXPECT_TRUE(localHas(0)); // the oldest by mtime, the most recently used
    EXPECT_TRUE(localHas(1));
    EXPECT_TRUE(localHas(2));
  }
  // Not an order file: ignored, removed when read, and the mtimes decide.
  std::ofstream(order) << "not an order\n" << kFolder << "\t5/7/7_0.png\n";
  {
    auto t = tiered(600);
    t->settle();
    EXPECT_EQ(t->localTier().files, 5U);
    EXPECT_FALSE(fs::exists(order));
    put(*t, tile(7), body(7)); // 700: the two oldest by mtime go (by the record: 2 and 1)
    put(*t, tile(8), body(8));
    t->settle();
    EXPECT_FALSE(localHas(0));
    EXPECT_FALSE(localHas(1));
    EXPECT_TRUE(localHas(2));
    EXPECT_TRUE(localHas(5));
  }
}

TEST_F(LocalTier, RemovalsRollbacksAndRewritesKeepTheRecordTrue) {
  auto t = tiered(10000);
  put(*t, tile(0), body(0));
  put(*t, tile(1), body(1));
  EXPECT_EQ(t->localTier().bytes, 200U);
  put(*t, tile(1), body(1, 300)); // a refresh: the new size
  EXPECT_EQ(t->localTier().bytes, 400U);
  t->remove(tile(0));
  EXPECT_EQ(t->localTier().bytes, 300U);
  auto staged = t->stage(tile(2), body(2));
  ASSERT_TRUE(staged);
  ASSERT_TRUE((*staged)->install());
  (*staged)->finish(false); // rolled back: no file, no record
  EXPECT_EQ(t->localTier().bytes, 300U);
  auto removal = t->stageRemoval(tile(1));
  ASSERT_TRUE(removal->hide());
  removal->finish(true);
  EXPECT_EQ(t->localTier().bytes, 0U);
  EXPECT_EQ(t->localTier().files, 0U);
  EXPECT_EQ(tilesOnDisk(dir.path()).second, 0);
}

TEST_F(LocalTier, WithoutALimitNothingIsRecordedOrRemoved) {
  auto t = tiered(0);
  for (int i = 0; i < 20; ++i)
    put(*t, tile(i), body(i));
  t->settle();
  EXPECT_EQ(t->localTier().files, 0U);
  EXPECT_EQ(tilesOnDisk(dir.path()).second, 20);
}

TEST_F(LocalTier, ManyThreadsReadWhileItEvicts) {
  constexpr int kTiles = 64;
  auto t = tiered(2000); // 20 of the 64 tiles
  for (int i = 0; i < kTiles; ++i)
    put(*shared, tile(i), body(i)); // stored by another instance: every first read copies
  std::atomic<int> wrong{0};
  std::vector<std::thread> readers;
  for (int r = 0; r < 4; ++r) {
    readers.emplace_back([&, r] {
      for (int n = 0; n < 200; ++n) {
        const int i = (n * 7 + r * 13) % kTiles;
        const auto got = t->open(tile(i), 100);
        const auto bytes = got ? got->file->readAll() : std::nullopt;
        if (!bytes || *bytes != body(i)) ++wrong;
      }
    });
  }
  for (auto& th : readers)
    th.join();
  t->settle();
  EXPECT_EQ(wrong.load(), 0);
  EXPECT_LE(t->localTier().bytes, 2000U);
  EXPECT_LE(tilesOnDisk(dir.path()).first, t->localTier().bytes); // never more than recorded
  EXPECT_GT(t->localTier().evictions, 0U);
  EXPECT_EQ(shared->removals.load(), 0);
}
