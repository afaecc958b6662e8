// The tile service's use of single-flight leases across processes (TileServiceOptions::leases,
// issue 27), against a scripted ITileLeases: a miss whose lease another process holds waits and
// serves the tile that process stored, fetching nothing; a miss that takes the lease fetches,
// stores, and gives the lease back after the row is committed. PostgreSQL's leases themselves are
// tested in tests/cache_pg/, three real instances in tests/cli/test_scale_out.sh.

#include "../support/CacheFixtures.hpp"
#include "../support/FakeUpstream.hpp"
#include "../support/MemoryTileIndex.hpp"
#include "../support/TempDir.hpp"

#include <tellus/cache/Clock.hpp>
#include <tellus/cache/TileLeases.hpp>
#include <tellus/cache/TileStore.hpp>
#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/ImageCodec.hpp>
#include <tellus/proxy/TileService.hpp>

#include <gtest/gtest.h>

#include <atomic>
#include <condition_variable>
#include <cstring>
#include <future>
#include <mutex>

using namespace tellus;
using namespace std::chrono_literals;

namespace {

/** Answers every acquireOrWait with `outcome`; keeps the waiters' retries for the test to call. */
class ScriptedLeases final : public ITileLeases {
public:
  explicit ScriptedLeases(LeaseOutcome outcome) : outcome_(outcome) {}

  LeaseOutcome acquireOrWait(const LeaseKey& key,
                             std::chrono::milliseconds,
                             std::function<void()> retry) override {
    if (onAsk) onAsk(key);
    std::lock_guard lock(mutex_);
    asked.push_back(key);
    if (outcome_ == LeaseOutcome::Waiting) retries_.push_back(std::move(retry));
    changed_.notify_all();
    return outcome_;
  }
  void release(const LeaseKey& key) override {
    if (onRelease) onRelease(key);
    std::lock_guard lock(mutex_);
    released.push_back(key);
  }
  void progress(const LeaseKey& key) override {
    if (onProgress) onProgress(key);
    std::lock_guard lock(mutex_);
    progressed.push_back(key);
  }
  bool healthy() const override { return true; }

  /** Waits until someone waits for a lease. */
  bool waiterArrived() {
    std::unique_lock lock(mutex_);
    return changed_.wait_for(lock, 30s, [this] { return !retries_.empty(); });
  }

  /** Lets later asks take the lease and wakes the first waiter (as the holder's release does). */
  bool wakeOneWaiter() {
    std::function<void()> retry;
    {
      std::unique_lock lock(mutex_);
      if (retries_.empty()) return false;
      retry = std::move(retries_.front());
      retries_.erase(retries_.begin());
      outcome_ = LeaseOutcome::Acquired;
    }
    retry();
    return true;
  }

  std::vector<LeaseKey> asked, released, progressed;
  std::function<void(const LeaseKey&)> onAsk, onRelease, onProgress;

private:
  std::mutex mutex_;
  std::condition_variable changed_;
  LeaseOutcome outcome_;
  std::vector<std::function<void()>> retries_;
};

struct Service {
  test::TempDir dir{"leases"};
  std::unique_ptr<TileCache> cache;
  Fetcher fetcher;
  std::unique_ptr<TileService> tiles;

  Service(const std::string& url,
          std::shared_ptr<ITileLeases> leases,
          int metaTiles = 1,
          bool metaTilesOnMiss = false,
          int workers = 2,
          const Clock* clock = nullptr,
          std::chrono::milliseconds ttl = 0ms,
          std::shared_ptr<ITileIndex> index = nullptr,
          const std::string& mime = "image/png")
      : cache(index ? openOn(dir.path(), std::move(index)) : test::openTestCache(dir.path())) {
    UpstreamSpec u;
    u.name = "up";
    u.type = UpstreamSpec::Type::Wms;
    u.url = url;
    u.policy.retries = 0;
    u.metaTiles = metaTiles;
    LayerSpec l;
    l.name = "sat";
    l.upstream = "up";
    l.dataset.grid = GridSpec{Sector{}, 36.0, 64, 64, 3};
    l.dataset.mimeType = mime;
    l.ttl = ttl;
    TileServiceOptions o;
    if (clock) o.clock = clock;
    o.leases = std::move(leases);
    o.metaTilesOnMiss = metaTilesOnMiss;
    o.renderThreads = workers;
    auto t = TileService::create(*cache, fetcher, {u}, {l}, o);
    EXPECT_TRUE(t) << (t ? "" : t.error());
    if (t) tiles = std::move(*t);
  }
  ~Service() { tiles.reset(); }

  /** A cache of `index` and a folder of files. */
  static std::unique_ptr<TileCache> openOn(const std::filesystem::path& root,
                                           std::shared_ptr<ITileIndex> index) {
    auto files = openFileTileStore(FileTileStoreOptions{root, false, false});
    EXPECT_TRUE(files);
    TileCache::Options o;
    o.root = root;
    o.fsyncTiles = false;
    auto c = TileCache::open(o, std::move(index), std::move(*files));
    EXPECT_TRUE(c) << (c ? "" : c.error().message);
    return c ? std::move(*c) : nullptr;
  }

  DatasetId datasetId() { return *cache->registerDataset(tiles->layer("sat")->dataset); }

  std::future<TileAnswer> get(const TileKey& k) {
    auto p = std::make_shared<std::promise<TileAnswer>>();
    tiles->getTile("sat", "", k, [p](TileAnswer&& a) { p->set_value(std::move(a)); });
    return p->get_future();
  }
};

/** A valid 64 px PNG: what the tile service's validation takes. */
test::FakeReply pngReply(const test::FakeRequest&) {
  const std::vector<std::uint8_t> px(64 * 64 * 3, 90);
  const auto bytes = *encodeImage("image/png", 64, 64, 3, px.data());
  return test::FakeReply::ok(std::string(reinterpret_cast<const char*>(bytes.data()), bytes.size()),
                             "image/png");
}

/** An image of the GetMap's WIDTH x HEIGHT (a metatile's, split by the service): a grey ramp, as
 * `mime` (a JPEG is 4:2:0, so that 64 px tiles are cut without decoding). */
test::FakeReply sizedReply(const test::FakeRequest& r, const std::string& mime) {
  auto param = [&](const std::string& name) {
    const auto at = r.target.find(name + "=");
    return at == std::string::npos ? 0 : std::atoi(r.target.c_str() + at + name.size() + 1);
  };
  const int w = param("WIDTH"), h = param("HEIGHT");
  if (w <= 0 || h <= 0 || w > 1024 || h > 1024) return test::FakeReply::withStatus(400, "size");
  std::vector<std::uint8_t> px(static_cast<std::size_t>(w * h * 3));
  for (std::size_t i = 0; i < px.size(); ++i)
    px[i] = static_cast<std::uint8_t>((i / 3 % static_cast<std::size_t>(w)) * 255 /
                                      static_cast<std::size_t>(w));
  const auto bytes = *encodeImage(mime, w, h, 3, px.data());
  return test::FakeReply::ok(std::string(reinterpret_cast<const char*>(bytes.data()), bytes.size()),
                             mime);
}

test::FakeReply sizedPngReply(const test::FakeRequest& r) {
  return sizedReply(r, "image/png");
}

test::FakeReply sizedJpegReply(const test::FakeRequest& r) {
  return sizedReply(r, "image/jpeg");
}

std::string text(const std::vector<std::byte>& b) {
  return std::string(reinterpret_cast<const char*>(b.data()), b.size());
}

std::vector<std::byte> bytesOf(const std::string& s) {
  std::vector<std::byte> b(s.size());
  std::memcpy(b.data(), s.data(), s.size());
  return b;
}

/** Stores `content` as every tile of the level-1 metatile at (0, 0), as its holder (another
 * process on the same index) does. */
void storeMetatileAsHolder(Service& s, const std::string& content, const std::string& mime) {
  const std::vector<std::byte> bytes = bytesOf(content);
  const DatasetId id = s.datasetId();
  TileMeta meta;
  meta.contentType = mime;
  for (std::int64_t r = 0; r < 4; ++r)
    for (std::int64_t c = 0; c < 4; ++c)
      ASSERT_TRUE(s.cache->put(id, TileKey{1, r, c}, bytes, meta));
}

} // namespace

TEST(TileLeases, AMissWaitingForAnotherProcessServesTheTileItStoredAndFetchesNothing) {
  test::FakeUpstream up(pngReply);
  auto leases = std::make_shared<ScriptedLeases>(LeaseOutcome::Waiting);
  Service s(up.url("/wms"), leases);
  const TileKey k{1, 2, 3};
  auto answer = s.get(k);
  ASSERT_TRUE(leases->waiterArrived());
  EXPECT_NE(answer.wait_for(0s), std::future_status::ready);
  // The holder, another process on the same index, stores the tile and releases its lease.
  const std::string theirs = "stored by the holder";
  TileMeta meta;
  meta.contentType = "image/png";
  ASSERT_TRUE(s.cache->put(s.datasetId(), k, bytesOf(theirs), meta));
  ASSERT_TRUE(leases->wakeOneWaiter());
  ASSERT_EQ(answer.wait_for(30s), std::future_status::ready);
  const TileAnswer a = answer.get();
  ASSERT_EQ(a.kind, TileAnswer::Kind::Tile) << a.message;
  ASSERT_TRUE(a.file);
  const auto served = a.file->readAll();
  ASSERT_TRUE(served);
  EXPECT_EQ(text(*served), theirs);
  EXPECT_EQ(up.requests(), 0u);
  ASSERT_EQ(leases->asked.size(), 1u);
  EXPECT_EQ(leases->asked[0].key, k);
  EXPECT_EQ(leases->asked[0].folder, datasetFolder(s.tiles->layer("sat")->dataset));
  EXPECT_TRUE(leases->released.empty()) << "a waiter holds no lease";
}

// A burst for one missing tile: the requests after the first join its flight without asking the
// index (on a shared index each lookup is a round trip, and the fetch's own waited behind them).
TEST(TileLeases, RequestsForATileInFlightJoinItWithoutLookingItUp) {
  test::FakeUpstream up(sizedPngReply);
  auto leases = std::make_shared<ScriptedLeases>(LeaseOutcome::Waiting);
  auto index = std::make_shared<test::MemoryTileIndex>();
  Service s(up.url("/wms"), leases, 4, true, 2, nullptr, 0ms, index);
  ASSERT_TRUE(s.cache && s.tiles);
  const TileKey k{1, 2, 3};
  std::vector<std::future<TileAnswer>> answers;
  answers.push_back(s.get(k));
  ASSERT_TRUE(leases->waiterArrived());
  const std::int64_t lookedUp = index->lookups();
  EXPECT_GT(lookedUp, 0);
  for (int i = 0; i < 20; ++i)
    answers.push_back(s.get(k));
  // Another tile of the metatile: its flight was opened by the first miss, which fetches the block.
  answers.push_back(s.get(TileKey{1, 0, 1}));
  EXPECT_EQ(index->lookups(), lookedUp) << "a request for a tile in flight asked the index";
  EXPECT_EQ(leases->asked.size(), 1u);
  // The holder stores the metatile and releases: every request gets its tile, nothing is fetched.
  const std::string theirs = "stored by the holder";
  storeMetatileAsHolder(s, theirs, "image/png");
  ASSERT_TRUE(leases->wakeOneWaiter());
  for (auto& answer : answers) {
    ASSERT_EQ(answer.wait_for(30s), std::future_status::ready);
    const TileAnswer a = answer.get();
    ASSERT_EQ(a.kind, TileAnswer::Kind::Tile) << a.message;
    ASSERT_TRUE(a.file);
    EXPECT_EQ(text(*a.file->readAll()), theirs);
  }
  EXPECT_EQ(up.requests(), 0u);
  // Once landed, a request looks the tile up again (a hit).
  auto later = s.get(k);
  ASSERT_EQ(later.wait_for(30s), std::future_status::ready);
  EXPECT_EQ(later.get().kind, TileAnswer::Kind::Tile);
  EXPECT_GT(index->lookups(), lookedUp);
}

TEST(TileLeases, AMissThatTakesTheLeaseFetchesStoresThenReleasesIt) {
  test::FakeUpstream up(pngReply);
  auto leases = std::make_shared<ScriptedLeases>(LeaseOutcome::Acquired);
  Service s(up.url("/wms"), leases);
  const TileKey k{1, 2, 3};
  bool storedAtRelease = false;
  leases->onRelease = [&](const LeaseKey&) {
    auto row = s.cache->peek(s.datasetId(), k);
    storedAtRelease = row && row->kind == CacheLookup::Kind::Hit;
  };
  auto answer = s.get(k);
  ASSERT_EQ(answer.wait_for(30s), std::future_status::ready);
  EXPECT_EQ(answer.get().kind, TileAnswer::Kind::Tile);
  EXPECT_EQ(up.requests(), 1u);
  ASSERT_EQ(leases->released.size(), 1u);
  EXPECT_EQ(leases->released[0].key, k);
  EXPECT_TRUE(storedAtRelease) << "the lease went back before the tile's row was committed";
  // A second request is a hit: no lease asked.
  auto again = s.get(k);
  ASSERT_EQ(again.wait_for(30s), std::future_status::ready);
  EXPECT_EQ(leases->asked.size(), 1u);
}

TEST(TileLeases, AMissFetchesItsWholeMetatileUnderTheMetatilesLeaseReleasedOnceEveryTileIsStored) {
  // serve on a shared index (metaTilesOnMiss): instances missing different tiles of one metatile
  // ask for one lease, the metatile's, so that one of them fetches it all.
  test::FakeUpstream up(sizedPngReply);
  auto leases = std::make_shared<ScriptedLeases>(LeaseOutcome::Acquired);
  Service s(up.url("/wms"), leases, 4, true, 1); // one worker: the tiles stored in their order
  const TileKey k{1, 2, 3}; // level 1: 10 x 5 tiles; its metatile is rows 0-3, columns 0-3
  std::size_t storedAtRelease = 0;
  std::promise<void> releasedOnce;
  leases->onRelease = [&](const LeaseKey&) {
    for (std::int64_t r = 0; r < 4; ++r)
      for (std::int64_t c = 0; c < 4; ++c) {
        auto row = s.cache->peek(s.datasetId(), TileKey{1, r, c});
        storedAtRelease += row && row->kind == CacheLookup::Kind::Hit;
      }
    releasedOnce.set_value();
  };
  // The first tile stored while the lease is held (the asked-for one) is announced (progress): the
  // other instances' waiters look again then, and serve it before the whole block is stored.
  std::promise<bool> firstProgress;
  bool announced = false;
  leases->onProgress = [&](const LeaseKey& key) {
    if (announced) return;
    announced = true;
    EXPECT_EQ(key.key, (TileKey{1, 0, 0}));
    auto row = s.cache->peek(s.datasetId(), k);
    firstProgress.set_value(row && row->kind == CacheLookup::Kind::Hit);
  };
  auto answer = s.get(k);
  ASSERT_EQ(answer.wait_for(30s), std::future_status::ready);
  EXPECT_EQ(answer.get().kind, TileAnswer::Kind::Tile);
  // The tile's own answer may come before its neighbours are stored; the lease goes back after.
  ASSERT_EQ(releasedOnce.get_future().wait_for(30s), std::future_status::ready);
  auto first = firstProgress.get_future();
  ASSERT_EQ(first.wait_for(0s), std::future_status::ready) << "no tile announced before release";
  EXPECT_TRUE(first.get()) << "the asked-for tile is stored (and announced) first";
  EXPECT_EQ(leases->progressed.size(), 1u) << "the first tile stored only";
  EXPECT_EQ(up.requests(), 1u);
  EXPECT_EQ(s.tiles->metaTileFetches(), 1u);
  ASSERT_EQ(leases->asked.size(), 1u);
  EXPECT_EQ(leases->asked[0].key, (TileKey{1, 0, 0})) << "the metatile's lease, not the tile's";
  EXPECT_EQ(storedAtRelease, 16u) << "the lease went back before every tile was stored";
  // Another tile of the metatile is a hit: no lease, no request.
  auto other = s.get(TileKey{1, 0, 1});
  ASSERT_EQ(other.wait_for(30s), std::future_status::ready);
  EXPECT_EQ(other.get().origin, TileOrigin::Hit);
  EXPECT_EQ(up.requests(), 1u);
  EXPECT_EQ(leases->asked.size(), 1u);
}

// A metatile cut without decoding (JPEG): its other tiles are stored together, and their lease
// goes back before their clients in this process are answered, so that the clients waiting in
// other processes (most of a burst's) are woken first.
TEST(TileLeases, AMetatilesLeaseGoesBackBeforeTheClientsHereOfItsOtherTilesAreAnswered) {
  std::promise<void> go;
  std::shared_future<void> released = go.get_future().share();
  test::FakeUpstream up([released](const test::FakeRequest& r) {
    released.wait(); // the fetch is under way until the test lets it answer
    return sizedJpegReply(r);
  });
  auto leases = std::make_shared<ScriptedLeases>(LeaseOutcome::Acquired);
  // One worker: the asked-for tile is stored and answered, then the others.
  Service s(up.url("/wms"), leases, 4, true, 1, nullptr, 0ms, nullptr, "image/jpeg");
  ASSERT_TRUE(s.cache && s.tiles);
  auto asked = s.get(TileKey{1, 2, 3});
  ASSERT_TRUE(up.waitForRequests(1));
  auto other = s.get(TileKey{1, 0, 0}); // joins the flight the miss opened for it
  bool otherAnsweredAtRelease = true;
  std::size_t storedAtRelease = 0;
  leases->onRelease = [&](const LeaseKey&) {
    otherAnsweredAtRelease = other.wait_for(0s) == std::future_status::ready;
    for (std::int64_t r = 0; r < 4; ++r)
      for (std::int64_t c = 0; c < 4; ++c)
        if (auto row = s.cache->peek(s.datasetId(), TileKey{1, r, c});
            row && row->kind == CacheLookup::Kind::Hit)
          ++storedAtRelease;
  };
  go.set_value();
  for (auto* f : {&asked, &other}) {
    ASSERT_EQ(f->wait_for(30s), std::future_status::ready);
    const TileAnswer a = f->get();
    EXPECT_EQ(a.kind, TileAnswer::Kind::Tile) << a.message;
    EXPECT_EQ(a.contentType, "image/jpeg");
  }
  EXPECT_EQ(up.requests(), 1u);
  EXPECT_EQ(s.tiles->metaTileFetches(), 1u);
  ASSERT_EQ(leases->released.size(), 1u);
  EXPECT_EQ(leases->released[0].key, (TileKey{1, 0, 0}));
  EXPECT_EQ(storedAtRelease, 16u) << "the lease went back before the metatile was stored";
  EXPECT_FALSE(otherAnsweredAtRelease) << "a client here was answered before the release";
  ASSERT_EQ(leases->progressed.size(), 1u) << "the asked-for tile is announced once stored";
}

// Before the lease of a missing tile's metatile, each of its tiles is looked up once (the tile as
// the request arrives, the others together); under the lease all are looked up again, and those
// another process stored meanwhile are served from the cache, their lease given back before their
// clients are answered.
TEST(TileLeases, AMetatileStoredByAnotherProcessBeforeTheLeaseIsServedAndItsLeaseGivenBackFirst) {
  test::FakeUpstream up(sizedJpegReply);
  auto leases = std::make_shared<ScriptedLeases>(LeaseOutcome::Acquired);
  auto index = std::make_shared<test::MemoryTileIndex>();
  Service s(up.url("/wms"), leases, 4, true, 2, nullptr, 0ms, index, "image/jpeg");
  ASSERT_TRUE(s.cache && s.tiles);
  const std::string theirs = "stored by another process";
  std::int64_t lookedUpBeforeTheLease = -1;
  leases->onAsk = [&](const LeaseKey&) {
    lookedUpBeforeTheLease = index->lookups();
    storeMetatileAsHolder(s, theirs, "image/jpeg");
  };
  std::atomic<bool> answered{false};
  bool answeredAtRelease = true;
  leases->onRelease = [&](const LeaseKey&) { answeredAtRelease = answered.load(); };
  auto p = std::make_shared<std::promise<TileAnswer>>();
  std::future<TileAnswer> answer = p->get_future();
  s.tiles->getTile("sat", "", TileKey{1, 2, 3}, [p, &answered](TileAnswer&& a) {
    answered = true;
    p->set_value(std::move(a));
  });
  ASSERT_EQ(answer.wait_for(30s), std::future_status::ready);
  const TileAnswer a = answer.get();
  ASSERT_EQ(a.kind, TileAnswer::Kind::Tile) << a.message;
  ASSERT_TRUE(a.file);
  EXPECT_EQ(text(*a.file->readAll()), theirs);
  EXPECT_EQ(up.requests(), 0u);
  EXPECT_EQ(lookedUpBeforeTheLease, 16) << "the asked-for tile once, the 15 others once";
  ASSERT_EQ(leases->released.size(), 1u);
  EXPECT_FALSE(answeredAtRelease) << "the client was answered before the lease went back";
}

TEST(TileLeases, ARefreshOnASharedIndexTakesItsMetatilesLease) {
  // A tile refreshed alone (a conditional GetMap) must not overlap another instance's fetch of its
  // metatile: it takes the metatile's lease, not its own tile's.
  test::FakeUpstream up(sizedPngReply);
  auto leases = std::make_shared<ScriptedLeases>(LeaseOutcome::Acquired);
  // The service's clock is a day behind the cache's: every tile it stores (TTL 100 ms) has
  // expired when the cache is asked for it again.
  ManualClock aDayAgo(std::chrono::steady_clock::now(), std::chrono::system_clock::now() - 24h);
  Service s(up.url("/wms"), leases, 4, true, 2, &aDayAgo, 100ms);
  const TileKey k{1, 2, 3};
  std::promise<void> released;
  leases->onRelease = [&](const LeaseKey&) { released.set_value(); };
  auto miss = s.get(k);
  ASSERT_EQ(miss.wait_for(30s), std::future_status::ready);
  ASSERT_EQ(miss.get().kind, TileAnswer::Kind::Tile);
  ASSERT_EQ(released.get_future().wait_for(30s), std::future_status::ready);
  leases->onRelease = nullptr;
  auto refreshed = s.get(k);
  ASSERT_EQ(refreshed.wait_for(30s), std::future_status::ready);
  EXPECT_EQ(refreshed.get().kind, TileAnswer::Kind::Tile);
  EXPECT_EQ(up.requests(), 2u) << "the metatile, then the one tile refreshed";
  ASSERT_EQ(leases->asked.size(), 2u);
  EXPECT_EQ(leases->asked[0].key, (TileKey{1, 0, 0}));
  EXPECT_EQ(leases->asked[1].key, (TileKey{1, 0, 0})) << "the refresh took its tile's own lease";
}

TEST(TileLeases, AMissWaitingForTheMetatilesHolderServesWhatItStoredAndFetchesNothing) {
  test::FakeUpstream up(sizedPngReply);
  auto leases = std::make_shared<ScriptedLeases>(LeaseOutcome::Waiting);
  Service s(up.url("/wms"), leases, 4, true);
  const TileKey k{1, 2, 3};
  auto answer = s.get(k);
  ASSERT_TRUE(leases->waiterArrived());
  ASSERT_EQ(leases->asked.size(), 1u);
  EXPECT_EQ(leases->asked[0].key, (TileKey{1, 0, 0}));
  // The holder (another instance, asked for another tile of the metatile) stores them all.
  const std::string theirs = "stored by the holder";
  storeMetatileAsHolder(s, theirs, "image/png");
  ASSERT_TRUE(leases->wakeOneWaiter());
  ASSERT_EQ(answer.wait_for(30s), std::future_status::ready);
  const TileAnswer a = answer.get();
  ASSERT_EQ(a.kind, TileAnswer::Kind::Tile) << a.message;
  ASSERT_TRUE(a.file);
  EXPECT_EQ(text(*a.file->readAll()), theirs);
  EXPECT_EQ(up.requests(), 0u);
  EXPECT_TRUE(leases->released.empty());
}

TEST(TileLeases, WithoutMetaTilesOnMissAMissFetchesItsTileAloneUnderTheTilesLease) {
  test::FakeUpstream up(sizedPngReply);
  auto leases = std::make_shared<ScriptedLeases>(LeaseOutcome::Acquired);
  Service s(up.url("/wms"), leases, 4, false);
  auto answer = s.get(TileKey{1, 2, 3});
  ASSERT_EQ(answer.wait_for(30s), std::future_status::ready);
  EXPECT_EQ(answer.get().kind, TileAnswer::Kind::Tile);
  EXPECT_EQ(s.tiles->metaTileFetches(), 0u);
  ASSERT_EQ(leases->asked.size(), 1u);
  EXPECT_EQ(leases->asked[0].key, (TileKey{1, 2, 3}));
}

TEST(TileLeases, SeedingsMetatilesTakeTheMetatilesLease) {
  // getTiles (what `tellus seed` asks for): one lease for the block, released after its tiles.
  test::FakeUpstream up(sizedPngReply);
  auto leases = std::make_shared<ScriptedLeases>(LeaseOutcome::Acquired);
  Service s(up.url("/wms"), leases, 4, false);
  const std::vector<TileKey> keys{{1, 0, 4}, {1, 0, 5}, {1, 1, 4}, {1, 1, 5}};
  std::mutex m;
  std::condition_variable cv;
  std::size_t answered = 0, releases = 0;
  leases->onRelease = [&](const LeaseKey&) {
    std::lock_guard lock(m);
    ++releases;
    cv.notify_all();
  };
  s.tiles->getTiles("sat", "", keys, [&](const TileKey&, TileAnswer&& a) {
    EXPECT_EQ(a.kind, TileAnswer::Kind::Tile) << a.message;
    std::lock_guard lock(m);
    ++answered;
    cv.notify_all();
  });
  {
    std::unique_lock lock(m);
    ASSERT_TRUE(cv.wait_for(lock, 30s, [&] { return answered == keys.size() && releases > 0; }));
    EXPECT_EQ(releases, 1u);
  }
  EXPECT_EQ(up.requests(), 1u);
  ASSERT_EQ(leases->asked.size(), 1u);
  EXPECT_EQ(leases->asked[0].key, (TileKey{1, 0, 4}));
}

// The shared index out of reach after a fetched tile could not be stored (its commit failed as the
// database went): the copy kept in memory is served, not a 503, and the upstream is not asked
// again; a tile neither stored nor kept is still unavailable.
TEST(TileLeases, ATileKeptUnstoredIsServedWhileTheSharedIndexIsOutOfReach) {
  test::FakeUpstream up(pngReply);
  auto leases = std::make_shared<ScriptedLeases>(LeaseOutcome::Acquired);
  auto index = std::make_shared<test::MemoryTileIndex>();
  Service s(up.url("/wms"), leases, 1, false, 2, nullptr, 0ms, index);
  ASSERT_TRUE(s.cache && s.tiles);
  const TileKey k{1, 2, 3};
  const CacheError gone{CacheErrc::Io, "the database went away"};
  index->failCommits(gone);
  auto first = s.get(k);
  ASSERT_EQ(first.wait_for(30s), std::future_status::ready);
  const TileAnswer fetched = first.get();
  ASSERT_EQ(fetched.kind, TileAnswer::Kind::Tile) << fetched.message;
  ASSERT_TRUE(fetched.notStored);
  EXPECT_EQ(up.requests(), 1u);

  index->failLookups(gone);
  auto again = s.get(k);
  ASSERT_EQ(again.wait_for(30s), std::future_status::ready);
  const TileAnswer kept = again.get();
  ASSERT_EQ(kept.kind, TileAnswer::Kind::Tile) << kept.message;
  EXPECT_EQ(kept.bytes, fetched.bytes);
  EXPECT_EQ(up.requests(), 1u);

  auto other = s.get(TileKey{1, 2, 4});
  ASSERT_EQ(other.wait_for(30s), std::future_status::ready);
  const TileAnswer none = other.get();
  EXPECT_EQ(none.kind, TileAnswer::Kind::Error);
  EXPECT_EQ(none.failure, TileAnswer::Failure::Unavailable) << none.message;
  EXPECT_EQ(up.requests(), 1u);
}
