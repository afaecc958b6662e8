// Layers on other bodies through tellus serve's pieces on a loopback port (issue 26,
// docs/design/bodies-proxy.md): a layer says its body through its DatasetSpec; WMS capabilities
// give a Moon or Mars layer its IAU CRS instead of the Earth's (both versions valid against the
// official schemas), GetMap and GetFeatureInfo take that CRS (lat/lon in 1.3.0) and refuse the
// Earth's Web Mercator and other bodies' codes; WMTS gives such a layer its own World Wind set
// in the body's CRS only; the cache keeps its tiles in a dataset of that body.
#include "../support/WmsSchemas.hpp"
#include "../support/WmtsServer.hpp"

#include <tellus/proxy/BodyCrs.hpp>
#include <tellus/proxy/Wms.hpp>

#include <gtest/gtest.h>

using namespace tellus;
using namespace std::chrono_literals;

namespace {

LayerSpec layerOn(const std::string& name, const std::string& body) {
  LayerSpec l;
  l.name = name;
  l.title = name;
  l.upstream = "up";
  l.dataset.grid = GridSpec{Sector{}, 36.0, 256, 256, 3};
  l.dataset.mimeType = "image/png";
  l.dataset.body = body;
  l.maxAge = 3600s;
  return l;
}

/** "sat" on the Earth, "lroc" on the Moon, "mola" on Mars, "rheasilvia" on Vesta (a body
 * without a built-in IAU code), all from one fake WMS upstream of gradient tiles. */
struct BodyServer {
  test::FakeUpstream up{test::gradientTile};
  test::TempDir dir{"bodies"};
  std::unique_ptr<TileCache> cache;
  std::unique_ptr<Fetcher> fetcher;
  std::unique_ptr<TileService> tiles;
  std::unique_ptr<test::ServedFrontEnd> web; ///< after the service: stopped before it goes

  explicit BodyServer(std::vector<LayerSpec> layers = {layerOn("sat", "earth"),
                                                       layerOn("lroc", "moon"),
                                                       layerOn("mola", "mars"),
                                                       layerOn("rheasilvia", "vesta")}) {
    cache = test::openTestCache(dir.path());
    fetcher = std::make_unique<Fetcher>();
    UpstreamSpec u;
    u.name = "up";
    u.type = UpstreamSpec::Type::Wms;
    u.url = up.url("/wms");
    u.policy.timeout = 2000ms;
    u.policy.retries = 0;
    auto t = TileService::create(*cache, *fetcher, {u}, std::move(layers), {});
    EXPECT_TRUE(t) << (t ? "" : t.error());
    tiles = std::move(*t);
    web = std::make_unique<test::ServedFrontEnd>(*tiles);
  }
  test::HttpResult get(const std::string& target) const { return web->get(target); }
};

/** The text of the <Layer> element whose Name is `name` (up to its closing tag). */
std::string layerBlock(const std::string& xml, const std::string& name) {
  const auto at = xml.find("<Name>" + name + "</Name>");
  if (at == std::string::npos) return {};
  return xml.substr(at, xml.find("</Layer>", at) - at);
}

std::string getMap(const std::string& version,
                   const std::string& layers,
                   const std::string& crs,
                   const std::string& bbox) {
  return "/wms?SERVICE=WMS&VERSION=" + version + "&REQUEST=GetMap&LAYERS=" + layers + "&STYLES=&" +
         (version == "1.3.0" ? "CRS=" : "SRS=") + crs + "&BBOX=" + bbox +
         "&WIDTH=64&HEIGHT=32&FORMAT=image/png";
}

} // namespace

TEST(BodyCrs, KnowsTheMoonAndMarsAndReadsEverySpellingOfTheirCodes) {
  ASSERT_TRUE(bodyCrs("moon"));
  EXPECT_EQ(bodyCrs("Moon")->iauCode, 30100);
  EXPECT_EQ(bodyCrs("mars")->iauCode, 49900);
  EXPECT_DOUBLE_EQ(bodyCrs("moon")->meanRadiusM, 1737400.0);
  EXPECT_FALSE(bodyCrs("earth"));
  EXPECT_FALSE(bodyCrs("vesta"));
  for (const char* s : {"IAU:30100", "iau2000:30100", "IAU_2015:30100", "IAU:2015:30100"})
    EXPECT_EQ(parseIauCrs(s), 30100) << s;
  for (const char* s : {"EPSG:4326", "IAU:", "IAU:30100x", "IAU:-1", "IAU2000:0"})
    EXPECT_FALSE(parseIauCrs(s)) << s;
  EXPECT_EQ(iauCrs130(49900), "IAU:49900");
  EXPECT_EQ(iauCrs111(49900), "IAU2000:49900");
  EXPECT_EQ(iauCrsUrn(30100), "urn:ogc:def:crs:IAU:2015:30100");
}

TEST(BodyCrs, GetMapParsesAnIauCrsInEachVersionsAxisOrder) {
  auto v130 = parseWms(parseQuery("VERSION=1.3.0&REQUEST=GetMap&LAYERS=lroc&STYLES=&"
                                  "CRS=IAU:30100&BBOX=-80,-170,-30,-100&WIDTH=64&HEIGHT=32&"
                                  "FORMAT=image/png")
                           .value());
  ASSERT_TRUE(v130) << v130.error().message;
  const auto& m = std::get<GetMapRequest>(*v130);
  EXPECT_EQ(m.crs, "IAU:30100");
  EXPECT_EQ(m.bbox, (Sector{-170, -80, -100, -30})); // lat/lon read as lon/lat
  auto v111 = parseWms(parseQuery("VERSION=1.1.1&REQUEST=GetMap&LAYERS=lroc&STYLES=&"
                                  "SRS=IAU2000:30100&BBOX=-170,-80,-100,-30&WIDTH=64&HEIGHT=32&"
                                  "FORMAT=image/png")
                           .value());
  ASSERT_TRUE(v111) << v111.error().message;
  EXPECT_EQ(std::get<GetMapRequest>(*v111).crs, "IAU:30100");
  EXPECT_EQ(std::get<GetMapRequest>(*v111).bbox, (Sector{-170, -80, -100, -30}));
  // A projected IAU code (30110, equirectangular) is not a geographic CRS.
  auto projected = parseWms(parseQuery("VERSION=1.3.0&REQUEST=GetMap&LAYERS=lroc&STYLES=&"
                                       "CRS=IAU:30110&BBOX=0,0,1,1&WIDTH=64&HEIGHT=32&"
                                       "FORMAT=image/png")
                                .value());
  ASSERT_FALSE(projected);
  EXPECT_EQ(projected.error().code, "InvalidCRS");
}

TEST(BodiesIntegration, WmsCapabilitiesGiveEachBodysLayerItsIauCrsAndAreValid) {
  BodyServer s;
  const auto v130 = s.get("/wms?SERVICE=WMS&REQUEST=GetCapabilities&VERSION=1.3.0");
  ASSERT_EQ(v130.status, 200);
  const auto ok130 = test::validateWms(v130.body, test::WmsDocument::Capabilities130);
  EXPECT_TRUE(ok130.valid) << ok130.output << "\n" << v130.body;
  const std::string moon = layerBlock(v130.body, "lroc");
  EXPECT_NE(moon.find("<CRS>IAU:30100</CRS>"), std::string::npos) << moon;
  // Latitude first, as the IAU 2015 CRS's axes are (and EPSG:4326's in 1.3.0).
  EXPECT_NE(moon.find(R"(<BoundingBox CRS="IAU:30100" minx="-90" miny="-180" maxx="90")"),
            std::string::npos)
      << moon;
  for (const char* earth : {"EPSG:4326", "CRS:84", "EPSG:3857"})
    EXPECT_EQ(moon.find(earth), std::string::npos) << earth << " on the Moon:\n" << moon;
  EXPECT_NE(layerBlock(v130.body, "mola").find("<CRS>IAU:49900</CRS>"), std::string::npos);
  const std::string sat = layerBlock(v130.body, "sat");
  for (const char* earth : {"<CRS>EPSG:4326</CRS>", "<CRS>CRS:84</CRS>", "<CRS>EPSG:3857</CRS>"})
    EXPECT_NE(sat.find(earth), std::string::npos) << earth << "\n" << sat;
  // The root layer names no CRS (its children would inherit the Earth's).
  const auto root = v130.body.substr(0, v130.body.find("<Layer queryable"));
  EXPECT_EQ(root.find("<CRS>"), std::string::npos) << root;
  // A body without a known IAU code has no CRS to be listed under.
  EXPECT_EQ(v130.body.find("rheasilvia"), std::string::npos);

  const auto v111 = s.get("/wms?SERVICE=WMS&REQUEST=GetCapabilities&VERSION=1.1.1");
  ASSERT_EQ(v111.status, 200);
  const auto ok111 = test::validateWms(v111.body, test::WmsDocument::Capabilities111);
  EXPECT_TRUE(ok111.valid) << ok111.output << "\n" << v111.body;
  const std::string moon111 = layerBlock(v111.body, "lroc");
  EXPECT_NE(moon111.find("<SRS>IAU2000:30100</SRS>"), std::string::npos) << moon111;
  EXPECT_NE(moon111.find(R"(<BoundingBox SRS="IAU2000:30100" minx="-180" miny="-90")"),
            std::string::npos)
      << moon111;
  EXPECT_EQ(moon111.find("EPSG"), std::string::npos) << moon111;
  EXPECT_NE(layerBlock(v111.body, "sat").find("<SRS>EPSG:4326</SRS>"), std::string::npos);
}

TEST(BodiesIntegration, AnEarthOnlyServiceKeepsItsCapabilitiesAsTheyWere) {
  BodyServer s({layerOn("sat", "earth")});
  const auto v130 = s.get("/wms?SERVICE=WMS&REQUEST=GetCapabilities&VERSION=1.3.0");
  const auto root = v130.body.substr(0, v130.body.find("<Layer queryable"));
  EXPECT_NE(root.find("<CRS>EPSG:4326</CRS>"), std::string::npos) << root;
  EXPECT_EQ(layerBlock(v130.body, "sat").find("<CRS>"), std::string::npos);
}

TEST(BodiesIntegration, GetMapTakesTheBodysCrsInEachVersionsAxisOrder) {
  BodyServer s;
  const auto reference = s.get(getMap("1.3.0", "lroc", "CRS:84", "-170,-80,-100,-30"));
  ASSERT_EQ(reference.status, 200) << reference.body;
  ASSERT_EQ(reference.header("content-type"), "image/png") << reference.body;
  for (const auto& [version, crs, bbox] :
       {std::tuple{"1.3.0", "IAU:30100", "-80,-170,-30,-100"},
        std::tuple{"1.3.0", "IAU_2015:30100", "-80,-170,-30,-100"},
        std::tuple{"1.1.1", "IAU2000:30100", "-170,-80,-100,-30"},
        // Degrees on the Moon, as USGS Astrogeology's planetary servers label theirs.
        std::tuple{"1.3.0", "EPSG:4326", "-80,-170,-30,-100"},
        std::tuple{"1.1.1", "EPSG:4326", "-170,-80,-100,-30"}}) {
    const auto r = s.get(getMap(version, "lroc", crs, bbox));
    EXPECT_EQ(r.body, reference.body) << version << " " << crs;
  }
  // The tiles are kept in a dataset of the Moon.
  bool moon = false;
  for (const auto& d : s.cache->datasets())
    moon = moon || (d.spec.name == "lroc" && d.spec.body == "moon");
  EXPECT_TRUE(moon);
}

TEST(BodiesIntegration, GetMapRefusesACrsOfAnotherBodyAndMixedBodies) {
  BodyServer s;
  struct Case {
    std::string target, code;
  };
  for (const Case& c : std::vector<Case>{
           {getMap("1.3.0", "lroc", "EPSG:3857", "-1e6,-1e6,1e6,1e6"), "InvalidCRS"},
           {getMap("1.3.0", "lroc", "IAU:49900", "-80,-170,-30,-100"), "InvalidCRS"},
           {getMap("1.3.0", "sat", "IAU:30100", "-80,-170,-30,-100"), "InvalidCRS"},
           {getMap("1.1.1", "mola", "IAU2000:30100", "-170,-80,-100,-30"), "InvalidSRS"},
           {getMap("1.1.1", "lroc", "EPSG:900913", "-1e6,-1e6,1e6,1e6"), "InvalidSRS"},
           {getMap("1.3.0", "rheasilvia", "CRS:84", "-170,-80,-100,-30"), "InvalidCRS"},
           {getMap("1.3.0", "sat,lroc", "CRS:84", "-170,-80,-100,-30"), "InvalidParameterValue"},
       }) {
    const auto r = s.get(c.target);
    EXPECT_NE(r.body.find("code=\"" + c.code + "\""), std::string::npos) << c.target << "\n"
                                                                         << r.body;
    const bool v111 = c.target.find("1.1.1") != std::string::npos;
    const auto v = test::validateWms(
        r.body, v111 ? test::WmsDocument::Exception111 : test::WmsDocument::Exception130);
    EXPECT_TRUE(v.valid) << v.output;
  }
  EXPECT_EQ(s.up.requests(), 0u);
}

TEST(BodiesIntegration, GetFeatureInfoChecksTheBodyBeforeTheLayer) {
  BodyServer s;
  const std::string base = "/wms?SERVICE=WMS&VERSION=1.3.0&REQUEST=GetFeatureInfo&LAYERS=lroc"
                           "&QUERY_LAYERS=lroc&STYLES=&BBOX=-80,-170,-30,-100&WIDTH=64&HEIGHT=32"
                           "&FORMAT=image/png&INFO_FORMAT=text/plain&I=3&J=4&CRS=";
  // The Moon's CRS passes the body check: what is left is that the layer is not queryable.
  const auto own = s.get(base + "IAU:30100");
  EXPECT_NE(own.body.find("code=\"LayerNotQueryable\""), std::string::npos) << own.body;
  const auto mars = s.get(base + "IAU:49900");
  EXPECT_NE(mars.body.find("code=\"InvalidCRS\""), std::string::npos) << mars.body;
}

TEST(BodiesIntegration, WmtsGivesABodysLayerOnlyItsOwnSetInTheBodysCrs) {
  BodyServer s;
  const auto caps = s.get("/wmts?SERVICE=WMTS&REQUEST=GetCapabilities");
  ASSERT_EQ(caps.status, 200) << caps.body;
  const auto v = test::validateWmtsCapabilities(caps.body);
  EXPECT_TRUE(v.valid) << v.output << "\n" << caps.body;
  const auto lroc = caps.body.find("<ows:Identifier>lroc</ows:Identifier>");
  ASSERT_NE(lroc, std::string::npos);
  const auto layerStart = caps.body.rfind("<Layer>", lroc);
  const std::string layer =
      caps.body.substr(layerStart, caps.body.find("</Layer>", lroc) - layerStart);
  EXPECT_EQ(layer.find("WGS84BoundingBox"), std::string::npos) << layer;
  EXPECT_NE(layer.find(R"(<ows:BoundingBox crs="urn:ogc:def:crs:IAU:2015:30100">)"),
            std::string::npos)
      << layer;
  EXPECT_NE(layer.find("<TileMatrixSet>WorldWind_lroc</TileMatrixSet>"), std::string::npos);
  EXPECT_EQ(layer.find("WorldCRS84Quad"), std::string::npos) << layer;
  EXPECT_EQ(layer.find("GoogleMapsCompatible"), std::string::npos) << layer;
  // The set: the Moon's CRS, latitude first in TopLeftCorner, scales on the Moon's radius.
  const auto set = caps.body.find("<ows:Identifier>WorldWind_lroc</ows:Identifier>\n");
  ASSERT_NE(set, std::string::npos);
  const std::string def = caps.body.substr(set, caps.body.find("</TileMatrixSet>", set) - set);
  EXPECT_NE(def.find("<ows:SupportedCRS>urn:ogc:def:crs:IAU:2015:30100</ows:SupportedCRS>"),
            std::string::npos)
      << def;
  EXPECT_NE(def.find("<TopLeftCorner>90 -180</TopLeftCorner>"), std::string::npos) << def;
  // Level 0: 36 degrees over 256 px on a sphere of 1737.4 km, 0.28 mm pixels.
  const double scale = 36.0 / 256 * 1737400.0 * std::numbers::pi / 180.0 / 0.00028;
  const auto sd = def.find("<ScaleDenominator>");
  ASSERT_NE(sd, std::string::npos);
  EXPECT_NEAR(std::stod(def.substr(sd + 18)), scale, scale * 1e-12);
  EXPECT_EQ(caps.body.find("rheasilvia"), std::string::npos);

  const auto own = s.get("/wmts/1.0.0/lroc/default/WorldWind_lroc/1/2/3.png");
  EXPECT_EQ(own.status, 200) << own.body;
  const auto quad = s.get("/wmts/1.0.0/lroc/default/WorldCRS84Quad/1/0/0.png");
  EXPECT_EQ(quad.status, 400) << quad.body;
  EXPECT_NE(quad.body.find("TileMatrixSet"), std::string::npos) << quad.body;
  // The Earth's layer keeps every set.
  EXPECT_EQ(s.get("/wmts/1.0.0/sat/default/WorldCRS84Quad/1/0/0.png").status, 200);
}
