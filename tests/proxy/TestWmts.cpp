// WMTS 1.0.0's pure parts (Wmts.hpp): KVP and RESTful parsing, the tile matrix sets (scale
// denominators of the standards, limits, row flipping), the capabilities and exception reports
// validated against the official schemas (tests/data/schemas).
#include "../support/WmsSchemas.hpp"

#include <tellus/proxy/Wmts.hpp>

#include <gtest/gtest.h>

#include <cmath>

using namespace tellus;

namespace {

QueryParams kvp(std::string_view q) {
  return *parseQuery(q);
}

const std::string kTile = "SERVICE=WMTS&REQUEST=GetTile&VERSION=1.0.0&LAYER=sat&STYLE=default"
                          "&FORMAT=image/jpeg&TILEMATRIXSET=WorldCRS84Quad&TILEMATRIX=3&TILEROW=2"
                          "&TILECOL=5";

std::string codeOf(const std::expected<WmtsRequest, OgcException>& r) {
  return r ? std::string("ok") : r.error().code + "/" + r.error().locator;
}

} // namespace

TEST(Wmts, KvpGetTileIsParsedWithNamesInAnyCase) {
  const auto r = parseWmtsKvp(kvp("service=wmts&request=gettile&version=1.0.0&layer=sat&style="
                                  "&format=image%2Fpng&tilematrixset=WorldWind_sat&tilematrix=0"
                                  "&TileRow=4&TileCol=9&Time=2024-03-01"));
  ASSERT_TRUE(r) << r.error().message;
  const auto& t = std::get<WmtsGetTileRequest>(*r);
  EXPECT_EQ(t.layer, "sat");
  EXPECT_EQ(t.style, "");
  EXPECT_EQ(t.format, "image/png");
  EXPECT_EQ(t.tileMatrixSet, "WorldWind_sat");
  EXPECT_EQ(t.tileMatrix, "0");
  EXPECT_EQ(t.row, 4);
  EXPECT_EQ(t.col, 9);
  EXPECT_EQ(t.time, "2024-03-01");
  EXPECT_TRUE(std::holds_alternative<WmtsGetCapabilitiesRequest>(
      *parseWmtsKvp(kvp("SERVICE=WMTS&REQUEST=GetCapabilities"))));
}

TEST(Wmts, KvpErrorsHaveTheCodesOfTheStandard) {
  EXPECT_EQ(codeOf(parseWmtsKvp(kvp("REQUEST=GetTile"))), "MissingParameterValue/SERVICE");
  EXPECT_EQ(codeOf(parseWmtsKvp(kvp("SERVICE=WMS&REQUEST=GetTile"))),
            "InvalidParameterValue/SERVICE");
  EXPECT_EQ(codeOf(parseWmtsKvp(kvp("SERVICE=WMTS"))), "MissingParameterValue/REQUEST");
  EXPECT_EQ(codeOf(parseWmtsKvp(kvp("SERVICE=WMTS&REQUEST=GetFeatureInfo"))),
            "OperationNotSupported/REQUEST");
  EXPECT_EQ(codeOf(parseWmtsKvp(kvp("SERVICE=WMTS&REQUEST=GetCapabilities&AcceptVersions=2.0.0"))),
            "VersionNegotiationFailed/AcceptVersions");
  EXPECT_EQ(
      codeOf(parseWmtsKvp(kvp("SERVICE=WMTS&REQUEST=GetCapabilities&AcceptVersions=2.0.0,1.0.0"))),
      "ok");
  for (const std::string_view drop : {"&LAYER=sat",
                                      "&FORMAT=image/jpeg",
                                      "&TILEMATRIXSET=WorldCRS84Quad",
                                      "&TILEMATRIX=3",
                                      "&TILEROW=2",
                                      "&TILECOL=5",
                                      "&VERSION=1.0.0"}) {
    std::string q = kTile;
    q.erase(q.find(drop), drop.size());
    const auto r = parseWmtsKvp(kvp(q));
    ASSERT_FALSE(r) << drop;
    EXPECT_EQ(r.error().code, "MissingParameterValue") << drop;
  }
  EXPECT_EQ(codeOf(parseWmtsKvp(kvp(kTile + "&TILEROW=3"))), "InvalidParameterValue/tilerow");
  std::string negative = kTile;
  negative.replace(negative.find("TILEROW=2"), 9, "TILEROW=-2");
  EXPECT_EQ(codeOf(parseWmtsKvp(kvp(negative))), "InvalidParameterValue/TILEROW");
  std::string v2 = kTile;
  v2.replace(v2.find("1.0.0"), 5, "2.0.0");
  EXPECT_EQ(codeOf(parseWmtsKvp(kvp(v2))), "InvalidParameterValue/VERSION");
}

TEST(Wmts, RestPathsFollowTheResourceUrlTemplates) {
  EXPECT_TRUE(
      std::holds_alternative<WmtsGetCapabilitiesRequest>(*parseWmtsRest("WMTSCapabilities.xml")));
  const auto r = parseWmtsRest("sat/default/WorldWind_sat/2/7/13.jpg");
  ASSERT_TRUE(r);
  const auto& t = std::get<WmtsGetTileRequest>(*r);
  EXPECT_EQ(t.layer, "sat");
  EXPECT_EQ(t.style, "default");
  EXPECT_FALSE(t.time);
  EXPECT_EQ(t.tileMatrixSet, "WorldWind_sat");
  EXPECT_EQ(t.tileMatrix, "2");
  EXPECT_EQ(t.row, 7);
  EXPECT_EQ(t.col, 13);
  EXPECT_EQ(t.extension, "jpg");
  const auto timed =
      parseWmtsRest("sst/default/2024-03-01T06%3A00Z/GoogleMapsCompatible/4/5/6.png");
  ASSERT_TRUE(timed);
  EXPECT_EQ(std::get<WmtsGetTileRequest>(*timed).time, "2024-03-01T06:00Z");
  EXPECT_EQ(std::get<WmtsGetTileRequest>(*timed).tileMatrixSet, "GoogleMapsCompatible");
  for (const std::string_view bad : {"",
                                     "sat/default/WorldWind_sat/2/7",
                                     "sat/default/WorldWind_sat/2/7/13",
                                     "sat/default/WorldWind_sat/2/x/13.jpg",
                                     "sat/default/WorldWind_sat/2/7/13.",
                                     "sat//WorldWind_sat/2/7/13.jpg",
                                     "a/b/c/d/e/f/g/1/2.jpg",
                                     "sat/default/WorldWind_sat/2/7/%zz.jpg"})
    EXPECT_FALSE(parseWmtsRest(bad)) << bad;
}

TEST(Wmts, WorldWindSetFlipsRowsAndLimitsToTheSector) {
  // A 36-degree grid of 512-px tiles over Europe-ish, levels 1..3.
  const GridSpec g{Sector{-36, 18, 36, 72}, 36.0, 512, 512, 4};
  const auto s = worldWindMatrixSet("eu", g, 1);
  ASSERT_EQ(s.matrices.size(), 3u);
  EXPECT_EQ(s.identifier, "WorldWind_eu");
  const WmtsTileMatrix& m = s.matrices[0]; // level 1: 18-degree tiles, 20 x 10
  EXPECT_EQ(m.identifier, "1");
  EXPECT_EQ(m.matrixWidth, 20);
  EXPECT_EQ(m.matrixHeight, 10);
  EXPECT_EQ(m.minCol, 8);  // -36
  EXPECT_EQ(m.maxCol, 11); // 36
  EXPECT_EQ(m.minRow, 1);  // 72 from the top (90)
  EXPECT_EQ(m.maxRow, 3);  // 18
  // WMTS row 1 (72..54 N) is World Wind row 10 - 1 - 1 = 8 (counted from -90).
  const TileKey k = worldWindKeyOf(s, 0, 1, 8);
  EXPECT_EQ(k, (TileKey{1, 8, 8}));
  const Sector box = wmtsTileBox(m, 1, 8);
  EXPECT_EQ(box, (Sector{-36, 54, -18, 72}));
  EXPECT_EQ(*TileGrid::create(g)->keyAt(60, -30, 1), k);
  // The scale of a degree-based matrix: pixel span in metres on the WGS 84 axis / 0.28 mm.
  EXPECT_NEAR(m.scaleDenominator, 18.0 / 512 * 6378137.0 * M_PI / 180 / 0.00028, 1e-6);
}

TEST(Wmts, OutOfRangeTilesAndUnknownMatricesAreRefused) {
  const GridSpec g{Sector{-36, 18, 36, 72}, 36.0, 512, 512, 4};
  const auto s = worldWindMatrixSet("eu", g, 1);
  EXPECT_EQ(checkWmtsTile(s, "2", 3, 17).value(), 1u);
  EXPECT_EQ(checkWmtsTile(s, "1", 0, 8).error().code, "TileOutOfRange");
  EXPECT_EQ(checkWmtsTile(s, "1", 0, 8).error().locator, "TileRow");
  EXPECT_EQ(checkWmtsTile(s, "1", 1, 12).error().locator, "TileCol");
  EXPECT_EQ(checkWmtsTile(s, "0", 0, 0).error().code, "InvalidParameterValue"); // below level 1
  EXPECT_EQ(checkWmtsTile(s, "4", 0, 0).error().locator, "TileMatrix");
  EXPECT_EQ(wmtsExceptionHttpStatus("TileOutOfRange"), 400);
  EXPECT_EQ(wmtsExceptionHttpStatus("MissingParameterValue"), 400);
  EXPECT_EQ(wmtsExceptionHttpStatus("InvalidParameterValue"), 400);
  EXPECT_EQ(wmtsExceptionHttpStatus("OperationNotSupported"), 501);
  EXPECT_EQ(wmtsExceptionHttpStatus("NoApplicableCode"), 500);
}

TEST(Wmts, WellKnownSetsHaveTheStandardsScales) {
  const auto quad = composedMatrixSet(WmtsSetKind::WorldCRS84Quad, Sector{}, 3);
  ASSERT_EQ(quad.matrices.size(), 3u);
  EXPECT_EQ(quad.crs, "urn:ogc:def:crs:OGC:1.3:CRS84");
  // OGC 17-083r2 annex D.1: 279541132.0143589, 139770566.0071794, ...
  EXPECT_NEAR(quad.matrices[0].scaleDenominator, 279541132.0143589, 1e-6);
  EXPECT_NEAR(quad.matrices[1].scaleDenominator, 139770566.0071794, 1e-6);
  EXPECT_EQ(quad.matrices[0].matrixWidth, 2);
  EXPECT_EQ(quad.matrices[0].matrixHeight, 1);
  EXPECT_EQ(quad.matrices[2].matrixWidth, 8);
  EXPECT_EQ(quad.matrices[2].maxRow, 3);
  const auto merc = composedMatrixSet(WmtsSetKind::GoogleMapsCompatible, Sector{}, 19);
  EXPECT_EQ(merc.crs, "urn:ogc:def:crs:EPSG::3857");
  // WMTS 1.0.0 annex E.4: 559082264.0287178 at 0, 2132.729583849784 at 18.
  EXPECT_NEAR(merc.matrices[0].scaleDenominator, 559082264.0287178, 1e-6);
  EXPECT_NEAR(merc.matrices[18].scaleDenominator, 2132.729583849784, 1e-9);
  EXPECT_DOUBLE_EQ(merc.matrices[0].left, -20037508.342789244);
  EXPECT_EQ(merc.matrices[3].matrixWidth, 8);
  EXPECT_EQ(merc.matrices[3].maxRow, 7); // the whole world up to 85.05 degrees
  // A layer over Europe: its tiles only.
  const auto eu = composedMatrixSet(WmtsSetKind::GoogleMapsCompatible, Sector{0, 45, 45, 90}, 3);
  EXPECT_EQ(eu.matrices[2].minCol, 2);
  EXPECT_EQ(eu.matrices[2].maxCol, 2);
  EXPECT_EQ(eu.matrices[2].minRow, 0);
  EXPECT_EQ(eu.matrices[2].maxRow, 1);
  // Row 0 col 0 of WorldCRS84Quad level 1 is the north-west 90-degree square; its cache key
  // counts rows from the south.
  EXPECT_EQ(wmtsTileBox(quad.matrices[1], 0, 0), (Sector{-180, 0, -90, 90}));
  EXPECT_EQ(crs84QuadCacheKey(1, 0, 0), (TileKey{1, 1, 0}));
}

TEST(Wmts, ComposedSetsAreKeptInGridsOfTheirMatrixSizes) {
  // GoogleMapsCompatible: 2^z x 2^z tiles at every level, the keys from the matrix's rows (from
  // the south) and columns; the tiles past them are not the grid's.
  const auto merc = TileGrid::create(composedCacheGrid(WmtsSetKind::GoogleMapsCompatible, 7));
  ASSERT_TRUE(merc) << merc.error();
  for (const std::int32_t z : {0, 1, 4, 6}) {
    const std::int64_t n = std::int64_t{1} << z;
    EXPECT_EQ(merc->rowCount(z), n);
    EXPECT_TRUE(merc->isValid(crs84QuadCacheKey(z, 0, n - 1)));
    EXPECT_TRUE(merc->isValid(crs84QuadCacheKey(z, n - 1, 0)));
    EXPECT_FALSE(merc->isValid(crs84QuadCacheKey(z, 0, n))) << z;
  }
  EXPECT_EQ(merc->numLevels(), 7);
  EXPECT_EQ(merc->spec().tileWidth, 256);
  const auto quad = TileGrid::create(composedCacheGrid(WmtsSetKind::WorldCRS84Quad, 3));
  ASSERT_TRUE(quad) << quad.error();
  EXPECT_EQ(quad->spec(), (GridSpec{Sector{}, 180.0, 256, 256, 3}));
  EXPECT_TRUE(quad->isValid(crs84QuadCacheKey(2, 0, 7)));
}

TEST(Wmts, ComposedSetsGoAsDeepAsTheLayer) {
  // 36-degree, 512 px, 10 levels: finest pixel 36/512/512 degrees; WorldCRS84Quad's level z has
  // 180/256/2^z: z = 9 is 0.00137 > 0.000137..., z = 13 ... the first at least as fine.
  const GridSpec g{Sector{}, 36.0, 512, 512, 10};
  const std::int32_t n = composedLevels(WmtsSetKind::WorldCRS84Quad, g);
  const double finest = 36.0 / 512 / 512;
  EXPECT_LE(180.0 / 256 / std::ldexp(1.0, n - 1), finest);
  EXPECT_GT(180.0 / 256 / std::ldexp(1.0, n - 2), finest);
  EXPECT_EQ(composedLevels(WmtsSetKind::GoogleMapsCompatible, g), n + 1);
}

TEST(Wmts, CapabilitiesAndExceptionsAreValid) {
  const GridSpec g{Sector{-36, 18, 36, 72}, 36.0, 512, 512, 4};
  const auto own = worldWindMatrixSet("eu & co", g, 0);
  const auto quad = composedMatrixSet(WmtsSetKind::WorldCRS84Quad, g.sector, 6);
  const auto merc = composedMatrixSet(WmtsSetKind::GoogleMapsCompatible, g.sector, 7);
  const auto quadDef = composedMatrixSet(WmtsSetKind::WorldCRS84Quad, Sector{}, 6);
  const auto mercDef = composedMatrixSet(WmtsSetKind::GoogleMapsCompatible, Sector{}, 7);
  WmtsCapabilitiesModel m;
  m.title = "tellus <test>";
  m.baseUrl = "http://example.org:8080";
  WmtsLayerInfo l;
  l.identifier = "eu & co";
  l.title = "Europe";
  l.bbox = g.sector;
  l.format = "image/jpeg";
  l.extension = "jpg";
  l.timeValues = {"2024-03-01", "2024-03-02"};
  l.timePeriod = "2024-01-01/2024-02-01/P1D";
  l.timeDefault = "2024-03-02";
  l.sets = {&own, &quad, &merc};
  m.layers.push_back(l);
  m.sets = {&own, &quadDef, &mercDef};
  const std::string xml = wmtsCapabilitiesXml(m);
  const auto verdict = test::validateWmtsCapabilities(xml);
  EXPECT_TRUE(verdict.valid) << verdict.output << "\n" << xml;
  EXPECT_NE(xml.find("<Default>2024-03-02</Default>"), std::string::npos);
  EXPECT_NE(xml.find("<Value>2024-01-01/2024-02-01/P1D</Value>"), std::string::npos);
  EXPECT_NE(xml.find("template=\"http://example.org:8080/wmts/1.0.0/eu%20%26%20co/{Style}/{Time}/"
                     "{TileMatrixSet}/{TileMatrix}/{TileRow}/{TileCol}.jpg\""),
            std::string::npos)
      << xml;
  EXPECT_NE(xml.find("<ScaleDenominator>559082264.0287178</ScaleDenominator>"), std::string::npos);
  EXPECT_NE(xml.find("<TopLeftCorner>-180 90</TopLeftCorner>"), std::string::npos);
  // A document the schema refuses must fail (the check can fail).
  std::string broken = xml;
  broken.replace(broken.find("<ows:Identifier>eu &amp; co"), 15, "<ows:Identifer>");
  EXPECT_FALSE(test::validateWmtsCapabilities(broken).valid);

  for (const std::string_view code : {"MissingParameterValue",
                                      "InvalidParameterValue",
                                      "TileOutOfRange",
                                      "NoApplicableCode",
                                      "OperationNotSupported"}) {
    const std::string e =
        wmtsExceptionXml(OgcException{std::string(code), "TileRow", "bad <value> & http://x/y"});
    const auto v = test::validateWms(e, test::WmsDocument::OwsException110);
    EXPECT_TRUE(v.valid) << v.output << "\n" << e;
    EXPECT_NE(e.find("exceptionCode=\"" + std::string(code) + "\""), std::string::npos);
    EXPECT_EQ(e.find("http://x/y"), std::string::npos) << e; // redacted
  }
  EXPECT_EQ(wmtsExceptionXml(OgcException{"NoApplicableCode", "", "x"}).find("locator"),
            std::string::npos);
}
