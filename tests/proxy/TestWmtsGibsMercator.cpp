// A Web Mercator WMTS upstream end to end: a fake WMTS of our own on loopback serves the
// capabilities of tests/data/wmts/webmercator-minimal.xml and GoogleMapsCompatible PNG tiles whose
// colour says where each pixel row lies (red: the row in its tile, green: the tile's row, so the
// Mercator row is green x 256 + red), and tellus serve's pieces in front of it answer /wwtile
// requests composed onto the lat/long grid. Each output row's colour is read back as a Mercator
// row and checked against the Mercator formulas (forward form, written here) at the row's
// latitude; nothing is drawn above 85.0511 N; upstream errors store nothing.

#include "../support/CacheFixtures.hpp"
#include "../support/FakeUpstream.hpp"
#include "../support/HttpClient.hpp"
#include "../support/ServedFrontEnd.hpp"
#include "../support/TempDir.hpp"

#include <tellus/cache/TileCache.hpp>
#include <tellus/codec/Jpeg.hpp>
#include <tellus/codec/Png.hpp>
#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/HttpServer.hpp>
#include <tellus/proxy/ProxyFrontEnd.hpp>
#include <tellus/proxy/TileService.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>
#include <set>
#include <span>
#include <sstream>

using namespace tellus;
using namespace std::chrono_literals;

namespace {

constexpr double kR = 6378137.0;
constexpr double kHalf = std::numbers::pi * kR;
const double kMaxLat =
    2.0 * std::atan(std::exp(std::numbers::pi)) * 180.0 / std::numbers::pi - 90.0;

double mercatorY(double lat) {
  return kR * std::log(std::tan(std::numbers::pi / 4.0 + lat * std::numbers::pi / 360.0));
}

std::string capabilities(const std::string& base) {
  std::ifstream in(std::string(TELLUS_TEST_SOURCE_DIR) + "/data/wmts/webmercator-minimal.xml",
                   std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  std::string doc = s.str();
  const std::string host = "https://wmts.example/merc";
  for (auto at = doc.find(host); at != std::string::npos; at = doc.find(host, at + base.size()))
    doc.replace(at, host.size(), base);
  return doc;
}

/** Tile (row, col) of any zoom: pixel row j is (red j, green row, blue 128), opaque. */
std::string latitudeTile(int row) {
  std::vector<std::uint8_t> px(256 * 256 * 4);
  for (std::size_t i = 0; i < 256 * 256; ++i) {
    px[i * 4 + 0] = static_cast<std::uint8_t>(i / 256);
    px[i * 4 + 1] = static_cast<std::uint8_t>(row);
    px[i * 4 + 2] = 128;
    px[i * 4 + 3] = 255;
  }
  auto png = codec::encodePng(256, 256, 4, px.data());
  EXPECT_TRUE(png);
  return png ? std::string(reinterpret_cast<const char*>(png->data()), png->size()) : "";
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

/** /merc/1.0.0/WMTSCapabilities.xml, and tiles at
 * /merc/Latitude_Bands/default/<time>/<set>/<zoom>/<row>/<col>.png; 2000-01-01 fails with 500. */
test::FakeReply serve(const test::FakeRequest& r, const std::string& base) {
  if (r.target == "/merc/1.0.0/WMTSCapabilities.xml")
    return test::FakeReply::ok(capabilities(base), "application/xml");
  const auto parts = split(r.target, '/'); // "", merc, layer, default, time, set, z, row, col
  const bool jpeg = parts.size() == 9 && parts[2] == "Latitude_Bands_Jpeg";
  if (parts.size() != 9 || (parts[2] != "Latitude_Bands" && !jpeg) ||
      !parts[8].ends_with(jpeg ? ".jpg" : ".png"))
    return test::FakeReply::withStatus(404, "no such path");
  const int z = std::stoi(parts[6]), row = std::stoi(parts[7]);
  const int col = std::stoi(parts[8]);
  if (row < 0 || col < 0 || row >= (1 << z) || col >= (1 << z))
    return test::FakeReply::withStatus(400, "no such tile");
  if (parts[4] == "2000-01-01") return test::FakeReply::withStatus(500, "down");
  if (jpeg) { // mid grey
    const std::vector<std::uint8_t> grey(256 * 256 * 3, 128);
    const auto bytes = codec::encodeJpeg(256, 256, 3, grey.data());
    EXPECT_TRUE(bytes);
    return test::FakeReply::ok(
        std::string(reinterpret_cast<const char*>(bytes->data()), bytes->size()), "image/jpeg");
  }
  return test::FakeReply::ok(latitudeTile(row), "image/png");
}

struct Fake {
  std::string base;
  test::FakeUpstream up;
  Fake() : up([this](const test::FakeRequest& r) { return serve(r, base); }) {
    base = up.url("/merc");
  }
  std::vector<std::string> tiles() const {
    std::vector<std::string> out;
    for (const auto& r : up.received())
      if (!r.target.starts_with("/merc/1.0.0/")) out.push_back(r.target);
    return out;
  }
};

/** The cache, fetcher, tile service and HTTP front; layers "bands" (PNG, 36-degree grid of 3
 * levels) and "small" (4.5-degree tiles of 64 px; "small-jpeg" the same in JPEG) on the fake's
 * GoogleMapsCompatible set. */
struct Proxy {
  std::unique_ptr<TileCache> cache;
  std::unique_ptr<Fetcher> fetcher;
  std::unique_ptr<TileService> tiles;
  std::unique_ptr<test::ServedFrontEnd> web; ///< after the service: stopped before it goes
  std::string error;

  Proxy(const std::filesystem::path& root, const std::string& capsUrl) {
    cache = test::openTestCache(root);
    fetcher = std::make_unique<Fetcher>();
    UpstreamSpec u;
    u.name = "merc";
    u.type = UpstreamSpec::Type::Wmts;
    u.url = capsUrl;
    u.policy.timeout = 5000ms;
    u.policy.retries = 0;
    u.policy.failureThreshold = 1000;
    LayerSpec l;
    l.name = "bands";
    l.upstream = "merc";
    l.upstreamLayer = "Latitude_Bands";
    l.tileMatrixSet = "GoogleMapsCompatible_Level7";
    l.dataset.grid = GridSpec{Sector{}, 36.0, 512, 512, 3};
    l.dataset.mimeType = "image/png";
    l.timeValues = {"2000-01-01", "2014-02-07"};
    l.timeDefault = "2014-02-07";
    LayerSpec small = l;
    small.name = "small";
    small.dataset.grid = GridSpec{Sector{}, 4.5, 64, 64, 1};
    LayerSpec jpeg = small;
    jpeg.name = "small-jpeg";
    jpeg.upstreamLayer = "Latitude_Bands_Jpeg";
    jpeg.dataset.mimeType = "image/jpeg";
    auto t = TileService::create(*cache, *fetcher, {u}, {l, small, jpeg}, TileServiceOptions{});
    if (!t) {
      error = t.error();
      return;
    }
    tiles = std::move(*t);
    web = std::make_unique<test::ServedFrontEnd>(*tiles);
  }
  test::HttpResult get(const std::string& target) const { return web->get(target); }
  bool cached(const std::string& time, const TileKey& key) {
    auto spec = *tiles->describe("bands", time);
    auto id = cache->registerDataset(spec);
    if (!id) return false;
    auto got = cache->get(*id, key);
    return got && got->kind == CacheLookup::Kind::Hit;
  }
};

codec::Image decoded(const std::string& body) {
  auto img =
      codec::decodePng(std::span(reinterpret_cast<const std::byte*>(body.data()), body.size()));
  EXPECT_TRUE(img) << (img ? "" : img.error());
  return img ? *img : codec::Image{};
}

/** Checks every row of a level-2 tile of grid row `row` (9 degrees, zoom 7: 1223 m pixels) against
 * the Mercator row of its latitude; returns how many rows were drawn. */
int checkRows(const codec::Image& img, int row) {
  EXPECT_EQ(img.width, 512);
  EXPECT_EQ(img.height, 512);
  EXPECT_EQ(img.channels, 4);
  const double north = -90.0 + (row + 1) * 9.0;
  const double p = 2.0 * kHalf / (256.0 * 128.0);
  int drawn = 0;
  for (int j = 0; j < 512; ++j) {
    const double lat = north - (j + 0.5) * (9.0 / 512.0);
    for (const int i : {0, 255, 511}) {
      const std::uint8_t* px =
          img.pixels.data() + (static_cast<std::size_t>(j) * 512 + static_cast<std::size_t>(i)) * 4;
      if (lat > kMaxLat) {
        EXPECT_EQ(px[3], 0) << "row " << j << " at " << lat << " N: nothing past 85.0511";
        continue;
      }
      EXPECT_EQ(px[3], 255) << "row " << j << " at " << lat << " N";
      // The source row (centres at whole numbers) of this latitude, from the forward formula.
      const double v = std::max(0.0, (kHalf - mercatorY(lat)) / p - 0.5);
      if (static_cast<int>(std::floor(v)) % 256 == 255) continue; // blends two tiles' colours
      const double got = px[1] * 256.0 + px[0];
      EXPECT_NEAR(got, v, 0.51) << "row " << j << " at " << lat << " N, column " << i;
    }
    if (lat <= kMaxLat) ++drawn;
  }
  return drawn;
}

} // namespace

TEST(WmtsGibsMercator, RowsLandAtTheirLatitudesFromTheCoveringTilesOnly) {
  Fake fake;
  test::TempDir dir("wmts-merc");
  Proxy p(dir.path(), fake.up.url("/merc/1.0.0/WMTSCapabilities.xml"));
  ASSERT_TRUE(p.tiles) << p.error;
  struct Case {
    const char* where;
    int row, col;
    std::int64_t r0, r1, c0, c1; // the zoom-7 tiles (TestWmtsUpstreamMercator.cpp's ranges)
  };
  const Case cases[] = {{"0-9 N", 10, 20, 60, 63, 64, 67},
                        {"54-63 N", 16, 20, 34, 41, 64, 67},
                        {"72-81 N", 18, 20, 12, 26, 64, 67},
                        {"0-9 N at the antimeridian", 10, 39, 60, 63, 124, 127}};
  for (const Case& c : cases) {
    const std::size_t before = fake.tiles().size();
    const auto r =
        p.get("/wwtile?T=bands&L=2&X=" + std::to_string(c.col) + "&Y=" + std::to_string(c.row));
    ASSERT_EQ(r.status, 200) << c.where << ": " << r.body;
    EXPECT_EQ(checkRows(decoded(r.body), c.row), 512) << c.where;
    std::set<std::string> asked;
    const auto all = fake.tiles();
    for (std::size_t i = before; i < all.size(); ++i)
      asked.insert(all[i]);
    std::set<std::string> expected;
    for (auto tr = c.r0; tr <= c.r1; ++tr)
      for (auto tc = c.c0; tc <= c.c1; ++tc)
        expected.insert("/merc/Latitude_Bands/default/2014-02-07/GoogleMapsCompatible_Level7/7/" +
                        std::to_string(tr) + "/" + std::to_string(tc) + ".png");
    EXPECT_EQ(asked, expected) << c.where;
    EXPECT_EQ(all.size() - before, expected.size()) << c.where << ": each tile asked for once";
  }
}

TEST(WmtsGibsMercator, NothingAbove85NorthAndTilesBeyondTheSquareAreAbsent) {
  Fake fake;
  test::TempDir dir("wmts-merc-pole");
  Proxy p(dir.path(), fake.up.url("/merc/1.0.0/WMTSCapabilities.xml"));
  ASSERT_TRUE(p.tiles) << p.error;
  // 81-90 N: rows up to 85.0511 N drawn (from zoom-7 rows 0-12), transparent above.
  const auto r = p.get("/wwtile?T=bands&L=2&X=20&Y=19");
  ASSERT_EQ(r.status, 200) << r.body;
  const int drawn = checkRows(decoded(r.body), 19);
  EXPECT_EQ(drawn, static_cast<int>(std::floor((kMaxLat - 81.0) / (9.0 / 512.0) + 0.5)));
  EXPECT_EQ(fake.tiles().size(), 13u * 4u);
  // A tile wholly above 85.0511 N (layer "small": 4.5-degree tiles of 64 px, row 39 is 85.5-90 N)
  // has no upstream tile: absent, nothing asked.
  const std::size_t before = fake.tiles().size();
  EXPECT_EQ(p.get("/wwtile?T=small&L=0&X=20&Y=39").status, 404);
  EXPECT_EQ(fake.tiles().size(), before);
  // The row below it (81-85.5 N) is drawn up to 85.0511 N.
  const auto below = p.get("/wwtile?T=small&L=0&X=20&Y=38");
  ASSERT_EQ(below.status, 200) << below.body;
  const auto img = decoded(below.body);
  ASSERT_EQ(img.height, 64);
  for (int j = 0; j < 64; ++j) {
    const double lat = 85.5 - (j + 0.5) * (4.5 / 64.0);
    EXPECT_EQ(img.pixels[static_cast<std::size_t>(j) * 64 * 4 + 3], lat > kMaxLat ? 0 : 255) << lat;
  }
  // A JPEG layer has no alpha: the same rows are black, the others the upstream's grey.
  const auto dark = p.get("/wwtile?T=small-jpeg&L=0&X=20&Y=38");
  ASSERT_EQ(dark.status, 200) << dark.body;
  auto grey = codec::decodeJpeg(
      std::span(reinterpret_cast<const std::byte*>(dark.body.data()), dark.body.size()));
  ASSERT_TRUE(grey);
  for (int j = 0; j < 64; ++j) {
    const double lat = 85.5 - (j + 0.5) * (4.5 / 64.0);
    const int v = grey->pixels[(static_cast<std::size_t>(j) * 64 + 32) * 3];
    // (JPEG blurs the edge row pair: those two rows are not checked.)
    if (std::fabs(lat - kMaxLat) < 4.5 / 64.0) continue;
    if (lat > kMaxLat) {
      EXPECT_LT(v, 12) << lat;
    } else {
      EXPECT_NEAR(v, 128, 6) << lat;
    }
  }
}

TEST(WmtsGibsMercator, UpstreamErrorsAreNotCached) {
  Fake fake;
  test::TempDir dir("wmts-merc-fail");
  Proxy p(dir.path(), fake.up.url("/merc/1.0.0/WMTSCapabilities.xml"));
  ASSERT_TRUE(p.tiles) << p.error;
  const TileKey key{2, 10, 20};
  const auto down = p.get("/tiles/bands/2/10/10_20.png?time=2000-01-01");
  EXPECT_GE(down.status, 500) << down.body;
  EXPECT_FALSE(p.cached("2000-01-01", key));
  const std::size_t n = fake.tiles().size();
  EXPECT_GE(p.get("/tiles/bands/2/10/10_20.png?time=2000-01-01").status, 500);
  EXPECT_GT(fake.tiles().size(), n) << "asked again: the failure was not kept";
  // The good day is composed and cached; asked again, it is a hit with no upstream request.
  const auto good = p.get("/wwtile?T=bands&L=2&X=20&Y=10");
  ASSERT_EQ(good.status, 200) << good.body;
  EXPECT_TRUE(p.cached("2014-02-07", key));
  const std::size_t m = fake.tiles().size();
  const auto again = p.get("/wwtile?T=bands&L=2&X=20&Y=10");
  EXPECT_EQ(again.headers.at("x-cache"), "HIT");
  EXPECT_EQ(again.body, good.body);
  EXPECT_EQ(fake.tiles().size(), m);
}
