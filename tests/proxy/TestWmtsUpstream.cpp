// A WMTS server as an upstream (tellus/proxy/WmtsUpstream.hpp): the small XML reader, NASA GIBS's
// real capabilities (tests/data/wmts, PROVENANCE.md there) parsed, its EPSG:4326 sets mapped onto
// World Wind grids by arithmetic, tile URLs (REST and KVP, rows flipped), and the refusals.

#include "../../proxy/src/upstream/MiniXml.hpp"
#include "../../proxy/src/upstream/WmtsCompose.hpp"

#include <tellus/codec/Png.hpp>
#include <tellus/proxy/WmtsUpstream.hpp>

#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <sstream>

using namespace tellus;

namespace {

std::string gibsDocument() {
  std::ifstream in(std::string(TELLUS_TEST_SOURCE_DIR) + "/data/wmts/gibs-geographic-2014.xml",
                   std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

const WmtsCapabilities& gibs() {
  static const WmtsCapabilities caps = [] {
    auto c = parseWmtsCapabilities(gibsDocument());
    EXPECT_TRUE(c) << (c ? "" : c.error());
    return c ? *c : WmtsCapabilities{};
  }();
  return caps;
}

/** The World Wind grid of tellus's imagery layers: 36-degree level 0, 512 px tiles. */
GridSpec wwGrid(std::int32_t levels, std::int32_t tile = 512) {
  return GridSpec{Sector{}, 36.0, tile, tile, levels};
}

WmtsChoice modis() {
  WmtsChoice c;
  c.layer = "MODIS_Terra_CorrectedReflectance_TrueColor";
  c.format = "image/jpeg";
  return c;
}

/** A one-set document with the given CRS and matrices (each: identifier, scale denominator,
 * corner, matrix width and height), 512 px tiles. */
std::string syntheticDocument(const std::string& crs, const std::string& matrices) {
  return R"(<?xml version="1.0"?>
<Capabilities xmlns="http://www.opengis.net/wmts/1.0" xmlns:ows="http://www.opengis.net/ows/1.1"
    xmlns:xlink="http://www.w3.org/1999/xlink" version="1.0.0">
  <Contents>
    <Layer><ows:Identifier>L</ows:Identifier><Format>image/png</Format>
      <TileMatrixSetLink><TileMatrixSet>S</TileMatrixSet></TileMatrixSetLink></Layer>
    <TileMatrixSet><ows:Identifier>S</ows:Identifier>
      <ows:SupportedCRS>)" +
         crs + "</ows:SupportedCRS>" + matrices + R"(</TileMatrixSet>
  </Contents>
</Capabilities>)";
}

std::string matrix(const std::string& id,
                   const std::string& sd,
                   const std::string& corner,
                   int w,
                   int h,
                   int tile = 512) {
  return "<TileMatrix><ows:Identifier>" + id + "</ows:Identifier><ScaleDenominator>" + sd +
         "</ScaleDenominator><TopLeftCorner>" + corner + "</TopLeftCorner><TileWidth>" +
         std::to_string(tile) + "</TileWidth><TileHeight>" + std::to_string(tile) +
         "</TileHeight><MatrixWidth>" + std::to_string(w) + "</MatrixWidth><MatrixHeight>" +
         std::to_string(h) + "</MatrixHeight></TileMatrix>";
}

WmtsChoice synthetic() {
  WmtsChoice c;
  c.layer = "L";
  c.format = "image/png";
  c.capabilitiesUrl = "http://up.example/wmts?SERVICE=WMTS&REQUEST=GetCapabilities";
  return c;
}

} // namespace

// ------------------------------------------------------------------------------ the XML reader

TEST(MiniXml, ReadsElementsAttributesTextEntitiesAndCdata) {
  auto doc =
      xml::parse("\xEF\xBB\xBF<?xml version=\"1.0\"?>\n<!-- a comment -->\n"
                 "<a:root x='1' b:y=\"&lt;&#65;&#x42;&amp;\">"
                 "<a:child>one &gt; two</a:child><!-- skip --><child><![CDATA[<raw>]]></child>"
                 "<empty/></a:root>\n");
  ASSERT_TRUE(doc) << doc.error();
  const xml::Element& root = **doc;
  EXPECT_EQ(root.name, "a:root");
  EXPECT_EQ(root.local(), "root");
  ASSERT_NE(root.attribute("y"), nullptr);
  EXPECT_EQ(*root.attribute("y"), "<AB&");
  EXPECT_EQ(*root.attribute("x"), "1");
  EXPECT_EQ(root.childText("child"), "one > two");
  ASSERT_EQ(root.all("child").size(), 2u);
  EXPECT_EQ(root.all("child")[1]->text, "<raw>");
  ASSERT_NE(root.child("empty"), nullptr);
  EXPECT_EQ(root.child("missing"), nullptr);
}

TEST(MiniXml, RefusesMalformedAndHostileDocuments) {
  for (const std::string bad : {"",
                                "plain text",
                                "<a>",
                                "<a></b>",
                                "<a x=1/>",
                                "<a x='1' x='2'/>",
                                "<a>&custom;</a>",
                                "<a>&#0;</a>",
                                "<a/><b/>",
                                "<!DOCTYPE a [<!ENTITY e 'x'>]><a>&e;</a>",
                                "<a><!-- unterminated </a>"}) {
    SCOPED_TRACE(bad);
    auto doc = xml::parse(bad);
    ASSERT_FALSE(doc);
    EXPECT_NE(doc.error().find("XML: "), std::string::npos) << doc.error();
  }
  std::string deep;
  for (int i = 0; i < 100; ++i)
    deep += "<a>";
  for (int i = 0; i < 100; ++i)
    deep += "</a>";
  auto d = xml::parse(deep);
  ASSERT_FALSE(d);
  EXPECT_NE(d.error().find("nested too deep"), std::string::npos) << d.error();
}

// ------------------------------------------------------------------------------ GIBS's document

TEST(WmtsCapabilities, GibsDocumentIsReadWhole) {
  const WmtsCapabilities& c = gibs();
  EXPECT_EQ(c.title, "NASA Global Imagery Browse Services for EOSDIS");
  EXPECT_EQ(c.getTileKvpUrl, "http://map1.vis.earthdata.nasa.gov/wmts-geo/wmts.cgi?");
  ASSERT_EQ(c.layers.size(), 4u);
  ASSERT_EQ(c.tileMatrixSets.size(), 5u);
  const WmtsLayer* m = c.layer("MODIS_Terra_CorrectedReflectance_TrueColor");
  ASSERT_NE(m, nullptr);
  EXPECT_EQ(m->styles, std::vector<std::string>{"default"});
  EXPECT_EQ(m->formats, std::vector<std::string>{"image/jpeg"});
  EXPECT_EQ(m->tileMatrixSets, std::vector<std::string>{"EPSG4326_250m"});
  ASSERT_EQ(m->dimensions.size(), 1u);
  EXPECT_EQ(m->dimensions[0].identifier, "time");
  EXPECT_EQ(m->dimensions[0].defaultValue, "2014-02-07");
  EXPECT_EQ(m->dimensions[0].values, std::vector<std::string>{"2012-05-08/2014-02-07/P1D"});
  ASSERT_EQ(m->resourceUrls.size(), 1u);
  EXPECT_EQ(m->resourceUrls[0].resourceType, "tile");
  EXPECT_EQ(m->resourceUrls[0].tmpl,
            "http://map1.vis.earthdata.nasa.gov/wmts-geo/MODIS_Terra_CorrectedReflectance_TrueColor"
            "/default/{Time}/{TileMatrixSet}/{TileMatrix}/{TileRow}/{TileCol}.jpg");
  EXPECT_TRUE(c.layer("VIIRS_CityLights_2012")->dimensions.empty());
  const UpstreamTileMatrixSet* s = c.tileMatrixSet("EPSG4326_250m");
  ASSERT_NE(s, nullptr);
  EXPECT_EQ(s->crs, "urn:ogc:def:crs:OGC:1.3:CRS84");
  ASSERT_EQ(s->matrices.size(), 9u);
  EXPECT_EQ(s->matrices[0].identifier, "0");
  EXPECT_DOUBLE_EQ(s->matrices[0].scaleDenominator, 223632905.6114871);
  EXPECT_EQ(s->matrices[0].topLeftX, -180.0);
  EXPECT_EQ(s->matrices[0].topLeftY, 90.0);
  EXPECT_EQ(s->matrices[0].matrixWidth, 2);
  EXPECT_EQ(s->matrices[0].matrixHeight, 1);
  EXPECT_EQ(s->matrices[8].matrixWidth, 320);
  EXPECT_EQ(s->matrices[8].matrixHeight, 160);
  EXPECT_EQ(s->matrices[8].tileWidth, 512);
}

TEST(WmtsCapabilities, RefusesWhatIsNotCapabilities) {
  auto e = parseWmtsCapabilities(
      "<ExceptionReport xmlns='http://www.opengis.net/ows/1.1'><Exception exceptionCode="
      "'InvalidParameterValue'><ExceptionText>Unrecognized request</ExceptionText></Exception>"
      "</ExceptionReport>");
  ASSERT_FALSE(e);
  EXPECT_NE(e.error().find("Unrecognized request"), std::string::npos) << e.error();
  auto w = parseWmtsCapabilities("<WMS_Capabilities/>");
  ASSERT_FALSE(w);
  EXPECT_NE(w.error().find("WMS_Capabilities"), std::string::npos) << w.error();
  auto bad =
      parseWmtsCapabilities(syntheticDocument("EPSG:4326", matrix("0", "-5", "90 -180", 1, 1)));
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().find("ScaleDenominator"), std::string::npos) << bad.error();
  auto corner =
      parseWmtsCapabilities(syntheticDocument("EPSG:4326", matrix("0", "1000", "90", 1, 1)));
  ASSERT_FALSE(corner);
  EXPECT_NE(corner.error().find("TopLeftCorner"), std::string::npos) << corner.error();
}

// ------------------------------------------------------------------------------ mapping

TEST(WmtsMapping, GibsLevelNPlus3IsWorldWindLevelNWithRowsFlipped) {
  auto t = bindWmtsLayer(gibs(), modis(), wwGrid(6));
  ASSERT_TRUE(t) << t.error();
  EXPECT_TRUE(t->rest);
  EXPECT_EQ(t->style, "default");
  EXPECT_EQ(t->tileMatrixSet, "EPSG4326_250m");
  EXPECT_EQ(t->timeName, "time");
  EXPECT_EQ(t->timeDefault, "2014-02-07");
  ASSERT_EQ(t->levels.size(), 6u);
  for (int n = 0; n < 6; ++n) {
    SCOPED_TRACE(n);
    const WmtsLevel& lv = t->levels[static_cast<std::size_t>(n)];
    EXPECT_EQ(lv.matrix, std::to_string(n + 3));
    EXPECT_EQ(lv.colBase, 0);
    EXPECT_EQ(lv.rowBase, (5 << n) - 1); // the northernmost World Wind row is WMTS row 0
    EXPECT_EQ(lv.matrixHeight, 5 << n);
    EXPECT_EQ(lv.matrixWidth, 10 << n);
  }
  const std::string base = "http://map1.vis.earthdata.nasa.gov/wmts-geo/"
                           "MODIS_Terra_CorrectedReflectance_TrueColor/default/";
  // World Wind row 0 is the southernmost: WMTS row 4 of matrix 3.
  EXPECT_EQ(wmtsTileUrl(*t, TileKey{0, 0, 0}, ""), base + "2014-02-07/EPSG4326_250m/3/4/0.jpg");
  EXPECT_EQ(wmtsTileUrl(*t, TileKey{0, 4, 9}, "2013-06-01"),
            base + "2013-06-01/EPSG4326_250m/3/0/9.jpg");
  EXPECT_EQ(wmtsTileUrl(*t, TileKey{5, 0, 319}, "2013-06-01"),
            base + "2013-06-01/EPSG4326_250m/8/159/319.jpg");
  EXPECT_FALSE(wmtsTileUrl(*t, TileKey{6, 0, 0}, ""));
  EXPECT_FALSE(wmtsTileUrl(*t, TileKey{0, 5, 0}, ""));
}

TEST(WmtsMapping, KvpGetTileCarriesEveryParameter) {
  WmtsChoice c = modis();
  c.encoding = WmtsEncoding::Kvp;
  auto t = bindWmtsLayer(gibs(), c, wwGrid(2));
  ASSERT_TRUE(t) << t.error();
  EXPECT_FALSE(t->rest);
  EXPECT_EQ(wmtsTileUrl(*t, TileKey{1, 2, 7}, "2013-06-01"),
            "http://map1.vis.earthdata.nasa.gov/wmts-geo/wmts.cgi?SERVICE=WMTS&REQUEST=GetTile"
            "&VERSION=1.0.0&LAYER=MODIS_Terra_CorrectedReflectance_TrueColor&STYLE=default"
            "&FORMAT=image%2Fjpeg&TILEMATRIXSET=EPSG4326_250m&TILEMATRIX=4&TILEROW=7&TILECOL=7"
            "&TIME=2013-06-01");
  // A layer without a time dimension sends none.
  WmtsChoice night;
  night.layer = "VIIRS_CityLights_2012";
  night.format = "image/jpeg";
  auto n = bindWmtsLayer(gibs(), night, wwGrid(5));
  ASSERT_TRUE(n) << n.error();
  EXPECT_EQ(wmtsTileUrl(*n, TileKey{0, 0, 0}, "2013-06-01"),
            "http://map1.vis.earthdata.nasa.gov/wmts-geo/VIIRS_CityLights_2012/default/"
            "EPSG4326_500m/3/4/0.jpg");
}

// Found by fuzz_wmts_capabilities: a ResourceURL whose template is missing (a misspelt attribute)
// or addresses no tile made empty URLs. Such a ResourceURL is not used: KVP instead, or a refusal
// when the configuration asks for REST.
TEST(WmtsMapping, ResourceUrlsThatAddressNoTileAreNotUsed) {
  const std::string layer = "<ows:Identifier>L</ows:Identifier><Format>image/png</Format>";
  for (const std::string& resource :
       {std::string("<ResourceURL format=\"image/png\" resourceType=\"tile\" tpmelate=\"x\"/>"),
        std::string("<ResourceURL format=\"image/png\" resourceType=\"tile\" "
                    "template=\"{Style}\"/>"),
        std::string("<ResourceURL format=\"image/png\" resourceType=\"tile\" "
                    "template=\"http://up.example/{TileMatrix}/{TileRow}.png\"/>")}) {
    std::string doc = syntheticDocument("urn:ogc:def:crs:OGC:1.3:CRS84",
                                        matrix("0", "27954113.20143589", "-180 90", 10, 5));
    doc.replace(doc.find(layer), layer.size(), layer + resource);
    auto caps = parseWmtsCapabilities(doc);
    ASSERT_TRUE(caps) << caps.error();
    WmtsChoice c = synthetic();
    auto t = bindWmtsLayer(*caps, c, wwGrid(1));
    ASSERT_TRUE(t) << t.error();
    EXPECT_FALSE(t->rest) << resource;
    const auto url = wmtsTileUrl(*t, TileKey{0, 0, 0}, "");
    ASSERT_TRUE(url);
    EXPECT_TRUE(url->starts_with("http://up.example/wmts?SERVICE=WMTS&REQUEST=GetTile")) << *url;
    c.encoding = WmtsEncoding::Rest;
    auto r = bindWmtsLayer(*caps, c, wwGrid(1));
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().find("names {TileMatrix}, {TileRow} and {TileCol}"), std::string::npos)
        << r.error();
  }
}

TEST(WmtsMapping, LevelsPastTheSetsFinestAreRefusedWithTheLimit) {
  auto t = bindWmtsLayer(gibs(), modis(), wwGrid(7));
  ASSERT_FALSE(t);
  EXPECT_NE(t.error().find("levels 0-5"), std::string::npos) << t.error();
  EXPECT_NE(t.error().find("at most 6"), std::string::npos) << t.error();
}

TEST(WmtsMapping, SetsTooCoarseOrProjectedAreRefusedSayingWhy) {
  // GIBS's 16 km set stops at 72-degree tiles: nothing of it is as fine as a World Wind level.
  WmtsChoice sst;
  sst.layer = "Sea_Surface_Temp_Microwave";
  sst.format = "image/png";
  auto t = bindWmtsLayer(gibs(), sst, wwGrid(1));
  ASSERT_FALSE(t);
  EXPECT_NE(t.error().find("no matrix as fine as the grid's level 0"), std::string::npos)
      << t.error();
  EXPECT_NE(t.error().find("72 deg"), std::string::npos) << t.error();
  // A projected CRS other than Web Mercator (UTM 33 N), even with Web Mercator's numbers.
  auto utm = parseWmtsCapabilities(
      syntheticDocument("urn:ogc:def:crs:EPSG::32633",
                        matrix("0", "559082264.0287178", "-20037508.34 20037508.34", 1, 1)));
  ASSERT_TRUE(utm) << utm.error();
  auto m = bindWmtsLayer(*utm, synthetic(), wwGrid(1));
  ASSERT_FALSE(m);
  EXPECT_NE(m.error().find("only Web Mercator"), std::string::npos) << m.error();
  // Web Mercator (512 px tiles) whose finest zoom is coarser than level 0
  // (TestWmtsUpstreamMercator.cpp).
  auto merc = parseWmtsCapabilities(
      syntheticDocument("urn:ogc:def:crs:EPSG::3857",
                        matrix("0", "279541132.0143589", "-20037508.34 20037508.34", 1, 1)));
  ASSERT_TRUE(merc) << merc.error();
  auto coarse = bindWmtsLayer(*merc, synthetic(), wwGrid(1));
  ASSERT_FALSE(coarse);
  EXPECT_NE(coarse.error().find("has no zoom as fine as the grid's level 0"), std::string::npos)
      << coarse.error();
}

TEST(WmtsMapping, LevelsNoMatrixLinesUpWithAreComposedFromTheCoarsestFineEnough) {
  // 256 px grid tiles: no GIBS matrix has them; level 0 (0.14 deg/px) comes from GIBS matrix 2
  // (72-degree tiles of 512 px: the same pixel), level 1 from matrix 3.
  auto t = bindWmtsLayer(gibs(), modis(), wwGrid(2, 256));
  ASSERT_TRUE(t) << t.error();
  EXPECT_EQ(t->levels[0].composeFrom, 2);
  EXPECT_EQ(t->levels[1].composeFrom, 3);
  EXPECT_TRUE(wmtsComposed(*t, TileKey{0, 0, 0}));
  EXPECT_FALSE(wmtsTileUrl(*t, TileKey{0, 0, 0}, ""));
  // The south-westernmost 36-degree tile lies in GIBS tile (row 2, col 0) of matrix 2 alone.
  const auto src =
      wmtsSourceTiles(*t, TileKey{0, 0, 0}, Sector{-180, -90, -144, -54}, 256, 256, "2013-06-01");
  ASSERT_EQ(src.size(), 1u);
  EXPECT_EQ(src[0].row, 2);
  EXPECT_EQ(src[0].col, 0);
  EXPECT_NE(src[0].url.find("/2013-06-01/EPSG4326_250m/2/2/0.jpg"), std::string::npos)
      << src[0].url;
  // A corner half a tile off the grid's edges: composed from that matrix, two tiles a grid tile.
  const std::string sd36 = "27954113.20143589";
  auto off = parseWmtsCapabilities(
      syntheticDocument("urn:ogc:def:crs:OGC:1.3:CRS84", matrix("a", sd36, "-180 72", 10, 5)));
  ASSERT_TRUE(off) << off.error();
  auto o = bindWmtsLayer(*off, synthetic(), wwGrid(1));
  ASSERT_TRUE(o) << o.error();
  EXPECT_EQ(o->levels[0].composeFrom, 0);
  const auto two = wmtsSourceTiles(*o, TileKey{0, 3, 0}, Sector{-180, 18, -144, 54}, 512, 512, "");
  ASSERT_EQ(two.size(), 2u);
  EXPECT_EQ(two[0].row, 0);
  EXPECT_EQ(two[1].row, 1);
  EXPECT_EQ(two[1].col, 0);
  // North of the matrix (72-90 N is outside it; the tile 54-90 N needs only its row 0).
  EXPECT_EQ(wmtsSourceTiles(*o, TileKey{0, 4, 0}, Sector{-180, 54, -144, 90}, 512, 512, "").size(),
            1u);
}

TEST(WmtsMapping, AlignmentIsArithmeticWithATolerance) {
  // The set's name says nothing; EPSG:4326 corners latitude first (as the standard has them);
  // a scale denominator rounded to 10 digits still lines up (0.01 px over the whole matrix), one
  // 4e-6 off does not (that level is composed instead).
  for (const auto& [sd, aligned] : std::vector<std::pair<std::string, bool>>{
           {"27954113.20143589", true}, {"27954113.20", true}, {"27954000.0", false}}) {
    SCOPED_TRACE(sd);
    auto caps = parseWmtsCapabilities(
        syntheticDocument("urn:ogc:def:crs:EPSG::4326", matrix("top", sd, "90 -180", 10, 5)));
    ASSERT_TRUE(caps) << caps.error();
    auto t = bindWmtsLayer(*caps, synthetic(), wwGrid(1));
    ASSERT_TRUE(t) << t.error();
    EXPECT_EQ(t->levels[0].composeFrom < 0, aligned);
    if (aligned) {
      EXPECT_EQ(t->levels[0].rowBase, 4);
      EXPECT_FALSE(t->rest); // no ResourceURL: KVP, on the capabilities URL's path
      EXPECT_EQ(wmtsTileUrl(*t, TileKey{0, 0, 0}, ""),
                "http://up.example/wmts?SERVICE=WMTS&REQUEST=GetTile&VERSION=1.0.0&LAYER=L"
                "&STYLE=default&FORMAT=image%2Fpng&TILEMATRIXSET=S&TILEMATRIX=top&TILEROW=4"
                "&TILECOL=0");
    }
  }
  // A matrix that covers part of the globe (its corner at 54N 0E): tiles outside it do not exist.
  auto part = parseWmtsCapabilities(
      syntheticDocument("CRS:84", matrix("p", "27954113.20143589", "0 54", 2, 1)));
  ASSERT_TRUE(part) << part.error();
  auto p = bindWmtsLayer(*part, synthetic(), wwGrid(1));
  ASSERT_TRUE(p) << p.error();
  EXPECT_EQ(p->levels[0].colBase, -5);
  EXPECT_EQ(p->levels[0].rowBase, 3); // WMTS row = 3 - World Wind row: row 3 (18-54N) is row 0
  EXPECT_NE(wmtsTileUrl(*p, TileKey{0, 3, 6}, "").value_or("").find("TILEROW=0&TILECOL=1"),
            std::string::npos);
  EXPECT_TRUE(wmtsTileUrl(*p, TileKey{0, 3, 6}, ""));
  EXPECT_FALSE(wmtsTileUrl(*p, TileKey{0, 3, 4}, ""));
  EXPECT_FALSE(wmtsTileUrl(*p, TileKey{0, 2, 5}, ""));
  EXPECT_FALSE(wmtsTileUrl(*p, TileKey{0, 4, 5}, ""));
}

TEST(WmtsMapping, WrongChoicesNameWhatExists) {
  WmtsChoice c = modis();
  c.layer = "MODIS_Nope";
  auto l = bindWmtsLayer(gibs(), c, wwGrid(1));
  ASSERT_FALSE(l);
  EXPECT_NE(l.error().find("no layer 'MODIS_Nope'"), std::string::npos) << l.error();
  EXPECT_NE(l.error().find("'Sea_Surface_Temp_Blended'"), std::string::npos) << l.error();
  c = modis();
  c.format = "image/png";
  auto f = bindWmtsLayer(gibs(), c, wwGrid(1));
  ASSERT_FALSE(f);
  EXPECT_NE(f.error().find("no format 'image/png' (it has 'image/jpeg')"), std::string::npos)
      << f.error();
  c = modis();
  c.style = "bright";
  auto s = bindWmtsLayer(gibs(), c, wwGrid(1));
  ASSERT_FALSE(s);
  EXPECT_NE(s.error().find("no style 'bright' (it has 'default')"), std::string::npos) << s.error();
  c = modis();
  c.tileMatrixSet = "EPSG4326_500m";
  auto m = bindWmtsLayer(gibs(), c, wwGrid(1));
  ASSERT_FALSE(m);
  EXPECT_NE(m.error().find("(it links 'EPSG4326_250m')"), std::string::npos) << m.error();
  c = modis();
  c.tileMatrixSet = "EPSG4326_250m";
  EXPECT_TRUE(bindWmtsLayer(gibs(), c, wwGrid(1)));
}

TEST(WmtsMapping, CapabilitiesUrlIsCompletedOnlyWhenItAsksForNothing) {
  EXPECT_EQ(wmtsCapabilitiesUrl("https://gibs.earthdata.nasa.gov/wmts/epsg4326/best/wmts.cgi"),
            "https://gibs.earthdata.nasa.gov/wmts/epsg4326/best/wmts.cgi"
            "?SERVICE=WMTS&REQUEST=GetCapabilities&VERSION=1.0.0");
  EXPECT_EQ(wmtsCapabilitiesUrl("http://h/wmts?key=1"),
            "http://h/wmts?key=1&SERVICE=WMTS&REQUEST=GetCapabilities&VERSION=1.0.0");
  EXPECT_EQ(wmtsCapabilitiesUrl("http://h/wmts?request=GetCapabilities&service=WMTS"),
            "http://h/wmts?request=GetCapabilities&service=WMTS");
  EXPECT_EQ(wmtsCapabilitiesUrl("https://h/wmts/1.0.0/WMTSCapabilities.xml"),
            "https://h/wmts/1.0.0/WMTSCapabilities.xml");
}

// ------------------------------------------------------------------------------ composition

namespace {

std::vector<std::byte> solidPng(int w, int h, std::array<std::uint8_t, 4> rgba) {
  std::vector<std::uint8_t> px(static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * 4);
  for (std::size_t i = 0; i < px.size(); ++i)
    px[i] = rgba[i % 4];
  return *codec::encodePng(w, h, 4, px.data());
}

std::array<int, 4> pixelAt(const codec::Image& img, int x, int y) {
  const auto i = (static_cast<std::size_t>(y) * static_cast<std::size_t>(img.width) +
                  static_cast<std::size_t>(x)) *
                 4;
  return {img.pixels[i], img.pixels[i + 1], img.pixels[i + 2], img.pixels[i + 3]};
}

} // namespace

TEST(WmtsCompose, TilesAreSampledWhereTheyLieAndNothingOutsideTheMatrix) {
  // Matrix "a": 36-degree tiles of 512 px from (-180, 72); grid tile (0, 3, 0) spans 18-54 N:
  // its top half is the bottom half of source row 0, its bottom half the top of source row 1.
  auto caps = parseWmtsCapabilities(syntheticDocument(
      "urn:ogc:def:crs:OGC:1.3:CRS84", matrix("a", "27954113.20143589", "-180 72", 10, 5)));
  ASSERT_TRUE(caps) << caps.error();
  auto t = bindWmtsLayer(*caps, synthetic(), wwGrid(1));
  ASSERT_TRUE(t) << t.error();
  const Sector sector{-180, 18, -144, 54};
  auto src = wmtsSourceTiles(*t, TileKey{0, 3, 0}, sector, 512, 512, "");
  ASSERT_EQ(src.size(), 2u);
  std::vector<WmtsFetchedTile> fetched{{src[0], solidPng(512, 512, {200, 10, 10, 255})},
                                       {src[1], solidPng(512, 512, {10, 10, 200, 255})}};
  auto png = composeWmtsTile(*t, TileKey{0, 3, 0}, sector, 512, 512, fetched, "image/png");
  ASSERT_TRUE(png) << png.error();
  auto img = codec::decodePng(*png);
  ASSERT_TRUE(img);
  ASSERT_EQ(img->width, 512);
  EXPECT_EQ(pixelAt(*img, 0, 0), (std::array<int, 4>{200, 10, 10, 255}));
  EXPECT_EQ(pixelAt(*img, 300, 255), (std::array<int, 4>{200, 10, 10, 255}));
  EXPECT_EQ(pixelAt(*img, 300, 256), (std::array<int, 4>{10, 10, 200, 255}));
  EXPECT_EQ(pixelAt(*img, 511, 511), (std::array<int, 4>{10, 10, 200, 255}));
  // A source tile the server does not have (404) is transparent, not black.
  fetched[1].bytes.clear();
  auto hole = composeWmtsTile(*t, TileKey{0, 3, 0}, sector, 512, 512, fetched, "image/png");
  ASSERT_TRUE(hole) << hole.error();
  auto h = codec::decodePng(*hole);
  ASSERT_TRUE(h);
  EXPECT_EQ(pixelAt(*h, 10, 10), (std::array<int, 4>{200, 10, 10, 255}));
  EXPECT_EQ(pixelAt(*h, 10, 400)[3], 0);
  // The tile 54-90 N: north of 72 N is outside the matrix, transparent.
  const Sector north{-180, 54, -144, 90};
  auto top = wmtsSourceTiles(*t, TileKey{0, 4, 0}, north, 512, 512, "");
  ASSERT_EQ(top.size(), 1u);
  std::vector<WmtsFetchedTile> one{{top[0], solidPng(512, 512, {200, 10, 10, 255})}};
  auto edge = composeWmtsTile(*t, TileKey{0, 4, 0}, north, 512, 512, one, "image/png");
  ASSERT_TRUE(edge) << edge.error();
  auto e = codec::decodePng(*edge);
  ASSERT_TRUE(e);
  EXPECT_EQ(pixelAt(*e, 5, 200)[3], 0);
  EXPECT_EQ(pixelAt(*e, 5, 300), (std::array<int, 4>{200, 10, 10, 255}));
  // A source tile of the wrong size, or garbage, is an error naming its URL.
  std::vector<WmtsFetchedTile> bad{{src[0], solidPng(256, 256, {0, 0, 0, 255})}};
  auto wrong = composeWmtsTile(*t, TileKey{0, 3, 0}, sector, 512, 512, bad, "image/jpeg");
  ASSERT_FALSE(wrong);
  EXPECT_NE(wrong.error().find("256 x 256"), std::string::npos) << wrong.error();
}

// Issue 26: a layer on the Moon reads a NASA-Trek-like set (2 x 1 tiles of 180 degrees and 256 px
// at zoom 0) in the Moon's IAU CRS, latitude first, whether its scale denominators are counted
// on the Moon's radius or on the Earth's; a 45-degree grid is zoom 2 on, re-indexed.
TEST(WmtsMapping, AnotherBodysSetIsReadInItsIauCrsOnWhicheverRadiusItCounts) {
  const double moonMetresPerDegree = 1737400.0 * std::numbers::pi / 180.0;
  const auto trekLike = [](double metresPerDegree) {
    std::string ms;
    for (int z = 0; z < 4; ++z) {
      char sd[64];
      std::snprintf(sd, sizeof sd, "%.10f", 180.0 / (1 << z) / 256 * metresPerDegree / 0.00028);
      ms += matrix(std::to_string(z), sd, "90 -180", 2 << z, 1 << z, 256);
    }
    return syntheticDocument("urn:ogc:def:crs:IAU:2015:30100", ms);
  };
  const GridSpec grid{Sector{}, 45.0, 256, 256, 2};
  WmtsChoice moon = synthetic();
  moon.bodyMetresPerDegree = moonMetresPerDegree;
  for (const double counted : {moonMetresPerDegree, 111319.49079327357}) {
    SCOPED_TRACE(counted);
    auto caps = parseWmtsCapabilities(trekLike(counted));
    ASSERT_TRUE(caps) << caps.error();
    auto t = bindWmtsLayer(*caps, moon, grid);
    ASSERT_TRUE(t) << t.error();
    ASSERT_EQ(t->levels.size(), 2u);
    EXPECT_LT(t->levels[0].composeFrom, 0);
    EXPECT_EQ(t->levels[0].matrix, "2");
    EXPECT_EQ(t->levels[1].matrix, "3");
    EXPECT_EQ(t->levels[0].rowBase, 3);
  }
  // An Earth layer does not take the Moon's CRS.
  auto caps = parseWmtsCapabilities(trekLike(moonMetresPerDegree));
  ASSERT_TRUE(caps);
  auto earth = bindWmtsLayer(*caps, synthetic(), grid);
  ASSERT_FALSE(earth);
  EXPECT_NE(earth.error().find("IAU:2015:30100"), std::string::npos) << earth.error();
}
