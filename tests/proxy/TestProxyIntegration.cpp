// tellus serve's pieces wired as the executable wires them (cache, fetcher, tile service, front
// end, HTTP server on a loopback port), against a scriptable fake upstream and a real MapServer.

#include "../../proxy/src/compose/MapComposer.hpp"
#include "../support/CacheFixtures.hpp"
#include "../support/FakeUpstream.hpp"
#include "../support/HttpClient.hpp"
#include "../support/TempDir.hpp"

#include <tellus/cache/TileCache.hpp>
#include <tellus/cache/TilePath.hpp>
#include <tellus/codec/Jpeg.hpp>
#include <tellus/proxy/Compose.hpp>
#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/HttpServer.hpp>
#include <tellus/proxy/ImageCodec.hpp>
#include <tellus/proxy/Log.hpp>
#include <tellus/proxy/ProxyFrontEnd.hpp>
#include <tellus/proxy/RemoteTileSource.hpp>
#include <tellus/proxy/Seeder.hpp>
#include <tellus/proxy/TileService.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <arpa/inet.h>
#include <array>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <future>
#include <map>
#include <mutex>
#include <netinet/in.h>
#include <poll.h>
#include <span>
#include <spawn.h>
#include <string_view>
#include <sys/socket.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>
#include <vector>

using namespace tellus;
using namespace std::chrono_literals;
namespace fs = std::filesystem;

namespace {

/** A metric's value in a /metrics body (its name with any labels); -1 when it is not there. */
long long metricValue(const std::string& body, const std::string& name) {
  const auto at = body.find("\n" + name + " ");
  if (at == std::string::npos) return -1;
  return std::stoll(body.substr(at + name.size() + 2));
}

/** A real JPEG whose colour depends on the request, so different tiles have different bytes. */
std::string jpegFor(const std::string& target, int size = 256) {
  const auto h = stableHash64(target);
  std::vector<std::uint8_t> px(static_cast<std::size_t>(size * size * 3));
  for (std::size_t i = 0; i < px.size(); i += 3) {
    px[i] = static_cast<std::uint8_t>(h);
    px[i + 1] = static_cast<std::uint8_t>(h >> 8);
    px[i + 2] = static_cast<std::uint8_t>(h >> 16);
  }
  const auto bytes = *encodeImage("image/jpeg", size, size, 3, px.data());
  return std::string(reinterpret_cast<const char*>(bytes.data()), bytes.size());
}

test::FakeReply tileReply(const test::FakeRequest& req) {
  auto r = test::FakeReply::ok(jpegFor(req.target), "image/jpeg");
  r.headers.emplace_back("ETag", "\"v1\"");
  return r;
}

struct Proxy {
  test::TempDir dir{"proxy"};
  std::unique_ptr<TileCache> cache;
  std::unique_ptr<Fetcher> fetcher;
  std::unique_ptr<TileService> tiles;
  std::unique_ptr<ProxyFrontEnd> front;
  std::unique_ptr<HttpServer> server;

  /** One WMS (or World Wind) layer "sat": 36-degree grid, 256-px JPEG, 4 levels. */
  explicit Proxy(const std::string& upstreamUrl,
                 UpstreamSpec::Type type = UpstreamSpec::Type::Wms,
                 std::chrono::milliseconds ttl = 0ms,
                 UpstreamPolicy policy = fastPolicy(),
                 const std::string& upstreamLayer = "upsat",
                 FrontEndOptions frontOptions = {},
                 std::vector<LayerSpec> extraLayers = {},
                 HttpServerOptions serverOptions = {},
                 TileServiceOptions serviceOptions = {}) {
    cache = test::openTestCache(dir.path());
    fetcher = std::make_unique<Fetcher>();
    UpstreamSpec u;
    u.name = "up";
    u.type = type;
    u.url = upstreamUrl;
    u.wmsVersion = "1.3.0";
    u.crs = "EPSG:4326";
    u.policy = policy;
    LayerSpec l;
    l.name = "sat";
    l.title = "Satellite";
    l.upstream = "up";
    l.upstreamLayer = upstreamLayer;
    l.dataset.grid = GridSpec{Sector{}, 36.0, 256, 256, 4};
    l.dataset.mimeType = "image/jpeg";
    l.ttl = ttl;
    l.maxAge = 3600s;
    std::vector<LayerSpec> all{l};
    for (auto& x : extraLayers) {
      x.upstream = "up";
      all.push_back(std::move(x));
    }
    auto t = TileService::create(*cache, *fetcher, {u}, std::move(all), serviceOptions);
    EXPECT_TRUE(t) << (t ? "" : t.error());
    tiles = std::move(*t);
    front = std::make_unique<ProxyFrontEnd>(*tiles, std::move(frontOptions));
    HttpServerOptions so = std::move(serverOptions);
    so.threads = 2;
    server = std::make_unique<HttpServer>(so, [this](HttpRequest&& r, Responder respond) {
      front->handle(std::move(r), std::move(respond));
    });
    EXPECT_TRUE(server->start());
  }
  ~Proxy() {
    server->stop(); // no more requests
    front.reset();  // the composer's queued maps finish while the tile service lives
    tiles.reset();  // then the service (its workers finish)
    fetcher.reset();
  }
  static UpstreamPolicy fastPolicy() {
    UpstreamPolicy p;
    p.timeout = 2000ms;
    p.connectTimeout = 500ms;
    p.retries = 1;
    p.retryBackoff = 10ms;
    return p;
  }
  std::string url(const std::string& target) const {
    return "http://127.0.0.1:" + std::to_string(server->port()) + target;
  }
  test::HttpResult get(const std::string& target,
                       const std::vector<std::pair<std::string, std::string>>& headers = {}) const {
    return test::httpGet(url(target), headers);
  }
};

const std::string kWms111 =
    "/wms?SERVICE=WMS&REQUEST=GetMap&VERSION=1.1.1&LAYERS=sat&STYLES=&SRS=EPSG:4326"
    "&BBOX=-180,-90,-144,-54&WIDTH=256&HEIGHT=256&FORMAT=image/jpeg";
const std::string kWms130 =
    "/wms?service=WMS&request=GetMap&version=1.3.0&layers=sat&styles=&crs=EPSG:4326"
    "&bbox=-90,-180,-54,-144&width=256&height=256&format=image%2Fjpeg";
const std::string kWms130Crs84 =
    "/wms?SERVICE=WMS&REQUEST=GetMap&VERSION=1.3.0&LAYERS=sat&STYLES=&CRS=CRS:84"
    "&BBOX=-180,-90,-144,-54&WIDTH=256&HEIGHT=256&FORMAT=image/jpeg";

} // namespace

TEST(ProxyIntegration, EveryProtocolGivesTheSameCachedBytes) {
  test::FakeUpstream up(tileReply);
  Proxy p(up.url("/wms"));
  const auto first = p.get("/wwtile?T=sat&L=0&X=0&Y=0");
  ASSERT_EQ(first.status, 200) << first.body;
  EXPECT_EQ(first.header("x-cache"), "MISS");
  EXPECT_EQ(first.header("content-type"), "image/jpeg");
  EXPECT_EQ(first.header("access-control-allow-origin"), "*");
  EXPECT_EQ(first.header("cache-control"), // s-maxage: no ttl, so max_age (HttpCaching.hpp)
            "public, max-age=3600, s-maxage=3600, stale-while-revalidate=3600, "
            "stale-if-error=604800");
  for (const auto& target : {kWms111,
                             kWms130,
                             kWms130Crs84,
                             std::string("/tiles/sat/0/0/0_0.jpg"),
                             std::string("/wwtile?T=sat&L=0&X=0&Y=0")}) {
    const auto r = p.get(target);
    EXPECT_EQ(r.status, 200) << target << "\n" << r.body;
    EXPECT_EQ(r.body, first.body) << target; // byte for byte, no re-encoding
    EXPECT_EQ(r.header("x-cache"), "HIT") << target;
    EXPECT_EQ(r.header("etag"), first.header("etag"));
  }
  ASSERT_EQ(up.requests(), 1u);
  // What went upstream: WMS 1.3.0 EPSG:4326 in lat/lon order, the upstream's layer name.
  const std::string sent = up.received().at(0).target;
  EXPECT_NE(sent.find("CRS=EPSG:4326"), std::string::npos) << sent;
  EXPECT_NE(sent.find("BBOX=-90,-180,-54,-144"), std::string::npos) << sent;
  EXPECT_NE(sent.find("LAYERS=upsat"), std::string::npos) << sent;
  EXPECT_NE(sent.find("WIDTH=256&HEIGHT=256"), std::string::npos) << sent;
  // Another tile is another upstream request with another box.
  EXPECT_EQ(p.get("/wwtile?T=sat&L=1&X=19&Y=9").status, 200);
  EXPECT_NE(up.received().at(1).target.find("BBOX=72,162,90,180"), std::string::npos)
      << up.received().at(1).target;
  // The file is where World Wind Java and WebWorldWind expect it.
  EXPECT_TRUE(fs::exists(p.dir.path() / "up"));
}

TEST(ProxyIntegration, SixtyFourClientsOneUpstreamRequest) {
  test::FakeUpstream up([](const test::FakeRequest& r) {
    auto reply = tileReply(r);
    reply.delayBeforeHeaders = 300ms; // all 64 arrive while the first fetch is under way
    return reply;
  });
  Proxy p(up.url("/wms"));
  std::vector<std::thread> clients;
  std::vector<test::HttpResult> results(64);
  for (std::size_t i = 0; i < results.size(); ++i) {
    clients.emplace_back(
        [&, i] { results[i] = p.get(i % 2 ? kWms130 : "/wwtile?T=sat&L=0&X=0&Y=0"); });
  }
  for (auto& c : clients)
    c.join();
  for (const auto& r : results) {
    EXPECT_EQ(r.status, 200);
    EXPECT_EQ(r.body, results[0].body);
  }
  EXPECT_EQ(up.requests(), 1u);
  EXPECT_EQ(p.tiles->upstreamFetches(), 1u);
}

TEST(ProxyIntegration, WhatIsNotATileIsNeverCached) {
  std::atomic<int> mode{0};
  test::FakeUpstream up([&](const test::FakeRequest& r) {
    switch (mode.load()) {
    case 0: // a ServiceException with status 200 and an image content type
      return test::FakeReply::ok(R"(<?xml version="1.0"?><ServiceExceptionReport><ServiceException>
        Layer upsat is broken at http://secret.example/internal</ServiceException></ServiceExceptionReport>)",
                                 "image/jpeg");
    case 1:
      return test::FakeReply::ok("<html>Bad gateway</html>", "text/html");
    case 2:
      return test::FakeReply::ok(jpegFor(r.target, 128), "image/jpeg"); // wrong size
    default:
      return tileReply(r);
    }
  });
  Proxy p(up.url("/wms"));
  for (int m = 0; m < 3; ++m) {
    mode = m;
    const auto ww = p.get("/wwtile?T=sat&L=0&X=0&Y=0");
    EXPECT_EQ(ww.status, 502) << m << ww.body;
    const auto wms = p.get(kWms130);
    EXPECT_EQ(wms.status, 200) << m; // WMS exceptions are HTTP 200 by default
    EXPECT_NE(wms.body.find("ServiceException"), std::string::npos) << wms.body;
    EXPECT_EQ(wms.body.find("secret.example"), std::string::npos)
        << "upstream URLs never reach clients";
  }
  EXPECT_EQ(*p.cache->totalBytes(), 0);
  mode = 3;
  const auto good = p.get("/wwtile?T=sat&L=0&X=0&Y=0");
  EXPECT_EQ(good.status, 200);
  EXPECT_EQ(good.header("x-cache"), "MISS");
  EXPECT_EQ(up.requests(), 7u); // nothing was cached in between
}

TEST(ProxyIntegration, AbsentIsRememberedServerErrorsAreNot) {
  std::atomic<int> status{404};
  test::FakeUpstream up([&](const test::FakeRequest& r) {
    if (status == 200) return tileReply(r);
    return test::FakeReply::withStatus(status.load(), "nope");
  });
  Proxy p(up.url("/wms"));
  EXPECT_EQ(p.get("/wwtile?T=sat&L=2&X=3&Y=4").status, 404);
  EXPECT_EQ(p.get("/wwtile?T=sat&L=2&X=3&Y=4").status, 404);
  EXPECT_EQ(up.requests(), 1u); // the second answer came from the cache's "absent" row
  // A WMS client gets an empty map there, not an error.
  const auto wms =
      p.get("/wms?SERVICE=WMS&REQUEST=GetMap&VERSION=1.1.1&LAYERS=sat&STYLES=&SRS=EPSG:4326"
            "&BBOX=-153,-54,-144,-45&WIDTH=256&HEIGHT=256&FORMAT=image/jpeg");
  EXPECT_EQ(wms.status, 200);
  EXPECT_EQ(wms.header("content-type"), "image/jpeg");
  status = 500; // a temporary failure: 503 with Retry-After, not cached
  const auto failed = p.get("/wwtile?T=sat&L=1&X=0&Y=0");
  EXPECT_EQ(failed.status, 503);
  EXPECT_FALSE(failed.header("retry-after").empty());
  const auto before = up.requests();
  EXPECT_EQ(before, 1u + 2u); // one retry
  status = 200;
  EXPECT_EQ(p.get("/wwtile?T=sat&L=1&X=0&Y=0").status, 200);
  EXPECT_GT(up.requests(), before);
  // Outside the grid: a fast 404 without asking anybody.
  EXPECT_EQ(p.get("/wwtile?T=sat&L=0&X=10&Y=0").status, 404);
  EXPECT_EQ(p.get("/wwtile?T=sat&L=9&X=0&Y=0").status, 404);
  EXPECT_EQ(p.get("/wwtile?T=nope&L=0&X=0&Y=0").status, 404);
  EXPECT_EQ(p.get("/wwtile?T=sat&L=0&X=-1&Y=0").status, 400);
}

TEST(ProxyIntegration, ConditionalRequestsGet304) {
  test::FakeUpstream up(tileReply);
  Proxy p(up.url("/wms"));
  const auto r = p.get(kWms111);
  ASSERT_EQ(r.status, 200);
  const std::string etag = r.header("etag");
  ASSERT_TRUE(etag.size() > 2 && etag.front() == '"' && etag.back() == '"')
      << "strong, quoted: " << etag;
  EXPECT_EQ(p.get(kWms111, {{"If-None-Match", etag}}).status, 304);
  EXPECT_EQ(p.get(kWms111, {{"If-None-Match", "W/" + etag}}).status, 304); // weak comparison
  EXPECT_EQ(p.get(kWms111, {{"If-None-Match", "\"x\", " + etag}}).status, 304);
  EXPECT_EQ(p.get(kWms111, {{"If-None-Match", "*"}}).status, 304);
  EXPECT_EQ(p.get(kWms111, {{"If-None-Match", "\"other\""}}).status, 200);
  const std::string lm = r.header("last-modified");
  EXPECT_EQ(p.get(kWms111, {{"If-Modified-Since", lm}}).status, 304); // same second
  EXPECT_EQ(p.get(kWms111, {{"If-Modified-Since", "Mon, 01 Jan 2001 00:00:00 GMT"}}).status, 200);
  const auto notModified = p.get("/tiles/sat/0/0/0_0.jpg", {{"If-None-Match", etag}});
  EXPECT_EQ(notModified.status, 304);
  EXPECT_TRUE(notModified.body.empty());
  EXPECT_EQ(notModified.header("etag"), etag);
}

TEST(ProxyIntegration, OfflineServesTheCacheAndAnswersTheRestAtOnce) {
  test::FakeUpstream up(tileReply);
  Proxy p(up.url("/wms"));
  ASSERT_EQ(p.get("/wwtile?T=sat&L=0&X=0&Y=0").status, 200);
  p.tiles->setOffline(true);
  EXPECT_TRUE(p.tiles->offline());
  const auto hit = p.get("/wwtile?T=sat&L=0&X=0&Y=0");
  EXPECT_EQ(hit.status, 200);
  EXPECT_EQ(hit.header("x-cache"), "HIT");
  const auto t0 = std::chrono::steady_clock::now();
  const auto miss = p.get("/wwtile?T=sat&L=0&X=1&Y=0");
  EXPECT_LT(std::chrono::steady_clock::now() - t0,
            1500ms); // no upstream timeout (2 s) was waited for
  EXPECT_EQ(miss.status, 404);
  EXPECT_EQ(miss.header("x-cache"), "OFFLINE");
  const auto wms = p.get(kWms130Crs84.substr(0, kWms130Crs84.find("BBOX")) +
                         "BBOX=-144,-90,-108,-54&WIDTH=256&HEIGHT=256&FORMAT=image/jpeg");
  EXPECT_NE(wms.body.find("ServiceException"), std::string::npos) << wms.body;
  EXPECT_EQ(up.requests(), 1u);
}

TEST(ProxyIntegration, ADeadUpstreamOpensTheBreakerAndGoesOffline) {
  auto policy = Proxy::fastPolicy();
  policy.retries = 0;
  policy.failureThreshold = 2;
  policy.openInterval = 60s;
  Proxy p("http://127.0.0.1:" + std::to_string(test::FakeUpstream::closedPort()) + "/wms",
          UpstreamSpec::Type::Wms,
          0ms,
          policy);
  // Unreachable is not "no such tile": 503 with Retry-After, never 404.
  EXPECT_EQ(p.get("/wwtile?T=sat&L=0&X=0&Y=0").status, 503);
  EXPECT_EQ(p.get("/wwtile?T=sat&L=0&X=1&Y=0").status, 503);
  EXPECT_TRUE(p.tiles->offline());
  const auto t0 = std::chrono::steady_clock::now();
  const auto r = p.get("/wwtile?T=sat&L=0&X=2&Y=0");
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 1500ms); // the breaker answers, not a timeout
  EXPECT_EQ(r.status, 503);
  EXPECT_EQ(r.header("x-cache"), "OFFLINE");
  // Until the breaker lets a probe through (60 s).
  EXPECT_GE(std::stoi(r.header("retry-after")), 55) << r.header("retry-after");
  EXPECT_EQ(r.header("cache-control"), "no-store");
}

TEST(ProxyIntegration, ExpiredTilesAreRevalidatedOrServedStale) {
  std::atomic<int> mode{0};
  test::FakeUpstream up([&](const test::FakeRequest& r) {
    if (mode == 1 && r.header("if-none-match") == "\"v1\"") return test::FakeReply::withStatus(304);
    if (mode == 2) return test::FakeReply::withStatus(503, "down");
    return tileReply(r);
  });
  // The service's clock is a day behind the cache's: every tile it fetches (TTL 100 ms) has expired
  // by the time the cache is asked for it again, with no waiting.
  ManualClock aDayAgo(std::chrono::steady_clock::now(), std::chrono::system_clock::now() - 24h);
  TileServiceOptions so;
  so.clock = &aDayAgo;
  Proxy p(
      up.url("/wms"), UpstreamSpec::Type::Wms, 100ms, Proxy::fastPolicy(), "upsat", {}, {}, {}, so);
  const auto first = p.get("/wwtile?T=sat&L=0&X=0&Y=0");
  ASSERT_EQ(first.status, 200);
  EXPECT_EQ(first.header("x-cache"), "MISS");
  mode = 1;
  aDayAgo.advance(5s); // the revalidation comes later than the fetch
  const auto revalidated = p.get("/wwtile?T=sat&L=0&X=0&Y=0");
  EXPECT_EQ(revalidated.status, 200);
  EXPECT_EQ(revalidated.header("x-cache"), "HIT");
  EXPECT_EQ(revalidated.body, first.body);
  EXPECT_EQ(up.received().back().header("if-none-match"), "\"v1\"");
  // Unchanged upstream, unchanged tile: its ETag and Last-Modified stay, so a client (or a CDN)
  // revalidating its copy gets a 304, not the same bytes again (they moved with each 304 before).
  EXPECT_EQ(revalidated.header("etag"), first.header("etag"));
  EXPECT_EQ(revalidated.header("last-modified"), first.header("last-modified"));
  EXPECT_EQ(p.get("/wwtile?T=sat&L=0&X=0&Y=0", {{"If-None-Match", first.header("etag")}}).status,
            304);
  mode = 2;
  const auto stale = p.get("/wwtile?T=sat&L=0&X=0&Y=0");
  EXPECT_EQ(stale.status, 200);
  EXPECT_EQ(stale.header("x-cache"), "STALE");
  EXPECT_EQ(stale.body, first.body);
}

TEST(ProxyIntegration, WmsErrorsAreExceptionsOfTheRightVersion) {
  test::FakeUpstream up(tileReply);
  Proxy p(up.url("/wms"));
  const auto undefined =
      p.get("/wms?SERVICE=WMS&REQUEST=GetMap&VERSION=1.3.0&LAYERS=nope&STYLES=&CRS=CRS:84"
            "&BBOX=-180,-90,-144,-54&WIDTH=256&HEIGHT=256&FORMAT=image/jpeg");
  EXPECT_EQ(undefined.status, 200);
  EXPECT_EQ(undefined.header("content-type"), "text/xml");
  EXPECT_NE(undefined.body.find("code=\"LayerNotDefined\""), std::string::npos) << undefined.body;
  const auto v111 =
      p.get("/wms?SERVICE=WMS&REQUEST=GetMap&VERSION=1.1.1&LAYERS=sat&STYLES=&SRS=EPSG:4326"
            "&BBOX=-180,-90,-144,-54&WIDTH=256&HEIGHT=256&FORMAT=image/gif");
  EXPECT_EQ(v111.header("content-type"), "application/vnd.ogc.se_xml");
  EXPECT_NE(v111.body.find("InvalidFormat"), std::string::npos) << v111.body;
  const auto tooManyTiles =
      p.get("/wms?SERVICE=WMS&REQUEST=GetMap&VERSION=1.3.0&LAYERS=sat&STYLES=&CRS=CRS:84"
            "&BBOX=-36,-36,36,36&WIDTH=4096&HEIGHT=4096&FORMAT=image/jpeg");
  EXPECT_NE(tooManyTiles.body.find("InvalidParameterValue"), std::string::npos)
      << tooManyTiles.body;
  EXPECT_NE(tooManyTiles.body.find("more than 256 tiles"), std::string::npos) << tooManyTiles.body;
  const auto mixed =
      p.get("/wms?SERVICE=WMS&REQUEST=GetMap&VERSION=1.3.0&LAYERS=sat&STYLES=&CRS=CRS:84"
            "&BBOX=-170,-90,-134,-54&WIDTH=256&HEIGHT=256&FORMAT=image/jpeg&OPACITIES=0.5,1");
  EXPECT_NE(mixed.body.find("locator=\"OPACITIES\""), std::string::npos) << mixed.body;
  const auto inverted =
      p.get("/wms?SERVICE=WMS&REQUEST=GetMap&VERSION=1.3.0&LAYERS=sat&STYLES=&CRS=CRS:84"
            "&BBOX=-144,-90,-180,-54&WIDTH=256&HEIGHT=256&FORMAT=image/jpeg");
  EXPECT_NE(inverted.body.find("InvalidParameterValue"), std::string::npos) << inverted.body;
  const auto blank =
      p.get("/wms?SERVICE=WMS&REQUEST=GetMap&VERSION=1.3.0&LAYERS=nope&STYLES=&CRS=CRS:84"
            "&BBOX=-180,-90,-144,-54&WIDTH=64&HEIGHT=32&FORMAT=image/jpeg&EXCEPTIONS=BLANK");
  EXPECT_EQ(blank.status, 200);
  EXPECT_EQ(blank.header("content-type"), "image/jpeg");
  EXPECT_EQ(up.requests(), 0u);
  const auto caps =
      p.get("/wms?SERVICE=WMS&REQUEST=GetCapabilities", {{"Host", "maps.example.org:8080"}});
  EXPECT_EQ(caps.status, 200);
  EXPECT_NE(caps.body.find("<WMS_Capabilities"), std::string::npos);
  EXPECT_NE(caps.body.find("http://maps.example.org:8080/wms?"), std::string::npos);
  EXPECT_NE(caps.body.find("<Name>sat</Name>"), std::string::npos);
  EXPECT_NE(caps.body.find("<Keyword>LastUpdate="), std::string::npos)
      << "World Wind Java's cache expiry";
  const auto caps111 = p.get("/wms?SERVICE=WMS&REQUEST=GetCapabilities&VERSION=1.1.1",
                             {{"Host", "<script>"}, {"X-Forwarded-Proto", "https"}});
  EXPECT_NE(caps111.body.find("WMT_MS_Capabilities"), std::string::npos);
  EXPECT_EQ(caps111.body.find("<script>"), std::string::npos)
      << "a hostile Host header is not echoed";
}

TEST(ProxyIntegration, AProxyChainOfTwoTellus) {
  test::FakeUpstream up(tileReply);
  Proxy origin(up.url("/wms"));
  // The second tellus's upstream is the first one's World Wind endpoint.
  Proxy edge(origin.url("/wwtile"), UpstreamSpec::Type::WorldWind, 0ms, Proxy::fastPolicy(), "sat");
  const auto viaEdge = edge.get("/tiles/sat/1/3/3_7.jpg");
  ASSERT_EQ(viaEdge.status, 200) << viaEdge.body;
  const auto direct = origin.get("/wwtile?T=sat&L=1&X=7&Y=3");
  EXPECT_EQ(direct.header("x-cache"), "HIT");
  EXPECT_EQ(viaEdge.body, direct.body);
  EXPECT_EQ(up.requests(), 1u);
}

// ------------------------------------------------------------------------------------------------
// The planet's remote tile source (RemoteTileSource) against a real `tellus serve` front end.

namespace {

/** Collects a tile source's answers on its worker threads. */
struct Answers {
  std::mutex m;
  std::condition_variable cv;
  std::vector<std::pair<int, TileResult>> got; // (tag, result) in completion order

  ITileSource::Callback callback(int tag) {
    return [this, tag](TileResult&& r) {
      std::lock_guard lock(m);
      got.emplace_back(tag, std::move(r));
      cv.notify_all();
    };
  }
  bool waitFor(std::size_t n, std::chrono::milliseconds timeout = 10s) {
    std::unique_lock lock(m);
    return cv.wait_for(lock, timeout, [&] { return got.size() >= n; });
  }
};

LayerSpec timeLayer() {
  LayerSpec l;
  l.name = "daily";
  l.upstreamLayer = "updaily";
  l.dataset.grid = GridSpec{Sector{}, 36.0, 256, 256, 2};
  l.dataset.mimeType = "image/jpeg";
  l.timeValues = {"2024-01-01", "2024-01-02"};
  l.timeDefault = "2024-01-02";
  return l;
}

} // namespace

TEST(RemoteTileSource, LayersAndTilesComeFromTheServer) {
  test::FakeUpstream up([](const test::FakeRequest& r) {
    // Level 1, row 7, column 9 (lon -18..0, lat 36..54) does not exist upstream.
    if (r.target.find("BBOX=36,-18,54,0") != std::string::npos)
      return test::FakeReply::withStatus(404, "none");
    return tileReply(r);
  });
  Proxy p(up.url("/wms"),
          UpstreamSpec::Type::Wms,
          0ms,
          Proxy::fastPolicy(),
          "upsat",
          {},
          {timeLayer()});
  auto src = RemoteTileSource::connect(p.url("/"));
  ASSERT_TRUE(src) << src.error();
  auto& s = **src;
  ASSERT_EQ(s.layers().size(), 2u);
  const auto d = s.describe("sat", "");
  ASSERT_TRUE(d);
  EXPECT_EQ(d->grid, (GridSpec{Sector{}, 36.0, 256, 256, 4}));
  EXPECT_EQ(d->mimeType, "image/jpeg");
  EXPECT_EQ(d->extension, "jpg");
  EXPECT_FALSE(s.describe("nope"));
  EXPECT_EQ(s.describe("daily", "2024-01-01")->time, "2024-01-01");

  Answers a;
  s.request({"sat", "", TileKey{1, 3, 7}}, 1.0, a.callback(0));
  s.request({"sat", "", TileKey{1, 7, 9}}, 1.0, a.callback(1));  // 404 upstream
  s.request({"sat", "", TileKey{0, 5, 0}}, 1.0, a.callback(2));  // outside the grid
  s.request({"nope", "", TileKey{0, 0, 0}}, 1.0, a.callback(3)); // no such layer
  s.request({"daily", "2024-01-01", TileKey{0, 1, 2}}, 1.0, a.callback(4));
  s.request({"daily", "1999-01-01", TileKey{0, 1, 2}}, 1.0, a.callback(5)); // not a listed time
  ASSERT_TRUE(a.waitFor(6));
  std::map<int, TileResult> by;
  for (auto& [tag, r] : a.got)
    by.emplace(tag, std::move(r));
  ASSERT_EQ(by[0].status, TileStatus::Ok) << by[0].message;
  const auto direct = p.get("/tiles/sat/1/3/3_7.jpg");
  EXPECT_EQ(direct.header("x-cache"), "HIT");
  EXPECT_EQ(std::string(reinterpret_cast<const char*>(by[0].bytes.data()), by[0].bytes.size()),
            direct.body);
  EXPECT_EQ(by[0].contentType, "image/jpeg");
  EXPECT_EQ(by[1].status, TileStatus::Absent) << by[1].message;
  EXPECT_EQ(by[2].status, TileStatus::Absent) << by[2].message;
  EXPECT_EQ(by[3].status, TileStatus::Failed);
  EXPECT_NE(by[3].message.find("nope"), std::string::npos);
  ASSERT_EQ(by[4].status, TileStatus::Ok) << by[4].message;
  EXPECT_EQ(by[5].status, TileStatus::Failed);
  EXPECT_NE(by[5].message.find("InvalidDimensionValue"), std::string::npos) << by[5].message;
  // The time went upstream, and the default time is another tile.
  std::size_t withTime = 0;
  for (const auto& r : up.received())
    withTime += r.target.find("TIME=2024-01-01") != std::string::npos;
  EXPECT_EQ(withTime, 1u);
  EXPECT_EQ(p.get("/tiles/daily/0/1/1_2.jpg?time=2024-01-01").header("x-cache"), "HIT");
  EXPECT_EQ(p.get("/tiles/daily/0/1/1_2.jpg").header("x-cache"), "MISS");
}

TEST(RemoteTileSource, QueuedRequestsRunByPriorityAndCanBeCancelled) {
  // Every reply is held until the queue below has been arranged.
  const auto arranged = std::make_shared<test::Gate>();
  test::FakeUpstream up([&](const test::FakeRequest& r) {
    auto reply = tileReply(r);
    reply.holdUntilOpen = arranged;
    return reply;
  });
  Proxy p(up.url("/wms"));
  RemoteSourceOptions o;
  o.maxInFlight = 1;
  auto src = RemoteTileSource::connect(p.url(""), o);
  ASSERT_TRUE(src) << src.error();
  auto& s = **src;
  Answers a;
  s.request({"sat", "", TileKey{2, 0, 0}}, 0.0, a.callback(0)); // on the wire at once
  const auto low = s.request({"sat", "", TileKey{2, 0, 1}}, 1.0, a.callback(1));
  const auto high = s.request({"sat", "", TileKey{2, 0, 2}}, 3.0, a.callback(2));
  const auto mid = s.request({"sat", "", TileKey{2, 0, 3}}, 2.0, a.callback(3));
  const auto gone = s.request({"sat", "", TileKey{2, 0, 4}}, 5.0, a.callback(4));
  EXPECT_EQ(s.queued(), 4u);
  EXPECT_TRUE(s.cancel(gone));
  EXPECT_FALSE(s.cancel(gone));
  s.reprioritize(low, 2.5);           // now between high and mid
  ASSERT_TRUE(up.waitForRequests(1)); // the first request has reached the upstream (and waits)
  EXPECT_EQ(s.queued(), 3u);
  arranged->open();
  ASSERT_TRUE(a.waitFor(4));
  std::vector<int> order;
  for (const auto& [tag, r] : a.got) {
    EXPECT_EQ(r.status, TileStatus::Ok) << r.message;
    order.push_back(tag);
  }
  EXPECT_EQ(order, (std::vector<int>{0, 2, 1, 3}));
  (void)high;
  (void)mid;
  // The cancelled one (the highest priority) would have gone second: it never went.
  EXPECT_EQ(s.queued(), 0u);
  EXPECT_EQ(a.got.size(), 4u);
  EXPECT_EQ(up.requests(), 4u);
}

TEST(RemoteTileSource, AnUnreachableServerIsAClearErrorAndALostOneFailsTiles) {
  std::uint16_t port = 0;
  {
    test::FakeUpstream closed;
    port = closed.port();
  }
  RemoteSourceOptions o;
  o.connectTimeout = 500ms;
  o.retries = 0;
  auto none = RemoteTileSource::connect("http://127.0.0.1:" + std::to_string(port), o);
  ASSERT_FALSE(none);
  EXPECT_NE(none.error().find("/layers.json"), std::string::npos) << none.error();
  EXPECT_FALSE(RemoteTileSource::connect("ftp://127.0.0.1:1"));

  test::FakeUpstream up(tileReply);
  auto p = std::make_unique<Proxy>(up.url("/wms"));
  auto src = RemoteTileSource::connect(p->url("/"), o);
  ASSERT_TRUE(src) << src.error();
  p.reset(); // the server goes away
  Answers a;
  (*src)->request({"sat", "", TileKey{0, 0, 0}}, 1.0, a.callback(0));
  ASSERT_TRUE(a.waitFor(1));
  EXPECT_EQ(a.got[0].second.status, TileStatus::Failed);
  EXPECT_FALSE(a.got[0].second.message.empty());
}

TEST(RemoteTileSource, LayersJsonErrorsNameWhatIsWrong) {
  EXPECT_FALSE(parseLayersJson("", "s"));
  EXPECT_FALSE(parseLayersJson("[]", "s"));
  EXPECT_FALSE(parseLayersJson("{\"layers\":[{\"name\":\"a\"}]}", "s"));
  const auto bad = parseLayersJson("{\"layers\":[1,]}", "s");
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().find("offset"), std::string::npos);
  const std::string ok =
      R"({"title":"t","layers":[{"name":"a\u00e9","title":"x","format":"image/png",)"
      R"("extension":"png","elevation":false,"levelZeroDelta":45,"tileWidth":256,)"
      R"("tileHeight":128,"levels":3,"firstLevel":0,)"
      R"("sector":{"west":-180,"south":-90,"east":180,"north":90}}]})";
  const auto l = parseLayersJson(ok, "host:1");
  ASSERT_TRUE(l) << l.error();
  ASSERT_EQ(l->size(), 1u);
  EXPECT_EQ((*l)[0].name, "a\xc3\xa9");
  EXPECT_EQ((*l)[0].dataset.server, "host:1");
  EXPECT_EQ((*l)[0].dataset.grid, (GridSpec{Sector{-180, -90, 180, 90}, 45.0, 256, 128, 3}));
  // A grid the tile math refuses is refused here too.
  std::string badDelta = ok;
  badDelta.replace(badDelta.find("45"), 2, "7");
  EXPECT_FALSE(parseLayersJson(badDelta, "s"));
}

// ------------------------------------------------------------------------------------------------
// A real MapServer (Debian's mapserv CGI) behind a CGI bridge on a loopback port.

namespace {

const char* kMapserv = "/usr/lib/cgi-bin/mapserv";

/** Runs mapserv once as a CGI program and turns its output into a reply. posix_spawn, not fork
 * and setenv: the bridge's threads (and the sanitizers' allocators) may hold locks at the fork,
 * and a child that takes one before exec hangs; the pipe is close-on-exec so that mapserv
 * processes started at the same time do not keep each other's pipes open. */
test::FakeReply
runMapserv(const test::FakeRequest& req, const fs::path& conf, const fs::path& map) {
  const auto q = req.target.find('?');
  const std::string query = q == std::string::npos ? "" : req.target.substr(q + 1);
  std::vector<std::string> env{"QUERY_STRING=" + query,
                               "REQUEST_METHOD=GET",
                               "MAPSERVER_CONFIG_FILE=" + conf.string(),
                               "MS_MAPFILE=" + map.string()};
  for (char** e = environ; *e != nullptr; ++e) {
    const std::string_view v(*e);
    const bool ours = std::any_of(env.begin(), env.end(), [&](const std::string& o) {
      return v.substr(0, v.find('=') + 1) == std::string_view(o).substr(0, o.find('=') + 1);
    });
    if (!ours) env.emplace_back(v);
  }
  std::vector<char*> envp;
  for (auto& e : env)
    envp.push_back(e.data());
  envp.push_back(nullptr);
  int out[2];
  if (::pipe2(out, O_CLOEXEC) != 0) return test::FakeReply::withStatus(500, "pipe");
  posix_spawn_file_actions_t actions;
  ::posix_spawn_file_actions_init(&actions);
  ::posix_spawn_file_actions_adddup2(&actions, out[1], 1); // dup2 clears close-on-exec on 1
  std::string program = kMapserv;
  char* argv[] = {program.data(), nullptr};
  pid_t pid = 0;
  const int spawned = ::posix_spawn(&pid, kMapserv, &actions, nullptr, argv, envp.data());
  ::posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) {
    ::close(out[0]);
    ::close(out[1]);
    return test::FakeReply::withStatus(500, "posix_spawn");
  }
  ::close(out[1]);
  std::string all;
  char buf[65536];
  ssize_t n = 0;
  while ((n = ::read(out[0], buf, sizeof buf)) > 0)
    all.append(buf, static_cast<std::size_t>(n));
  ::close(out[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  const auto end = all.find("\r\n\r\n");
  if (end == std::string::npos) return test::FakeReply::withStatus(500, "mapserv: " + all);
  test::FakeReply r;
  r.body = all.substr(end + 4);
  std::string head = all.substr(0, end);
  std::size_t pos = 0;
  while (pos < head.size()) {
    auto eol = head.find("\r\n", pos);
    if (eol == std::string::npos) eol = head.size();
    const std::string line = head.substr(pos, eol - pos);
    if (const auto colon = line.find(':'); colon != std::string::npos) {
      std::string value = line.substr(colon + 1);
      while (!value.empty() && value.front() == ' ')
        value.erase(0, 1);
      if (line.substr(0, colon) == "Status")
        r.status = std::stoi(value);
      else
        r.headers.emplace_back(line.substr(0, colon), value);
    }
    pos = eol + 2;
  }
  return r;
}

} // namespace

TEST(ProxyIntegration, RealMapServerUpstream) {
  if (!fs::exists(kMapserv)) GTEST_SKIP() << "Debian's cgi-mapserver is not installed";
  test::TempDir dir("mapserv");
  // The project's mapfile, pointed at the bundled data, and the config file MapServer 8 requires.
  std::ifstream in(fs::path(TELLUS_TEST_SOURCE_DIR) / "data" / "mapserver" / "tellus-test.map.in");
  std::string mapText((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (auto at = mapText.find("@DATA@"); at != std::string::npos; at = mapText.find("@DATA@")) {
    mapText.replace(at, 6, TELLUS_TEST_DATA_DIR);
  }
  const fs::path map = dir.path() / "tellus-test.map";
  std::ofstream(map) << mapText;
  const fs::path conf = dir.path() / "mapserver.conf";
  std::ofstream(conf)
      << "CONFIG\n  ENV\n    MS_MAP_PATTERN \"tellus-test\\.map$\"\n    MS_MAPFILE \""
      << map.string() << "\"\n  END\nEND\n";
  test::FakeUpstream mapserver(
      [&](const test::FakeRequest& r) { return runMapserv(r, conf, map); });

  test::TempDir cacheDir("mapserv-cache");
  auto cache = test::openTestCache(cacheDir.path());
  Fetcher fetcher;
  UpstreamSpec u;
  u.name = "mapserver";
  u.type = UpstreamSpec::Type::Wms;
  u.url = mapserver.url("/cgi-bin/mapserv");
  u.policy = Proxy::fastPolicy();
  u.policy.timeout = 10s;
  LayerSpec imagery;
  imagery.name = "bmng";
  imagery.upstream = "mapserver";
  imagery.dataset.grid = GridSpec{Sector{}, 36.0, 512, 512, 3};
  imagery.dataset.mimeType = "image/jpeg";
  LayerSpec heights;
  heights.name = "etopo";
  heights.upstream = "mapserver";
  heights.dataset.grid = GridSpec{Sector{}, 20.0, 150, 150, 3};
  heights.dataset.mimeType = "application/bil16";
  heights.elevation = true;
  for (const char* version : {"1.3.0", "1.1.1"}) {
    SCOPED_TRACE(version);
    u.wmsVersion = version;
    u.name = std::string("mapserver-") + version;
    imagery.upstream = heights.upstream = u.name;
    auto tiles =
        TileService::create(*cache, fetcher, {u}, {imagery, heights}, TileServiceOptions{});
    ASSERT_TRUE(tiles) << tiles.error();
    auto fetch = [&](const std::string& layer, TileKey k) {
      std::promise<TileAnswer> done;
      (*tiles)->getTile(layer, "", k, [&](TileAnswer&& a) { done.set_value(std::move(a)); });
      return done.get_future().get();
    };
    // Africa at level 0: a real 512x512 JPEG from MapServer, validated and cached.
    const auto africa = fetch("bmng", TileKey{0, 2, 5});
    ASSERT_EQ(africa.kind, TileAnswer::Kind::Tile) << africa.message;
    EXPECT_EQ(africa.contentType, "image/jpeg");
    // The Himalaya at level 0 of the 20-degree elevation grid: 150x150 Int16 little-endian.
    const auto himalaya = fetch("etopo", TileKey{0, 5, 13});
    ASSERT_EQ(himalaya.kind, TileAnswer::Kind::Tile) << himalaya.message;
    ASSERT_EQ(himalaya.bytes.size(), 150u * 150u * 2u);
    int highest = -32768;
    for (std::size_t i = 0; i < himalaya.bytes.size(); i += 2) {
      const auto h =
          static_cast<std::int16_t>(std::to_integer<std::uint16_t>(himalaya.bytes[i]) |
                                    (std::to_integer<std::uint16_t>(himalaya.bytes[i + 1]) << 8));
      highest = std::max(highest, static_cast<int>(h));
    }
    EXPECT_GT(highest, 5000) << "Tibet and the Himalaya";
    EXPECT_LT(highest, 8900);
    const auto again = fetch("bmng", TileKey{0, 2, 5});
    EXPECT_EQ(again.origin, TileOrigin::Hit);
  }
  EXPECT_EQ(mapserver.requests(), 4u);
}

TEST(SeederIntegration, RealMapServerMetaTilesGiveTheTilesOfPerTileFetching) {
  if (!fs::exists(kMapserv)) GTEST_SKIP() << "Debian's cgi-mapserver is not installed";
  test::TempDir dir("mapserv-meta");
  std::ifstream in(fs::path(TELLUS_TEST_SOURCE_DIR) / "data" / "mapserver" / "tellus-test.map.in");
  std::string mapText((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (auto at = mapText.find("@DATA@"); at != std::string::npos; at = mapText.find("@DATA@"))
    mapText.replace(at, 6, TELLUS_TEST_DATA_DIR);
  const fs::path map = dir.path() / "tellus-test.map";
  std::ofstream(map) << mapText;
  const fs::path conf = dir.path() / "mapserver.conf";
  std::ofstream(conf)
      << "CONFIG\n  ENV\n    MS_MAP_PATTERN \"tellus-test\\.map$\"\n    MS_MAPFILE \""
      << map.string() << "\"\n  END\nEND\n";
  test::FakeUpstream mapserver(
      [&](const test::FakeRequest& r) { return runMapserv(r, conf, map); });
  // The same layer seeded twice from MapServer: per tile, and in 4x4 metatiles.
  struct Seeded {
    test::TempDir dir{"mapserv-meta-cache"};
    std::unique_ptr<TileCache> cache;
    std::unique_ptr<Fetcher> fetcher = std::make_unique<Fetcher>();
    std::unique_ptr<TileService> tiles;
  };
  auto seeded = [&](int metaTiles) {
    auto s = std::make_unique<Seeded>();
    s->cache = test::openTestCache(s->dir.path());
    UpstreamSpec u;
    u.name = "mapserver";
    u.type = UpstreamSpec::Type::Wms;
    u.url = mapserver.url("/cgi-bin/mapserv");
    u.policy = Proxy::fastPolicy();
    u.policy.timeout = 20s;
    u.metaTiles = metaTiles;
    LayerSpec imagery;
    imagery.name = "bmng";
    imagery.upstream = "mapserver";
    imagery.dataset.grid = GridSpec{Sector{}, 36.0, 512, 512, 3};
    imagery.dataset.mimeType = "image/jpeg";
    auto t = TileService::create(*s->cache, *s->fetcher, {u}, {imagery}, TileServiceOptions{});
    EXPECT_TRUE(t) << (t ? "" : t.error());
    s->tiles = std::move(*t);
    ServiceSeedOptions o;
    o.range.box = Sector{36, -18, 180, 90}; // level 0: to the antimeridian and the pole, 12 tiles
    auto r = seedThroughService(*s->tiles, *s->cache, "bmng", o);
    EXPECT_TRUE(r) << (r ? "" : r.error());
    if (r) {
      EXPECT_EQ(r->written, 12);
      EXPECT_EQ(r->failed, 0) << (r->failures.empty() ? "" : r->failures[0]);
    }
    return s;
  };
  const auto perTile = seeded(1);
  EXPECT_EQ(mapserver.requests(), 12u);
  const auto meta = seeded(4);
  EXPECT_EQ(mapserver.requests(), 12u + 4u); // 2x2, 2x2, 2x1 and 2x1 tiles
  EXPECT_EQ(meta->tiles->metaTileFetches(), 4u);
  const auto ds = [](Seeded& s) { return *s.cache->registerDataset(*s.tiles->describe("bmng")); };
  for (std::int64_t row = 2; row <= 4; ++row) {
    for (std::int64_t col = 6; col <= 9; ++col) {
      SCOPED_TRACE(::testing::Message() << "R" << row << " C" << col);
      const auto a = meta->cache->get(ds(*meta), TileKey{0, row, col});
      const auto b = perTile->cache->get(ds(*perTile), TileKey{0, row, col});
      ASSERT_TRUE(a && b && a->kind == CacheLookup::Kind::Hit && b->kind == CacheLookup::Kind::Hit);
      // A valid 512x512 JPEG (the DCT split keeps MapServer's own encoding: 4:2:0, quality 85).
      const auto pa = decodeImagery(a->bytes, "image/jpeg", 512, 512);
      const auto pb = decodeImagery(b->bytes, "image/jpeg", 512, 512);
      ASSERT_TRUE(pa && pb);
      ASSERT_EQ(pa->pixels.size(), pb->pixels.size());
      double sum = 0;
      for (std::size_t i = 0; i < pa->pixels.size(); ++i)
        sum += std::abs(static_cast<int>(pa->pixels[i]) - static_cast<int>(pb->pixels[i]));
      // The same place drawn by MapServer in a larger image: within JPEG's tolerance.
      EXPECT_LT(sum / static_cast<double>(pa->pixels.size()), 2.0);
    }
  }
}

TEST(ProxyIntegration, LayerLastUpdateSurvivesRestartsAndMovesWithTheDefinition) {
  test::TempDir dir("lastupdate");
  auto cache = test::openTestCache(dir.path());
  Fetcher fetcher;
  UpstreamSpec u;
  u.name = "up";
  u.type = UpstreamSpec::Type::Wms;
  u.url = "http://127.0.0.1:9/wms";
  LayerSpec l;
  l.name = "sat";
  l.upstream = "up";
  l.dataset.grid = GridSpec{Sector{}, 36.0, 256, 256, 4};
  l.dataset.mimeType = "image/jpeg";
  auto since = [&](const LayerSpec& layer) {
    auto t = TileService::create(*cache, fetcher, {u}, {layer}, TileServiceOptions{});
    EXPECT_TRUE(t) << (t ? "" : t.error());
    return t ? (*t)->layerSince("sat") : 0;
  };
  // The time is the cache's registration time of the layer's dataset (TileCache reads its own
  // clock): compared with the datasets' records, not by waiting for the clock to move.
  const UnixMillis first = since(l);
  EXPECT_GT(first, 0);
  ASSERT_EQ(cache->datasets().size(), 1u);
  EXPECT_EQ(since(l), first) << "a restart must not make World Wind Java drop its tiles";
  EXPECT_EQ(cache->datasets().size(), 1u) << "a restart registers nothing new";
  LayerSpec changed = l;
  changed.dataset.mimeType = "image/png"; // another definition: another dataset
  const UnixMillis changedSince = since(changed);
  const auto datasets = cache->datasets();
  ASSERT_EQ(datasets.size(), 2u);
  for (const auto& d : datasets)
    EXPECT_EQ(d.createdAt, d.spec.mimeType == "image/png" ? changedSince : first) << d.folder;
  EXPECT_GE(changedSince, first);
  EXPECT_EQ(since(l), first);
}

TEST(ProxyIntegration, MetricsCountWhatHappened) {
  test::FakeUpstream up(tileReply);
  Proxy p(up.url("/wms"));
  ASSERT_EQ(p.get("/wwtile?T=sat&L=0&X=0&Y=0").status, 200);  // miss
  ASSERT_EQ(p.get("/wwtile?T=sat&L=0&X=0&Y=0").status, 200);  // hit
  ASSERT_EQ(p.get(kWms130).status, 200);                      // hit
  ASSERT_EQ(p.get("/tiles/sat/0/0/0_0.jpg").status, 200);     // hit
  ASSERT_EQ(p.get("/wwtile?T=sat&L=0&X=99&Y=0").status, 404); // outside the grid
  ASSERT_EQ(p.get("/nothing-here").status, 404);
  const auto m = p.get("/metrics");
  ASSERT_EQ(m.status, 200);
  EXPECT_EQ(m.header("content-type"), "text/plain; version=0.0.4; charset=utf-8");
  auto has = [&](const std::string& line) {
    EXPECT_NE(m.body.find("\n" + line + "\n"), std::string::npos) << line << "\n" << m.body;
  };
  has("tellus_http_requests_total{protocol=\"worldwind\",code=\"200\"} 2");
  has("tellus_http_requests_total{protocol=\"worldwind\",code=\"404\"} 1");
  has("tellus_http_requests_total{protocol=\"wms\",code=\"200\"} 1");
  has("tellus_http_requests_total{protocol=\"static\",code=\"200\"} 1");
  has("tellus_http_requests_total{protocol=\"other\",code=\"404\"} 1");
  has("tellus_tiles_total{layer=\"sat\",result=\"miss\"} 1");
  has("tellus_tiles_total{layer=\"sat\",result=\"hit\"} 3");
  has("tellus_tiles_total{layer=\"sat\",result=\"absent\"} 1");
  has("tellus_upstream_requests_total{upstream=\"up\"} 1");
  has("tellus_upstream_request_duration_seconds_count{upstream=\"up\"} 1");
  has("tellus_upstream_breaker_open{upstream=\"up\"} 0");
  has("tellus_http_requests_in_flight{protocol=\"metrics\"} 1"); // this very request
  const auto bytes = m.body.find("\ntellus_cache_bytes ");
  ASSERT_NE(bytes, std::string::npos);
  EXPECT_GT(std::stoll(m.body.substr(bytes + 20)), 0);
}

TEST(ProxyIntegration, AccessLogHasALinePerRequest) {
  test::FakeUpstream up(tileReply);
  Proxy p(up.url("/wms"));
  const auto file = p.dir.path() / "access.log";
  std::string err;
  ASSERT_TRUE(logger().openAccessLog(file.string(), &err)) << err;
  ASSERT_EQ(p.get("/wwtile?T=sat&L=0&X=0&Y=0").status, 200);
  ASSERT_EQ(p.get("/wwtile?T=sat&L=0&X=0&Y=0").status, 200);
  ASSERT_EQ(p.get("/nothing").status, 404);
  ASSERT_TRUE(logger().openAccessLog("", &err)); // off again for the other tests
  std::ifstream in(file);
  std::vector<std::string> got;
  for (std::string l; std::getline(in, l);)
    got.push_back(l);
  ASSERT_EQ(got.size(), 3u);
  EXPECT_NE(got[0].find("target=\"/wwtile?T=sat&L=0&X=0&Y=0\" status=200"), std::string::npos)
      << got[0];
  EXPECT_NE(got[0].find("cache=MISS protocol=worldwind"), std::string::npos) << got[0];
  EXPECT_NE(got[1].find("cache=HIT"), std::string::npos) << got[1];
  EXPECT_NE(got[2].find("target=/nothing status=404"), std::string::npos) << got[2];
  EXPECT_NE(got[2].find("remote=127.0.0.1 method=GET"), std::string::npos) << got[2];
}

// ------------------------------------------------------------------ seeding through the service

TEST(SeederIntegration, SeedsARemoteLayerOnceAndResumesFromTheIndex) {
  test::FakeUpstream up(tileReply);
  Proxy p(up.url("/wms"));
  ServiceSeedOptions o;
  o.range.fromLevel = 0;
  o.range.toLevel = 1;
  o.range.box = Sector{-180, -90, -108, -18}; // 2x2 tiles at level 0, 4x4 at level 1
  o.concurrency = 3;
  int progressCalls = 0;
  auto r = seedThroughService(
      *p.tiles, *p.cache, "sat", o, [&](const SeedReport&, double) { ++progressCalls; });
  ASSERT_TRUE(r) << r.error();
  EXPECT_EQ(r->planned, 20);
  EXPECT_EQ(r->written, 20);
  EXPECT_EQ(r->failed, 0);
  EXPECT_GT(r->bytes, 0);
  EXPECT_GE(progressCalls, 1);
  EXPECT_EQ(up.requests(), 20u);
  EXPECT_LE(up.maxConcurrent(), 3);
  // Again: everything is in the index, nothing goes upstream.
  auto again = seedThroughService(*p.tiles, *p.cache, "sat", o);
  ASSERT_TRUE(again);
  EXPECT_EQ(again->skipped, 20);
  EXPECT_EQ(again->written, 0);
  EXPECT_EQ(up.requests(), 20u);
  // A dry run counts and estimates, and asks nobody.
  o.range.toLevel = 2;
  o.range.dryRun = true;
  o.estimateBytesPerTile = 1000;
  auto dry = seedThroughService(*p.tiles, *p.cache, "sat", o);
  ASSERT_TRUE(dry);
  EXPECT_EQ(dry->planned, 20 + 64);
  EXPECT_EQ(dry->bytes, 84000);
  EXPECT_EQ(up.requests(), 20u);
}

TEST(SeederIntegration, AbsentIsNotAFailureAndFailuresAreRetriedThenListed) {
  std::atomic<int> brokenCalls{0};
  test::FakeUpstream up([&](const test::FakeRequest& req) {
    // Level 0 of the 36-degree grid: the tile at column 0 is missing, the one at column 1 broken.
    if (req.target.find("BBOX=-90,-180,-54,-144") != std::string::npos)
      return test::FakeReply::withStatus(404, "no tile");
    if (req.target.find("BBOX=-90,-144,-54,-108") != std::string::npos) {
      ++brokenCalls;
      return test::FakeReply::withStatus(500, "broken");
    }
    return tileReply(req);
  });
  Proxy p(up.url("/wms")); // upstream policy: 1 retry inside each fetch
  ServiceSeedOptions o;
  o.range.box = Sector{-180, -90, -72, -54}; // 3 tiles at level 0
  o.retries = 2;
  auto r = seedThroughService(*p.tiles, *p.cache, "sat", o);
  ASSERT_TRUE(r) << r.error();
  EXPECT_EQ(r->planned, 3);
  EXPECT_EQ(r->written, 1);
  EXPECT_EQ(r->absent, 1);
  EXPECT_EQ(r->failed, 1);
  EXPECT_EQ(r->retried, 2);
  ASSERT_EQ(r->failures.size(), 1u);
  EXPECT_NE(r->failures[0].find("L0 R0 C1"), std::string::npos) << r->failures[0];
  EXPECT_EQ(brokenCalls.load(), 3 * 2); // 3 seeding attempts, each fetch tried twice
}

TEST(SeederIntegration, RateLimitSpacesTheStarts) {
  test::FakeUpstream up(tileReply);
  Proxy p(up.url("/wms"));
  ServiceSeedOptions o;
  o.range.fromLevel = o.range.toLevel = 1;
  o.range.box = Sector{-180, -90, -108, -18}; // 16 tiles
  o.rate = 50;
  const auto t0 = std::chrono::steady_clock::now();
  auto r = seedThroughService(*p.tiles, *p.cache, "sat", o);
  const auto took = std::chrono::steady_clock::now() - t0;
  ASSERT_TRUE(r) << r.error();
  EXPECT_EQ(r->written, 16);
  EXPECT_GE(took, 290ms); // 16 starts at 50/s: the last one 300 ms after the first
}

// ------------------------------------------------------------------------------ composed GetMap

namespace {

/** The pixels of a PNG or JPEG answer. */
DecodedImage decodeAnswer(const test::HttpResult& r, int width, int height) {
  std::span<const std::byte> bytes(reinterpret_cast<const std::byte*>(r.body.data()),
                                   r.body.size());
  auto img = decodeImagery(bytes, r.header("content-type"), width, height);
  EXPECT_TRUE(img) << (img ? "" : img.error()) << " " << r.body.substr(0, 300);
  return img ? std::move(*img) : DecodedImage{};
}

std::array<int, 3> rgbAt(const DecodedImage& img, int x, int y) {
  const auto* p = &img.pixels[static_cast<std::size_t>((y * img.width + x) * img.channels)];
  return {p[0], p[1], p[2]};
}

/** The colour of a cached tile of "sat" (its centre pixel), through the World Wind endpoint. */
std::array<int, 3> tileColour(const Proxy& p, int level, int col, int row) {
  const auto r = p.get("/wwtile?T=sat&L=" + std::to_string(level) + "&X=" + std::to_string(col) +
                       "&Y=" + std::to_string(row));
  EXPECT_EQ(r.status, 200);
  const auto img = decodeAnswer(r, 256, 256);
  return img.pixels.empty() ? std::array<int, 3>{-1, -1, -1} : rgbAt(img, 128, 128);
}

void expectNear(std::array<int, 3> a,
                std::array<int, 3> b,
                int tolerance,
                const std::string& what) {
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(a[static_cast<std::size_t>(c)], b[static_cast<std::size_t>(c)], tolerance)
        << what << " channel " << c;
}

std::string getMap(const std::string& layers,
                   const std::string& bbox,
                   int w,
                   int h,
                   const std::string& format,
                   const std::string& extra = "") {
  return "/wms?SERVICE=WMS&REQUEST=GetMap&VERSION=1.3.0&LAYERS=" + layers +
         "&STYLES=&CRS=CRS:84&BBOX=" + bbox + "&WIDTH=" + std::to_string(w) +
         "&HEIGHT=" + std::to_string(h) + "&FORMAT=" + format + extra;
}

/** A layer of "sat"'s upstream data (JPEG) on another grid (issue 29). */
LayerSpec satDataOn(const std::string& name, const GridSpec& grid) {
  LayerSpec l;
  l.name = name;
  l.upstreamLayer = "upsat";
  l.dataset.grid = grid;
  l.dataset.mimeType = "image/jpeg";
  l.maxAge = 3600s;
  return l;
}

/** The answer is tile (3, 4, 8) of "sat-geographic" as the upstream sent it: the one GetMap made,
 * of 256 x 256 pixels, its bytes untouched, the same as that layer's /tiles/ answer. */
void expectTheGeographicTile(test::FakeUpstream& up, Proxy& p, const auto& r) {
  ASSERT_EQ(up.requests(), 1u);
  const std::string asked = up.received().front().target;
  EXPECT_NE(asked.find("WIDTH=256&HEIGHT=256"), std::string::npos) << asked;
  EXPECT_EQ(r.body, jpegFor(asked)) << "the upstream's bytes as they are, not composed";
  EXPECT_EQ(p.get("/tiles/sat-geographic/3/4/4_8.jpg").body, r.body);
}

} // namespace

TEST(ComposeIntegration, AnyBoxIsComposedFromTilesFetchedOnce) {
  test::FakeUpstream up(tileReply);
  Proxy p(up.url("/wms"));
  // Level 0 (0.14 degree texels) serves 0.23-degree pixels: 3 x 2 tiles of 36 degrees.
  const std::string target = getMap("sat", "-170,-80,-100,-30", 300, 200, "image/png");
  const auto r = p.get(target);
  ASSERT_EQ(r.status, 200);
  ASSERT_EQ(r.header("content-type"), "image/png") << r.body.substr(0, 400);
  EXPECT_EQ(up.requests(), 6u);
  const auto img = decodeAnswer(r, 300, 200);
  ASSERT_EQ(img.channels, 3) << "an opaque PNG is 24-bit";
  // (-160, -70) lies in tile (0, 0, 0); (-120, -40) in tile (0, row 1, col 1).
  expectNear(rgbAt(img, 43, 160), tileColour(p, 0, 0, 0), 2, "tile 0/0/0");
  expectNear(rgbAt(img, 214, 40), tileColour(p, 0, 1, 1), 2, "tile 0/1/1");
  EXPECT_EQ(up.requests(), 6u) << "the World Wind requests were hits";
  // Again: every tile a hit, the same validator, and 304 for a client that has it.
  const auto again = p.get(target);
  EXPECT_EQ(again.header("x-cache"), "HIT");
  EXPECT_EQ(again.header("etag"), r.header("etag"));
  EXPECT_EQ(again.body, r.body);
  EXPECT_EQ(p.get(target, {{"If-None-Match", r.header("etag")}}).status, 304);
  // An 8-bit PNG (MapServer's and MapProxy's spelling, and GeoServer's): a palette image.
  for (const char* f : {"image/png;%20mode=8bit", "image/png8"}) {
    const auto p8 = p.get(getMap("sat", "-170,-80,-100,-30", 300, 200, f));
    ASSERT_EQ(p8.header("content-type"), "image/png") << p8.body.substr(0, 400);
    ASSERT_GT(p8.body.size(), 26u);
    EXPECT_EQ(static_cast<int>(p8.body[25]), 3) << "IHDR colour type 3: palette";
    const auto img8 = decodeAnswer(p8, 300, 200);
    expectNear(rgbAt(img8, 43, 160), tileColour(p, 0, 0, 0), 8, "8-bit tile 0/0/0");
  }
  // JPEG and a transparent PNG of the same box; a box past the pole has transparent rows.
  const auto jpeg = p.get(getMap("sat", "-170,-80,-100,-30", 300, 200, "image/jpeg"));
  EXPECT_EQ(jpeg.header("content-type"), "image/jpeg");
  const auto clear =
      p.get(getMap("sat", "-170,60,-100,110", 70, 50, "image/png", "&TRANSPARENT=TRUE"));
  const auto rgba = decodeAnswer(clear, 70, 50);
  ASSERT_EQ(rgba.channels, 4);
  EXPECT_EQ(rgba.pixels[3], 0) << "north of the pole: transparent";
  EXPECT_EQ(rgba.pixels[static_cast<std::size_t>((49 * 70) * 4 + 3)], 255) << "lat 60: opaque";
}

TEST(ComposeIntegration, AntimeridianBoxJoinsBothSides) {
  test::FakeUpstream up(tileReply);
  Proxy p(up.url("/wms"));
  // 0.08-degree pixels: level 1 (18-degree tiles; level 0's 0.14-degree texels would be 1.76
  // pixels), columns 19 and 0, rows 4 and 5.
  const auto r = p.get(getMap("sat", "170,-10,190,10", 250, 250, "image/png"));
  ASSERT_EQ(r.status, 200);
  ASSERT_EQ(r.header("content-type"), "image/png") << r.body.substr(0, 400);
  EXPECT_EQ(up.requests(), 4u);
  const auto img = decodeAnswer(r, 250, 250);
  expectNear(rgbAt(img, 62, 62), tileColour(p, 1, 19, 5), 2, "west of 180, north");
  expectNear(rgbAt(img, 187, 187), tileColour(p, 1, 0, 4), 2, "east of 180, south");
}

// Issue 29: a map coarser than level zero comes from a layer of the same upstream layer on a
// coarser global grid (here 90-degree tiles: 8 tiles for the world, not level zero's 50), and
// /metrics counts what composed maps cost upstream against what they return. A map that the
// coarser grid would magnify more than sqrt 2 times still comes from "sat".
TEST(ComposeIntegration, CoarseMapsComeFromTheSameDataOnACoarserGrid) {
  test::FakeUpstream up(tileReply);
  const LayerSpec ov = satDataOn("sat-overview", GridSpec{Sector{}, 90.0, 256, 256, 1});
  Proxy p(up.url("/wms"), UpstreamSpec::Type::Wms, 0ms, Proxy::fastPolicy(), "upsat", {}, {ov});
  // 1-degree pixels: the overview's 0.35-degree texels.
  ASSERT_EQ(p.get(getMap("sat", "-180,-90,180,90", 360, 180, "image/png")).status, 200);
  EXPECT_EQ(up.requests(), 8u);
  // 0.2-degree pixels: the overview would be 1.76 times the pixel; level 0 of "sat", 3 x 2 tiles.
  ASSERT_EQ(p.get(getMap("sat", "-170,-80,-100,-30", 350, 250, "image/png")).status, 200);
  EXPECT_EQ(up.requests(), 14u);
  const auto m = p.get("/metrics");
  ASSERT_EQ(m.status, 200);
  const auto value = [&](const std::string& name) { return metricValue(m.body, name); };
  EXPECT_EQ(value("tellus_compose_output_texels_total"), 360 * 180 + 350 * 250) << m.body;
  EXPECT_EQ(value("tellus_compose_source_texels_total{origin=\"upstream\"}"), 14 * 256 * 256);
  EXPECT_EQ(value("tellus_compose_source_texels_total{origin=\"cache\"}"), 0);
}

// Issue 29: a GetMap that is exactly one tile of another layer of the same upstream data (here on
// CesiumJS's geographic grid: 180-degree roots of 256 px) is that layer's tile, fetched once as it
// is and then served from the cache, whichever of the two names it asks for. Composed from "sat"
// (36-degree roots) the same map took four of its level-1 tiles.
TEST(ComposeIntegration, AGetMapThatIsATileOfTheSameDataOnAnotherGridIsThatTile) {
  test::FakeUpstream up(tileReply);
  const LayerSpec geo = satDataOn("sat-geographic", GridSpec{Sector{}, 180.0, 256, 256, 8});
  Proxy p(up.url("/wms"), UpstreamSpec::Type::Wms, 0ms, Proxy::fastPolicy(), "upsat", {}, {geo});
  const std::string box = "0,0,22.5,22.5"; // level 3 of that grid: row 4, column 8
  const auto r = p.get(getMap("sat", box, 256, 256, "image/jpeg"));
  ASSERT_EQ(r.status, 200) << r.body.substr(0, 400);
  EXPECT_EQ(r.header("content-type"), "image/jpeg");
  expectTheGeographicTile(up, p, r);
  for (const char* name : {"sat", "sat-geographic"}) {
    const auto again = p.get(getMap(name, box, 256, 256, "image/jpeg"));
    EXPECT_EQ(again.header("x-cache"), "HIT") << name;
    EXPECT_EQ(again.body, r.body) << name;
  }
  EXPECT_EQ(up.requests(), 1u);
  // In another format, or a box that is no tile of either: composed from "sat", as before.
  ASSERT_EQ(p.get(getMap("sat", box, 256, 256, "image/png")).status, 200);
  EXPECT_EQ(up.requests(), 5u);
  ASSERT_EQ(p.get(getMap("sat", "0,0,22,22", 256, 256, "image/jpeg")).status, 200);
  EXPECT_EQ(up.requests(), 5u) << "the same four tiles of sat";
}

// The same through WMTS: a WorldCRS84Quad tile (256 px, rows from the north) that is exactly one
// tile of a layer of the same upstream data on a grid that lines up is that tile, served as it is
// and cached once, whichever of the two layers it names; composed from "sat"'s tiles before.
TEST(ComposeIntegration, AWmtsQuadTileThatIsATileOfTheSameDataOnAnotherGridIsThatTile) {
  test::FakeUpstream up(tileReply);
  const LayerSpec geo = satDataOn("sat-geographic", GridSpec{Sector{}, 180.0, 256, 256, 8});
  Proxy p(up.url("/wms"), UpstreamSpec::Type::Wms, 0ms, Proxy::fastPolicy(), "upsat", {}, {geo});
  // WorldCRS84Quad level 3 is 22.5-degree tiles: row 3 (from 90 N), column 8 is 0..22.5 E, 0..22.5
  // N, tile (3, 4, 8) of "sat-geographic".
  const auto r = p.get("/wmts/1.0.0/sat/default/WorldCRS84Quad/3/3/8.jpg");
  ASSERT_EQ(r.status, 200) << r.body.substr(0, 400);
  expectTheGeographicTile(up, p, r);
  for (const char* name : {"sat", "sat-geographic"}) {
    const auto again =
        p.get("/wmts/1.0.0/" + std::string(name) + "/default/WorldCRS84Quad/3/3/8.jpg");
    EXPECT_EQ(again.header("x-cache"), "HIT") << name;
    EXPECT_EQ(again.body, r.body) << name;
  }
  EXPECT_EQ(up.requests(), 1u);
  // Without the layer on that grid: composed from four of "sat"'s level-1 tiles.
  Proxy alone(up.url("/wms"), UpstreamSpec::Type::Wms, 0ms, Proxy::fastPolicy(), "upsat");
  ASSERT_EQ(alone.get("/wmts/1.0.0/sat/default/WorldCRS84Quad/3/3/8.jpg").status, 200);
  EXPECT_EQ(up.requests(), 5u);
}

// A client asking for another format than the layer's (World Wind's imagery JPEG, a CesiumJS set
// up for PNG): a PNG GetMap of "sat" (JPEG) that is exactly a tile of a PNG layer of the same
// data is that layer's tile. Before, its format being not "sat"'s, it was composed from "sat"'s.
TEST(ComposeIntegration, AGetMapInAnotherFormatIsATileOfTheSameDataInThatFormat) {
  test::FakeUpstream up([](const test::FakeRequest& req) {
    if (req.target.find("png") == std::string::npos) return tileReply(req); // FORMAT, encoded
    std::vector<std::uint8_t> px(256 * 256 * 3, 77);
    const auto png = *encodeImage("image/png", 256, 256, 3, px.data());
    return test::FakeReply::ok(std::string(reinterpret_cast<const char*>(png.data()), png.size()),
                               "image/png");
  });
  LayerSpec geo = satDataOn("sat-geographic", GridSpec{Sector{}, 180.0, 256, 256, 8});
  geo.dataset.mimeType = "image/png";
  Proxy p(up.url("/wms"), UpstreamSpec::Type::Wms, 0ms, Proxy::fastPolicy(), "upsat", {}, {geo});
  const auto r = p.get(getMap("sat", "0,0,22.5,22.5", 256, 256, "image/png"));
  ASSERT_EQ(r.status, 200) << r.body.substr(0, 400);
  EXPECT_EQ(r.header("content-type"), "image/png");
  EXPECT_EQ(up.requests(), 1u);
  EXPECT_EQ(p.get("/tiles/sat-geographic/3/4/4_8.png").body, r.body);
  EXPECT_EQ(p.get(getMap("sat", "0,0,22.5,22.5", 256, 256, "image/png")).body, r.body);
  EXPECT_EQ(up.requests(), 1u);
  // In "sat"'s own JPEG: composed from its tiles (no JPEG layer on that grid).
  ASSERT_EQ(p.get(getMap("sat", "0,0,22.5,22.5", 256, 256, "image/jpeg")).status, 200);
  EXPECT_EQ(up.requests(), 5u);
}

TEST(ComposeIntegration, LayersAreDrawnInOrderWithTheirOpacity) {
  // The overlay answers an opaque blue PNG; "sat" a JPEG of its own colour.
  test::FakeUpstream up([](const test::FakeRequest& req) {
    if (req.target.find("LAYERS=upoverlay") == std::string::npos) return tileReply(req);
    std::vector<std::uint8_t> px(256 * 256 * 4);
    for (std::size_t i = 0; i < px.size(); i += 4) {
      px[i + 2] = 255;
      px[i + 3] = 255;
    }
    const auto png = *encodeImage("image/png", 256, 256, 4, px.data());
    return test::FakeReply::ok(std::string(reinterpret_cast<const char*>(png.data()), png.size()),
                               "image/png");
  });
  LayerSpec overlay;
  overlay.name = "overlay";
  overlay.upstreamLayer = "upoverlay";
  overlay.dataset.grid = GridSpec{Sector{}, 36.0, 256, 256, 4};
  overlay.dataset.mimeType = "image/png";
  overlay.opacity = 0.25;
  Proxy p(
      up.url("/wms"), UpstreamSpec::Type::Wms, 0ms, Proxy::fastPolicy(), "upsat", {}, {overlay});
  const auto base = tileColour(p, 0, 5, 2);
  const std::string box = "5,-15,30,10"; // inside tile (0, 2, 5)
  const auto half = decodeAnswer(
      p.get(getMap("sat,overlay", box, 50, 50, "image/png", "&OPACITIES=1,0.5")), 50, 50);
  expectNear(rgbAt(half, 25, 25),
             {(base[0] + 1) / 2, (base[1] + 1) / 2, (base[2] + 255 + 1) / 2},
             2,
             "half blue over the base");
  // Without OPACITIES the configured 0.25 applies.
  const auto quarter = decodeAnswer(p.get(getMap("sat,overlay", box, 50, 50, "image/png")), 50, 50);
  expectNear(rgbAt(quarter, 25, 25),
             {base[0] * 3 / 4, base[1] * 3 / 4, (base[2] * 3 + 255) / 4},
             2,
             "a quarter blue over the base");
  // In the other order the opaque base hides the overlay.
  const auto hidden = decodeAnswer(p.get(getMap("overlay,sat", box, 50, 50, "image/png")), 50, 50);
  expectNear(rgbAt(hidden, 25, 25), base, 2, "base on top");
}

TEST(ComposeIntegration, HolesAreFilledFromCoarserLevelsOrReported) {
  std::atomic<int> status{200};
  test::FakeUpstream up([&](const test::FakeRequest& r) {
    if (status == 200) return tileReply(r);
    return test::FakeReply::withStatus(status.load(), "nope");
  });
  Proxy p(up.url("/wms"));
  const auto parent = tileColour(p, 0, 5, 2); // cached: level 0, lon 0..36, lat -18..18
  // Level 1 has no tiles there (404): the map is drawn from level 0, and not kept for long.
  status = 404;
  const std::string target = getMap("sat", "2,-16,16,-2", 200, 200, "image/png");
  const auto filled = p.get(target);
  ASSERT_EQ(filled.header("content-type"), "image/png") << filled.body.substr(0, 400);
  EXPECT_EQ(filled.header("cache-control"), "public, max-age=60, s-maxage=60");
  expectNear(rgbAt(decodeAnswer(filled, 200, 200), 100, 100), parent, 2, "level 0 fills in");
  // A failing upstream where level 0 is cached: still a map, from level 0.
  status = 500;
  const auto failing = p.get(getMap("sat", "20,2,34,16", 200, 200, "image/png"));
  EXPECT_EQ(failing.header("content-type"), "image/png") << failing.body.substr(0, 400);
  // A failing upstream and nothing cached at all: an exception, never a blank map.
  const auto nothing = p.get(getMap("sat", "-110,2,-96,16", 200, 200, "image/png"));
  EXPECT_NE(nothing.body.find("NoApplicableCode"), std::string::npos) << nothing.body;
  // The pixel limit.
  FrontEndOptions small;
  small.maxMapPixels = 10000;
  Proxy limited(up.url("/wms"), UpstreamSpec::Type::Wms, 0ms, Proxy::fastPolicy(), "upsat", small);
  const auto big = limited.get(getMap("sat", "2,-16,16,-2", 101, 100, "image/png"));
  EXPECT_NE(big.body.find("InvalidParameterValue"), std::string::npos) << big.body;
}

namespace {

/** jpegFor's tile, with 4:4:4 sampling (no chroma subsampling). */
std::string jpeg444For(const std::string& target, int size = 256) {
  const auto h = stableHash64(target);
  std::vector<std::uint8_t> px(static_cast<std::size_t>(size * size * 3));
  for (std::size_t i = 0; i < px.size(); i += 3) {
    px[i] = static_cast<std::uint8_t>(h);
    px[i + 1] = static_cast<std::uint8_t>(h >> 8);
    px[i + 2] = static_cast<std::uint8_t>(h >> 16);
  }
  // 4:4:4 (luma 1 x 1), quality 75: a tile that the composer's YCbCr path leaves to the RGB path.
  const auto bytes = *codec::encodeJpeg(
      size, size, 3, px.data(), {.quality = 75, .lumaSamplingH = 1, .lumaSamplingV = 1});
  return std::string(reinterpret_cast<const char*>(bytes.data()), bytes.size());
}

} // namespace

TEST(ComposeIntegration, JpegMapsFromTilesOfAnySubsampling) {
  // JPEG maps of 4:2:0 JPEG tiles are composed on Y, Cb and Cr planes; a tile of another
  // subsampling sends the map to the RGB path. Either way the map shows each tile's colour, and
  // the background (BGCOLOR) past the pole.
  for (const int every : {0, 1, 3}) { // 4:4:4 tiles: none, all, every third
    SCOPED_TRACE(every);
    test::FakeUpstream up([every](const test::FakeRequest& req) {
      const bool full = every > 0 && stableHash64(req.target) % static_cast<unsigned>(every) == 0;
      auto r =
          test::FakeReply::ok(full ? jpeg444For(req.target) : jpegFor(req.target), "image/jpeg");
      r.headers.emplace_back("ETag", "\"v1\"");
      return r;
    });
    Proxy p(up.url("/wms"));
    // Level 0, 3 x 2 tiles; an odd size.
    const auto r = p.get(getMap("sat", "-170,-80,-100,-30", 301, 201, "image/jpeg"));
    ASSERT_EQ(r.header("content-type"), "image/jpeg") << r.body.substr(0, 400);
    const auto img = decodeAnswer(r, 301, 201);
    ASSERT_FALSE(img.pixels.empty());
    // (-160, -70) lies in tile (0, 0, 0); (-120, -40) in tile (0, row 1, col 1).
    expectNear(rgbAt(img, 43, 160), tileColour(p, 0, 0, 0), 4, "tile 0/0/0");
    expectNear(rgbAt(img, 214, 40), tileColour(p, 0, 1, 1), 4, "tile 0/1/1");
    // Past the north pole: BGCOLOR (navy), converted to YCbCr on the planar path.
    const auto pole =
        p.get(getMap("sat", "-170,60,-100,110", 71, 51, "image/jpeg", "&BGCOLOR=0x000080"));
    ASSERT_EQ(pole.header("content-type"), "image/jpeg") << pole.body.substr(0, 400);
    const auto navy = decodeAnswer(pole, 71, 51);
    expectNear(rgbAt(navy, 35, 2), {0, 0, 128}, 4, "north of the pole");
    expectNear(rgbAt(navy, 35, 48), tileColour(p, 0, 1, 4), 4, "lat 62");
  }
}

TEST(ComposeIntegration, HeightsAreExactWhereTheBoxIsAligned) {
  // The upstream's heights are ten times the longitude of each texel's centre (and "sat" is
  // imagery as everywhere).
  test::FakeUpstream up([](const test::FakeRequest& req) {
    if (req.target.find("LAYERS=upsat") != std::string::npos) return tileReply(req);
    const auto at = req.target.find("BBOX=");
    double s = 0, w = 0, n = 0, e = 0;
    std::sscanf(req.target.c_str() + at + 5, "%lf,%lf,%lf,%lf", &s, &w, &n, &e);
    std::string body(256 * 256 * 2, '\0');
    for (int y = 0; y < 256; ++y) {
      for (int x = 0; x < 256; ++x) {
        const auto h = static_cast<std::uint16_t>(
            static_cast<std::int16_t>(std::lround((w + (x + 0.5) * (e - w) / 256) * 10)));
        body[static_cast<std::size_t>((y * 256 + x) * 2)] = static_cast<char>(h & 0xFF);
        body[static_cast<std::size_t>((y * 256 + x) * 2 + 1)] = static_cast<char>(h >> 8);
      }
    }
    return test::FakeReply::ok(body, "application/bil16");
  });
  LayerSpec dem;
  dem.name = "dem";
  dem.upstreamLayer = "updem";
  dem.dataset.grid = GridSpec{Sector{}, 36.0, 256, 256, 4};
  dem.dataset.mimeType = "application/bil16";
  dem.elevation = true;
  Proxy p(up.url("/wms"), UpstreamSpec::Type::Wms, 0ms, Proxy::fastPolicy(), "upsat", {}, {dem});
  // Level 0 texels are 36/256 degrees; a box of 100 x 60 texels from texel (1290, 700), across
  // tiles, is aligned with them but with no tile.
  const double t = 36.0 / 256.0;
  const double west = -180.0 + 1290 * t, north = 90.0 - 700 * t;
  char bbox[160];
  std::snprintf(
      bbox, sizeof bbox, "%.17g,%.17g,%.17g,%.17g", west, north - 60 * t, west + 100 * t, north);
  for (const char* format : {"application/bil16", "image/tiff", "image/png"}) {
    SCOPED_TRACE(format);
    const auto r = p.get(getMap("dem", bbox, 100, 60, format));
    ASSERT_EQ(r.header("content-type"), format) << r.body.substr(0, 400);
    const auto heights =
        decodeHeights(std::span<const std::byte>(reinterpret_cast<const std::byte*>(r.body.data()),
                                                 r.body.size()),
                      format,
                      100,
                      60);
    ASSERT_TRUE(heights) << heights.error();
    int wrong = 0;
    for (int j = 0; j < 60; ++j) {
      for (int i = 0; i < 100; ++i) {
        const auto expected = std::lround((west + (i + 0.5) * t) * 10);
        wrong += (*heights)[static_cast<std::size_t>(j * 100 + i)] != expected;
      }
    }
    EXPECT_EQ(wrong, 0);
  }
  // Heights in a picture format are the grey picture of the same heights (heightToGrey), exact
  // in a lossless one; so are heights drawn over imagery (they have data everywhere here).
  for (const std::string layers : {"dem", "sat,dem"}) {
    for (const char* format : {"image/png;%20mode=24bit", "image/png"}) {
      if (layers == "dem" && std::string_view(format) == "image/png") continue; // 16-bit heights
      SCOPED_TRACE(layers + " " + format);
      const auto r = p.get(getMap(layers, bbox, 100, 60, format));
      ASSERT_EQ(r.header("content-type"), "image/png") << r.body.substr(0, 400);
      const auto img = decodeAnswer(r, 100, 60);
      ASSERT_FALSE(img.pixels.empty());
      int wrong = 0;
      for (int j = 0; j < 60; ++j) {
        for (int i = 0; i < 100; ++i) {
          const int grey =
              heightToGrey(static_cast<std::int16_t>(std::lround((west + (i + 0.5) * t) * 10)));
          wrong += rgbAt(img, i, j) != std::array<int, 3>{grey, grey, grey};
        }
      }
      EXPECT_EQ(wrong, 0);
    }
  }
  const auto jpeg = p.get(getMap("dem", bbox, 100, 60, "image/jpeg"));
  EXPECT_EQ(jpeg.header("content-type"), "image/jpeg") << jpeg.body.substr(0, 400);
  // Imagery in heights is its luminance: drawn over the heights it replaces them (0 - 255).
  const auto luma = p.get(getMap("dem,sat", bbox, 100, 60, "application/bil16"));
  ASSERT_EQ(luma.header("content-type"), "application/bil16") << luma.body.substr(0, 400);
  const auto values =
      decodeHeights(std::span<const std::byte>(reinterpret_cast<const std::byte*>(luma.body.data()),
                                               luma.body.size()),
                    "application/bil16",
                    100,
                    60);
  ASSERT_TRUE(values) << values.error();
  EXPECT_EQ(std::count_if(
                values->begin(), values->end(), [](std::int16_t v) { return v < 0 || v > 255; }),
            0);
}

namespace {
/** A 300 x 200 JPEG map of one layer through `c`, waited for. */
ComposedMap composeJpeg(MapComposer& c, const LayerSpec* layer, const Sector& box, double opacity) {
  ComposeRequest r;
  r.layers = {ComposeLayer{layer, "", opacity}};
  r.bbox = box;
  r.width = 300;
  r.height = 200;
  r.format = MapFormat::Jpeg;
  std::promise<ComposedMap> done;
  EXPECT_TRUE(c.compose(r, nullptr, [&](ComposedMap&& m) { done.set_value(std::move(m)); }));
  return done.get_future().get();
}
} // namespace

TEST(ComposeIntegration, MetricsShowTheDecodedTilesKept) {
  // tellus serve's default budget (server.limits.decoded_tile_cache, 32 MiB): the same map three
  // times decodes its tiles for the first two (the second keeps them) and samples kept ones in
  // the third; /metrics says so.
  test::FakeUpstream up(tileReply);
  Proxy p(up.url("/wms"));
  const std::string map = getMap("sat", "-170,-80,-100,-30", 300, 200, "image/jpeg");
  for (int i = 0; i < 3; ++i)
    ASSERT_EQ(p.get(map).status, 200);
  const auto m = p.get("/metrics");
  ASSERT_EQ(m.status, 200);
  const auto value = [&](const std::string& name) { return metricValue(m.body, name); };
  const long long decoded = value("tellus_composed_map_tiles_total{source=\"decoded\"}");
  const long long kept = value("tellus_composed_map_tiles_total{source=\"kept\"}");
  EXPECT_GT(kept, 0) << m.body;
  EXPECT_EQ(decoded, 2 * kept) << m.body;
  EXPECT_GT(value("tellus_decoded_tile_cache_bytes"), 0) << m.body;
}

// Issue 29: two maps that need the same missing tiles at once cause one fetch of each; the first
// map counts them as fetched upstream, the second as joined in flight, so that the upstream
// texels /metrics adds up are what the upstream served.
TEST(ComposeIntegration, AFetchJoinedInFlightIsCountedUpstreamOnce) {
  const auto held = std::make_shared<test::Gate>();
  test::FakeUpstream up([&](const test::FakeRequest& r) {
    auto reply = tileReply(r);
    reply.holdUntilOpen = held;
    return reply;
  });
  Proxy p(up.url("/wms"));
  MapComposer c(*p.tiles, 2, 256, 0);
  ComposeRequest r;
  r.layers = {ComposeLayer{p.tiles->layer("sat"), "", 1.0}};
  r.bbox = Sector{-170, -80, -100, -30};
  r.width = 300;
  r.height = 200;
  r.format = MapFormat::Png;
  std::promise<ComposedMap> first, second;
  // Both ask for their tiles (compose() registers them before it returns) while no answer can
  // come back: the second joins the first's fetches.
  ASSERT_TRUE(c.compose(r, nullptr, [&](ComposedMap&& m) { first.set_value(std::move(m)); }));
  ASSERT_TRUE(c.compose(r, nullptr, [&](ComposedMap&& m) { second.set_value(std::move(m)); }));
  held->open();
  const ComposedMap a = first.get_future().get(), b = second.get_future().get();
  ASSERT_EQ(a.kind, ComposedMap::Kind::Map) << a.message;
  ASSERT_EQ(b.kind, ComposedMap::Kind::Map) << b.message;
  EXPECT_EQ(up.requests(), 6u);
  EXPECT_EQ(a.upstreamTexels, 6u * 256 * 256);
  EXPECT_EQ(a.joinedTexels, 0u);
  EXPECT_EQ(b.upstreamTexels, 0u);
  EXPECT_EQ(b.joinedTexels, 6u * 256 * 256);
  EXPECT_EQ(b.bytes, a.bytes);
}

TEST(ComposeIntegration, DecodedTilesAreReusedAndGiveTheSameMap) {
  test::FakeUpstream up(tileReply);
  Proxy p(up.url("/wms"));
  const LayerSpec* sat = p.tiles->layer("sat");
  ASSERT_NE(sat, nullptr);
  const auto compose = [&](MapComposer& c, const Sector& box) {
    return composeJpeg(c, sat, box, 1.0);
  };
  MapComposer cached(*p.tiles, 2, 256, 8u << 20);
  MapComposer uncached(*p.tiles, 2, 256, 0);
  const Sector box{-170, -80, -100, -30};
  const auto first = compose(cached, box);
  ASSERT_EQ(first.kind, ComposedMap::Kind::Map) << first.message;
  EXPECT_EQ(first.decodedTiles, 6u);
  // Tiles are kept from their second use on (the first decodes only the part it samples).
  const auto second = compose(cached, box);
  EXPECT_EQ(second.decodedTiles, 6u);
  EXPECT_EQ(second.bytes, first.bytes);
  const auto third = compose(cached, box);
  EXPECT_EQ(third.decodedTiles, 0u) << "every tile came decoded from the cache";
  EXPECT_EQ(third.bytes, first.bytes);
  // A neighbouring box shares tiles: only the new ones are decoded.
  const auto shifted = compose(cached, Sector{-150, -80, -80, -30});
  EXPECT_LT(shifted.decodedTiles, 6u);
  // Whole tiles cached, or the sampled parts decoded each time: the same map.
  const auto partial = compose(uncached, box);
  EXPECT_EQ(partial.decodedTiles, 6u);
  EXPECT_EQ(partial.bytes, first.bytes);
  // A budget smaller than one tile keeps nothing.
  MapComposer tiny(*p.tiles, 1, 256, 1000);
  compose(tiny, box);
  compose(tiny, box);
  EXPECT_EQ(compose(tiny, box).decodedTiles, 6u);
}

namespace {
/** The first value of a JPEG's first quantisation table (the luma DC step: 16 at quality 50,
 * 5 at 85, 3 at 90 with libjpeg's scaling), or -1 without one. */
int firstQuantStep(const std::vector<std::byte>& jpeg) {
  for (std::size_t i = 2; i + 5 < jpeg.size(); ++i)
    if (jpeg[i] == std::byte{0xFF} && jpeg[i + 1] == std::byte{0xDB})
      return std::to_integer<int>(jpeg[i + 5]); // after the marker, the length and Pq/Tq
  return -1;
}
} // namespace

TEST(ComposeIntegration, JpegMapsHaveTheConfiguredQuality) {
  test::FakeUpstream up(tileReply);
  Proxy p(up.url("/wms"));
  const LayerSpec* sat = p.tiles->layer("sat");
  ASSERT_NE(sat, nullptr);
  // Opaque: the YCbCr planes path; translucent: the RGB path.
  const auto compose = [&](MapComposer& c, double opacity) {
    return composeJpeg(c, sat, Sector{-170, -80, -100, -30}, opacity);
  };
  MapComposer byDefault(*p.tiles, 2, 256, 0);
  MapComposer q85(*p.tiles, 2, 256, 0, 85);
  MapComposer q50(*p.tiles, 2, 256, 0, 50);
  MapComposer outOfRange(*p.tiles, 1, 256, 0, 1000); // clamped to 100
  for (const double opacity : {1.0, 0.5}) {
    SCOPED_TRACE(opacity);
    const auto d = compose(byDefault, opacity), a = compose(q85, opacity),
               b = compose(q50, opacity), top = compose(outOfRange, opacity);
    for (const auto* m : {&d, &a, &b, &top})
      ASSERT_EQ(m->kind, ComposedMap::Kind::Map) << m->message;
    EXPECT_EQ(firstQuantStep(d.bytes), 3);
    EXPECT_EQ(firstQuantStep(a.bytes), 5);
    EXPECT_EQ(firstQuantStep(b.bytes), 16);
    EXPECT_EQ(firstQuantStep(top.bytes), 1);
    EXPECT_LT(b.bytes.size(), a.bytes.size());
    EXPECT_LT(a.bytes.size(), d.bytes.size());
    EXPECT_LT(d.bytes.size(), top.bytes.size());
  }
}

// ------------------------------------------------------------------ issue 21: HTTP edges,
// credentials

namespace {

/** Sends exactly these bytes on a new loopback connection and returns what comes back until the
 * server closes or `quiet` passes without a byte. */
std::string
rawExchange(std::uint16_t port, const std::string& bytes, std::chrono::milliseconds quiet = 500ms) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port);
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  std::string got;
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0) {
    (void)::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL);
    for (;;) {
      pollfd p{fd, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(quiet.count())) <= 0) break;
      char buf[65536];
      const auto n = ::recv(fd, buf, sizeof buf, 0);
      if (n <= 0) break;
      got.append(buf, static_cast<std::size_t>(n));
    }
  }
  ::close(fd);
  return got;
}

std::vector<std::string> readLines(const fs::path& file) {
  std::ifstream in(file);
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);)
    lines.push_back(l);
  return lines;
}

bool hasLine(const std::string& body, const std::string& line) {
  return body.find("\n" + line + "\n") != std::string::npos;
}

} // namespace

TEST(ProxyIntegration, CorsPreflightGets204WithWhatTheBrowserAsked) {
  test::FakeUpstream up(tileReply);
  Proxy p(up.url("/wms"));
  const std::string preflight = rawExchange(
      p.server->port(),
      "OPTIONS /tiles/sat/0/0/0_0.jpg HTTP/1.1\r\nHost: a\r\nOrigin: http://127.0.0.1:9\r\n"
      "Access-Control-Request-Method: GET\r\n"
      "Access-Control-Request-Headers: authorization,x-requested-with\r\n\r\n");
  EXPECT_TRUE(preflight.starts_with("HTTP/1.1 204")) << preflight;
  EXPECT_NE(preflight.find("Access-Control-Allow-Origin: *\r\n"), std::string::npos) << preflight;
  EXPECT_NE(preflight.find("Access-Control-Allow-Methods: GET, HEAD, OPTIONS\r\n"),
            std::string::npos)
      << preflight;
  EXPECT_NE(preflight.find("Access-Control-Allow-Headers: authorization,x-requested-with\r\n"),
            std::string::npos)
      << preflight;
  EXPECT_NE(preflight.find("Access-Control-Max-Age: 86400\r\n"), std::string::npos) << preflight;
  // A plain OPTIONS (no Origin, no requested method) says what is allowed.
  const std::string plain =
      rawExchange(p.server->port(), "OPTIONS /wms HTTP/1.1\r\nHost: a\r\n\r\n");
  EXPECT_TRUE(plain.starts_with("HTTP/1.1 204")) << plain;
  EXPECT_NE(plain.find("Allow: GET, HEAD, OPTIONS\r\n"), std::string::npos) << plain;
  EXPECT_EQ(plain.find("Access-Control-Allow-Methods"), std::string::npos) << plain;
  // Other methods: 405 with Allow.
  const std::string del = rawExchange(p.server->port(), "DELETE /wms HTTP/1.1\r\nHost: a\r\n\r\n");
  EXPECT_TRUE(del.starts_with("HTTP/1.1 405")) << del;
  EXPECT_NE(del.find("Allow: GET, HEAD, OPTIONS\r\n"), std::string::npos) << del;
  // Nothing asked of the upstream by any of it; the real request then works cross-origin.
  EXPECT_EQ(up.requests(), 0u);
  const auto tile = p.get("/tiles/sat/0/0/0_0.jpg",
                          {{"Origin", "http://127.0.0.1:9"}, {"Authorization", "Bearer x"}});
  EXPECT_EQ(tile.status, 200);
  EXPECT_EQ(tile.header("access-control-allow-origin"), "*");
}

// 405, 413, 429, 431 and 400 (the raw space) are in the access log and the request counters like
// any other request.
TEST(ProxyIntegration, RefusedRequestsAreCountedAndLogged) {
  test::FakeUpstream up(tileReply);
  ManualClock clock; // the rate limit's: its tokens come back when the test says
  HttpServerOptions so;
  so.requestsPerSecond = 1; // a burst of 2
  so.maxHeaderBytes = 2048;
  so.clock = &clock;
  Proxy p(up.url("/wms"), UpstreamSpec::Type::Wms, 0ms, Proxy::fastPolicy(), "upsat", {}, {}, so);
  const auto file = p.dir.path() / "access.log";
  std::string err;
  ASSERT_TRUE(logger().openAccessLog(file.string(), &err)) << err;
  const std::uint16_t port = p.server->port();
  const auto statusOf = [](const std::string& r) { return r.substr(0, 12); };
  // Connection: close, so that each exchange ends at once (the rate limit refills meanwhile).
  EXPECT_EQ(
      statusOf(rawExchange(
          port,
          "POST /wms HTTP/1.1\r\nHost: a\r\nConnection: close\r\nContent-Length: 1\r\n\r\nx")),
      "HTTP/1.1 405");
  EXPECT_EQ(statusOf(rawExchange(port, "GET /wwtile?T=sat a HTTP/1.1\r\nHost: a\r\n\r\n")),
            "HTTP/1.1 400");
  EXPECT_EQ(statusOf(rawExchange(port,
                                 "GET /tiles/big HTTP/1.1\r\nHost: a\r\nX-Big: " +
                                     std::string(3000, 'b') + "\r\n\r\n")),
            "HTTP/1.1 431");
  EXPECT_EQ(statusOf(rawExchange(
                port, "GET /wms HTTP/1.1\r\nHost: a\r\nContent-Length: 9999999\r\n\r\n")),
            "HTTP/1.1 413");
  int limited = 0;
  for (int i = 0; i < 4; ++i)
    limited += statusOf(rawExchange(
                   port, "GET /nothing HTTP/1.1\r\nHost: a\r\nConnection: close\r\n\r\n")) ==
               "HTTP/1.1 429";
  EXPECT_GE(limited, 1);
  ASSERT_TRUE(logger().openAccessLog("", &err));
  const auto lines = readLines(file);
  const auto logged = [&](const std::string& what) {
    return std::count_if(lines.begin(), lines.end(), [&](const std::string& l) {
      return l.find(what) != std::string::npos;
    });
  };
  EXPECT_EQ(logged("method=POST target=/wms status=405"), 1) << testing::PrintToString(lines);
  EXPECT_EQ(logged("target=\"/wwtile?T=sat a\" status=400"), 1) << testing::PrintToString(lines);
  EXPECT_EQ(logged("status=431"), 1) << testing::PrintToString(lines);
  EXPECT_EQ(logged("target=/wms status=413"), 1) << testing::PrintToString(lines);
  EXPECT_EQ(logged("target=/nothing status=429"), limited) << testing::PrintToString(lines);
  // The request counters: the rate limit lets the metrics request through a second later.
  clock.advance(1100ms);
  const auto m = p.get("/metrics");
  ASSERT_EQ(m.status, 200) << m.body;
  EXPECT_TRUE(hasLine(m.body, "tellus_http_requests_total{protocol=\"wms\",code=\"405\"} 1"))
      << m.body;
  EXPECT_TRUE(hasLine(m.body, "tellus_http_requests_total{protocol=\"worldwind\",code=\"400\"} 1"))
      << m.body;
  EXPECT_TRUE(hasLine(m.body, "tellus_http_requests_total{protocol=\"wms\",code=\"413\"} 1"))
      << m.body;
  EXPECT_TRUE(hasLine(m.body, "tellus_http_requests_total{protocol=\"static\",code=\"431\"} 1"))
      << m.body;
  EXPECT_TRUE(hasLine(m.body,
                      "tellus_http_requests_total{protocol=\"other\",code=\"429\"} " +
                          std::to_string(limited)))
      << m.body;
  EXPECT_EQ(up.requests(), 0u);
}

// An upstream error text with a server path, a URL with user:password and API keys: no endpoint
// may echo any of it, in any form of error.
TEST(ProxyIntegration, NoEndpointEchoesTheUpstreamsSecrets) {
  test::FakeUpstream up([](const test::FakeRequest&) {
    return test::FakeReply::ok(
        "<?xml version=\"1.0\"?><ServiceExceptionReport><ServiceException>msWMSLoadGetMapParams: "
        "cannot open /srv/maps/secret-world.map via http://admin:hunter2@tiles.internal:8080/x "
        "(apikey=SECRET123, db admin:pw42@db.internal, Authorization: Bearer TOKEN42)"
        "</ServiceException></ServiceExceptionReport>",
        "text/xml");
  });
  Proxy p(up.url("/wms"));
  const std::vector<std::string> targets{
      "/wwtile?T=sat&L=0&X=0&Y=0",
      "/tiles/sat/0/1/1_1.jpg",
      kWms130,
      kWms130 + "&EXCEPTIONS=XML",
      getMap("sat", "2,-16,16,-2", 200, 200, "image/png"),
      "/wms?SERVICE=WMS&REQUEST=GetMap&VERSION=1.1.1&LAYERS=sat&STYLES=&SRS=EPSG:4326"
      "&BBOX=-108,-90,-72,-54&WIDTH=256&HEIGHT=256&FORMAT=image/jpeg"};
  for (const auto& target : targets) {
    const auto r = p.get(target);
    for (const char* secret : {"secret-world",
                               "/srv/",
                               "hunter2",
                               "tiles.internal",
                               "SECRET123",
                               "pw42",
                               "db.internal",
                               "TOKEN42"}) {
      EXPECT_EQ(r.body.find(secret), std::string::npos)
          << target << " echoes '" << secret << "': " << r.body;
    }
    EXPECT_FALSE(r.body.empty()) << target; // an error was said, only without the secrets
  }
  EXPECT_EQ(*p.cache->totalBytes(), 0);
}

// A connection the upstream drops or resets, a 5xx, a timeout: temporary failures, answered 503
// with Retry-After on every endpoint, never "absent" (404, an empty map), and never cached.
TEST(ProxyIntegration, AnUpstreamResetIsATemporaryFailureOnEveryEndpoint) {
  std::atomic<int> mode{0};
  test::FakeUpstream up([&](const test::FakeRequest& r) {
    test::FakeReply reply = tileReply(r);
    reply.closeWithoutResponse = mode == 0;
    reply.resetWithoutResponse = mode == 1;
    reply.hangForever = mode == 3;
    if (mode == 2) return test::FakeReply::withStatus(502, "upstream's proxy says no");
    return reply;
  });
  auto policy = Proxy::fastPolicy();
  policy.timeout = 400ms;            // mode 3 hangs: two attempts of this each
  policy.failureThreshold = 1000000; // the breaker stays closed: each request meets the fault
  Proxy p(up.url("/wms"), UpstreamSpec::Type::Wms, 0ms, policy);
  const std::vector<std::string> targets{
      "/wwtile?T=sat&L=1&X=3&Y=2",
      "/tiles/sat/1/4/4_5.jpg",
      kWms130,                                                   // one tile: the cached file path
      getMap("sat", "-170,-80,-150,-60", 256, 256, "image/png"), // composed from tiles
      getMap("sat", "-170,-80,-150,-60", 256, 256, "image/png", "&EXCEPTIONS=INIMAGE")};
  for (int m = 0; m < 4; ++m) {
    mode = m;
    for (const auto& target : targets) {
      const auto r = p.get(target);
      EXPECT_EQ(r.status, 503) << "mode " << m << " " << target << "\n" << r.body.substr(0, 300);
      EXPECT_GE(std::atoi(r.header("retry-after").c_str()), 1) << "mode " << m << " " << target;
      EXPECT_EQ(r.header("cache-control"), "no-store") << "mode " << m << " " << target;
    }
  }
  EXPECT_EQ(*p.cache->totalBytes(), 0);
  // Nothing was remembered as absent: once the upstream is back, every tile comes.
  mode = 4;
  for (const auto& target : targets) {
    const auto r = p.get(target);
    EXPECT_EQ(r.status, 200) << target << "\n" << r.body.substr(0, 300);
  }
  // Only a real "no such tile" is 404: the upstream's 404 or 204, or a key outside the grid.
  test::FakeUpstream empty(
      [](const test::FakeRequest&) { return test::FakeReply::withStatus(204); });
  Proxy q(empty.url("/wms"));
  EXPECT_EQ(q.get("/wwtile?T=sat&L=1&X=3&Y=2").status, 404);
  EXPECT_EQ(q.get("/wwtile?T=sat&L=0&X=10&Y=0").status, 404);
}

// A redirect to another origin is refused by default: the tile is an upstream failure, nothing is
// cached, and the other origin never sees the configured API key.
TEST(ProxyIntegration, ARedirectToAnotherOriginIsRefusedAndNeverCached) {
  test::FakeUpstream elsewhere(tileReply);
  test::FakeUpstream up([&](const test::FakeRequest& r) {
    auto reply = test::FakeReply::withStatus(302);
    reply.headers.emplace_back("Location", elsewhere.url(r.target));
    return reply;
  });
  auto policy = Proxy::fastPolicy();
  policy.headers = {{"X-Api-Key", "SECRET-KEY"}};
  {
    Proxy p(up.url("/wms"), UpstreamSpec::Type::Wms, 0ms, policy);
    const auto r = p.get("/wwtile?T=sat&L=0&X=0&Y=0");
    EXPECT_EQ(r.status, 502) << r.body;
    EXPECT_EQ(elsewhere.requests(), 0u);
    EXPECT_EQ(*p.cache->totalBytes(), 0);
    EXPECT_EQ(p.get("/wwtile?T=sat&L=0&X=0&Y=0").status, 502) << "not remembered as anything";
  }
  policy.redirects = UpstreamPolicy::Redirects::Any;
  Proxy p(up.url("/wms"), UpstreamSpec::Type::Wms, 0ms, policy);
  EXPECT_EQ(p.get("/wwtile?T=sat&L=0&X=0&Y=0").status, 200);
  ASSERT_EQ(elsewhere.requests(), 1u);
  EXPECT_EQ(elsewhere.received().at(0).header("x-api-key"), "");
  EXPECT_EQ(up.received().back().header("x-api-key"), "SECRET-KEY");
}

// A client past its budget of upstream fetches gets 429 (an OGC exception with status 429 on
// /wms) with Retry-After, while what is cached is still served, and /metrics counts it.
TEST(ProxyIntegration, TheFetchBudgetRefusesPastItAndServesTheCache) {
  test::FakeUpstream up(tileReply);
  ManualClock t;
  FrontEndOptions fo;
  fo.fetchesPerClientPerMinute = 3; // three at once, then one every 20 s
  fo.clock = &t;
  Proxy p(up.url("/wms"), UpstreamSpec::Type::Wms, 0ms, Proxy::fastPolicy(), "upsat", fo);
  for (int x = 0; x < 3; ++x)
    ASSERT_EQ(p.get("/wwtile?T=sat&L=1&X=" + std::to_string(x) + "&Y=0").status, 200) << x;
  const auto refused = p.get("/wwtile?T=sat&L=1&X=3&Y=0");
  EXPECT_EQ(refused.status, 429) << refused.body;
  EXPECT_EQ(refused.header("retry-after"), "20");
  EXPECT_EQ(refused.header("cache-control"), "no-store");
  EXPECT_EQ(p.get("/tiles/sat/1/1/1_5.jpg").status, 429);
  // Cached tiles stay served.
  const auto hit = p.get("/tiles/sat/1/0/0_0.jpg");
  EXPECT_EQ(hit.status, 200);
  EXPECT_EQ(hit.header("x-cache"), "HIT");
  // /wms: an OGC exception with the status 429, for one tile and for a composed map.
  const auto wms = p.get(kWms130);
  EXPECT_EQ(wms.status, 429);
  EXPECT_NE(wms.body.find("ServiceException"), std::string::npos) << wms.body;
  EXPECT_EQ(wms.header("retry-after"), "20");
  const auto composed = p.get(getMap("sat", "-110,2,-96,16", 200, 200, "image/png"));
  EXPECT_EQ(composed.status, 429) << composed.body.substr(0, 300);
  EXPECT_EQ(up.requests(), 3u);
  // A minute's share later, one more fetch.
  t.advance(20s);
  EXPECT_EQ(p.get("/wwtile?T=sat&L=1&X=3&Y=0").status, 200);
  EXPECT_EQ(p.get("/wwtile?T=sat&L=1&X=4&Y=0").status, 429);
  const auto m = p.get("/metrics");
  EXPECT_TRUE(hasLine(m.body, "tellus_client_fetch_budget_per_minute 3")) << m.body;
  const auto count = [&](const std::string& name) {
    const auto at = m.body.find("\n" + name + " ");
    return at == std::string::npos ? -1 : std::stoll(m.body.substr(at + name.size() + 2));
  };
  // Four requests of one tile each, and the composed map's tiles.
  EXPECT_GE(count("tellus_tiles_total{layer=\"sat\",result=\"refused\"}"), 5) << m.body;
  EXPECT_EQ(count("tellus_tiles_total{layer=\"sat\",result=\"refused\"}"),
            count("tellus_client_fetch_budget_refused_total"))
      << m.body;
  EXPECT_TRUE(hasLine(m.body, "tellus_http_requests_total{protocol=\"worldwind\",code=\"429\"} 2"))
      << m.body;
  EXPECT_EQ(up.requests(), 4u);
}
