// A WMTS upstream end to end: a fake WMTS of our own on loopback serves capabilities and tiles in
// NASA GIBS's layout (EPSG:4326, 512 px tiles, level 0 of 2 x 1 tiles of 288 degrees, REST
// templates with {Time} and KVP GetTile), and tellus serve's pieces in front of it answer World
// Wind tiles with the upstream's bytes unchanged, rows flipped, TIME passed through; failures
// store nothing; the capabilities saved at start let a later start work offline.

#include "../support/CacheFixtures.hpp"
#include "../support/FakeUpstream.hpp"
#include "../support/HttpClient.hpp"
#include "../support/ServedFrontEnd.hpp"
#include "../support/TempDir.hpp"

#include <tellus/cache/TileCache.hpp>
#include <tellus/codec/Jpeg.hpp>
#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/HttpServer.hpp>
#include <tellus/proxy/ProxyFrontEnd.hpp>
#include <tellus/proxy/TileService.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <map>
#include <span>

using namespace tellus;
using namespace std::chrono_literals;

namespace {

/** GIBS's EPSG:4326 matrices 0-5 (2 x 1 tiles of 288 degrees, then 3 x 2, 5 x 3, 10 x 5 ...). */
std::string gibsMatrices() {
  const char* sds[] = {"223632905.6114871",
                       "111816452.8057436",
                       "55908226.40287178",
                       "27954113.20143589",
                       "13977056.60071795",
                       "6988528.300358973"};
  const int widths[] = {2, 3, 5, 10, 20, 40};
  const int heights[] = {1, 2, 3, 5, 10, 20};
  std::string out;
  for (int i = 0; i < 6; ++i)
    out += "<TileMatrix><ows:Identifier>" + std::to_string(i) +
           "</ows:Identifier><ScaleDenominator>" + sds[i] +
           "</ScaleDenominator><TopLeftCorner>-180 90</TopLeftCorner><TileWidth>512</TileWidth>"
           "<TileHeight>512</TileHeight><MatrixWidth>" +
           std::to_string(widths[i]) + "</MatrixWidth><MatrixHeight>" + std::to_string(heights[i]) +
           "</MatrixHeight></TileMatrix>";
  return out;
}

std::string capabilities(const std::string& base) {
  return R"(<?xml version="1.0" encoding="UTF-8"?>
<Capabilities xmlns="http://www.opengis.net/wmts/1.0" xmlns:ows="http://www.opengis.net/ows/1.1"
    xmlns:xlink="http://www.w3.org/1999/xlink" version="1.0.0">
  <ows:OperationsMetadata>
    <ows:Operation name="GetTile"><ows:DCP><ows:HTTP>
      <ows:Get xlink:href=")" +
         base + R"(/wmts.cgi?"><ows:Constraint name="GetEncoding"><ows:AllowedValues>
        <ows:Value>KVP</ows:Value></ows:AllowedValues></ows:Constraint></ows:Get>
    </ows:HTTP></ows:DCP></ows:Operation>
  </ows:OperationsMetadata>
  <Contents>
    <Layer>
      <ows:Identifier>MODIS_Terra_CorrectedReflectance_TrueColor</ows:Identifier>
      <Style isDefault="true"><ows:Identifier>default</ows:Identifier></Style>
      <Format>image/jpeg</Format>
      <Dimension><ows:Identifier>Time</ows:Identifier><ows:UOM>ISO8601</ows:UOM>
        <Default>2014-02-07</Default><Value>2012-05-08/2014-02-07/P1D</Value></Dimension>
      <TileMatrixSetLink><TileMatrixSet>250m</TileMatrixSet></TileMatrixSetLink>
      <ResourceURL format="image/jpeg" resourceType="tile" template=")" +
         base +
         R"(/MODIS_Terra_CorrectedReflectance_TrueColor/default/{Time}/{TileMatrixSet}/{TileMatrix}/{TileRow}/{TileCol}.jpg"/>
    </Layer>
    <Layer>
      <ows:Identifier>Shifted</ows:Identifier>
      <Format>image/jpeg</Format>
      <Dimension><ows:Identifier>Time</ows:Identifier><Default>2014-02-07</Default></Dimension>
      <TileMatrixSetLink><TileMatrixSet>shifted</TileMatrixSet></TileMatrixSetLink>
      <ResourceURL format="image/jpeg" resourceType="tile" template=")" +
         base + R"(/Shifted/default/{Time}/{TileMatrixSet}/{TileMatrix}/{TileRow}/{TileCol}.jpg"/>
    </Layer>
    <TileMatrixSet><ows:Identifier>shifted</ows:Identifier>
      <ows:SupportedCRS>urn:ogc:def:crs:OGC:1.3:CRS84</ows:SupportedCRS>
      <TileMatrix><ows:Identifier>0</ows:Identifier><ScaleDenominator>27954113.20143589</ScaleDenominator>
        <TopLeftCorner>-180 72</TopLeftCorner><TileWidth>512</TileWidth><TileHeight>512</TileHeight>
        <MatrixWidth>10</MatrixWidth><MatrixHeight>5</MatrixHeight></TileMatrix>
    </TileMatrixSet>
    <TileMatrixSet><ows:Identifier>250m</ows:Identifier>
      <ows:SupportedCRS>urn:ogc:def:crs:OGC:1.3:CRS84</ows:SupportedCRS>)" +
         gibsMatrices() + R"(</TileMatrixSet>
  </Contents>
</Capabilities>)";
}

/** The tile the fake serves for (time, matrix, row, col): a real 512 px JPEG, different for each.
 */
std::string fakeTile(const std::string& time,
                     const std::string& matrix,
                     const std::string& row,
                     const std::string& col) {
  const std::size_t h = std::hash<std::string>{}(time + "/" + matrix + "/" + row + "/" + col);
  std::vector<std::uint8_t> px(512 * 512 * 3);
  for (std::size_t i = 0; i < px.size(); ++i)
    px[i] = static_cast<std::uint8_t>((h >> ((i % 3) * 8)) + (i / 1536));
  auto jpeg = codec::encodeJpeg(512, 512, 3, px.data());
  EXPECT_TRUE(jpeg);
  return jpeg ? std::string(reinterpret_cast<const char*>(jpeg->data()), jpeg->size()) : "";
}

std::string param(const std::string& target, const std::string& name) {
  const auto q = target.find('?');
  std::size_t i = q == std::string::npos ? target.size() : q + 1;
  while (i < target.size()) {
    const std::size_t amp = std::min(target.find('&', i), target.size());
    const std::string kv = target.substr(i, amp - i);
    const auto eq = kv.find('=');
    if (eq != std::string::npos && kv.substr(0, eq) == name) return kv.substr(eq + 1);
    i = amp + 1;
  }
  return {};
}

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::size_t i = 0;
  for (;;) {
    const std::size_t at = s.find(sep, i);
    out.push_back(s.substr(i, at - i));
    if (at == std::string::npos) return out;
    i = at + 1;
  }
}

/** GIBS's layout: REST tiles under /wmts/<layer>/default/<time>/<set>/<matrix>/<row>/<col>.jpg,
 * KVP at /wmts/wmts.cgi, capabilities at /wmts/1.0.0/WMTSCapabilities.xml. Three days fail:
 * 2000-01-01 with 500, 2000-01-02 with 404, 2000-01-03 with bytes that are no JPEG. */
test::FakeReply serveWmts(const test::FakeRequest& r, const std::string& base) {
  const std::string path = r.target.substr(0, r.target.find('?'));
  if (path == "/wmts/1.0.0/WMTSCapabilities.xml")
    return test::FakeReply::ok(capabilities(base), "application/xml");
  std::string time, matrix, row, col;
  if (path == "/wmts/wmts.cgi") {
    if (param(r.target, "REQUEST") != "GetTile" || param(r.target, "TILEMATRIXSET") != "250m" ||
        param(r.target, "STYLE") != "default" || param(r.target, "FORMAT") != "image%2Fjpeg")
      return test::FakeReply::withStatus(400, "bad GetTile");
    time = param(r.target, "TIME");
    matrix = param(r.target, "TILEMATRIX");
    row = param(r.target, "TILEROW");
    col = param(r.target, "TILECOL");
  } else {
    const auto parts = split(path, '/'); // "", wmts, layer, default, time, set, matrix, row, col
    if (parts.size() != 9 || (parts[5] != "250m" && parts[5] != "shifted") ||
        !parts[8].ends_with(".jpg"))
      return test::FakeReply::withStatus(404, "no such path");
    time = parts[4];
    matrix = parts[6];
    row = parts[7];
    col = parts[8].substr(0, parts[8].size() - 4);
  }
  if (time == "2000-01-01") return test::FakeReply::withStatus(500, "down");
  if (time == "2000-01-02") return test::FakeReply::withStatus(404, "no tile");
  if (time == "2000-01-03") return test::FakeReply::ok("<html>not a tile</html>", "image/jpeg");
  return test::FakeReply::ok(fakeTile(time, matrix, row, col), "image/jpeg");
}

/** tellus serve's pieces: the cache, the fetcher, the tile service and the HTTP front, with two
 * layers on the fake WMTS: "modis" (REST) and "modis-kvp" (KVP), 36-degree grids of 3 levels. */
struct WmtsProxy {
  std::unique_ptr<TileCache> cache;
  std::unique_ptr<Fetcher> fetcher;
  std::unique_ptr<TileService> tiles;
  std::unique_ptr<test::ServedFrontEnd> web; ///< after the service: stopped before it goes
  std::string error;

  WmtsProxy(const std::filesystem::path& root, const std::string& capsUrl, bool offline = false) {
    cache = test::openTestCache(root);
    fetcher = std::make_unique<Fetcher>();
    std::vector<UpstreamSpec> ups;
    for (const auto encoding : {WmtsEncoding::Auto, WmtsEncoding::Kvp}) {
      UpstreamSpec u;
      u.name = encoding == WmtsEncoding::Kvp ? "gibs-kvp" : "gibs";
      u.type = UpstreamSpec::Type::Wmts;
      u.url = capsUrl;
      u.wmtsEncoding = encoding;
      u.policy.timeout = 5000ms;
      u.policy.retries = 0;
      u.policy.failureThreshold = 1000;
      ups.push_back(u);
    }
    std::vector<LayerSpec> layers;
    for (const auto& [name, upstream] : {std::pair<std::string, std::string>{"modis", "gibs"},
                                         {"modis-kvp", "gibs-kvp"},
                                         {"shifted", "gibs"}}) {
      LayerSpec l;
      l.name = name;
      l.upstream = upstream;
      l.upstreamLayer =
          name == "shifted" ? "Shifted" : "MODIS_Terra_CorrectedReflectance_TrueColor";
      l.dataset.grid = GridSpec{Sector{}, 36.0, 512, 512, name == "shifted" ? 1 : 3};
      l.dataset.mimeType = "image/jpeg";
      l.timeValues = {"2000-01-01", "2000-01-02", "2000-01-03", "2013-06-01", "2014-02-07"};
      l.timeDefault = "2014-02-07";
      layers.push_back(l);
    }
    TileServiceOptions o;
    o.offline = offline;
    auto t = TileService::create(*cache, *fetcher, ups, layers, o);
    if (!t) {
      error = t.error();
      return;
    }
    tiles = std::move(*t);
    web = std::make_unique<test::ServedFrontEnd>(*tiles);
  }
  test::HttpResult get(const std::string& target) const { return web->get(target); }
  /** Whether the cache holds a tile of `layer` at `time` for `key`. */
  bool cached(const std::string& layer, const std::string& time, const TileKey& key) {
    auto spec = *tiles->describe(layer, time);
    auto id = cache->registerDataset(spec);
    if (!id) return false;
    auto got = cache->get(*id, key);
    return got && got->kind == CacheLookup::Kind::Hit;
  }
};

struct Fake {
  std::string base;
  test::FakeUpstream up;
  Fake() : up([this](const test::FakeRequest& r) { return serveWmts(r, base); }) {
    base = up.url("/wmts");
  }
  std::size_t tileRequests() const {
    std::size_t n = 0;
    for (const auto& r : up.received())
      if (!r.target.starts_with("/wmts/1.0.0/")) ++n;
    return n;
  }
  std::string lastTarget() const { return up.received().back().target; }
};

} // namespace

TEST(WmtsGibs, AlignedTilesAreTheUpstreamsBytesRowsFlipped) {
  Fake fake;
  test::TempDir dir("wmts-up");
  WmtsProxy p(dir.path(), fake.up.url("/wmts/1.0.0/WMTSCapabilities.xml"));
  ASSERT_TRUE(p.tiles) << p.error;
  // World Wind level 0 is GIBS matrix 3; row 0 (the southernmost) is GIBS row 4.
  const auto first = p.get("/wwtile?T=modis&L=0&X=3&Y=0");
  ASSERT_EQ(first.status, 200) << first.body;
  EXPECT_EQ(first.body, fakeTile("2014-02-07", "3", "4", "3"));
  EXPECT_EQ(fake.lastTarget(),
            "/wmts/MODIS_Terra_CorrectedReflectance_TrueColor/default/2014-02-07/250m/3/4/3.jpg");
  EXPECT_EQ(first.headers.at("x-cache"), "MISS");
  // Level 2 is GIBS matrix 5 (40 x 20): row 1 from the south is row 18 from the top.
  const auto deep = p.get("/wwtile?T=modis&L=2&X=37&Y=1");
  ASSERT_EQ(deep.status, 200) << deep.body;
  EXPECT_EQ(deep.body, fakeTile("2014-02-07", "5", "18", "37"));
  // Cached as fetched: the next answer is a hit with the same bytes and no upstream request.
  const std::size_t before = fake.tileRequests();
  const auto again = p.get("/wwtile?T=modis&L=0&X=3&Y=0");
  EXPECT_EQ(again.status, 200);
  EXPECT_EQ(again.headers.at("x-cache"), "HIT");
  EXPECT_EQ(again.body, first.body);
  EXPECT_EQ(fake.tileRequests(), before);
  // KVP: the same tile through GetTile.
  const auto kvp = p.get("/wwtile?T=modis-kvp&L=1&X=0&Y=9");
  ASSERT_EQ(kvp.status, 200) << kvp.body;
  EXPECT_EQ(kvp.body, fakeTile("2014-02-07", "4", "0", "0"));
  EXPECT_NE(fake.lastTarget().find("/wmts/wmts.cgi?SERVICE=WMTS&REQUEST=GetTile&VERSION=1.0.0"),
            std::string::npos)
      << fake.lastTarget();
  EXPECT_NE(fake.lastTarget().find("&TILEMATRIX=4&TILEROW=0&TILECOL=0&TIME=2014-02-07"),
            std::string::npos)
      << fake.lastTarget();
}

TEST(WmtsGibs, TimePassesThroughToTheUpstream) {
  Fake fake;
  test::TempDir dir("wmts-time");
  WmtsProxy p(dir.path(), fake.up.url("/wmts/1.0.0/WMTSCapabilities.xml"));
  ASSERT_TRUE(p.tiles) << p.error;
  const auto old = p.get("/tiles/modis/0/0/0_0.jpg?time=2013-06-01");
  ASSERT_EQ(old.status, 200) << old.body;
  EXPECT_EQ(old.body, fakeTile("2013-06-01", "3", "4", "0"));
  EXPECT_NE(fake.lastTarget().find("/default/2013-06-01/250m/3/4/0.jpg"), std::string::npos);
  const auto kvp = p.get("/tiles/modis-kvp/0/4/4_9.jpg?time=2013-06-01");
  ASSERT_EQ(kvp.status, 200) << kvp.body;
  EXPECT_EQ(kvp.body, fakeTile("2013-06-01", "3", "0", "9"));
  EXPECT_NE(fake.lastTarget().find("&TIME=2013-06-01"), std::string::npos);
  EXPECT_TRUE(p.cached("modis", "2013-06-01", TileKey{0, 0, 0}));
  EXPECT_FALSE(p.cached("modis", "2014-02-07", TileKey{0, 0, 0}));
}

TEST(WmtsGibs, UpstreamFailuresDoNotPoisonTheCache) {
  Fake fake;
  test::TempDir dir("wmts-fail");
  WmtsProxy p(dir.path(), fake.up.url("/wmts/1.0.0/WMTSCapabilities.xml"));
  ASSERT_TRUE(p.tiles) << p.error;
  const TileKey key{0, 2, 5};
  // 500: a failure, nothing stored, asked again next time.
  const auto down = p.get("/tiles/modis/0/2/2_5.jpg?time=2000-01-01");
  EXPECT_GE(down.status, 500) << down.body;
  EXPECT_FALSE(p.cached("modis", "2000-01-01", key));
  const std::size_t n = fake.tileRequests();
  EXPECT_GE(p.get("/tiles/modis/0/2/2_5.jpg?time=2000-01-01").status, 500);
  EXPECT_EQ(fake.tileRequests(), n + 1);
  // Garbage that says it is a JPEG: refused, nothing stored.
  const auto garbage = p.get("/tiles/modis/0/2/2_5.jpg?time=2000-01-03");
  EXPECT_EQ(garbage.status, 502) << garbage.body;
  EXPECT_FALSE(p.cached("modis", "2000-01-03", key));
  // 404: there is no such tile (remembered as absent, never a tile).
  const auto none = p.get("/tiles/modis/0/2/2_5.jpg?time=2000-01-02");
  EXPECT_EQ(none.status, 404) << none.body;
  EXPECT_FALSE(p.cached("modis", "2000-01-02", key));
  // The good day still works, and the default time's tile is untouched by all of it.
  const auto good = p.get("/wwtile?T=modis&L=0&X=5&Y=2");
  ASSERT_EQ(good.status, 200);
  EXPECT_EQ(good.body, fakeTile("2014-02-07", "3", "2", "5"));
}

TEST(WmtsGibs, SavedCapabilitiesLetALaterStartWorkOffline) {
  test::TempDir dir("wmts-offline");
  std::string tile;
  {
    Fake fake;
    WmtsProxy p(dir.path(), fake.up.url("/wmts/1.0.0/WMTSCapabilities.xml"));
    ASSERT_TRUE(p.tiles) << p.error;
    const auto r = p.get("/wwtile?T=modis&L=0&X=1&Y=1");
    ASSERT_EQ(r.status, 200);
    tile = r.body;
  }
  EXPECT_TRUE(std::filesystem::exists(wmtsCapabilitiesFile(dir.path(), "gibs")));
  // The upstream is gone: the saved capabilities are read, cached tiles served.
  const std::string gone =
      "http://127.0.0.1:" + std::to_string(test::FakeUpstream::closedPort()) + "/wmts";
  {
    WmtsProxy p(dir.path(), gone);
    ASSERT_TRUE(p.tiles) << p.error;
    const auto r = p.get("/wwtile?T=modis&L=0&X=1&Y=1");
    EXPECT_EQ(r.status, 200);
    EXPECT_EQ(r.body, tile);
  }
  {
    WmtsProxy p(dir.path(), gone, /*offline=*/true);
    ASSERT_TRUE(p.tiles) << p.error;
    EXPECT_EQ(p.get("/wwtile?T=modis&L=0&X=1&Y=1").body, tile);
  }
  // Without a saved copy there is nothing to start from: the error says both why and where.
  test::TempDir empty("wmts-none");
  WmtsProxy none(empty.path(), gone);
  EXPECT_FALSE(none.tiles);
  EXPECT_NE(none.error.find("upstream 'gibs'"), std::string::npos) << none.error;
  EXPECT_NE(none.error.find("no copy is saved"), std::string::npos) << none.error;
}

TEST(WmtsGibs, ALayerTheUpstreamLacksIsRefusedAtStart) {
  Fake fake;
  test::TempDir dir("wmts-bad");
  auto cache = test::openTestCache(dir.path());
  Fetcher fetcher;
  UpstreamSpec u;
  u.name = "gibs";
  u.type = UpstreamSpec::Type::Wmts;
  u.url = fake.up.url("/wmts/1.0.0/WMTSCapabilities.xml");
  LayerSpec l;
  l.name = "sst";
  l.upstream = "gibs";
  l.upstreamLayer = "GHRSST_L4_MUR_Sea_Surface_Temperature";
  l.dataset.grid = GridSpec{Sector{}, 36.0, 512, 512, 3};
  l.dataset.mimeType = "image/png";
  auto t = TileService::create(*cache, fetcher, {u}, {l}, TileServiceOptions{});
  ASSERT_FALSE(t);
  EXPECT_NE(t.error().find("layer 'sst'"), std::string::npos) << t.error();
  EXPECT_NE(t.error().find("'MODIS_Terra_CorrectedReflectance_TrueColor'"), std::string::npos)
      << t.error();
}

TEST(WmtsGibs, ASetThatDoesNotLineUpIsComposedFromTheTilesThatCoverIt) {
  Fake fake;
  test::TempDir dir("wmts-compose");
  WmtsProxy p(dir.path(), fake.up.url("/wmts/1.0.0/WMTSCapabilities.xml"));
  ASSERT_TRUE(p.tiles) << p.error;
  // The set "shifted" starts at 72 N: World Wind tile (0, 3, 0), 18-54 N, is the bottom half of
  // its row 0 over the top half of its row 1.
  const auto r = p.get("/wwtile?T=shifted&L=0&X=0&Y=3");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.headers.at("x-cache"), "MISS");
  std::vector<std::string> asked;
  for (const auto& q : fake.up.received())
    if (q.target.starts_with("/wmts/Shifted/")) asked.push_back(q.target);
  std::sort(asked.begin(), asked.end());
  EXPECT_EQ(asked,
            (std::vector<std::string>{"/wmts/Shifted/default/2014-02-07/shifted/0/0/0.jpg",
                                      "/wmts/Shifted/default/2014-02-07/shifted/0/1/0.jpg"}));
  const auto bytes = [](const std::string& s) {
    return std::span(reinterpret_cast<const std::byte*>(s.data()), s.size());
  };
  auto got = codec::decodeJpeg(bytes(r.body));
  auto upper = codec::decodeJpeg(bytes(fakeTile("2014-02-07", "0", "0", "0")));
  auto lower = codec::decodeJpeg(bytes(fakeTile("2014-02-07", "0", "1", "0")));
  ASSERT_TRUE(got && upper && lower);
  ASSERT_EQ(got->width, 512);
  ASSERT_EQ(got->height, 512);
  // Same pixel size, half a tile down: output row y is source row y + 256 of row 0 (y < 256),
  // row y - 256 of row 1 after; JPEG encoded again at quality 90.
  double diff = 0;
  for (int y = 0; y < 512; ++y)
    for (int x = 0; x < 512 * 3; ++x) {
      const auto& src = y < 256 ? *upper : *lower;
      const int sy = y < 256 ? y + 256 : y - 256;
      diff += std::abs(int(got->pixels[std::size_t(y) * 1536 + std::size_t(x)]) -
                       int(src.pixels[std::size_t(sy) * 1536 + std::size_t(x)]));
    }
  EXPECT_LT(diff / (512.0 * 1536.0), 4.0);
  const auto again = p.get("/wwtile?T=shifted&L=0&X=0&Y=3");
  EXPECT_EQ(again.headers.at("x-cache"), "HIT");
  EXPECT_EQ(again.body, r.body);
  // One source tile failing fails the tile and stores nothing.
  const auto down = p.get("/tiles/shifted/0/3/3_0.jpg?time=2000-01-01");
  EXPECT_GE(down.status, 500) << down.body;
  EXPECT_FALSE(p.cached("shifted", "2000-01-01", TileKey{0, 3, 0}));
}
