// tellus serve and tellus seed on a real full disk: a small tmpfs in a mount namespace
// (tests/support/Tmpfs.hpp), a fake WMS upstream that counts what it is asked, the real HTTP
// server.

#include "../support/FakeUpstream.hpp"
#include "../support/HttpClient.hpp"
#include "../support/TempDir.hpp"
#include "../support/Tmpfs.hpp"

#include <tellus/cache/Clock.hpp>
#include <tellus/cache/TileCache.hpp>
#include <tellus/cache/TilePath.hpp>
#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/HttpServer.hpp>
#include <tellus/proxy/ImageCodec.hpp>
#include <tellus/proxy/Log.hpp>
#include <tellus/proxy/ProxyFrontEnd.hpp>
#include <tellus/proxy/Seeder.hpp>
#include <tellus/proxy/TileService.hpp>

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

using namespace tellus;
using namespace std::chrono_literals;
namespace fs = std::filesystem;

namespace {

/** A 256-pixel JPEG of noise seeded by the request (about 60 KB: a 1 MiB disk holds a dozen). */
test::FakeReply noisyTile(const test::FakeRequest& req) {
  std::uint64_t x = stableHash64(req.target) | 1;
  std::vector<std::uint8_t> px(256 * 256 * 3);
  for (auto& p : px) {
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    p = static_cast<std::uint8_t>(x);
  }
  const auto bytes = *encodeImage("image/jpeg", 256, 256, 3, px.data());
  return test::FakeReply::ok(std::string(reinterpret_cast<const char*>(bytes.data()), bytes.size()),
                             "image/jpeg");
}

/** tellus serve's pieces over a cache at `root`: WMS layers (36-degree grid, 256-px JPEG, 4
 * levels; "sat" by default), the HTTP server on a loopback port. */
struct Stack {
  std::unique_ptr<TileCache> cache;
  std::unique_ptr<Fetcher> fetcher;
  std::unique_ptr<TileService> tiles;
  std::unique_ptr<ProxyFrontEnd> front;
  std::unique_ptr<HttpServer> server;

  Stack(const fs::path& root,
        const std::string& upstreamUrl,
        bool writeBehind = false,
        std::shared_ptr<ManualClock> clock = nullptr,
        const std::vector<std::string>& layerNames = {"sat"},
        std::chrono::seconds ttl = 0s) {
    TileCache::Options o;
    o.root = root;
    o.fsyncTiles = false;
    o.indexWriteBehind = writeBehind;
    o.fullRecheck = 10s;
    o.clock = std::move(clock); // the cache's (TileCache::Options::clock); null: the system's
    auto c = TileCache::open(o);
    EXPECT_TRUE(c) << (c ? "" : c.error().message);
    if (!c) return;
    cache = std::move(*c);
    fetcher = std::make_unique<Fetcher>();
    UpstreamSpec u;
    u.name = "up";
    u.type = UpstreamSpec::Type::Wms;
    u.url = upstreamUrl;
    u.policy.retries = 0;
    std::vector<LayerSpec> layers;
    for (const auto& name : layerNames) {
      LayerSpec l;
      l.name = name;
      l.upstream = "up";
      l.dataset.grid = GridSpec{Sector{}, 36.0, 256, 256, 4};
      l.dataset.mimeType = "image/jpeg";
      l.ttl = ttl;
      layers.push_back(std::move(l));
    }
    TileServiceOptions to;
    to.clock = o.clock.get(); // the kept tiles' retry interval on the same clock
    auto t = TileService::create(*cache, *fetcher, {u}, std::move(layers), to);
    EXPECT_TRUE(t) << (t ? "" : t.error());
    if (!t) return;
    tiles = std::move(*t);
    front = std::make_unique<ProxyFrontEnd>(*tiles, FrontEndOptions{});
    HttpServerOptions so;
    so.threads = 2;
    server = std::make_unique<HttpServer>(so, [this](HttpRequest&& r, Responder respond) {
      front->handle(std::move(r), std::move(respond));
    });
    EXPECT_TRUE(server->start());
  }
  ~Stack() {
    if (server) server->stop();
    front.reset();
    tiles.reset();
    fetcher.reset();
  }
  bool up() const { return server != nullptr; }
  test::HttpResult get(const std::string& target) const {
    return test::httpGet("http://127.0.0.1:" + std::to_string(server->port()) + target);
  }
  bool stored(const TileKey& k, const std::string& layer = "sat") const {
    for (const auto& d : cache->datasets()) {
      if (d.spec.name != layer) continue;
      const auto row = cache->peek(d.id, k);
      return row && row->kind == CacheLookup::Kind::Hit;
    }
    return false; // the layer's dataset is not even registered
  }
};

std::string wwtile(const TileKey& k, const std::string& layer = "sat") {
  return "/wwtile?T=" + layer + "&L=" + std::to_string(k.level) + "&X=" + std::to_string(k.col) +
         "&Y=" + std::to_string(k.row);
}

std::size_t countLines(const std::string& text, const std::string& needle) {
  std::size_t n = 0;
  for (auto pos = text.find(needle); pos != std::string::npos; pos = text.find(needle, pos + 1))
    ++n;
  return n;
}

std::string readAll(std::FILE* f) {
  std::fflush(f);
  std::rewind(f);
  std::string out;
  char buf[4096];
  for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, f)) > 0;)
    out.append(buf, n);
  return out;
}

} // namespace

TEST(ProxyFullDiskIntegration, SeedingOntoAFullDiskCountsWhatWasStoredAndStopsAskingTheUpstream) {
  TELLUS_ON_TMPFS(1 << 20, 4096, [&](const fs::path& mnt) {
    test::FakeUpstream upstream(noisyTile);
    const fs::path root = mnt / "cache";
    Stack s(root, upstream.url("/wms"), /*writeBehind=*/true); // as `tellus seed` opens it
    ASSERT_TRUE(s.up());
    ServiceSeedOptions o;
    o.range.fromLevel = 0;
    o.range.toLevel = 2; // 50 + 200 + 800 tiles, a dozen fit
    o.concurrency = 4;
    o.retries = 0;
    const auto r = seedThroughService(*s.tiles, *s.cache, "sat", o);
    ASSERT_TRUE(r) << r.error();
    EXPECT_EQ(r->planned, 1050);
    // What it says it stored is what the cache holds, and all of it is sound.
    const auto st = s.cache->stats();
    ASSERT_TRUE(st);
    EXPECT_EQ(r->written, st->at(0).tiles) << "written must count the tiles really stored";
    EXPECT_GT(r->written, 0);
    EXPECT_GE(r->notStored, 1);
    EXPECT_NE(r->stoppedBecause.find("the cache at " + root.string() + " is full ("),
              std::string::npos)
        << r->stoppedBecause;
    // Every request is accounted for, and the upstream was asked little more than what was stored.
    EXPECT_EQ(upstream.requests(),
              static_cast<std::size_t>(r->written + r->notStored + r->failed + r->absent));
    EXPECT_LT(upstream.requests(), 100u) << "the seeder went on fetching onto a full disk";
    const auto report = s.cache->verify();
    ASSERT_TRUE(report);
    EXPECT_TRUE(report->ok());
  });
}

TEST(ProxyFullDiskIntegration, ServingFromAFullDiskAnswersEverythingAndStoresAgainWhenThereIsRoom) {
  TELLUS_ON_TMPFS(1 << 20, 4096, [&](const fs::path& mnt) {
    test::FakeUpstream upstream(noisyTile);
    const fs::path root = mnt / "cache";
    const std::vector<TileKey> cached{{0, 0, 0}, {0, 0, 1}, {0, 1, 0}};
    {
      Stack s(root, upstream.url("/wms"));
      ASSERT_TRUE(s.up());
      for (const auto& k : cached)
        ASSERT_EQ(s.get(wwtile(k)).status, 200);
    }
    const fs::path filler = test::fillDisk(mnt);
    std::FILE* log = std::tmpfile();
    ASSERT_NE(log, nullptr);
    logger().setEventStream(log);

    // The restart on a full disk, with a layer added to the configuration ("new": its dataset
    // cannot be registered, so it is served from the upstream and nothing of it is kept).
    auto clock = std::make_shared<ManualClock>(); // from the present on, moved by hand
    Stack s(root, upstream.url("/wms"), false, clock, {"sat", "new"});
    ASSERT_TRUE(s.up()) << "tellus serve must start on a full disk";
    for (const auto& k : cached) {
      const auto r = s.get(wwtile(k));
      EXPECT_EQ(r.status, 200) << wwtile(k);
      EXPECT_EQ(r.header("x-cache"), "HIT") << wwtile(k);
    }
    const std::size_t before = upstream.requests();
    const TileKey miss{1, 0, 0};
    std::string missBody;
    for (int i = 0; i < 3; ++i) {
      const auto r = s.get(wwtile(miss));
      EXPECT_EQ(r.status, 200) << "a miss on a full disk is still answered";
      EXPECT_EQ(r.header("x-cache"), i == 0 ? "MISS" : "HIT") << i;
      EXPECT_EQ(r.body.substr(0, 2), "\xFF\xD8");
      if (i == 0) missBody = r.body;
      EXPECT_EQ(r.body, missBody) << i;
    }
    EXPECT_FALSE(s.stored(miss));
    // Not stored, but kept in memory: the upstream is asked once, not once per request.
    EXPECT_EQ(upstream.requests(), before + 1);
    EXPECT_EQ(s.get(wwtile({1, 0, 1})).status, 200);
    const auto fresh = s.get(wwtile({0, 0, 0}, "new"));
    EXPECT_EQ(fresh.status, 200) << "a layer the full cache cannot register is still served";
    EXPECT_EQ(fresh.header("x-cache"), "MISS");
    EXPECT_FALSE(s.stored({0, 0, 0}, "new"));
    auto metrics = s.get("/metrics").body;
    EXPECT_NE(metrics.find("\ntellus_cache_writable 0\n"), std::string::npos) << metrics;
    EXPECT_NE(metrics.find("\ntellus_cache_store_refused_total 3\n"), std::string::npos) << metrics;
    EXPECT_NE(metrics.find("\ntellus_cache_kept_unstored_tiles 3\n"), std::string::npos) << metrics;
    EXPECT_NE(metrics.find("\ntellus_cache_kept_unstored_served_total 2\n"), std::string::npos)
        << metrics;
    EXPECT_NE(metrics.find("\ntellus_cache_free_bytes 0\n"), std::string::npos) << metrics;

    // Room again: after the recheck interval the next miss is stored, and a kept tile is stored
    // from memory on its next request, without the upstream.
    fs::remove(filler);
    clock->advance(11s);
    const std::size_t beforeRoom = upstream.requests();
    const auto kept = s.get(wwtile(miss));
    EXPECT_EQ(kept.status, 200);
    EXPECT_EQ(kept.body, missBody);
    for (int i = 0; i < 200 && !s.stored(miss); ++i)
      std::this_thread::sleep_for(10ms); // stored on a worker after the answer
    EXPECT_TRUE(s.stored(miss)) << "a kept tile was not stored once there was room";
    EXPECT_EQ(upstream.requests(), beforeRoom) << "a kept tile was fetched again";
    const auto fromCache = s.get(wwtile(miss));
    EXPECT_EQ(fromCache.header("x-cache"), "HIT");
    EXPECT_EQ(fromCache.body, missBody);
    const TileKey later{1, 1, 0};
    EXPECT_EQ(s.get(wwtile(later)).status, 200);
    EXPECT_TRUE(s.stored(later)) << "storing did not resume";
    EXPECT_EQ(s.get(wwtile({0, 0, 1}, "new")).status, 200);
    EXPECT_TRUE(s.stored({0, 0, 1}, "new"))
        << "the new layer was not registered once there was room";
    metrics = s.get("/metrics").body;
    EXPECT_NE(metrics.find("\ntellus_cache_writable 1\n"), std::string::npos) << metrics;
    EXPECT_NE(metrics.find("\ntellus_cache_stored_later_total 1\n"), std::string::npos) << metrics;

    // The log says each change once, not once per tile.
    logger().setEventStream(stderr);
    const std::string text = readAll(log);
    std::fclose(log);
    EXPECT_EQ(countLines(text, "the cache is full"), 1u) << text;
    EXPECT_EQ(countLines(text, "the cache stores tiles again"), 1u) << text;
    EXPECT_NE(text.find("root=" + root.string()), std::string::npos) << text;
    const auto report = s.cache->verify();
    ASSERT_TRUE(report);
    EXPECT_TRUE(report->ok());
  });
}

TEST(ProxyFullDiskIntegration, AnExpiredTileRefreshedOnAFullDiskIsFetchedOnceAndStoredLater) {
  TELLUS_ON_TMPFS(1 << 20, 4096, [&](const fs::path& mnt) {
    test::FakeUpstream upstream(noisyTile);
    auto clock = std::make_shared<ManualClock>();
    Stack s(mnt / "cache", upstream.url("/wms"), false, clock, {"sat"}, 60s);
    ASSERT_TRUE(s.up());
    const TileKey k{1, 0, 0};
    const auto first = s.get(wwtile(k));
    ASSERT_EQ(first.status, 200);
    ASSERT_TRUE(s.stored(k));
    const fs::path filler = test::fillDisk(mnt);
    clock->advance(61s); // the tile expires: each request would refresh it
    const std::size_t before = upstream.requests();
    for (int i = 0; i < 3; ++i) {
      const auto r = s.get(wwtile(k));
      EXPECT_EQ(r.status, 200) << i;
      EXPECT_EQ(r.body, first.body) << i; // the fake upstream answers the same bytes again
    }
    // The refresh could not be stored; its copy is kept, so it is fetched once, not per request.
    EXPECT_EQ(upstream.requests(), before + 1);

    // Room again: the kept refresh is stored from memory, not fetched again, and is fresh.
    fs::remove(filler);
    clock->advance(11s);
    EXPECT_EQ(s.get(wwtile(k)).status, 200);
    const auto fresh = [&] {
      for (const auto& d : s.cache->datasets()) {
        if (d.spec.name != "sat") continue;
        const auto r = s.cache->peek(d.id, k);
        return r && r->kind == CacheLookup::Kind::Hit && !r->stale;
      }
      return false;
    };
    for (int i = 0; i < 200 && !fresh(); ++i)
      std::this_thread::sleep_for(10ms); // stored on a worker after the answer
    EXPECT_TRUE(fresh()) << "the kept refresh was not stored once there was room";
    EXPECT_EQ(upstream.requests(), before + 1);
    const auto after = s.get(wwtile(k));
    EXPECT_EQ(after.header("x-cache"), "HIT");
    EXPECT_EQ(upstream.requests(), before + 1);
  });
}
