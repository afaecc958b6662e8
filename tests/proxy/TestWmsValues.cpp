// Value layers over WMS (issue 24) on a running tellus (cache, fetcher, tile service, front end,
// HTTP server on a loopback port): STYLES naming colour maps, coloured GetMaps whose pixels are
// the values::colourOf of the values, GetLegendGraphic's PNG, GetFeatureInfo in every
// INFO_FORMAT and both versions, and the capabilities that declare it all, validated against the
// official schemas.

#include "../support/CacheFixtures.hpp"
#include "../support/FakeUpstream.hpp"
#include "../support/HttpClient.hpp"
#include "../support/TempDir.hpp"
#include "../support/WmsSchemas.hpp"
#include "../values/TiffBuilder.hpp"

#include <tellus/cache/TileCache.hpp>
#include <tellus/codec/Png.hpp>
#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/HttpServer.hpp>
#include <tellus/proxy/ImageCodec.hpp>
#include <tellus/proxy/ProxyFrontEnd.hpp>
#include <tellus/proxy/TileService.hpp>
#include <tellus/values/ColourScale.hpp>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <span>
#include <string>

using namespace tellus;
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

/** "upchl": a Float32 TIFF (Deflate, strips), 10^(column / width * 4 - 2): 0.01 at the west
 * edge of a tile to 100 at its east edge. */
test::FakeReply chlTile(int w, int h) {
  std::vector<std::uint32_t> bits;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      bits.push_back(std::bit_cast<std::uint32_t>(
          static_cast<float>(std::pow(10.0, (x + 0.5) / w * 4.0 - 2.0))));
  values::test::TiffSpec spec{
      .width = w, .height = h, .bits = 32, .sampleFormat = 3, .compression = 8, .rowsPerStrip = 8};
  const auto tiff = values::test::TiffBuilder(spec).build(bits);
  return test::FakeReply::ok(bytesOf(tiff), "image/tiff");
}

/** "upsst" and "updem": BIL16 whose raw sample is round(100 * the texel centre's longitude) (the
 * value, with scale 0.01, is the longitude in degrees), no data (-32768) north of 60 N. "upsat": a
 * JPEG. */
test::FakeReply upstreamTile(const test::FakeRequest& req) {
  const int w = std::atoi(paramOf(req.target, "WIDTH").c_str());
  const int h = std::atoi(paramOf(req.target, "HEIGHT").c_str());
  if (w <= 0 || h <= 0 || w > 1024 || h > 1024) return test::FakeReply::withStatus(400, "size");
  const auto n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  if (paramOf(req.target, "LAYERS") == "upchl") return chlTile(w, h);
  if (paramOf(req.target, "LAYERS") == "updown") return test::FakeReply::withStatus(500, "down");
  if (paramOf(req.target, "LAYERS") != "upsst" && paramOf(req.target, "LAYERS") != "updem") {
    std::vector<std::uint8_t> px(n * 3, 90);
    return test::FakeReply::ok(bytesOf(*encodeImage("image/jpeg", w, h, 3, px.data())),
                               "image/jpeg");
  }
  // WMS 1.3.0, EPSG:4326: BBOX is south,west,north,east.
  double b[4] = {};
  std::sscanf(paramOf(req.target, "BBOX").c_str(), "%lf,%lf,%lf,%lf", &b[0], &b[1], &b[2], &b[3]);
  std::vector<std::int16_t> v(n);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double lon = b[1] + (x + 0.5) * (b[3] - b[1]) / w;
      const double lat = b[2] - (y + 0.5) * (b[2] - b[0]) / h;
      v[std::size_t(y * w + x)] =
          lat > 60.0 ? std::int16_t(-32768) : static_cast<std::int16_t>(std::lround(lon * 100));
    }
  return test::FakeReply::ok(bytesOf(*encodeHeights("application/bil16", w, h, v.data())),
                             "application/bil16");
}

LayerSpec sst() {
  LayerSpec l;
  l.name = "sst";
  l.title = "Longitude as a value";
  l.upstream = "up";
  l.upstreamLayer = "upsst";
  l.dataset.grid = GridSpec{Sector{}, 36.0, 64, 64, 3};
  l.dataset.mimeType = "application/bil16";
  ValueLayerSpec v;
  v.format.container = values::Container::Bil;
  v.format.scale = 0.01;
  v.format.noData = -32768.0;
  v.format.unit = "deg";
  v.defaultStyle = "turbo";
  v.styles = {"viridis", "turbo", "coolwarm"};
  v.min = -180.0;
  v.max = 180.0;
  l.values = v;
  return l;
}

/** An elevation layer (the same samples): its default style is the grey ramp, its colour maps
 * are offered by name. */
LayerSpec dem() {
  LayerSpec l = sst();
  l.name = "dem";
  l.upstreamLayer = "updem";
  l.elevation = true;
  l.values->defaultStyle = "";
  l.values->styles = {"terrain", "viridis"};
  l.values->format.unit = "m";
  return l;
}

/** A Float32 TIFF layer on a log scale with its range from each map's data. */
LayerSpec chl() {
  LayerSpec l = sst();
  l.name = "chl";
  l.upstreamLayer = "upchl";
  l.dataset.mimeType = "image/tiff";
  l.values->format = values::ValueFormat{};
  l.values->format.container = values::Container::Tiff;
  l.values->format.encoding = values::Encoding::Float32; // `encoding: float32`
  l.values->format.unit = "mg/m³";
  l.values->defaultStyle = "viridis";
  l.values->styles = {"viridis"};
  l.values->rangeFromData = true;
  l.values->scaling = values::Scaling::Log;
  return l;
}

/** An elevation value layer whose upstream always fails (500). */
LayerSpec down() {
  LayerSpec l = dem();
  l.name = "down";
  l.upstreamLayer = "updown";
  return l;
}

LayerSpec sat() {
  LayerSpec l;
  l.name = "sat";
  l.title = "sat";
  l.upstream = "up";
  l.upstreamLayer = "upsat";
  l.dataset.grid = GridSpec{Sector{}, 36.0, 256, 256, 3};
  l.dataset.mimeType = "image/jpeg";
  return l;
}

struct Server {
  test::FakeUpstream up{upstreamTile};
  test::TempDir dir{"wms-values"};
  std::unique_ptr<TileCache> cache;
  std::unique_ptr<Fetcher> fetcher;
  std::unique_ptr<TileService> tiles;
  std::unique_ptr<ProxyFrontEnd> front;
  std::unique_ptr<HttpServer> server;

  explicit Server(std::vector<LayerSpec> layers = {sst(), sat(), dem(), chl(), down()}) {
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
    auto t = TileService::create(*cache, *fetcher, {u}, std::move(layers), TileServiceOptions{});
    EXPECT_TRUE(t) << (t ? "" : t.error());
    tiles = std::move(*t);
    FrontEndOptions options;
    options.limits = WmsLimits{512, 256};
    front = std::make_unique<ProxyFrontEnd>(*tiles, options);
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

std::span<const std::byte> span(const std::string& s) {
  return {reinterpret_cast<const std::byte*>(s.data()), s.size()};
}

/** The number after `prefix` in `body` (NaN when absent). */
double valueIn(const std::string& body, const std::string& prefix) {
  const auto at = body.find(prefix);
  if (at == std::string::npos) return std::nan("");
  return std::strtod(body.c_str() + at + prefix.size(), nullptr);
}

/** The map's RGBA pixel (x, y). */
std::array<std::uint8_t, 4> pixel(const codec::Image& im, int x, int y) {
  const auto at = (std::size_t(y) * std::size_t(im.width) + std::size_t(x)) * 4;
  return {im.pixels[at], im.pixels[at + 1], im.pixels[at + 2], im.pixels[at + 3]};
}

const std::string kMap = "SERVICE=WMS&VERSION=1.3.0&REQUEST=GetMap&LAYERS=sst&CRS=CRS:84"
                         "&BBOX=-180,-90,180,90&WIDTH=360&HEIGHT=180&FORMAT=image/png"
                         "&TRANSPARENT=TRUE";

// Each pixel of a styled map is the colour of the value there by values::colourOf (the value is
// the pixel's longitude; bilinear on a linear field is exact up to float rounding, so the index
// may differ by one only where t * 256 lies within 1e-4 of a bin edge: none of these pixels).
TEST(WmsValuesIntegration, StyledGetMapColoursEachPixelByTheScale) {
  Server s;
  for (const std::string style : {"turbo", "viridis", "", "default"}) {
    SCOPED_TRACE(style);
    const auto r = s.get(kMap + "&STYLES=" + style);
    ASSERT_EQ(r.status, 200) << r.body.substr(0, 400);
    ASSERT_EQ(r.header("content-type"), "image/png") << r.body.substr(0, 600);
    auto im = codec::decodePng(span(r.body));
    ASSERT_TRUE(im) << im.error();
    const values::ColourMap* map =
        values::findColourMap(style.empty() || style == "default" ? "turbo" : style);
    const values::ColourScale scale{map, -180.0, 180.0};
    for (const int x : {3, 90, 181, 250, 356}) {
      const float lon = static_cast<float>(-180.0 + x + 0.5);
      const auto c = values::colourOf(scale, lon);
      EXPECT_EQ(pixel(*im, x, 100), (std::array<std::uint8_t, 4>{c[0], c[1], c[2], 255})) << x;
    }
    // North of 60 N: no data, transparent.
    EXPECT_EQ(pixel(*im, 100, 10)[3], 0);
  }
}

// An elevation layer: STYLES= stays the grey ramp, a named colour map colours it.
TEST(WmsValuesIntegration, ElevationLayersKeepTheirDefaultAndOfferColourMaps) {
  Server s;
  const std::string q = "SERVICE=WMS&VERSION=1.3.0&REQUEST=GetMap&LAYERS=dem&CRS=CRS:84"
                        "&BBOX=-180,-90,180,90&WIDTH=360&HEIGHT=180&FORMAT=image/png";
  auto grey = codec::decodePng(span(s.get(q + "&STYLES=").body));
  ASSERT_TRUE(grey);
  const auto g = pixel(*grey, 250, 100);
  EXPECT_TRUE(g[0] == g[1] && g[1] == g[2]);
  auto terrain = codec::decodePng(span(s.get(q + "&STYLES=terrain").body));
  ASSERT_TRUE(terrain);
  const auto c = values::colourOf({values::findColourMap("terrain"), -180.0, 180.0}, 70.5f);
  EXPECT_EQ(pixel(*terrain, 250, 100), (std::array<std::uint8_t, 4>{c[0], c[1], c[2], 255}));
  const auto legend = s.get("SERVICE=WMS&REQUEST=GetLegendGraphic&FORMAT=image/png&LAYER=dem");
  EXPECT_NE(legend.body.find("StyleNotDefined"), std::string::npos) << legend.body;
  EXPECT_EQ(s.get("SERVICE=WMS&REQUEST=GetLegendGraphic&FORMAT=image/png&LAYER=dem&STYLE=terrain")
                .header("content-type"),
            "image/png");
}

// A Float32 TIFF layer, log scale, range from the map's data: west edges of tiles low, east high.
TEST(WmsValuesIntegration, Float32TiffOnALogScaleWithARangeFromTheData) {
  Server s;
  const auto r = s.get("SERVICE=WMS&VERSION=1.3.0&REQUEST=GetMap&LAYERS=chl&STYLES=&CRS=CRS:84"
                       "&BBOX=0,-36,36,0&WIDTH=64&HEIGHT=64&FORMAT=image/png");
  ASSERT_EQ(r.header("content-type"), "image/png") << r.body.substr(0, 500);
  auto im = codec::decodePng(span(r.body));
  ASSERT_TRUE(im);
  const auto& table = *values::findColourMap("viridis")->table;
  const auto west = pixel(*im, 0, 30), east = pixel(*im, 63, 30);
  // The range is the map's own: its ends get (nearly) the table's ends.
  EXPECT_LE(std::abs(int(west[0]) - table[0][0]) + std::abs(int(west[2]) - table[0][2]), 12);
  EXPECT_LE(std::abs(int(east[0]) - table[255][0]) + std::abs(int(east[2]) - table[255][2]), 12);
  const auto info = s.get("SERVICE=WMS&VERSION=1.3.0&REQUEST=GetFeatureInfo&LAYERS=chl&CRS=CRS:84"
                          "&BBOX=0,-36,36,0&WIDTH=64&HEIGHT=64&QUERY_LAYERS=chl"
                          "&INFO_FORMAT=text/plain&I=32&J=32");
  // The pixel centre lies on texel 32.5 of the level-0 tile: 10^(32.5 / 64 * 4 - 2).
  EXPECT_NEAR(valueIn(info.body, "value = "), std::pow(10.0, 32.5 / 64 * 4 - 2), 1e-3) << info.body;
  EXPECT_NE(info.body.find("mg/m³"), std::string::npos);
  const auto legend = s.get("SERVICE=WMS&REQUEST=GetLegendGraphic&FORMAT=image/png&LAYER=chl");
  EXPECT_EQ(legend.header("content-type"), "image/png") << legend.body;
}

TEST(WmsValuesIntegration, UnknownStyleIsStyleNotDefined) {
  Server s;
  const auto r = s.get(kMap + "&STYLES=magma");
  EXPECT_NE(r.body.find("StyleNotDefined"), std::string::npos) << r.body;
  const auto imagery =
      s.get("SERVICE=WMS&VERSION=1.3.0&REQUEST=GetMap&LAYERS=sat&CRS=CRS:84"
            "&BBOX=-180,-90,180,90&WIDTH=64&HEIGHT=32&FORMAT=image/png&STYLES=turbo");
  EXPECT_NE(imagery.body.find("StyleNotDefined"), std::string::npos) << imagery.body;
}

TEST(WmsValuesIntegration, CapabilitiesDeclareStylesLegendsAndQueryable) {
  Server s;
  for (const auto& [version, kind] : {std::pair{"1.3.0", test::WmsDocument::Capabilities130},
                                      std::pair{"1.1.1", test::WmsDocument::Capabilities111}}) {
    SCOPED_TRACE(version);
    const auto r = s.get(std::string("SERVICE=WMS&REQUEST=GetCapabilities&VERSION=") + version);
    ASSERT_EQ(r.status, 200);
    const auto verdict = test::validateWms(r.body, kind);
    EXPECT_TRUE(verdict.valid) << verdict.output << "\n" << r.body;
    EXPECT_NE(r.body.find("<GetFeatureInfo>"), std::string::npos);
    EXPECT_NE(r.body.find("<Format>application/json</Format>"), std::string::npos);
    const auto sstAt = r.body.find("<Name>sst</Name>");
    const auto satAt = r.body.find("<Name>sat</Name>");
    ASSERT_NE(sstAt, std::string::npos);
    EXPECT_NE(r.body.rfind("queryable=\"1\"", sstAt), std::string::npos);
    EXPECT_EQ(r.body.substr(r.body.rfind("<Layer", satAt), 40).find("queryable=\"0\""), 7u);
    // The default style first, each with its legend.
    const auto turbo = r.body.find("<Name>turbo</Name>");
    const auto viridis = r.body.find("<Name>viridis</Name>");
    EXPECT_LT(turbo, viridis);
    EXPECT_NE(r.body.find("REQUEST=GetLegendGraphic&amp;VERSION=1.3.0&amp;FORMAT=image/png"
                          "&amp;SLD_VERSION=1.1.0&amp;LAYER=sst&amp;STYLE=coolwarm"),
              std::string::npos);
    EXPECT_NE(r.body.find("<LegendURL width=\"256\" height=\"56\">"), std::string::npos);
    // GetLegendGraphic declared: the DTD's element in 1.1.1, SLD 1.1.0's in 1.3.0.
    EXPECT_NE(r.body.find(std::string(version) == "1.3.0" ? "<sld:GetLegendGraphic>"
                                                          : "<GetLegendGraphic>"),
              std::string::npos);
  }
}

TEST(WmsValuesIntegration, GetLegendGraphicIsAPng) {
  Server s;
  const std::string q = "SERVICE=WMS&REQUEST=GetLegendGraphic&VERSION=1.3.0&FORMAT=image/png"
                        "&SLD_VERSION=1.1.0&LAYER=sst";
  const auto r = s.get(q + "&STYLE=coolwarm");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.header("content-type"), "image/png");
  auto im = codec::decodePng(span(r.body));
  ASSERT_TRUE(im) << im.error();
  EXPECT_EQ(im->width, 256);
  EXPECT_EQ(im->height, 56);
  // The bar holds the colour map's first and last entries.
  const auto& table = *values::findColourMap("coolwarm")->table;
  bool first = false, last = false;
  for (int x = 0; x < im->width; ++x) {
    const auto p = pixel(*im, x, 28);
    first = first || (p[0] == table[0][0] && p[1] == table[0][1] && p[2] == table[0][2]);
    last = last || (p[0] == table[255][0] && p[1] == table[255][1] && p[2] == table[255][2]);
  }
  EXPECT_TRUE(first && last);
  auto sized = codec::decodePng(span(s.get(q + "&WIDTH=80&HEIGHT=300").body));
  ASSERT_TRUE(sized);
  EXPECT_EQ(sized->width, 80);
  EXPECT_EQ(sized->height, 300);
  EXPECT_NE(s.get(q + "&STYLE=magma").body.find("StyleNotDefined"), std::string::npos);
  EXPECT_NE(s.get("SERVICE=WMS&REQUEST=GetLegendGraphic&VERSION=1.3.0&FORMAT=image/jpeg&LAYER=sst")
                .body.find("InvalidFormat"),
            std::string::npos);
  EXPECT_NE(s.get("SERVICE=WMS&REQUEST=GetLegendGraphic&VERSION=1.3.0&FORMAT=image/png&LAYER=x")
                .body.find("LayerNotDefined"),
            std::string::npos);
  const auto imagery =
      s.get("SERVICE=WMS&REQUEST=GetLegendGraphic&VERSION=1.3.0&FORMAT=image/png&LAYER=sat");
  EXPECT_NE(imagery.body.find("no value layer"), std::string::npos) << imagery.body;
  EXPECT_TRUE(test::validateWms(imagery.body, test::WmsDocument::Exception130).valid);
}

const std::string kInfo130 = "SERVICE=WMS&VERSION=1.3.0&REQUEST=GetFeatureInfo&LAYERS=sst"
                             "&STYLES=&CRS=CRS:84&BBOX=-180,-90,180,90&WIDTH=360&HEIGHT=180"
                             "&FORMAT=image/png&QUERY_LAYERS=sst";

// The value at the pixel is its longitude (the pixel's centre; bilinear inside the tile).
TEST(WmsValuesIntegration, GetFeatureInfoAnswersTheValueWithItsUnit) {
  Server s;
  const auto text = s.get(kInfo130 + "&INFO_FORMAT=text/plain&I=200&J=100");
  ASSERT_EQ(text.status, 200) << text.body;
  EXPECT_EQ(text.header("content-type"), "text/plain; charset=utf-8");
  EXPECT_NE(text.body.find("Layer 'sst'"), std::string::npos) << text.body;
  // The raw samples are hundredths: bilinear between them is within 0.005 of the longitude.
  EXPECT_NEAR(valueIn(text.body, "value = "), 20.5, 0.006) << text.body;
  EXPECT_NE(text.body.find(" deg\n"), std::string::npos) << text.body;

  const auto json = s.get(kInfo130 + "&INFO_FORMAT=application/json&I=37&J=120");
  ASSERT_EQ(json.status, 200) << json.body;
  const auto doc = nlohmann::json::parse(json.body);
  ASSERT_EQ(doc["features"].size(), 1u);
  const auto& f = doc["features"][0];
  EXPECT_EQ(f["id"], "sst");
  EXPECT_NEAR(f["properties"]["value"].get<double>(), -142.5, 0.006);
  EXPECT_EQ(f["properties"]["unit"], "deg");
  EXPECT_NEAR(f["geometry"]["coordinates"][0].get<double>(), -142.5, 1e-9);
  EXPECT_NEAR(f["geometry"]["coordinates"][1].get<double>(), -30.5, 1e-9);

  const auto html = s.get(kInfo130 + "&INFO_FORMAT=text/html&I=200&J=100");
  EXPECT_NEAR(valueIn(html.body, "<td>-10.5</td><td>"), 20.5, 0.006) << html.body;
  EXPECT_NE(html.body.find("</td><td>deg</td></tr>"), std::string::npos) << html.body;
  for (const std::string gml : {"application/vnd.ogc.gml", "text/xml"}) {
    const auto g = s.get(kInfo130 + "&INFO_FORMAT=" + gml + "&I=200&J=100");
    EXPECT_EQ(g.header("content-type"), gml);
    EXPECT_NEAR(valueIn(g.body, "<value_0>"), 20.5, 0.006) << g.body;
    EXPECT_NE(g.body.find("<msGMLOutput"), std::string::npos);
  }
  // No data north of 60 N.
  const auto none = s.get(kInfo130 + "&INFO_FORMAT=application/json&I=200&J=5");
  EXPECT_TRUE(nlohmann::json::parse(none.body)["features"][0]["properties"]["value"].is_null());
}

TEST(WmsValuesIntegration, GetFeatureInfo111UsesXAndY) {
  Server s;
  const auto r = s.get("SERVICE=WMS&VERSION=1.1.1&REQUEST=GetFeatureInfo&LAYERS=sst&STYLES="
                       "&SRS=EPSG:4326&BBOX=0,-45,90,45&WIDTH=90&HEIGHT=90&FORMAT=image/png"
                       "&QUERY_LAYERS=sst&X=10&Y=45");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_NEAR(valueIn(r.body, "value = "), 10.5, 0.006) << r.body;
}

TEST(WmsValuesIntegration, GetFeatureInfoExceptionsAsTheStandardSays) {
  Server s;
  struct Case {
    std::string query, code;
    bool v130;
  };
  const std::string sat130 = "SERVICE=WMS&VERSION=1.3.0&REQUEST=GetFeatureInfo&LAYERS=sst,sat"
                             "&STYLES=,&CRS=CRS:84&BBOX=-180,-90,180,90&WIDTH=360&HEIGHT=180"
                             "&INFO_FORMAT=text/plain&I=1&J=1";
  const std::vector<Case> cases = {
      {sat130 + "&QUERY_LAYERS=sat", "LayerNotQueryable", true},
      {kInfo130 + "&INFO_FORMAT=text/plain&I=360&J=1", "InvalidPoint", true},
      {kInfo130 + "&INFO_FORMAT=text/plain&I=-1&J=1", "InvalidPoint", true},
      {kInfo130 + "&INFO_FORMAT=text/plain&I=1", "MissingParameterValue", true},
      {kInfo130 + "&I=1&J=1", "MissingParameterValue", true},
      {kInfo130 + "&INFO_FORMAT=image/png&I=1&J=1", "InvalidFormat", true},
      {sat130 + "&QUERY_LAYERS=other", "LayerNotDefined", true},
      {"SERVICE=WMS&VERSION=1.1.1&REQUEST=GetFeatureInfo&LAYERS=sst&STYLES=&SRS=EPSG:4326"
       "&BBOX=-180,-90,180,90&WIDTH=360&HEIGHT=180&QUERY_LAYERS=sst&X=400&Y=1",
       "InvalidParameterValue",
       false},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.query);
    const auto r = s.get(c.query);
    EXPECT_NE(r.body.find(c.code), std::string::npos) << r.body;
    const auto verdict = test::validateWms(
        r.body, c.v130 ? test::WmsDocument::Exception130 : test::WmsDocument::Exception111);
    EXPECT_TRUE(verdict.valid) << verdict.output << "\n" << r.body;
  }
}

/** A PNG's bit depth and colour type (IHDR), {0, 0} when it is not a PNG. */
std::pair<int, int> pngDepthAndType(const std::string& body) {
  if (body.size() < 26 || body.compare(1, 3, "PNG") != 0) return {0, 0};
  return {static_cast<unsigned char>(body[24]), static_cast<unsigned char>(body[25])};
}

// A styled map of an elevation value layer is a picture (8-bit RGBA), so a GetMap of it that
// fails with EXCEPTIONS=BLANK or INIMAGE (1.3.0) or se_blank / se_inimage (1.1.1) is answered
// with a picture too, as the map would have been, not with the 16-bit heights PNG that the layer
// unstyled is: both for a style the layer does not have and for an upstream that fails.
TEST(WmsValuesIntegration, StyledMapsFailAsPicturesWithBlankOrInImageExceptions) {
  Server s;
  const std::string v130 = "SERVICE=WMS&VERSION=1.3.0&REQUEST=GetMap&CRS=CRS:84"
                           "&BBOX=-180,-90,180,90&WIDTH=64&HEIGHT=32&FORMAT=image/png"
                           "&TRANSPARENT=TRUE";
  const std::string v111 = "SERVICE=WMS&VERSION=1.1.1&REQUEST=GetMap&SRS=EPSG:4326"
                           "&BBOX=-180,-90,180,90&WIDTH=64&HEIGHT=32&FORMAT=image/png"
                           "&TRANSPARENT=TRUE";
  struct Case {
    std::string query;
    bool inImage;
  };
  const std::vector<Case> cases = {
      {v130 + "&LAYERS=dem&STYLES=magma&EXCEPTIONS=BLANK", false},
      {v130 + "&LAYERS=dem&STYLES=magma&EXCEPTIONS=INIMAGE", true},
      {v130 + "&LAYERS=down&STYLES=terrain&EXCEPTIONS=BLANK", false},
      {v130 + "&LAYERS=down&STYLES=terrain&EXCEPTIONS=INIMAGE", true},
      {v111 + "&LAYERS=dem&STYLES=magma&EXCEPTIONS=application/vnd.ogc.se_blank", false},
      {v111 + "&LAYERS=down&STYLES=viridis&EXCEPTIONS=application/vnd.ogc.se_inimage", true},
      {v111 + "&LAYERS=sat,down&STYLES=,terrain&EXCEPTIONS=application/vnd.ogc.se_blank", false},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.query);
    const auto r = s.get(c.query);
    ASSERT_EQ(r.header("content-type"), "image/png") << r.body.substr(0, 400);
    EXPECT_EQ(pngDepthAndType(r.body), (std::pair{8, 6})); // 8-bit RGBA, as the map would be
    auto im = codec::decodePng(span(r.body));
    ASSERT_TRUE(im) << im.error();
    ASSERT_EQ(im->width, 64);
    ASSERT_EQ(im->height, 32);
    bool drawn = false;
    for (int y = 0; y < 32; ++y)
      for (int x = 0; x < 64; ++x)
        drawn = drawn || pixel(*im, x, y)[3] != 0;
    EXPECT_EQ(drawn, c.inImage); // blank: all transparent; in image: the message drawn
  }
  // The same failures unstyled are heights, as the map would have been (16-bit grey).
  const auto plain = s.get(v130 + "&LAYERS=down&STYLES=&EXCEPTIONS=BLANK");
  EXPECT_EQ(plain.header("content-type"), "image/png");
  EXPECT_EQ(pngDepthAndType(plain.body), (std::pair{16, 0}));
  // The styled map itself, for comparison: the same kind of PNG as its blank.
  const auto map = s.get(v130 + "&LAYERS=dem&STYLES=terrain&EXCEPTIONS=BLANK");
  EXPECT_EQ(pngDepthAndType(map.body), (std::pair{8, 6}));
}

// BIL is data: a style does not colour an elevation layer in a BIL16 map (its heights, the same
// bytes as unstyled), and such a map that fails is a blank BIL16.
TEST(WmsValuesIntegration, BilMapsOfStyledElevationLayersAreHeights) {
  Server s;
  const std::string q = "SERVICE=WMS&VERSION=1.3.0&REQUEST=GetMap&CRS=CRS:84"
                        "&BBOX=-180,-90,180,90&WIDTH=64&HEIGHT=32&FORMAT=application/bil16";
  const auto styled = s.get(q + "&LAYERS=dem&STYLES=terrain");
  ASSERT_EQ(styled.status, 200) << styled.body.substr(0, 400);
  EXPECT_EQ(styled.header("content-type"), "application/bil16");
  EXPECT_EQ(styled.body.size(), 64u * 32u * 2u);
  EXPECT_EQ(styled.body, s.get(q + "&LAYERS=dem&STYLES=").body);
  const auto failed = s.get(q + "&LAYERS=down&STYLES=terrain&EXCEPTIONS=BLANK");
  EXPECT_EQ(failed.header("content-type"), "application/bil16");
  EXPECT_EQ(failed.body.size(), 64u * 32u * 2u);
}

/** The Float32 values of an application/bil32 body (little-endian). */
std::vector<float> bil32Values(const std::string& body) {
  std::vector<float> v(body.size() / 4);
  for (std::size_t k = 0; k < v.size(); ++k) {
    std::uint32_t bits = 0;
    for (std::size_t b = 0; b < 4; ++b)
      bits |= std::uint32_t(static_cast<unsigned char>(body[k * 4 + b])) << (8 * b);
    v[k] = std::bit_cast<float>(bits);
  }
  return v;
}

// application/bil32: a map of Float32 values, little-endian, for layers of Float32 values only;
// offered in the capabilities when a layer has them. A pixel on a texel centre has the tile's
// value; a style does not apply; a failed map with EXCEPTIONS=BLANK is no data (NaN, or the
// layer's no-data value).
TEST(WmsValuesIntegration, Bil32MapsAreFloat32Values) {
  Server s;
  // 0..36 E, 36 S..0: the columns of one level-0 tile, rows across two (texel-aligned).
  const std::string q = "SERVICE=WMS&VERSION=1.3.0&REQUEST=GetMap&CRS=CRS:84"
                        "&BBOX=0,-36,36,0&WIDTH=64&HEIGHT=64&FORMAT=application/bil32";
  const auto r = s.get(q + "&LAYERS=chl&STYLES=");
  ASSERT_EQ(r.status, 200) << r.body.substr(0, 400);
  EXPECT_EQ(r.header("content-type"), "application/bil32") << r.body.substr(0, 400);
  ASSERT_EQ(r.body.size(), 64u * 64u * 4u);
  const std::vector<float> v = bil32Values(r.body);
  for (const int y : {0, 31, 63})
    for (const int x : {0, 17, 40, 63})
      EXPECT_FLOAT_EQ(v[std::size_t(y * 64 + x)],
                      static_cast<float>(std::pow(10.0, (x + 0.5) / 64 * 4.0 - 2.0)))
          << x << "," << y;
  // The style does not apply: the same values with the layer's colour map named.
  EXPECT_EQ(s.get(q + "&LAYERS=chl&STYLES=viridis").body, r.body);
  // Layers without Float32 values: InvalidFormat (an Int16 value layer, imagery).
  for (const std::string layer : {"sst", "sat", "dem"}) {
    const auto refused = s.get(q + "&LAYERS=" + layer + "&STYLES=");
    EXPECT_NE(refused.body.find("InvalidFormat"), std::string::npos) << layer << refused.body;
    EXPECT_TRUE(test::validateWms(refused.body, test::WmsDocument::Exception130).valid);
  }
  // BLANK: no data everywhere (chl names none: NaN).
  const auto blank = s.get(q + "&LAYERS=chl&STYLES=magma&EXCEPTIONS=BLANK");
  EXPECT_EQ(blank.header("content-type"), "application/bil32");
  ASSERT_EQ(blank.body.size(), 64u * 64u * 4u);
  const auto nan = bil32Values(blank.body);
  EXPECT_TRUE(std::all_of(nan.begin(), nan.end(), [](float f) { return std::isnan(f); }));
  // Advertised (service-wide, as every GetMap format) because chl's values are Float32.
  for (const std::string version : {"1.1.1", "1.3.0"}) {
    const auto caps = s.get("SERVICE=WMS&REQUEST=GetCapabilities&VERSION=" + version);
    EXPECT_NE(caps.body.find("<Format>application/bil32</Format>"), std::string::npos) << version;
  }
}

TEST(WmsValuesIntegration, Bil32IsOfferedOnlyWithFloat32LayersAndFillsTheirNoData) {
  Server withoutFloat32({sst(), sat(), dem()});
  const auto caps = withoutFloat32.get("SERVICE=WMS&REQUEST=GetCapabilities&VERSION=1.3.0");
  ASSERT_EQ(caps.status, 200);
  EXPECT_EQ(caps.body.find("application/bil32"), std::string::npos);
  LayerSpec marked = chl();
  marked.values->format.noData = -9999.0;
  Server withNoData({marked});
  const auto blank =
      withNoData.get("SERVICE=WMS&VERSION=1.3.0&REQUEST=GetMap&CRS=CRS:84&LAYERS=chl&STYLES=magma"
                     "&BBOX=0,-36,36,0&WIDTH=8&HEIGHT=4&FORMAT=application/bil32&EXCEPTIONS=BLANK");
  ASSERT_EQ(blank.body.size(), 8u * 4u * 4u) << blank.body;
  for (const float f : bil32Values(blank.body))
    EXPECT_EQ(f, -9999.0f);
}

} // namespace
