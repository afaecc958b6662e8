// WMS 1.1.1 (OGC 01-068r3) and 1.3.0 (OGC 06-042) as the standards write them, tried on a running
// tellus (cache, fetcher, tile service, front end, HTTP server on a loopback port) the way a
// conformance check does: every parameter of each request table missing, empty, repeated, in odd
// case and with an illegal value; every advertised format for every layer; every CRS; the edges of
// BBOX and size; EXCEPTIONS in every format; TIME abuse. Every XML answer is validated against the
// official schemas (tests/data/schemas) and every image decoded.

#include "../support/CacheFixtures.hpp"
#include "../support/FakeUpstream.hpp"
#include "../support/HttpClient.hpp"
#include "../support/TempDir.hpp"
#include "../support/WmsSchemas.hpp"

#include <tellus/cache/TileCache.hpp>
#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/HttpServer.hpp>
#include <tellus/proxy/ImageCodec.hpp>
#include <tellus/proxy/OgcExceptionFormat.hpp>
#include <tellus/proxy/ProxyFrontEnd.hpp>
#include <tellus/proxy/TileService.hpp>

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

using namespace tellus;
using namespace std::chrono_literals;
namespace fs = std::filesystem;

namespace {

// ------------------------------------------------------------------------------ the server

std::string bytesOf(const std::vector<std::byte>& b) {
  return std::string(reinterpret_cast<const char*>(b.data()), b.size());
}

/** A query parameter of an upstream request (upper-case name as tellus sends it). */
std::string paramOf(const std::string& target, const std::string& name) {
  const auto at = target.find(name + "=");
  if (at == std::string::npos) return {};
  const auto end = target.find('&', at);
  return target.substr(at + name.size() + 1,
                       end == std::string::npos ? std::string::npos : end - at - name.size() - 1);
}

/** The upstream: a JPEG for "upsat" and "updaily", a half-transparent PNG for "upoverlay", BIL16
 * heights (the column's longitude in tenths of a degree) for "updem"; each WIDTH x HEIGHT. */
test::FakeReply upstreamTile(const test::FakeRequest& req) {
  const std::string layer = paramOf(req.target, "LAYERS");
  const int w = std::atoi(paramOf(req.target, "WIDTH").c_str());
  const int h = std::atoi(paramOf(req.target, "HEIGHT").c_str());
  if (w <= 0 || h <= 0 || w > 1024 || h > 1024) return test::FakeReply::withStatus(400, "size");
  const auto n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  if (layer == "updem") {
    std::vector<std::int16_t> v(n);
    for (std::size_t i = 0; i < n; ++i)
      v[i] = static_cast<std::int16_t>(100 + (i % static_cast<std::size_t>(w)));
    return test::FakeReply::ok(bytesOf(*encodeHeights("application/bil16", w, h, v.data())),
                               "application/bil16");
  }
  if (layer == "upoverlay") {
    std::vector<std::uint8_t> px(n * 4);
    for (std::size_t i = 0; i < n; ++i) {
      px[i * 4] = 200;
      px[i * 4 + 1] = 30;
      px[i * 4 + 2] = 30;
      px[i * 4 + 3] = (i % 2) ? 255 : 0;
    }
    return test::FakeReply::ok(bytesOf(*encodeImage("image/png", w, h, 4, px.data())), "image/png");
  }
  std::vector<std::uint8_t> px(n * 3);
  for (std::size_t i = 0; i < n; ++i) {
    px[i * 3] = 20;
    px[i * 3 + 1] = layer == "updaily" ? 200 : 90;
    px[i * 3 + 2] = 160;
  }
  return test::FakeReply::ok(bytesOf(*encodeImage("image/jpeg", w, h, 3, px.data())), "image/jpeg");
}

LayerSpec layerSpec(const std::string& name,
                    const std::string& mime,
                    bool elevation,
                    std::int32_t tileSize,
                    std::int32_t levels) {
  LayerSpec l;
  l.name = name;
  l.title = name;
  l.upstream = "up";
  l.upstreamLayer = "up" + name;
  l.dataset.grid = GridSpec{Sector{}, 36.0, tileSize, tileSize, levels};
  l.dataset.mimeType = mime;
  l.elevation = elevation;
  return l;
}

LayerSpec sat() {
  return layerSpec("sat", "image/jpeg", false, 256, 4);
}
LayerSpec overlay() {
  LayerSpec l = layerSpec("overlay", "image/png", false, 64, 3);
  l.opacity = 0.5;
  return l;
}
LayerSpec dem() {
  return layerSpec("dem", "application/bil16", true, 64, 3);
}
/** Hourly for a year: 8760 values, kept as the period (as the configuration keeps one of more
 * than 10000). */
LayerSpec daily() {
  LayerSpec l = layerSpec("daily", "image/jpeg", false, 256, 2);
  l.timePeriod = "2010-01-01T00:00Z/2010-12-31T23:00Z/PT1H";
  l.timeDefault = "2010-12-31T23:00Z";
  return l;
}

struct Server {
  test::FakeUpstream up{upstreamTile};
  test::TempDir dir{"wms-conformance"};
  std::unique_ptr<TileCache> cache;
  std::unique_ptr<Fetcher> fetcher;
  std::unique_ptr<TileService> tiles;
  std::unique_ptr<ProxyFrontEnd> front;
  std::unique_ptr<HttpServer> server;
  FrontEndOptions options;

  explicit Server(std::vector<LayerSpec> layers, bool httpStatusCodes = false) {
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
    options.limits = WmsLimits{512, 256};
    options.exceptionsHttpStatus = httpStatusCodes;
    options.updateSequence = "1796151274";
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
  /** Dataset folders of a layer in the cache ("<server>/<layer>-<hash>"). */
  std::size_t datasetFolders(const std::string& layer) const {
    std::size_t n = 0;
    std::error_code ec;
    for (const auto& origin : fs::directory_iterator(dir.path(), ec)) {
      if (!origin.is_directory()) continue;
      for (const auto& d : fs::directory_iterator(origin.path(), ec))
        n += d.path().filename().string().starts_with(layer + "-");
    }
    return n;
  }
};

// ------------------------------------------------------------------------------ answers

struct Png {
  int width = 0, height = 0, bitDepth = 0, colourType = -1;
};
std::optional<Png> pngHeader(const std::string& b) {
  if (b.size() < 33 || b.compare(0, 8, "\x89PNG\r\n\x1a\n") != 0) return std::nullopt;
  const auto u32 = [&](std::size_t at) {
    return static_cast<int>(
        (static_cast<unsigned char>(b[at]) << 24) | (static_cast<unsigned char>(b[at + 1]) << 16) |
        (static_cast<unsigned char>(b[at + 2]) << 8) | static_cast<unsigned char>(b[at + 3]));
  };
  return Png{
      u32(16), u32(20), static_cast<unsigned char>(b[24]), static_cast<unsigned char>(b[25])};
}

std::span<const std::byte> span(const std::string& s) {
  return {reinterpret_cast<const std::byte*>(s.data()), s.size()};
}

/** Checks an image answer: Content-Type, size and kind (picture or heights); "" when right. */
std::string checkImage(const test::HttpResult& r,
                       MapFormat format,
                       bool heights,
                       int w,
                       int h,
                       bool transparent = false) {
  const std::string ct = r.header("content-type");
  if (r.status != 200) return "status " + std::to_string(r.status) + ": " + r.body.substr(0, 300);
  if (ct != contentTypeOf(format)) return "content type " + ct + ": " + r.body.substr(0, 300);
  if (heights) {
    const char* mime = format == MapFormat::Png ? "image/png" : toString(format).data();
    auto v = decodeHeights(span(r.body), mime, w, h);
    if (!v) return "heights: " + v.error();
    if (format == MapFormat::Png && pngHeader(r.body)->bitDepth != 16) return "not 16-bit";
    return {};
  }
  if (format == MapFormat::Jpeg) {
    auto img = decodeImagery(span(r.body), "image/jpeg", w, h);
    return img ? std::string() : "jpeg: " + img.error();
  }
  if (format == MapFormat::Tiff) { // a picture: 8-bit RGB, RGBA with TRANSPARENT
    auto img = decodeImagery(span(r.body), "image/tiff", w, h);
    if (!img) return "tiff: " + img.error();
    if (img->channels != (transparent ? 4 : 3))
      return "TIFF channels " + std::to_string(img->channels);
    return {};
  }
  const auto png = pngHeader(r.body);
  if (!png) return "not a PNG";
  if (png->width != w || png->height != h) return "PNG size";
  // A palette may be packed in fewer bits (libpng does with few colours).
  if (png->bitDepth != 8 && !(png->colourType == 3 && png->bitDepth < 8))
    return "PNG depth " + std::to_string(png->bitDepth);
  // Colour types: 2 RGB, 3 palette, 6 RGBA.
  const int want = format == MapFormat::Png8    ? 3
                   : format == MapFormat::Png32 ? 6
                   : format == MapFormat::Png24 ? 2
                   : transparent                ? 6
                                                : 2;
  if (png->colourType != want)
    return "PNG colour type " + std::to_string(png->colourType) + ", not " + std::to_string(want);
  auto img = decodeImagery(span(r.body), "image/png", w, h);
  return img ? std::string() : "png: " + img.error();
}

/** Checks an XML exception answer of a version: status, Content-Type, schema, code. */
std::string checkException(const test::HttpResult& r,
                           WmsVersion version,
                           std::string_view code,
                           bool httpStatusCodes) {
  const int status = httpStatusCodes ? wmsExceptionHttpStatus(code) : 200;
  if (r.status != status)
    return "status " + std::to_string(r.status) + ", not " + std::to_string(status);
  const bool v111 = version == WmsVersion::V111;
  const std::string ct = r.header("content-type");
  if (ct != (v111 ? "application/vnd.ogc.se_xml" : "text/xml"))
    return "content type " + ct + ": " + r.body.substr(0, 300);
  const auto verdict = test::validateWms(
      r.body, v111 ? test::WmsDocument::Exception111 : test::WmsDocument::Exception130);
  if (!verdict.valid) return "invalid: " + verdict.output + "\n" + r.body;
  if (r.body.find("code=\"" + std::string(code) + "\"") == std::string::npos)
    return "no code " + std::string(code) + ": " + r.body;
  return {};
}

// ------------------------------------------------------------------------------ requests

using Params = std::vector<std::pair<std::string, std::string>>;

std::string join(const Params& p) {
  std::string q;
  for (const auto& [k, v] : p) {
    if (!q.empty()) q += '&';
    q += k;
    if (v != "<no=>") q += "=" + v;
  }
  return q;
}

Params getMap(WmsVersion v, const std::string& layers = "sat") {
  if (v == WmsVersion::V111)
    return {{"VERSION", "1.1.1"},
            {"REQUEST", "GetMap"},
            {"LAYERS", layers},
            {"STYLES", ""},
            {"SRS", "EPSG:4326"},
            {"BBOX", "-170,-80,-100,-30"},
            {"WIDTH", "64"},
            {"HEIGHT", "32"},
            {"FORMAT", "image/png"}};
  return {{"VERSION", "1.3.0"},
          {"REQUEST", "GetMap"},
          {"LAYERS", layers},
          {"STYLES", ""},
          {"CRS", "EPSG:4326"},
          {"BBOX", "-80,-170,-30,-100"},
          {"WIDTH", "64"},
          {"HEIGHT", "32"},
          {"FORMAT", "image/png"}};
}

Params without(Params p, const std::string& key) {
  std::erase_if(p, [&](const auto& kv) { return kv.first == key; });
  return p;
}
Params with(Params p, const std::string& key, const std::string& value) {
  for (auto& [k, v] : p) {
    if (k == key) {
      v = value;
      return p;
    }
  }
  p.emplace_back(key, value);
  return p;
}
Params renamed(Params p, const std::string& key, const std::string& name) {
  for (auto& [k, v] : p) {
    if (k == key) k = name;
  }
  return p;
}

/** What a case expects: a map (of the base request's format and size) or an exception code. */
struct Expect {
  std::string code;                  ///< "" = a map
  std::optional<WmsVersion> version; ///< of the exception when not the request's (VERSION's own)
};
const Expect kMap{};
Expect fails(std::string_view code, std::optional<WmsVersion> version = std::nullopt) {
  return Expect{std::string(code), version};
}

std::string oddCase(const std::string& name) {
  std::string out = name;
  for (std::size_t i = 0; i < out.size(); ++i) {
    const char c = out[i];
    out[i] = i % 2 ? static_cast<char>(std::tolower(static_cast<unsigned char>(c)))
                   : static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  }
  return out == name ? "x" + name : out; // never equal: a changed spelling
}

} // namespace

// ------------------------------------------------------------------------------ GetCapabilities

// Every configuration's capabilities, both versions, valid against the official DTD / XSD, with
// the service-wide format list.
TEST(WmsConformanceIntegration, CapabilitiesOfEveryConfigurationAreValid) {
  const std::vector<std::pair<std::string, std::vector<LayerSpec>>> configs{
      {"imagery only", {sat()}},
      {"heights only", {dem()}},
      {"time", {daily()}},
      {"overlays", {sat(), overlay()}},
      {"everything", {sat(), overlay(), dem(), daily()}},
  };
  for (const auto& [what, layers] : configs) {
    Server s(layers);
    for (const auto& [version, kind] : {std::pair{"1.1.1", test::WmsDocument::Capabilities111},
                                        std::pair{"1.3.0", test::WmsDocument::Capabilities130}}) {
      const auto r = s.get(std::string("SERVICE=WMS&REQUEST=GetCapabilities&VERSION=") + version);
      ASSERT_EQ(r.status, 200) << what;
      const auto verdict = test::validateWms(r.body, kind);
      EXPECT_TRUE(verdict.valid) << what << " " << version << "\n" << verdict.output;
      for (const MapFormat f :
           {MapFormat::Jpeg, MapFormat::Png, MapFormat::Png8, MapFormat::Bil16, MapFormat::Tiff})
        EXPECT_NE(r.body.find("<Format>" + std::string(toString(f)) + "</Format>"),
                  std::string::npos)
            << what << " " << toString(f);
    }
  }
}

// OGC 06-042 Table 3 / 01-068r3 7.1.2: VERSION O, SERVICE=WMS M, REQUEST M, FORMAT O,
// UPDATESEQUENCE O.
TEST(WmsConformanceIntegration, GetCapabilitiesParameterTable) {
  for (const bool statusCodes : {false, true}) {
    Server s({sat(), dem()}, statusCodes);
    struct Case {
      std::string query;
      WmsVersion version; ///< of the answer
      std::string code;   ///< "" = the document
    };
    const std::string miss(ogc::kMissingParameterValue), inv(ogc::kInvalidParameterValue);
    const std::vector<Case> cases{
        {"SERVICE=WMS&REQUEST=GetCapabilities", WmsVersion::V130, ""},
        {"service=WMS&request=GetCapabilities&version=1.3.0", WmsVersion::V130, ""},
        {"sErViCe=wms&ReQuEsT=getcapabilities&VeRsIoN=1.1.1", WmsVersion::V111, ""},
        {"SERVICE=WMS&REQUEST=GetCapabilities&VERSION=1.1.0", WmsVersion::V111, ""},
        {"SERVICE=WMS&REQUEST=GetCapabilities&VERSION=1.2.0", WmsVersion::V111, ""},
        {"SERVICE=WMS&REQUEST=GetCapabilities&VERSION=2.0.0", WmsVersion::V130, ""},
        {"SERVICE=WMS&REQUEST=capabilities&WMTVER=1.0.0", WmsVersion::V111, ""},
        {"SERVICE=WMS&REQUEST=GetCapabilities&VERSION=", WmsVersion::V130, ""},
        {"SERVICE=WMS&REQUEST=GetCapabilities&FORMAT=application/json", WmsVersion::V130, ""},
        {"SERVICE=WMS&REQUEST=GetCapabilities&SERVICE=WMS", WmsVersion::V130, ""},
        {"SERVICE=WMS&REQUEST=GetCapabilities&UPDATESEQUENCE=1796151273", WmsVersion::V130, ""},
        {"REQUEST=GetCapabilities", WmsVersion::V130, miss},
        {"SERVICE=&REQUEST=GetCapabilities", WmsVersion::V130, miss},
        {"SERVICE=WFS&REQUEST=GetCapabilities", WmsVersion::V130, inv},
        {"SERVICE=WMS", WmsVersion::V130, miss},
        {"SERVICE=WMS&REQUEST=", WmsVersion::V130, miss},
        {"SERVICE=WMS&REQUEST=GetCapabilities&VERSION=x.y", WmsVersion::V130, inv},
        {"SERVICE=WMS&REQUEST=GetCapabilities&VERSION=1.1.1&VERSION=1.3.0", WmsVersion::V111, inv},
        {"SERVICE=WMS&REQUEST=GetCapabilities&SERVICE=WFS", WmsVersion::V130, inv},
        {"SERVICE=WMS&REQUEST=GetCapabilities&UPDATESEQUENCE=1796151274",
         WmsVersion::V130,
         std::string(ogc::kCurrentUpdateSequence)},
        {"SERVICE=WMS&REQUEST=GetCapabilities&UPDATESEQUENCE=1.796151274E9&VERSION=1.1.1",
         WmsVersion::V111,
         std::string(ogc::kCurrentUpdateSequence)},
        {"SERVICE=WMS&REQUEST=GetCapabilities&UPDATESEQUENCE=%2B01796151274.0",
         WmsVersion::V130,
         std::string(ogc::kCurrentUpdateSequence)},
        {"SERVICE=WMS&REQUEST=GetCapabilities&UPDATESEQUENCE=1796151275",
         WmsVersion::V130,
         std::string(ogc::kInvalidUpdateSequence)},
        {"SERVICE=WMS&REQUEST=GetCapabilities&UPDATESEQUENCE=1.8E9",
         WmsVersion::V130,
         std::string(ogc::kInvalidUpdateSequence)},
    };
    for (const Case& c : cases) {
      SCOPED_TRACE(c.query + (statusCodes ? " (HTTP status codes)" : ""));
      const auto r = s.get(c.query);
      if (c.code.empty()) {
        ASSERT_EQ(r.status, 200) << r.body.substr(0, 400);
        const bool v111 = c.version == WmsVersion::V111;
        EXPECT_EQ(r.header("content-type"), v111 ? "application/vnd.ogc.wms_xml" : "text/xml");
        const auto verdict = test::validateWms(
            r.body, v111 ? test::WmsDocument::Capabilities111 : test::WmsDocument::Capabilities130);
        EXPECT_TRUE(verdict.valid) << verdict.output;
      } else {
        EXPECT_EQ(checkException(r, c.version, c.code, statusCodes), "");
      }
    }
  }
}

// What tellus answers for the operations it does not serve (its capabilities list none of them).
// GetFeatureInfo and GetLegendGraphic are served for value layers (TestWmsValues.cpp); on an
// imagery layer they are LayerNotQueryable and InvalidParameterValue (below).
TEST(WmsConformanceIntegration, UnservedOperationsAreOperationNotSupported) {
  for (const bool statusCodes : {false, true}) {
    Server s({sat()}, statusCodes);
    for (const WmsVersion v : {WmsVersion::V111, WmsVersion::V130}) {
      const std::string version(toString(v));
      const auto info = s.get("REQUEST=GetFeatureInfo&VERSION=" + version + "&" +
                              join(without(getMap(v), "REQUEST")) +
                              "&QUERY_LAYERS=sat&INFO_FORMAT=text/plain&I=1&J=1&X=1&Y=1");
      EXPECT_EQ(checkException(info, v, ogc::kLayerNotQueryable, statusCodes), "");
      const auto legend = s.get("SERVICE=WMS&REQUEST=GetLegendGraphic&VERSION=" + version +
                                "&LAYER=sat&FORMAT=image/png");
      EXPECT_EQ(checkException(legend, v, ogc::kInvalidParameterValue, statusCodes), "");
      for (const std::string& q :
           {"SERVICE=WMS&REQUEST=DescribeLayer&VERSION=" + version + "&LAYERS=sat",
            "SERVICE=WMS&REQUEST=GetStyles&VERSION=" + version + "&LAYERS=sat",
            "SERVICE=WMS&REQUEST=Frobnicate&VERSION=" + version}) {
        SCOPED_TRACE(q);
        const auto r = s.get(q);
        EXPECT_EQ(checkException(r, v, ogc::kOperationNotSupported, statusCodes), "");
        if (v == WmsVersion::V130) {
          EXPECT_NE(r.body.find("locator=\"REQUEST\""), std::string::npos) << r.body;
        }
      }
    }
    EXPECT_EQ(s.up.requests(), 0u);
  }
}

// ------------------------------------------------------------------------------ GetMap

// OGC 06-042 Table 8 and 01-068r3 7.2.2, parameter by parameter: missing, empty, repeated with
// the same and with another value, the name in odd case, and illegal values; answered through the
// real front end, each map decoded and each exception validated.
TEST(WmsConformanceIntegration, GetMapParameterTable) {
  for (const bool statusCodes : {false, true}) {
    Server s({sat(), overlay(), dem(), daily()}, statusCodes);
    for (const WmsVersion v : {WmsVersion::V111, WmsVersion::V130}) {
      const bool v130 = v == WmsVersion::V130;
      const std::string crsName = v130 ? "CRS" : "SRS";
      const Params base = getMap(v);
      const std::string miss(ogc::kMissingParameterValue), inv(ogc::kInvalidParameterValue);
      struct Row {
        std::string name;
        Expect missing, empty;
        std::vector<std::pair<std::string, Expect>> values; ///< other values and their answers
      };
      const std::vector<Row> table{
          // Without a usable VERSION the exception is 1.3.0's; below 1.3.0 it is 1.1.1's.
          {"VERSION",
           fails(miss, WmsVersion::V130),
           fails(miss, WmsVersion::V130),
           {{"1.0.0", fails(inv, WmsVersion::V111)},
            {"1.2.0", fails(inv, WmsVersion::V111)},
            {"2.0", fails(inv, WmsVersion::V130)},
            {"x", fails(inv, WmsVersion::V130)}}},
          {"REQUEST",
           fails(miss),
           fails(miss),
           {{"getmap", kMap},
            {"GETMAP", kMap},
            {"map", kMap},
            {"GetMapX", fails(ogc::kOperationNotSupported)}}},
          {"SERVICE", kMap, kMap, {{"WMS", kMap}, {"wms", kMap}, {"WFS", fails(inv)}}},
          {"LAYERS",
           fails(miss),
           fails(miss),
           {{"SAT", fails(ogc::kLayerNotDefined)},
            {"nope", fails(ogc::kLayerNotDefined)},
            {"sat,", fails(ogc::kLayerNotDefined)},
            {",sat", fails(ogc::kLayerNotDefined)},
            {"sat,overlay", kMap} /* STYLES= is the default style of each */}},
          {"STYLES",
           fails(miss),
           kMap,
           {{"default", kMap},
            {"DEFAULT", fails(ogc::kStyleNotDefined)},
            {"shaded", fails(ogc::kStyleNotDefined)},
            {",", fails(inv)}}},
          {crsName,
           fails(miss),
           fails(miss),
           {{"epsg:4326", kMap},
            {"EPSG:32633", fails(invalidCrsCode(v))},
            {"EPSG:43260", fails(invalidCrsCode(v))},
            {"AUTO:42001", fails(invalidCrsCode(v))}}},
          {"BBOX",
           fails(miss),
           fails(miss),
           {{"1,2,3", fails(inv)},
            {"1,2,3,4,5", fails(inv)},
            {"a,b,c,d", fails(inv)},
            {"nan,0,1,1", fails(inv)},
            {"0,0,1e400,1", fails(inv)},
            {"-30,-100,-80,-170", fails(inv)} /* min > max on both axes */,
            {"-80,-170,-80,-100", fails(inv)} /* min == max */,
            {"-80,-100,-30,-170", fails(inv)},
            {"-80,-170,-30,-170", fails(inv)}}},
          {"WIDTH",
           fails(miss),
           fails(miss),
           {{"0", fails(inv)},
            {"-64", fails(inv)},
            {"64.5", fails(inv)},
            {"1e2", fails(inv)},
            {"513", fails(inv)},
            {"0064", kMap}}},
          {"HEIGHT",
           fails(miss),
           fails(miss),
           {{"0", fails(inv)}, {"257", fails(inv)}, {"x", fails(inv)}}},
          {"FORMAT",
           fails(miss),
           fails(miss),
           {{"IMAGE/PNG", kMap},
            {"image/gif", fails(ogc::kInvalidFormat)},
            {"image/dds", fails(ogc::kInvalidFormat)},
            {"png", fails(ogc::kInvalidFormat)},
            {"text/xml", fails(ogc::kInvalidFormat)}}},
          {"TRANSPARENT",
           kMap,
           kMap,
           {{"FALSE", kMap}, {"false", kMap}, {"1", fails(inv)}, {"yes", fails(inv)}}},
          {"BGCOLOR",
           kMap,
           kMap,
           {{"0x00FF00", kMap},
            {"0X00ff00", kMap},
            {"00FF00", fails(inv)},
            {"%2300FF00", fails(inv)},
            {"0x00FF0", fails(inv)}}},
          {"EXCEPTIONS",
           kMap,
           kMap,
           {{"XML", kMap},
            {"application/vnd.ogc.se_xml", kMap},
            {"INIMAGE", kMap},
            {"application/vnd.ogc.se_blank", kMap},
            {"JSON", fails(inv)}}},
          {"TIME", kMap, kMap, {{"2010-99-99", kMap}} /* sat has no TIME: ignored */},
          {"ELEVATION", kMap, kMap, {{"1000", kMap}} /* no elevation dimension: ignored */},
      };
      const auto expectAnswer = [&](const Params& p, const Expect& e, const std::string& what) {
        const std::string q = join(p);
        SCOPED_TRACE(std::string(toString(v)) + " " + what + ": " + q +
                     (statusCodes ? " (HTTP status codes)" : ""));
        const auto r = s.get(q);
        if (e.code.empty()) {
          EXPECT_EQ(checkImage(r, MapFormat::Png, false, 64, 32), "");
        } else {
          EXPECT_EQ(checkException(r, e.version.value_or(v), e.code, statusCodes), "");
        }
      };
      expectAnswer(base, kMap, "the base request");
      for (const Row& row : table) {
        const bool inBase = std::any_of(
            base.begin(), base.end(), [&](const auto& kv) { return kv.first == row.name; });
        const std::string baseValue =
            inBase ? std::find_if(base.begin(),
                                  base.end(),
                                  [&](const auto& kv) { return kv.first == row.name; })
                         ->second
                   : std::string();
        expectAnswer(without(base, row.name), row.missing, row.name + " missing");
        expectAnswer(with(base, row.name, ""), row.empty, row.name + " empty");
        expectAnswer(with(base, row.name, "<no=>"), row.empty, row.name + " without '='");
        if (inBase) {
          Params twice = base;
          twice.emplace_back(row.name, baseValue);
          expectAnswer(twice, kMap, row.name + " repeated with the same value");
          Params twiceOdd = base;
          twiceOdd.emplace_back(oddCase(row.name), baseValue);
          expectAnswer(twiceOdd, kMap, row.name + " repeated in another case");
          expectAnswer(renamed(base, row.name, oddCase(row.name)), kMap, row.name + " odd case");
        }
        for (const auto& [value, expect] : row.values) {
          expectAnswer(with(base, row.name, value), expect, row.name + "=" + value);
          if (inBase && value != baseValue) {
            Params conflicting = base;
            conflicting.emplace_back(row.name, value);
            expectAnswer(conflicting, fails(inv), row.name + " repeated with " + value);
          }
        }
      }
      // The other version's CRS parameter name is read too (clients mix them up).
      expectAnswer(renamed(base, crsName, v130 ? "SRS" : "CRS"), kMap, "the other CRS name");
    }
    EXPECT_EQ(s.up.requests() > 0, true);
  }
}

// A client may ask any advertised format for any layer, alone or mixed (the Format list is
// service-wide): every format x every layer list x both versions, decoded.
TEST(WmsConformanceIntegration, EveryFormatForEveryLayer) {
  Server s({sat(), overlay(), dem(), daily()});
  const auto caps = s.get("SERVICE=WMS&REQUEST=GetCapabilities&VERSION=1.3.0");
  std::vector<std::string> advertised;
  const auto getMapAt = caps.body.find("<GetMap>");
  const auto getMapEnd = caps.body.find("</GetMap>");
  for (auto at = caps.body.find("<Format>", getMapAt); at < getMapEnd;
       at = caps.body.find("<Format>", at + 1)) {
    const auto end = caps.body.find("</Format>", at);
    advertised.push_back(caps.body.substr(at + 8, end - at - 8));
  }
  ASSERT_GE(advertised.size(), 5u) << caps.body;
  for (const char* f : {"image/png; mode=24bit", "image/png; mode=32bit", "image/png8"})
    advertised.push_back(f); // accepted spellings beyond the list
  for (const WmsVersion v : {WmsVersion::V111, WmsVersion::V130}) {
    for (const std::string layers :
         {"sat", "overlay", "dem", "daily", "sat,overlay", "sat,dem", "dem,sat", "dem,overlay"}) {
      const bool allElevation = layers == "dem";
      for (const std::string& f : advertised) {
        for (const bool transparent : {false, true}) {
          const auto format = parseMapFormat(f);
          ASSERT_TRUE(format) << f;
          std::string escaped = f;
          for (auto at = escaped.find(' '); at != std::string::npos; at = escaped.find(' '))
            escaped.replace(at, 1, "%20");
          // 1x1, a tile-aligned box of the layers' own tile, and an odd box.
          for (const auto& [box, w, h] :
               {std::tuple{
                    v == WmsVersion::V130 ? "-90,-180,-54,-144" : "-180,-90,-144,-54", 256, 256},
                std::tuple{
                    v == WmsVersion::V130 ? "-80,-170,-30,-100" : "-170,-80,-100,-30", 64, 32},
                std::tuple{v == WmsVersion::V130 ? "10,10,11,11" : "10,10,11,11", 1, 1}}) {
            Params p = with(with(with(with(getMap(v, layers), "FORMAT", escaped), "BBOX", box),
                                 "WIDTH",
                                 std::to_string(w)),
                            "HEIGHT",
                            std::to_string(h));
            if (transparent) p = with(p, "TRANSPARENT", "TRUE");
            SCOPED_TRACE(join(p));
            const auto r = s.get(join(p));
            EXPECT_EQ(
                checkImage(r, *format, mapIsHeights(*format, allElevation), w, h, transparent), "");
          }
        }
      }
    }
  }
}

// Every CRS the capabilities name, for every layer, gives the same map (axis order included).
TEST(WmsConformanceIntegration, EveryCrsForEveryLayer) {
  Server s({sat(), overlay(), dem(), daily()});
  for (const std::string layer : {"sat", "overlay", "dem", "daily"}) {
    const auto reference = s.get(join(
        with(with(getMap(WmsVersion::V130, layer), "CRS", "CRS:84"), "BBOX", "-170,-80,-100,-30")));
    ASSERT_EQ(checkImage(reference, MapFormat::Png, layer == "dem", 64, 32), "") << layer;
    for (const auto& [v, crs, box] :
         {std::tuple{WmsVersion::V130, "EPSG:4326", "-80,-170,-30,-100"},
          std::tuple{WmsVersion::V130, "CRS:84", "-170,-80,-100,-30"},
          std::tuple{WmsVersion::V111, "EPSG:4326", "-170,-80,-100,-30"},
          std::tuple{WmsVersion::V111, "CRS:84", "-170,-80,-100,-30"}}) {
      Params p = getMap(v, layer);
      p = with(with(p, v == WmsVersion::V130 ? "CRS" : "SRS", crs), "BBOX", box);
      const auto r = s.get(join(p));
      EXPECT_EQ(r.body, reference.body) << layer << " " << toString(v) << " " << crs;
    }
  }
}

// Sizes 1x1 and the maximum (server.limits.max_width / max_height: 512 x 256 here), one more
// refused; BBOX min >= max refused.
TEST(WmsConformanceIntegration, SizesAndBoxesAtTheirEdges) {
  Server s({sat(), dem()});
  for (const WmsVersion v : {WmsVersion::V111, WmsVersion::V130}) {
    for (const std::string layer : {"sat", "dem"}) {
      for (const auto& [w, h] :
           {std::pair{1, 1}, std::pair{512, 256}, std::pair{512, 1}, std::pair{1, 256}}) {
        const Params p = with(
            with(with(getMap(v, layer), "WIDTH", std::to_string(w)), "HEIGHT", std::to_string(h)),
            "BBOX",
            "-90,-180,90,180");
        const Params box =
            with(p, "BBOX", v == WmsVersion::V130 ? "-90,-180,90,180" : "-180,-90,180,90");
        EXPECT_EQ(checkImage(s.get(join(box)), MapFormat::Png, layer == "dem", w, h), "")
            << layer << " " << w << "x" << h;
      }
      EXPECT_EQ(checkException(s.get(join(with(getMap(v, layer), "WIDTH", "513"))),
                               v,
                               ogc::kInvalidParameterValue,
                               false),
                "");
      EXPECT_EQ(checkException(s.get(join(with(getMap(v, layer), "HEIGHT", "257"))),
                               v,
                               ogc::kInvalidParameterValue,
                               false),
                "");
      for (const char* box :
           {"0,0,0,0", "10,10,10,20", "10,10,20,10", "20,10,10,20", "10,20,20,10"}) {
        EXPECT_EQ(checkException(s.get(join(with(getMap(v, layer), "BBOX", box))),
                                 v,
                                 ogc::kInvalidParameterValue,
                                 false),
                  "")
            << box;
      }
    }
  }
}

// EXCEPTIONS=BLANK and INIMAGE (both versions' spellings) in every format, 8-bit PNG included,
// with BGCOLOR and TRANSPARENT; heights formats give a map of no-data.
TEST(WmsConformanceIntegration, BlankAndInImageInEveryFormat) {
  Server s({sat(), dem()});
  for (const WmsVersion v : {WmsVersion::V111, WmsVersion::V130}) {
    for (const std::string exceptions :
         {"BLANK", "INIMAGE", "application/vnd.ogc.se_blank", "application/vnd.ogc.se_inimage"}) {
      for (const std::string layers : {"sat", "dem", "nope"}) {
        for (const MapFormat f : {MapFormat::Jpeg,
                                  MapFormat::Png,
                                  MapFormat::Png8,
                                  MapFormat::Png24,
                                  MapFormat::Png32,
                                  MapFormat::Bil16,
                                  MapFormat::Tiff}) {
          for (const bool transparent : {false, true}) {
            std::string format(toString(f));
            for (auto at = format.find(' '); at != std::string::npos; at = format.find(' '))
              format.replace(at, 1, "%20");
            // An error: the CRS is not served.
            Params p =
                with(with(with(with(getMap(v, layers), "FORMAT", format), "EXCEPTIONS", exceptions),
                          "BGCOLOR",
                          "0x336699"),
                     v == WmsVersion::V130 ? "CRS" : "SRS",
                     "EPSG:32633");
            if (transparent) p = with(p, "TRANSPARENT", "TRUE");
            SCOPED_TRACE(join(p));
            const auto r = s.get(join(p));
            const bool heights = mapIsHeights(f, layers == "dem");
            const std::string problem = checkImage(r, f, heights, 64, 32, transparent);
            EXPECT_EQ(problem, "");
            if (!problem.empty()) continue;
            EXPECT_EQ(r.header("cache-control"), "no-store");
            if (heights) {
              const auto values = decodeHeights(
                  span(r.body), f == MapFormat::Png ? "image/png" : toString(f).data(), 64, 32);
              ASSERT_TRUE(values);
              EXPECT_EQ(std::count(values->begin(), values->end(), std::int16_t{-32768}), 64 * 32);
              continue;
            }
            if (exceptions.find("blank") == std::string::npos &&
                exceptions.find("BLANK") == std::string::npos)
              continue; // INIMAGE has text on it
            const auto img = decodeImagery(span(r.body),
                                           f == MapFormat::Jpeg   ? "image/jpeg"
                                           : f == MapFormat::Tiff ? "image/tiff"
                                                                  : "image/png",
                                           64,
                                           32);
            ASSERT_TRUE(img) << img.error();
            const std::uint8_t* px = &img->pixels[static_cast<std::size_t>(img->channels) * 100];
            const bool alpha = f == MapFormat::Png32 ||
                               (transparent && (f == MapFormat::Png || f == MapFormat::Png8 ||
                                                f == MapFormat::Tiff));
            EXPECT_EQ(img->channels, alpha ? 4 : 3);
            if (alpha) {
              EXPECT_EQ(px[3], transparent ? 0 : 255);
            }
            if (alpha && transparent) continue; // no colour to see
            EXPECT_NEAR(px[0], 0x33, 2);
            EXPECT_NEAR(px[1], 0x66, 2);
            EXPECT_NEAR(px[2], 0x99, 2);
          }
        }
      }
    }
  }
  EXPECT_EQ(s.up.requests(), 0u);
}

// ------------------------------------------------------------------------------ TIME

// TIME on a layer whose dimension is kept as a period: a value the layer does not have is
// InvalidDimensionValue and creates no dataset and no upstream request; every spelling of one
// instant shares one dataset.
TEST(WmsConformanceIntegration, TimeAbuseCreatesNoDatasetAndNoUpstreamRequest) {
  Server s({sat(), daily()});
  const auto map = [&](const std::string& time) {
    // SERVICE=WMS, which 1.3.0 GetMap does not need, so that only TIME is tried here.
    Params p = with(with(getMap(WmsVersion::V130, "daily"), "TIME", time), "SERVICE", "WMS");
    p = with(with(p, "FORMAT", "image/jpeg"), "BBOX", "-90,-180,-54,-144");
    return s.get(join(with(with(p, "WIDTH", "256"), "HEIGHT", "256")));
  };
  const std::size_t folders = s.datasetFolders("daily");
  for (const char* abuse : {"2010-99-99T99:99Z",
                            "2010-02-30T00:00Z",
                            "2010-06-01T00:30Z",
                            "2010-06-01T00:00:01Z",
                            "2010-06-01T00:00:00.5Z",
                            "2009-12-31T23:00Z",
                            "2011-01-01T00:00Z",
                            "2010/../..",
                            "2010-06-01T00:00Y",
                            "2010-06-01T00:00Z,2010-06-01T01:00Z",
                            "2010-06-01T00:00Z/2010-06-02T00:00Z",
                            "2010-06-01T00:00Z/2010-06-02T00:00Z/PT1H",
                            "%20",
                            "current"}) {
    const auto r = map(abuse);
    EXPECT_EQ(checkException(r, WmsVersion::V130, ogc::kInvalidDimensionValue, false), "") << abuse;
  }
  EXPECT_EQ(s.up.requests(), 0u);
  EXPECT_EQ(s.datasetFolders("daily"), folders);
  // One instant in five spellings: one dataset, one upstream request.
  for (const char* same : {"2010-06-01T05:00Z",
                           "2010-06-01T05:00:00Z",
                           "2010-06-01T05:00:00.000Z",
                           "2010-06-01T07:00%2B02:00",
                           "2010-06-01T05:00"}) {
    const auto r = map(same);
    EXPECT_EQ(r.status, 200) << same << " " << r.body.substr(0, 300);
    EXPECT_EQ(r.header("content-type"), "image/jpeg") << same;
  }
  EXPECT_EQ(s.up.requests(), 1u);
  ASSERT_EQ(s.up.received().size(), 1u);
  EXPECT_EQ(paramOf(s.up.received()[0].target, "TIME"), "2010-06-01T05:00Z");
  EXPECT_LE(s.datasetFolders("daily"), folders + 1);
  // The static tile path's ?time= is checked the same way.
  const auto tile = test::httpGet("http://127.0.0.1:" + std::to_string(s.server->port()) +
                                  "/tiles/daily/0/0/0_0.jpg?time=2010-99-99T99:99Z");
  EXPECT_EQ(tile.status, 400);
  EXPECT_EQ(s.up.requests(), 1u);
}
