// What a shared HTTP cache (a CDN, Varnish) is told by tellus's answers (HttpCaching.hpp,
// docs/design/cdn.md): Cache-Control with s-maxage and stale-*, strong ETags with 304, surrogate
// keys in `xkey`, no-store on every error, a short lifetime on absent tiles and empty maps; and
// the PURGE that `tellus cache prune` sends (CdnPurge.hpp).

#include "../support/CacheFixtures.hpp"
#include "../support/FakeUpstream.hpp"
#include "../support/HttpClient.hpp"
#include "../support/TempDir.hpp"

#include <tellus/cache/TileCache.hpp>
#include <tellus/proxy/CdnPurge.hpp>
#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/HttpCaching.hpp>
#include <tellus/proxy/HttpServer.hpp>
#include <tellus/proxy/ImageCodec.hpp>
#include <tellus/proxy/ProxyFrontEnd.hpp>
#include <tellus/proxy/TileService.hpp>

#include <gtest/gtest.h>

#include <atomic>
#include <vector>

using namespace tellus;
using namespace std::chrono_literals;

namespace {

std::string jpeg() {
  std::vector<std::uint8_t> px(256 * 256 * 3, 90);
  const auto bytes = *encodeImage("image/jpeg", 256, 256, 3, px.data());
  return std::string(reinterpret_cast<const char*>(bytes.data()), bytes.size());
}

/** tellus serve's pieces over a fake upstream: layer "sat" (36-degree grid, JPEG, ttl 1 h,
 * max_age 600 s) and "times" (the same with a TIME dimension). */
struct Served {
  test::TempDir dir{"cdn"};
  std::unique_ptr<TileCache> cache;
  std::unique_ptr<Fetcher> fetcher;
  std::unique_ptr<TileService> tiles;
  std::unique_ptr<ProxyFrontEnd> front;
  std::unique_ptr<HttpServer> server;

  Served(const std::string& upstreamUrl, FrontEndOptions fo = {}) {
    cache = test::openTestCache(dir.path());
    fetcher = std::make_unique<Fetcher>();
    UpstreamSpec u;
    u.name = "up";
    u.type = UpstreamSpec::Type::Wms;
    u.url = upstreamUrl;
    u.policy.timeout = 2000ms;
    u.policy.retries = 0;
    LayerSpec l;
    l.name = "sat";
    l.upstream = "up";
    l.dataset.grid = GridSpec{Sector{}, 36.0, 256, 256, 4};
    l.dataset.mimeType = "image/jpeg";
    l.ttl = 3600s;
    l.maxAge = 600s;
    LayerSpec t = l;
    t.name = "times";
    t.timeValues = {"2024-01-01", "2024-01-02"};
    t.timeDefault = "2024-01-02";
    auto s = TileService::create(*cache, *fetcher, {u}, {l, t}, {});
    EXPECT_TRUE(s) << (s ? "" : s.error());
    tiles = std::move(*s);
    front = std::make_unique<ProxyFrontEnd>(*tiles, std::move(fo));
    HttpServerOptions so;
    so.threads = 2;
    so.requestsPerSecond = 0;
    server = std::make_unique<HttpServer>(so, [this](HttpRequest&& r, Responder respond) {
      front->handle(std::move(r), std::move(respond));
    });
    EXPECT_TRUE(server->start());
  }
  ~Served() {
    server->stop();
    front.reset();
    tiles.reset();
    fetcher.reset();
  }
  test::HttpResult get(const std::string& target,
                       const std::vector<std::pair<std::string, std::string>>& h = {}) const {
    return test::httpGet("http://127.0.0.1:" + std::to_string(server->port()) + target, h);
  }
};

const std::string kOneTileMap =
    "/wms?SERVICE=WMS&REQUEST=GetMap&VERSION=1.1.1&LAYERS=sat&STYLES=&SRS=EPSG:4326"
    "&BBOX=-180,-90,-144,-54&WIDTH=256&HEIGHT=256&FORMAT=image/jpeg";
const std::string kComposedMap =
    "/wms?SERVICE=WMS&REQUEST=GetMap&VERSION=1.1.1&LAYERS=sat&STYLES=&SRS=EPSG:4326"
    "&BBOX=-180,-90,-150,-60&WIDTH=100&HEIGHT=100&FORMAT=image/png";

/** The upstream: a tile for every request, or what `fail` says. */
struct Upstream {
  std::atomic<int> fail{0}; // 0: tiles; else this status
  test::FakeUpstream server{[this](const test::FakeRequest&) {
    const int f = fail.load();
    if (f != 0) return test::FakeReply::withStatus(f, "down");
    auto r = test::FakeReply::ok(jpeg(), "image/jpeg");
    r.headers.emplace_back("ETag", "\"up1\"");
    return r;
  }};
};

} // namespace

TEST(CdnHeaders, CacheControlHasSharedLifetimesFromTheTilesExpiry) {
  const CdnOptions d;
  // ttl 1 h: a shared cache keeps the tile until tellus would revalidate it.
  EXPECT_EQ(tileCacheControl(600s, 3600s, d),
            "public, max-age=600, s-maxage=3600, stale-while-revalidate=3600, "
            "stale-if-error=604800");
  // Tiles that never expire: as long as a browser, stale-while-revalidate at most a day.
  EXPECT_EQ(tileCacheControl(172800s, 0ms, d),
            "public, max-age=172800, s-maxage=172800, stale-while-revalidate=86400, "
            "stale-if-error=604800");
  CdnOptions c;
  c.sMaxAge = 30s;
  c.staleWhileRevalidate = 0s;
  c.staleIfError = 0s;
  EXPECT_EQ(tileCacheControl(600s, 3600s, c), "public, max-age=600, s-maxage=30");
  c.shortMaxAge = 5s;
  EXPECT_EQ(shortCacheControl(c), "public, max-age=5, s-maxage=5");
}

TEST(CdnHeaders, OnlyAbsentTilesAmongErrorsAreKept) {
  EXPECT_TRUE(keepable(200, "public, max-age=1"));
  EXPECT_TRUE(keepable(304, ""));
  EXPECT_TRUE(keepable(404, "public, max-age=60, s-maxage=60"));
  EXPECT_FALSE(keepable(404, ""));
  EXPECT_FALSE(keepable(400, "public, max-age=60"));
  EXPECT_FALSE(keepable(429, "public, max-age=60"));
  EXPECT_FALSE(keepable(503, ""));
  EXPECT_FALSE(keepable(502, "public, max-age=60"));
}

TEST(CdnHeaders, SurrogateKeysNameLayerTimeAndLevel) {
  EXPECT_EQ(layerKeys("sat", "", 3), "tellus layer:sat layer:sat/3");
  EXPECT_EQ(layerKeys("sat", "2024-01-01", -1), "tellus layer:sat layer:sat@2024-01-01");
  EXPECT_EQ(layerKey("sat", "a b,c"), "layer:sat@a_b_c"); // never split into two keys
  EXPECT_EQ(capabilitiesKeys(), "tellus capabilities");
}

TEST(CdnHeaders, TilesCarryKeysLifetimesAndStrongEtagsWith304) {
  Upstream up;
  Served s(up.server.url("/wms"));
  for (const std::string& target :
       {std::string("/wwtile?T=sat&L=1&X=2&Y=3"), std::string("/tiles/sat/1/3/3_2.jpg")}) {
    const auto r = s.get(target);
    ASSERT_EQ(r.status, 200) << target << r.body;
    EXPECT_EQ(r.header("cache-control"),
              "public, max-age=600, s-maxage=3600, stale-while-revalidate=3600, "
              "stale-if-error=604800");
    EXPECT_EQ(r.header("xkey"), "tellus layer:sat layer:sat/1");
    const std::string etag = r.header("etag");
    ASSERT_FALSE(etag.empty());
    EXPECT_EQ(etag.front(), '"') << "a strong validator, not W/: " << etag;
    const auto again = s.get(target, {{"If-None-Match", etag}});
    EXPECT_EQ(again.status, 304);
    EXPECT_TRUE(again.body.empty());
    EXPECT_EQ(again.header("etag"), etag);
    EXPECT_EQ(again.header("xkey"), "tellus layer:sat layer:sat/1");
    EXPECT_EQ(again.header("cache-control"), r.header("cache-control"));
  }
  // The WMS GetMap of exactly one tile is that tile, with the same keys.
  const auto map = s.get(kOneTileMap);
  ASSERT_EQ(map.status, 200);
  EXPECT_EQ(map.header("xkey"), "tellus layer:sat layer:sat/0");
  EXPECT_EQ(s.get(kOneTileMap, {{"If-None-Match", map.header("etag")}}).status, 304);
  // A layer with a TIME dimension: its time's key too (the default when none is asked).
  const auto timed = s.get("/tiles/times/0/0/0_0.jpg?time=2024-01-01");
  ASSERT_EQ(timed.status, 200);
  EXPECT_EQ(timed.header("xkey"), "tellus layer:times layer:times@2024-01-01 layer:times/0");
  EXPECT_EQ(s.get("/wwtile?T=times&L=0&X=0&Y=0").header("xkey"),
            "tellus layer:times layer:times@2024-01-02 layer:times/0");
}

TEST(CdnHeaders, ComposedMapsAndWmtsTilesHaveKeysAnd304) {
  Upstream up;
  Served s(up.server.url("/wms"));
  const auto map = s.get(kComposedMap);
  ASSERT_EQ(map.status, 200) << map.body;
  EXPECT_EQ(map.header("xkey"), "tellus layer:sat");
  EXPECT_NE(map.header("cache-control").find("s-maxage=3600"), std::string::npos)
      << map.header("cache-control");
  const auto again = s.get(kComposedMap, {{"If-None-Match", map.header("etag")}});
  EXPECT_EQ(again.status, 304);
  EXPECT_EQ(again.header("xkey"), "tellus layer:sat");
  // A composed WMTS tile: its layer's keys and its own set's at its level.
  const auto quad = s.get("/wmts/1.0.0/sat/default/WorldCRS84Quad/0/0/0.jpg");
  ASSERT_EQ(quad.status, 200) << quad.body;
  EXPECT_EQ(quad.header("xkey"),
            "tellus layer:sat layer:sat.WorldCRS84Quad layer:sat.WorldCRS84Quad/0");
  EXPECT_EQ(s.get("/wmts/1.0.0/sat/default/WorldCRS84Quad/0/0/0.jpg",
                  {{"If-None-Match", quad.header("etag")}})
                .status,
            304);
  // The capabilities documents: their own key, a short lifetime, 304.
  for (const std::string& caps : {std::string("/wms?SERVICE=WMS&REQUEST=GetCapabilities"),
                                  std::string("/wmts?SERVICE=WMTS&REQUEST=GetCapabilities")}) {
    const auto c = s.get(caps);
    ASSERT_EQ(c.status, 200);
    EXPECT_EQ(c.header("xkey"), "tellus capabilities");
    EXPECT_EQ(c.header("cache-control").rfind("public, max-age=60, s-maxage=60", 0), 0u)
        << c.header("cache-control");
    EXPECT_EQ(s.get(caps, {{"If-None-Match", c.header("etag")}}).status, 304) << caps;
  }
}

TEST(CdnHeaders, EveryErrorSaysNoStoreAndHasNoKeys) {
  Upstream up;
  FrontEndOptions fo;
  Served s(up.server.url("/wms"), fo);
  up.fail = 500;
  const std::vector<std::string> failing = {
      "/wwtile?T=sat&L=2&X=1&Y=1",
      "/tiles/sat/2/1/1_1.jpg",
      "/wmts/1.0.0/sat/default/WorldWind_sat/2/2/1.jpg", // WMTS exception report, 503
      "/wms?SERVICE=WMS&REQUEST=GetMap&VERSION=1.1.1&LAYERS=sat&STYLES=&SRS=EPSG:4326"
      "&BBOX=-180,-90,-162,-72&WIDTH=256&HEIGHT=256&FORMAT=image/jpeg", // OGC exception, 503
  };
  for (const auto& target : failing) {
    const auto r = s.get(target);
    EXPECT_GE(r.status, 500) << target;
    EXPECT_EQ(r.header("cache-control"), "no-store") << target;
    EXPECT_EQ(r.header("xkey"), "") << target;
  }
  // OGC exceptions sent with status 200 (exceptions_http_status off), bad requests, unknown
  // layers and paths: never kept either.
  for (const std::string& target :
       {std::string("/wms?SERVICE=WMS&REQUEST=GetMap&VERSION=1.1.1&LAYERS=nope&STYLES=&SRS="
                    "EPSG:4326&BBOX=-180,-90,-144,-54&WIDTH=256&HEIGHT=256&FORMAT=image/jpeg"),
        std::string("/wms?SERVICE=WMS&REQUEST=Nothing"),
        std::string("/wwtile?T=nope&L=0&X=0&Y=0"),
        std::string("/wwtile?T=sat"),
        std::string("/nowhere")}) {
    const auto r = s.get(target);
    EXPECT_EQ(r.header("cache-control"), "no-store") << target << " " << r.status;
    EXPECT_EQ(r.header("xkey"), "") << target;
  }
}

TEST(CdnHeaders, TooManyRequestsIsNotKept) {
  Upstream up;
  FrontEndOptions fo;
  fo.fetchesPerClientPerMinute = 1; // one fetch, then 429
  Served s(up.server.url("/wms"), fo);
  EXPECT_EQ(s.get("/wwtile?T=sat&L=1&X=0&Y=0").status, 200);
  const auto r = s.get("/wwtile?T=sat&L=1&X=1&Y=0");
  ASSERT_EQ(r.status, 429);
  EXPECT_EQ(r.header("cache-control"), "no-store");
}

TEST(CdnHeaders, AbsentTilesAndEmptyMapsLiveShortly) {
  Upstream up;
  FrontEndOptions fo;
  fo.cdn.shortMaxAge = 30s;
  Served s(up.server.url("/wms"), fo);
  up.fail = 404;
  const auto r = s.get("/wwtile?T=sat&L=1&X=4&Y=4");
  ASSERT_EQ(r.status, 404);
  EXPECT_EQ(r.header("cache-control"), "public, max-age=30, s-maxage=30");
  EXPECT_EQ(r.header("xkey"), "tellus layer:sat layer:sat/1");
  const auto empty =
      s.get("/wms?SERVICE=WMS&REQUEST=GetMap&VERSION=1.1.1&LAYERS=sat&STYLES=&SRS=EPSG:4326"
            "&BBOX=-144,-90,-108,-54&WIDTH=256&HEIGHT=256&FORMAT=image/jpeg");
  ASSERT_EQ(empty.status, 200);
  EXPECT_EQ(empty.header("cache-control"), "public, max-age=30, s-maxage=30");
}

TEST(CdnHeaders, KeysCanBeTurnedOff) {
  Upstream up;
  FrontEndOptions fo;
  fo.cdn.keyHeader = "";
  Served s(up.server.url("/wms"), fo);
  const auto r = s.get("/wwtile?T=sat&L=0&X=0&Y=0");
  ASSERT_EQ(r.status, 200);
  EXPECT_EQ(r.header("xkey"), "");
}

TEST(CdnPurge, SendsPurgeWithTheKeysInBatches) {
  std::mutex m;
  std::vector<test::FakeRequest> seen;
  test::FakeUpstream cdn([&](const test::FakeRequest& r) {
    std::lock_guard lock(m);
    seen.push_back(r);
    return test::FakeReply::withStatus(200, "purged");
  });
  const auto out = purgeKeys({cdn.url("/")}, {"layer:a", "layer:b@t", "layer:c"}, 5s, 2);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_TRUE(out[0].ok()) << out[0].error;
  std::lock_guard lock(m);
  ASSERT_EQ(seen.size(), 2u);
  EXPECT_EQ(seen[0].method, "PURGE");
  EXPECT_EQ(seen[0].header("xkey-purge"), "layer:a layer:b@t");
  EXPECT_EQ(seen[1].header("xkey-purge"), "layer:c");
}

TEST(CdnPurge, SaysWhichEndpointFailed) {
  test::FakeUpstream refusing(
      [](const test::FakeRequest&) { return test::FakeReply::withStatus(405, "no"); });
  const auto out = purgeKeys({refusing.url("/"), "http://127.0.0.1:1/"}, {"layer:a"}, 2s);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].status, 405);
  EXPECT_FALSE(out[0].ok());
  EXPECT_EQ(out[1].status, 0);
  EXPECT_FALSE(out[1].ok());
  // A key that would split into two is refused, nothing sent.
  EXPECT_FALSE(purgeKeys({refusing.url("/")}, {"layer:a b"}).at(0).ok());
}
