// Web Mercator GetMap and GetFeatureInfo on a running tellus (cache, fetcher, tile service, front
// end, HTTP server on a loopback port), over a Float32 value layer whose value is the latitude of
// each texel's centre: a map's rows are checked against the inverse Mercator of their centres, the
// rows past the Mercator square are no data / transparent / BGCOLOR, the aliases and both
// versions give the same map, and GetFeatureInfo's I/J go through the same rows.

#include "../support/CacheFixtures.hpp"
#include "../support/FakeUpstream.hpp"
#include "../support/HttpClient.hpp"
#include "../support/TempDir.hpp"
#include "../values/TiffBuilder.hpp"

#include <tellus/cache/TileCache.hpp>
#include <tellus/codec/Jpeg.hpp>
#include <tellus/codec/Png.hpp>
#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/HttpServer.hpp>
#include <tellus/proxy/ImageCodec.hpp>
#include <tellus/proxy/MapBox.hpp>
#include <tellus/proxy/ProxyFrontEnd.hpp>
#include <tellus/proxy/TileService.hpp>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <bit>
#include <cmath>
#include <cstring>
#include <span>
#include <string>

using namespace tellus;
using namespace tellus::mercator;
using namespace std::chrono_literals;

namespace {

std::string bytesOf(const std::vector<std::byte>& b) {
  return std::string(reinterpret_cast<const char*>(b.data()), b.size());
}

std::string paramOf(const std::string& target, const std::string& name) {
  const auto at = target.find(name + "=");
  if (at == std::string::npos) return {};
  const auto end = target.find('&', at);
  return target.substr(at + name.size() + 1,
                       end == std::string::npos ? std::string::npos : end - at - name.size() - 1);
}

double greyOf(double lat) {
  return 255.0 * (90.0 - lat) / 180.0;
}

/** A Float32 TIFF whose samples are their texel centre's latitude (WMS 1.3.0 EPSG:4326 upstream:
 * BBOX south,west,north,east). */
test::FakeReply latitudeTile(const test::FakeRequest& req) {
  const int w = std::atoi(paramOf(req.target, "WIDTH").c_str());
  const int h = std::atoi(paramOf(req.target, "HEIGHT").c_str());
  if (w <= 0 || h <= 0 || w > 1024 || h > 1024) return test::FakeReply::withStatus(400, "size");
  double b[4] = {};
  std::sscanf(paramOf(req.target, "BBOX").c_str(), "%lf,%lf,%lf,%lf", &b[0], &b[1], &b[2], &b[3]);
  if (paramOf(req.target, "LAYERS") == "uppic") { // grey = 255 * (90 - latitude) / 180
    std::vector<std::uint8_t> px;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        px.insert(
            px.end(),
            3,
            static_cast<std::uint8_t>(std::lround(greyOf(b[2] - (y + 0.5) * (b[2] - b[0]) / h))));
    return test::FakeReply::ok(bytesOf(*encodeImage("image/jpeg", w, h, 3, px.data())),
                               "image/jpeg");
  }
  std::vector<std::uint32_t> bits;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      bits.push_back(
          std::bit_cast<std::uint32_t>(static_cast<float>(b[2] - (y + 0.5) * (b[2] - b[0]) / h)));
  values::test::TiffSpec spec{
      .width = w, .height = h, .bits = 32, .sampleFormat = 3, .compression = 8, .rowsPerStrip = 8};
  return test::FakeReply::ok(bytesOf(values::test::TiffBuilder(spec).build(bits)), "image/tiff");
}

LayerSpec latitudeLayer() {
  LayerSpec l;
  l.name = "lat";
  l.title = "Latitude as a value";
  l.upstream = "up";
  l.upstreamLayer = "uplat";
  l.dataset.grid = GridSpec{Sector{}, 36.0, 64, 64, 6};
  l.dataset.mimeType = "image/tiff";
  ValueLayerSpec v;
  v.format.container = values::Container::Tiff;
  v.format.encoding = values::Encoding::Float32;
  v.format.unit = "deg";
  v.defaultStyle = "viridis";
  v.styles = {"viridis"};
  v.min = -90.0;
  v.max = 90.0;
  l.values = v;
  return l;
}

/** A JPEG picture layer whose grey is 255 * (90 - latitude) / 180. */
LayerSpec pictureLayer() {
  LayerSpec l;
  l.name = "pic";
  l.title = "Latitude as grey";
  l.upstream = "up";
  l.upstreamLayer = "uppic";
  l.dataset.grid = GridSpec{Sector{}, 36.0, 64, 64, 6};
  l.dataset.mimeType = "image/jpeg";
  return l;
}

struct Server {
  test::FakeUpstream up{latitudeTile};
  test::TempDir dir{"wms-mercator"};
  std::unique_ptr<TileCache> cache;
  std::unique_ptr<Fetcher> fetcher;
  std::unique_ptr<TileService> tiles;
  std::unique_ptr<ProxyFrontEnd> front;
  std::unique_ptr<HttpServer> server;

  /** With `overview`: "pic-overview", the same upstream layer as "pic" on 90-degree tiles. */
  explicit Server(bool overview = false) {
    cache = test::openTestCache(dir.path());
    fetcher = std::make_unique<Fetcher>();
    UpstreamSpec u;
    u.name = "up";
    u.type = UpstreamSpec::Type::Wms;
    u.url = up.url("/wms");
    u.wmsVersion = "1.3.0";
    u.crs = "EPSG:4326";
    u.policy.timeout = 2000ms;
    u.policy.retries = 0;
    std::vector<LayerSpec> layers{latitudeLayer(), pictureLayer()};
    if (overview) {
      LayerSpec o = pictureLayer();
      o.name = "pic-overview";
      o.dataset.grid = GridSpec{Sector{}, 90.0, 64, 64, 1};
      layers.push_back(o);
    }
    auto t = TileService::create(*cache, *fetcher, {u}, layers, TileServiceOptions{});
    EXPECT_TRUE(t) << (t ? "" : t.error());
    tiles = std::move(*t);
    front = std::make_unique<ProxyFrontEnd>(*tiles, FrontEndOptions{});
    HttpServerOptions so;
    so.threads = 2;
    server = std::make_unique<HttpServer>(so, [this](HttpRequest&& r, Responder respond) {
      front->handle(std::move(r), std::move(respond));
    });
    EXPECT_TRUE(server->start());
  }
  ~Server() {
    server->stop();
    front.reset();
    tiles.reset();
    fetcher.reset();
  }
  test::HttpResult get(const std::string& query) const {
    return test::httpGet("http://127.0.0.1:" + std::to_string(server->port()) + "/wms?" + query);
  }
};

std::vector<float> bil32(const std::string& body) {
  std::vector<float> v(body.size() / 4);
  std::memcpy(v.data(), body.data(), v.size() * 4);
  return v;
}

std::span<const std::byte> span(const std::string& s) {
  return {reinterpret_cast<const std::byte*>(s.data()), s.size()};
}

// 20 degrees of longitude, from 1000 km south of the equator to 3000 km past the square's edge.
constexpr double kSouth = -1.0e6, kNorth = kMaxY + 3.0e6;
constexpr int kWidth = 16, kHeight = 200;
const std::string kBox = "&BBOX=-1113194.9," + std::to_string(kSouth) + ",1113194.9," +
                         std::to_string(kNorth) + "&WIDTH=16&HEIGHT=200";

double rowY(int j) {
  return kNorth - (j + 0.5) * ((kNorth - kSouth) / kHeight);
}

} // namespace

TEST(WmsMercatorIntegration, RowsAreTheInverseMercatorAndNothingPastTheSquare) {
  Server s;
  const auto r = s.get("SERVICE=WMS&VERSION=1.3.0&REQUEST=GetMap&LAYERS=lat&STYLES=&CRS=EPSG:3857"
                       "&FORMAT=application/bil32" +
                       kBox);
  ASSERT_EQ(r.status, 200) << r.body.substr(0, 400);
  ASSERT_EQ(r.body.size(), std::size_t(kWidth * kHeight * 4));
  const auto v = bil32(r.body);
  int past = 0;
  for (int j = 0; j < kHeight; ++j) {
    const double y = rowY(j);
    for (const int i : {0, 7, 15}) {
      const float f = v[std::size_t(j * kWidth + i)];
      if (y > kMaxY) {
        EXPECT_TRUE(std::isnan(f)) << j;
      } else {
        EXPECT_NEAR(f, latitudeOfY(y), 3e-5) << "row " << j;
      }
    }
    past += y > kMaxY;
  }
  EXPECT_GT(past, 20);
  // The alias under 1.1.1 (x, y as well): the same map.
  const auto alias = s.get("SERVICE=WMS&VERSION=1.1.1&REQUEST=GetMap&LAYERS=lat&STYLES="
                           "&SRS=EPSG:900913&FORMAT=application/bil32" +
                           kBox);
  ASSERT_EQ(alias.status, 200);
  EXPECT_EQ(alias.body, r.body);
}

TEST(WmsMercatorIntegration, PicturesAreTransparentOrBackgroundPastTheSquare) {
  Server s;
  const std::string q = "SERVICE=WMS&VERSION=1.3.0&REQUEST=GetMap&LAYERS=lat&STYLES=viridis"
                        "&CRS=EPSG:3857&FORMAT=image/png" +
                        kBox;
  auto clear = codec::decodePng(span(s.get(q + "&TRANSPARENT=TRUE").body));
  ASSERT_TRUE(clear) << clear.error();
  auto filled = codec::decodePng(span(s.get(q + "&BGCOLOR=0x123456").body));
  ASSERT_TRUE(filled) << filled.error();
  ASSERT_EQ(clear->width, kWidth);
  ASSERT_EQ(clear->height, kHeight);
  const auto px = [](const codec::Image& im, int x, int y) {
    const auto at = (std::size_t(y) * std::size_t(im.width) + std::size_t(x)) * 4;
    return std::array<std::uint8_t, 4>{
        im.pixels[at], im.pixels[at + 1], im.pixels[at + 2], im.pixels[at + 3]};
  };
  for (int j = 0; j < kHeight; j += 3) {
    if (rowY(j) > kMaxY) {
      EXPECT_EQ(px(*clear, 4, j)[3], 0) << j;
      EXPECT_EQ(px(*filled, 4, j), (std::array<std::uint8_t, 4>{0x12, 0x34, 0x56, 255})) << j;
    } else {
      EXPECT_EQ(px(*clear, 4, j)[3], 255) << j;
      EXPECT_EQ(px(*filled, 4, j), px(*clear, 4, j)) << j;
    }
  }
}

TEST(WmsMercatorIntegration, GetFeatureInfoGoesThroughTheSameRows) {
  Server s;
  const std::string q = "SERVICE=WMS&VERSION=1.3.0&REQUEST=GetFeatureInfo&LAYERS=lat&STYLES="
                        "&CRS=EPSG:3857&FORMAT=image/png&QUERY_LAYERS=lat"
                        "&INFO_FORMAT=application/json" +
                        kBox;
  for (const int j : {40, 100, 199}) {
    const auto r = s.get(q + "&I=5&J=" + std::to_string(j));
    ASSERT_EQ(r.status, 200) << r.body;
    const auto f = nlohmann::json::parse(r.body)["features"][0];
    EXPECT_NEAR(f["properties"]["value"].get<double>(), latitudeOfY(rowY(j)), 3e-5) << j;
    EXPECT_NEAR(f["geometry"]["coordinates"][1].get<double>(), latitudeOfY(rowY(j)), 1e-9) << j;
    EXPECT_NEAR(f["geometry"]["coordinates"][0].get<double>(),
                longitudeOfX(-1113194.9 + 5.5 * 2 * 1113194.9 / kWidth),
                1e-9);
  }
  // Past the square: no value (and no tile asked for).
  const auto past = s.get(q + "&I=5&J=2");
  ASSERT_EQ(past.status, 200) << past.body;
  EXPECT_TRUE(nlohmann::json::parse(past.body)["features"][0]["properties"]["value"].is_null());
  // 1.1.1 with X/Y and the alias: the same answer.
  const auto v111 = s.get("SERVICE=WMS&VERSION=1.1.1&REQUEST=GetFeatureInfo&LAYERS=lat&STYLES="
                          "&SRS=EPSG:900913&FORMAT=image/png&QUERY_LAYERS=lat"
                          "&INFO_FORMAT=application/json&X=5&Y=100" +
                          kBox);
  EXPECT_EQ(v111.body, s.get(q + "&I=5&J=100").body);
}

// A JPEG map of one band (a box small in latitude) is composed on the YCbCr planes, the chroma's
// rows at the inverse Mercator too (an odd height: the chroma reaches half a sample past the box);
// the PNG of the same map is composed in RGB: both are the latitude's grey, row by row.
TEST(WmsMercatorIntegration, JpegMapsOnThePlanesAreTheSameRows) {
  Server s;
  const double y0 = yOfLatitude(40.0), y1 = yOfLatitude(50.0);
  const std::string q = "SERVICE=WMS&VERSION=1.3.0&REQUEST=GetMap&LAYERS=pic&STYLES=&CRS=EPSG:3857"
                        "&BBOX=0," +
                        std::to_string(y0) + ",1000000," + std::to_string(y1) +
                        "&WIDTH=64&HEIGHT=101";
  const auto jpeg = s.get(q + "&FORMAT=image/jpeg");
  ASSERT_EQ(jpeg.status, 200) << jpeg.body.substr(0, 300);
  auto j = codec::decodeJpeg(span(jpeg.body));
  auto p = codec::decodePng(span(s.get(q + "&FORMAT=image/png").body));
  ASSERT_TRUE(j);
  ASSERT_TRUE(p);
  ASSERT_EQ(j->height, 101);
  for (int row = 0; row < 101; ++row) {
    const double lat = latitudeOfY(y1 - (row + 0.5) * (y1 - y0) / 101);
    const auto at = (std::size_t(row) * 64 + 30);
    EXPECT_NEAR(p->pixels[at * std::size_t(p->channels) + 1], greyOf(lat), 2.5) << row;
    EXPECT_NEAR(j->pixels[at * std::size_t(j->channels) + 1], greyOf(lat), 3.5) << row;
  }
}

// Issue 29: a Web Mercator map of the world, 64 x 64 pixels (5.6 degrees of longitude a pixel): its
// rows up to 79.8 degrees of latitude are coarser than the overview's 1.4-degree texels times
// sqrt 2, and come from "pic-overview" (8 tiles); the rows nearer the poles from "pic"'s level
// zero (its polar rows of tiles, 20); without the overview all 50 of level zero. Every row is the
// grey of its latitude, whichever layer drew it.
TEST(WmsMercatorIntegration, AWorldMapTakesItsCoarseRowsFromACoarserLayer) {
  const std::string q = "SERVICE=WMS&VERSION=1.3.0&REQUEST=GetMap&LAYERS=pic&STYLES=&CRS=EPSG:3857"
                        "&FORMAT=image/png&BBOX=" +
                        std::to_string(-kMaxY) + "," + std::to_string(-kMaxY) + "," +
                        std::to_string(kMaxY) + "," + std::to_string(kMaxY) + "&WIDTH=64&HEIGHT=64";
  for (const bool overview : {false, true}) {
    Server s(overview);
    const auto r = s.get(q);
    ASSERT_EQ(r.status, 200) << r.body.substr(0, 300);
    EXPECT_EQ(s.up.requests(), overview ? 8u + 20u : 50u) << overview;
    auto p = codec::decodePng(span(r.body));
    ASSERT_TRUE(p);
    for (int row = 0; row < 64; ++row) {
      const double lat = latitudeOfY(kMaxY - (row + 0.5) * 2.0 * kMaxY / 64);
      const auto at = (std::size_t(row) * 64 + 21) * std::size_t(p->channels) + 1;
      EXPECT_NEAR(p->pixels[at], greyOf(lat), 3.0) << "row " << row << ", overview " << overview;
    }
  }
}
