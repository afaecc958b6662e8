// WMTS through tellus serve's pieces on a loopback port (as TestProxyIntegration wires them):
// capabilities valid against the schema, custom-set tiles byte for byte what /wwtile sends,
// WorldCRS84Quad tiles the pixels of a WMS GetMap of the same box and kept in a dataset of their
// own, OWS exceptions with WMTS's statuses, the Time dimension.
#include "../support/WmsSchemas.hpp"
#include "../support/WmtsServer.hpp"

#include <gtest/gtest.h>

using namespace tellus;
using test::WmtsServer;

TEST(WmtsIntegration, CapabilitiesAreValidAndListEverySet) {
  test::FakeUpstream up(test::gradientTile);
  WmtsServer s(up.url("/wms"));
  const auto kvp = s.get("/wmts?SERVICE=WMTS&REQUEST=GetCapabilities");
  ASSERT_EQ(kvp.status, 200) << kvp.body;
  EXPECT_EQ(kvp.header("content-type"), "application/xml");
  const auto v = test::validateWmtsCapabilities(kvp.body);
  EXPECT_TRUE(v.valid) << v.output << "\n" << kvp.body;
  for (const std::string_view want : {"<ows:Identifier>WorldWind_sat</ows:Identifier>",
                                      "<ows:Identifier>WorldCRS84Quad</ows:Identifier>",
                                      "<ows:Identifier>GoogleMapsCompatible</ows:Identifier>",
                                      "<Default>2024-03-02</Default>",
                                      "/wmts/1.0.0/daily/{Style}/{Time}/{TileMatrixSet}"})
    EXPECT_NE(kvp.body.find(want), std::string::npos) << want;
  const auto rest = s.get("/wmts/1.0.0/WMTSCapabilities.xml");
  EXPECT_EQ(rest.status, 200);
  EXPECT_EQ(rest.body, kvp.body);
  EXPECT_EQ(up.requests(), 0u);
}

TEST(WmtsIntegration, CustomSetTilesAreTheWorldWindTilesByteForByte) {
  test::FakeUpstream up(test::gradientTile);
  WmtsServer s(up.url("/wms"));
  // World Wind level 1, row 7 (from the south), column 3 is WMTS row 10 - 1 - 7 = 2.
  const auto ww = s.get("/wwtile?T=sat&L=1&X=3&Y=7");
  ASSERT_EQ(ww.status, 200) << ww.body;
  const auto kvp = s.get(
      "/wmts?SERVICE=WMTS&REQUEST=GetTile&VERSION=1.0.0&LAYER=sat&STYLE=default&FORMAT=image/png"
      "&TILEMATRIXSET=WorldWind_sat&TILEMATRIX=1&TILEROW=2&TILECOL=3");
  ASSERT_EQ(kvp.status, 200) << kvp.body;
  EXPECT_EQ(kvp.body, ww.body);
  EXPECT_EQ(kvp.header("etag"), ww.header("etag"));
  EXPECT_EQ(kvp.header("x-cache"), "HIT");
  const auto rest = s.get("/wmts/1.0.0/sat/default/WorldWind_sat/1/2/3.png");
  ASSERT_EQ(rest.status, 200) << rest.body;
  EXPECT_EQ(rest.body, ww.body);
  EXPECT_EQ(up.requests(), 1u);
  // Another row is another tile.
  EXPECT_NE(s.get("/wmts/1.0.0/sat/default/WorldWind_sat/1/3/3.png").body, ww.body);
}

TEST(WmtsIntegration, WorldCrs84QuadIsTheWmsMapOfTheBoxAndIsKept) {
  test::FakeUpstream up(test::gradientTile);
  WmtsServer s(up.url("/wms"));
  // WorldCRS84Quad level 2: 45-degree tiles; row 1, column 5 is 45..90 E, 0..45 N: its edges are
  // not World Wind's (36 degrees), so it is composed from several source tiles.
  const auto quad = s.get("/wmts/1.0.0/sat/default/WorldCRS84Quad/2/1/5.png");
  ASSERT_EQ(quad.status, 200) << quad.body;
  EXPECT_EQ(quad.header("content-type"), "image/png");
  const auto wms = s.get("/wms?SERVICE=WMS&VERSION=1.3.0&REQUEST=GetMap&LAYERS=sat&STYLES="
                         "&CRS=CRS:84&BBOX=45,0,90,45&WIDTH=256&HEIGHT=256&FORMAT=image/png"
                         "&TRANSPARENT=TRUE");
  ASSERT_EQ(wms.status, 200) << wms.body;
  EXPECT_EQ(test::pixels(quad), test::pixels(wms));
  EXPECT_GT(up.requests(), 1u);
  // Kept as a tile of its own dataset (level 2, row 3 - 1 - 1 = 1 from the south, column 5).
  bool found = false;
  for (const auto& d : s.cache->datasets()) {
    if (d.spec.name != "sat.WorldCRS84Quad") continue;
    found = true;
    EXPECT_EQ(d.spec.grid.levelZeroDeltaDeg, 180.0);
    const auto hit = s.cache->peek(d.id, TileKey{2, 2, 5});
    ASSERT_TRUE(hit);
    EXPECT_EQ(hit->kind, CacheLookup::Kind::Hit);
  }
  EXPECT_TRUE(found);
  // The second request is that cached file: the same bytes and validator, nothing fetched.
  const std::size_t fetched = up.requests();
  const auto again = s.get("/wmts?SERVICE=WMTS&REQUEST=GetTile&VERSION=1.0.0&LAYER=sat&STYLE="
                           "&FORMAT=image/png&TILEMATRIXSET=WorldCRS84Quad&TILEMATRIX=2&TILEROW=1"
                           "&TILECOL=5");
  ASSERT_EQ(again.status, 200);
  EXPECT_EQ(again.body, quad.body);
  EXPECT_EQ(again.header("etag"), quad.header("etag"));
  EXPECT_EQ(again.header("x-cache"), "HIT");
  EXPECT_EQ(up.requests(), fetched);
  const auto notModified = test::httpGet("http://127.0.0.1:" + std::to_string(s.web->port()) +
                                             "/wmts/1.0.0/sat/default/WorldCRS84Quad/2/1/5.png",
                                         {{"If-None-Match", quad.header("etag")}});
  EXPECT_EQ(notModified.status, 304);
}

TEST(WmtsIntegration, ErrorsAreOwsExceptionReportsWithWmtsStatuses) {
  test::FakeUpstream up(test::gradientTile);
  WmtsServer s(up.url("/wms"));
  const std::string base = "/wmts?SERVICE=WMTS&REQUEST=GetTile&VERSION=1.0.0&STYLE=default";
  struct Case {
    std::string target;
    long status;
    std::string code, locator;
  };
  for (const Case& c : std::vector<Case>{
           {base + "&LAYER=sat&FORMAT=image/png&TILEMATRIXSET=WorldWind_sat&TILEMATRIX=1"
                   "&TILEROW=10&TILECOL=0",
            400,
            "TileOutOfRange",
            "TileRow"},
           {base + "&LAYER=sat&FORMAT=image/png&TILEMATRIXSET=WorldWind_sat&TILEMATRIX=1"
                   "&TILEROW=0&TILECOL=20",
            400,
            "TileOutOfRange",
            "TileCol"},
           {base + "&LAYER=sat&FORMAT=image/png&TILEMATRIXSET=WorldWind_sat&TILEMATRIX=9"
                   "&TILEROW=0&TILECOL=0",
            400,
            "InvalidParameterValue",
            "TileMatrix"},
           {base + "&LAYER=nope&FORMAT=image/png&TILEMATRIXSET=WorldWind_sat&TILEMATRIX=0"
                   "&TILEROW=0&TILECOL=0",
            400,
            "InvalidParameterValue",
            "Layer"},
           {base + "&LAYER=sat&FORMAT=image/jpeg&TILEMATRIXSET=WorldWind_sat&TILEMATRIX=0"
                   "&TILEROW=0&TILECOL=0",
            400,
            "InvalidParameterValue",
            "Format"},
           {base + "&LAYER=sat&FORMAT=image/png&TILEMATRIXSET=WorldWind_daily&TILEMATRIX=0"
                   "&TILEROW=0&TILECOL=0",
            400,
            "InvalidParameterValue",
            "TileMatrixSet"},
           {base + "&LAYER=sat&FORMAT=image/png&TILEMATRIXSET=WorldWind_sat&TILEMATRIX=0",
            400,
            "MissingParameterValue",
            "TILEROW"},
           {base + "&LAYER=daily&FORMAT=image/png&TILEMATRIXSET=WorldWind_daily&TILEMATRIX=0"
                   "&TILEROW=0&TILECOL=0&TIME=2024-03-05",
            400,
            "InvalidParameterValue",
            "Time"},
           {base + "&LAYER=sat&FORMAT=image/png&TILEMATRIXSET=GoogleMapsCompatible&TILEMATRIX=1"
                   "&TILEROW=2&TILECOL=0",
            400,
            "TileOutOfRange",
            "TileRow"},
           {"/wmts?SERVICE=WMTS&REQUEST=GetFeatureInfo", 501, "OperationNotSupported", "REQUEST"},
       }) {
    const auto r = s.get(c.target);
    EXPECT_EQ(r.status, c.status) << c.target << "\n" << r.body;
    EXPECT_NE(r.body.find("exceptionCode=\"" + c.code + "\""), std::string::npos) << r.body;
    EXPECT_NE(r.body.find("locator=\"" + c.locator + "\""), std::string::npos) << r.body;
    const auto v = test::validateWms(r.body, test::WmsDocument::OwsException110);
    EXPECT_TRUE(v.valid) << v.output << "\n" << r.body;
  }
  EXPECT_EQ(s.get("/wmts/1.0.0/sat/default/WorldWind_sat/1/2").status, 404);
  EXPECT_EQ(up.requests(), 0u); // nothing refused reached the upstream
}

TEST(WmtsIntegration, TimeIsADimensionInKvpAndInThePath) {
  test::FakeUpstream up(test::gradientTile);
  WmtsServer s(up.url("/wms"));
  const auto second = s.get("/wmts/1.0.0/daily/default/2024-03-02/WorldWind_daily/0/0/0.png");
  ASSERT_EQ(second.status, 200) << second.body;
  const auto first = s.get("/wmts/1.0.0/daily/default/2024-03-01/WorldWind_daily/0/0/0.png");
  ASSERT_EQ(first.status, 200) << first.body;
  EXPECT_NE(first.body, second.body); // another time, another upstream request
  const auto kvpDefault =
      s.get("/wmts?SERVICE=WMTS&REQUEST=GetTile&VERSION=1.0.0&LAYER=daily&STYLE=default"
            "&FORMAT=image/png&TILEMATRIXSET=WorldWind_daily&TILEMATRIX=0&TILEROW=0&TILECOL=0");
  ASSERT_EQ(kvpDefault.status, 200);
  EXPECT_EQ(kvpDefault.body, second.body); // no TIME: the default
  // A path without the time segment is the default time too.
  EXPECT_EQ(s.get("/wmts/1.0.0/daily/default/WorldWind_daily/0/0/0.png").body, second.body);
  EXPECT_NE(up.received().back().target.find("TIME="), std::string::npos);
}
