// The hit path on every implementation of the index and store (CacheBackends.hpp): remembered rows
// and held-open tiles, what changes behind them, a full store; and bad keys and datasets.

#include "CacheBackends.hpp"

#include <tellus/cache/TilePath.hpp>

#include <chrono>
#include <filesystem>

using namespace tellus;
using namespace std::chrono_literals;
using tellus::test::payload;
namespace fs = std::filesystem;

namespace {

DatasetSpec imagery() {
  return test::imagerySpec();
}

std::vector<std::byte> filled(std::size_t n, unsigned char value) {
  return std::vector<std::byte>(n, static_cast<std::byte>(value));
}

class TileCacheHotPath : public test::CacheBackendTest {
protected:
  std::unique_ptr<TileCache> openWith(std::chrono::milliseconds otherWritersCheck,
                                      std::chrono::milliseconds fileRecheck) {
    auto o = options();
    o.otherWritersCheck = otherWritersCheck;
    o.fileRecheck = fileRecheck;
    return open(o);
  }

  /** Replaces a stored tile behind the index, as another program would. */
  void replaceBehindTheIndex(const TileLocation& where, const std::vector<std::byte>& bytes) {
    auto staged = store().stage(where, bytes);
    ASSERT_TRUE(staged);
    ASSERT_TRUE((*staged)->install());
    (*staged)->finish(true);
  }
};

class TileCacheContractExtremes : public test::CacheBackendTest {};

} // namespace

INSTANTIATE_TEST_SUITE_P(Backends,
                         TileCacheHotPath,
                         ::testing::Values(test::Backend::SqliteFiles, test::Backend::Memory),
                         test::backendName);
INSTANTIATE_TEST_SUITE_P(Backends,
                         TileCacheContractExtremes,
                         ::testing::Values(test::Backend::SqliteFiles, test::Backend::Memory),
                         test::backendName);

TEST_P(TileCacheHotPath, OwnReplacementIsSeenByTheNextGet) {
  auto cache = openWith(std::chrono::hours(1), std::chrono::hours(1));
  const auto id = *cache->registerDataset(imagery());
  const TileKey k{1, 0, 1};
  ASSERT_TRUE(cache->put(id, k, filled(300, 1), {}));
  ASSERT_EQ(cache->get(id, k)->bytes, filled(300, 1)); // now remembered, tile held open
  ASSERT_TRUE(cache->put(id, k, filled(300, 2), {}));  // same size, new bytes
  EXPECT_EQ(cache->get(id, k)->bytes, filled(300, 2));
  ASSERT_TRUE(cache->put(id, k, filled(120, 3), {})); // new size
  EXPECT_EQ(cache->openTile(id, k)->file->size(), 120);
  EXPECT_EQ(cache->get(id, k)->bytes, filled(120, 3));
  ASSERT_TRUE(cache->erase(id, k));
  EXPECT_EQ(cache->get(id, k)->kind, CacheLookup::Kind::Miss);
  ASSERT_TRUE(cache->putAbsent(id, k, clock->now() + 60000));
  EXPECT_EQ(cache->openTile(id, k)->kind, CacheLookup::Kind::Absent);
}

TEST_P(TileCacheHotPath, OpenTileKeepsItsBytesWhileTheTileIsReplaced) {
  auto cache = open();
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

TEST_P(TileCacheHotPath, TileReplacedOrRemovedBehindTheIndexIsNoticed) {
  auto cache = openWith(std::chrono::hours(1), std::chrono::milliseconds(0));
  const auto id = *cache->registerDataset(imagery());
  const TileKey k{1, 1, 0};
  ASSERT_TRUE(cache->put(id, k, filled(64, 1), {}));
  ASSERT_EQ(cache->get(id, k)->bytes, filled(64, 1));
  const auto info = *cache->dataset(id);
  replaceBehindTheIndex(at(info, k), filled(64, 5));
  EXPECT_EQ(cache->get(id, k)->bytes, filled(64, 5));
  store().remove(at(info, k));
  EXPECT_EQ(cache->get(id, k)->kind, CacheLookup::Kind::Miss);
}

TEST_P(TileCacheHotPath, AHeldTileIsCheckedAgainOnlyAfterFileRecheck) {
  auto cache = openWith(std::chrono::hours(1), std::chrono::seconds(1));
  const auto id = *cache->registerDataset(imagery());
  const TileKey k{1, 1, 2};
  ASSERT_TRUE(cache->put(id, k, filled(64, 1), {}));
  ASSERT_EQ(cache->get(id, k)->bytes, filled(64, 1));
  replaceBehindTheIndex(at(*cache->dataset(id), k), filled(64, 6));
  EXPECT_EQ(cache->get(id, k)->bytes, filled(64, 1)) << "looked again before fileRecheck";
  clock->advance(1s);
  EXPECT_EQ(cache->get(id, k)->bytes, filled(64, 6));
}

TEST_P(TileCacheHotPath, HeldOpenTilesStayWithinTheirLimit) {
  auto o = options();
  o.openFiles = 8;
  auto cache = open(o);
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

TEST_P(TileCacheHotPath, AFullStoreRefusesPutsUntilFullRecheckHasPassedThenStoresAgain) {
  auto o = options();
  o.fullRecheck = 30s;
  auto cache = open(o);
  const auto id = *cache->registerDataset(imagery());
  const TileKey kept{3, 1, 2};
  ASSERT_TRUE(cache->put(id, kept, payload(kept), {}));
  const auto before = *cache->totalBytes();
  const std::vector<std::byte> big(256 * 1024, std::byte{0x5A});
  fillStore(true, big.size());
  auto p = cache->put(id, kept, big, {});
  ASSERT_FALSE(p);
  EXPECT_EQ(p.error().code, CacheErrc::DiskFull) << p.error().message;
  EXPECT_NE(p.error().message.find("the cache at " + o.root.string() + " is full"),
            std::string::npos)
      << p.error().message;
  EXPECT_FALSE(cache->storeStatus().writable);
  EXPECT_EQ(cache->storeStatus().refused, 1u);
  fillStore(false, big.size());
  // Room again, but the refusal is recent: refused at once, nothing written.
  p = cache->put(id, TileKey{3, 1, 3}, big, {});
  ASSERT_FALSE(p);
  EXPECT_EQ(p.error().code, CacheErrc::DiskFull);
  EXPECT_NE(p.error().message.find("nothing was written"), std::string::npos);
  EXPECT_EQ(cache->storeStatus().refused, 2u);
  EXPECT_EQ(*cache->totalBytes(), before);
  EXPECT_EQ(cache->get(id, kept)->bytes, payload(kept)); // the old tile is intact
  clock->advance(30s);
  p = cache->put(id, TileKey{3, 1, 3}, big, {});
  ASSERT_TRUE(p) << p.error().message;
  EXPECT_TRUE(cache->storeStatus().writable);
  EXPECT_EQ(cache->get(id, TileKey{3, 1, 3})->bytes, big);
  EXPECT_TRUE(cache->verify()->ok());
}

TEST_P(TileCacheContractExtremes, RejectsKeysOutsideTheGrid) {
  auto cache = open();
  const auto id = *cache->registerDataset(imagery());
  const std::vector<std::byte> b(10, std::byte{1});
  for (const TileKey k : {TileKey{-1, 0, 0},
                          TileKey{12, 0, 0},
                          TileKey{31, 0, 0},
                          TileKey{0, -1, 0},
                          TileKey{0, 0, -1},
                          TileKey{0, 5, 0},
                          TileKey{0, 0, 10},
                          TileKey{11, 5 << 11, 0},
                          TileKey{0, INT64_MAX, INT64_MAX},
                          TileKey{INT32_MAX, 0, 0},
                          TileKey{INT32_MIN, INT64_MIN, INT64_MIN}}) {
    SCOPED_TRACE(tileRelativePath(k, "jpg"));
    auto p = cache->put(id, k, b, {});
    ASSERT_FALSE(p);
    EXPECT_EQ(p.error().code, CacheErrc::InvalidArgument);
    auto g = cache->get(id, k);
    ASSERT_FALSE(g);
    EXPECT_EQ(g.error().code, CacheErrc::InvalidArgument);
  }
  // The deepest tile of the grid is fine.
  EXPECT_TRUE(cache->put(id, TileKey{11, (5LL << 11) - 1, (10LL << 11) - 1}, b, {}));
  auto unknown = cache->put(id + 100, TileKey{0, 0, 0}, b, {});
  ASSERT_FALSE(unknown);
  EXPECT_EQ(unknown.error().code, CacheErrc::InvalidArgument);
  EXPECT_EQ(*cache->totalBytes(), 10);
}

TEST_P(TileCacheContractExtremes, RejectsBadDatasets) {
  auto cache = open();
  auto s = imagery();
  s.grid.levelZeroDeltaDeg = 37.0;
  EXPECT_FALSE(cache->registerDataset(s));
  s = imagery();
  s.extension = "../x";
  EXPECT_FALSE(cache->registerDataset(s));
  s = imagery();
  s.grid.numLevels = 40;
  EXPECT_FALSE(cache->registerDataset(s));
  EXPECT_TRUE(cache->datasets().empty());
}

TEST(TileCacheMemory, ACommitRefusedAfterTheInstallKeepsTheTileItWouldHaveReplaced) {
  // The rollback path of a put (what a full disk does to SQLite after the rename, see
  // CacheFullDiskIntegration), on the memory index, whose commits can be made to fail.
  auto index = std::make_shared<test::MemoryTileIndex>();
  auto store = std::make_shared<test::MemoryTileStore>();
  TileCache::Options o;
  o.root = "memory";
  o.fullRecheck = 0ms; // every put tries
  auto cache = std::move(*TileCache::open(o, index, store));
  const auto id = *cache->registerDataset(imagery());
  const TileKey k{4, 2, 3};
  ASSERT_TRUE(cache->put(id, k, filled(100, 1), {}));
  index->failCommits(CacheError{CacheErrc::DiskFull, "no room for the index"});
  auto p = cache->put(id, k, filled(3000, 2), {});
  ASSERT_FALSE(p);
  EXPECT_EQ(p.error().code, CacheErrc::DiskFull);
  const TileKey fresh{4, 2, 4};
  EXPECT_FALSE(cache->put(id, fresh, filled(3000, 3), {}));
  EXPECT_FALSE(cache->erase(id, k));
  index->failCommits(std::nullopt);
  EXPECT_EQ(cache->get(id, k)->bytes, filled(100, 1)) << "the tile being replaced was lost";
  EXPECT_EQ(cache->get(id, fresh)->kind, CacheLookup::Kind::Miss);
  const auto info = *cache->dataset(id);
  EXPECT_FALSE(store->stat(TileLocation{info.folder, info.spec.extension, fresh}));
  EXPECT_TRUE(cache->verify()->ok());
  EXPECT_FALSE(cache->storeStatus().writable);
  EXPECT_TRUE(cache->put(id, fresh, filled(3000, 3), {}));
  EXPECT_TRUE(cache->storeStatus().writable);
}

namespace {

/** A shared store that can be out of reach (an object store in an outage): while `down`, opening a
 * tile finds nothing and asking whether there is one is an error, as S3TileStore answers. */
class StoreOutOfReach final : public ITileStore {
public:
  explicit StoreOutOfReach(std::shared_ptr<ITileStore> inner) : inner_(std::move(inner)) {}
  bool down = false;

  Result prepareDataset(std::string_view f) override { return inner_->prepareDataset(f); }
  std::optional<std::string> readDescriptor(std::string_view f) override {
    return inner_->readDescriptor(f);
  }
  Result writeDescriptor(std::string_view f, std::string_view t) override {
    return inner_->writeDescriptor(f, t);
  }
  std::optional<StoredTile> open(const TileLocation& at, std::int64_t size) override {
    return down ? std::nullopt : inner_->open(at, size);
  }
  std::optional<TileStat> stat(const TileLocation& at) override {
    return down ? std::nullopt : inner_->stat(at);
  }
  std::expected<std::optional<TileStat>, CacheError> statOrError(const TileLocation& at) override {
    if (down) return std::unexpected(CacheError{CacheErrc::Io, "the store does not answer"});
    return inner_->stat(at);
  }
  std::expected<std::shared_ptr<StagedTile>, CacheError>
  stage(const TileLocation& at, std::span<const std::byte> bytes) override {
    return inner_->stage(at, bytes);
  }
  std::shared_ptr<StagedRemoval> stageRemoval(const TileLocation& at) override {
    return inner_->stageRemoval(at);
  }
  void remove(const TileLocation& at) override { inner_->remove(at); }
  Result lockChanges(std::chrono::milliseconds t) override { return inner_->lockChanges(t); }
  void unlockChanges() override { inner_->unlockChanges(); }
  std::optional<DiskSpace> freeSpace() const override { return inner_->freeSpace(); }
  std::size_t removeDeadTemps(std::string_view f) override { return inner_->removeDeadTemps(f); }
  std::vector<std::string> datasetFolders() override { return inner_->datasetFolders(); }
  void scan(std::string_view f, const EntryVisitor& v) override { inner_->scan(f, v); }
  void removeEntry(std::string_view f, std::string_view p) override { inner_->removeEntry(f, p); }

private:
  std::shared_ptr<ITileStore> inner_;
};

} // namespace

// Issue 27: a tile read while the shared store is out of reach is a miss, but its row stays in the
// (shared) index: an outage never empties the index, and once the store is back the tile is there.
TEST(TileCacheStoreOutage, ATileUnreadableDuringAnOutageKeepsItsRow) {
  auto clock = std::make_shared<ManualClock>();
  auto index = std::make_shared<test::MemoryTileIndex>();
  auto store = std::make_shared<StoreOutOfReach>(std::make_shared<test::MemoryTileStore>(clock));
  TileCache::Options o;
  o.root = "/nonexistent-memory-root";
  o.fsyncTiles = false;
  o.clock = clock;
  o.fileRecheck = std::chrono::milliseconds(0);
  auto cache = TileCache::open(o, index, store);
  ASSERT_TRUE(cache) << cache.error().message;
  const auto id = *(*cache)->registerDataset(imagery());
  const TileKey k{2, 1, 3};
  ASSERT_TRUE((*cache)->put(id, k, filled(400, 9), {}));
  store->down = true;
  EXPECT_EQ((*cache)->get(id, k)->kind, CacheLookup::Kind::Miss);
  (*cache)->flush(); // the self-healing the miss asked for has run
  EXPECT_EQ((*cache)->peek(id, k)->kind, CacheLookup::Kind::Hit);
  store->down = false;
  EXPECT_EQ((*cache)->get(id, k)->bytes, filled(400, 9));
}
