// WMTS GoogleMapsCompatible GetTile: composed by the WMS GetMap composition in EPSG:3857 (issue
// 25's Web Mercator part). The set in the capabilities, its scales and ranges and TileOutOfRange
// are tested in TestWmts and TestWmtsIntegration.
#include "../support/WmsSchemas.hpp"
#include "../support/WmtsServer.hpp"

#include <tellus/proxy/Capabilities.hpp>
#include <tellus/proxy/Wmts.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

using namespace tellus;
using test::WmtsServer;

namespace {

std::string mercatorTile(int z, int row, int col) {
  return "/wmts?SERVICE=WMTS&REQUEST=GetTile&VERSION=1.0.0&LAYER=sat&STYLE=default"
         "&FORMAT=image/png&TILEMATRIXSET=GoogleMapsCompatible&TILEMATRIX=" +
         std::to_string(z) + "&TILEROW=" + std::to_string(row) + "&TILECOL=" + std::to_string(col);
}

} // namespace

TEST(WmtsMercator, GetTileIsTheWmsMapInEpsg3857) {
  test::FakeUpstream up(test::gradientTile);
  WmtsServer s(up.url("/wms"));
  const auto tile = s.get(mercatorTile(2, 1, 2));
  ASSERT_EQ(tile.status, 200) << tile.body;
  EXPECT_EQ(tile.header("content-type"), "image/png");
  const double h = kWebMercatorHalf;
  const auto wms = s.get("/wms?SERVICE=WMS&VERSION=1.3.0&REQUEST=GetMap&LAYERS=sat&STYLES="
                         "&CRS=EPSG:3857&BBOX=0,0," +
                         formatCoordinate(h / 2) + "," + formatCoordinate(h / 2) +
                         "&WIDTH=256&HEIGHT=256&FORMAT=image/png&TRANSPARENT=TRUE");
  ASSERT_EQ(wms.status, 200) << wms.body;
  EXPECT_EQ(test::pixels(tile), test::pixels(wms));
}

TEST(WmtsMercator, RowsFollowMercatorLatitudes) {
  // Each row of a Mercator tile is the lat/long map at that row's latitude: compare a few rows
  // with one-pixel-high CRS:84 maps whose pixel centres are the row's (bilinear sampling on both
  // sides: within 2 levels of each channel). One level, so that both sample the same tiles.
  test::FakeUpstream up(test::gradientTile);
  WmtsServer s(up.url("/wms"), 1);
  const auto tile = test::pixels(s.get(mercatorTile(2, 1, 2)));
  ASSERT_EQ(tile.size(), 256u * 256u * 4u);
  const double span = kWebMercatorHalf / 2; // tile z=2 row 1 col 2: x 0..span, y 0..span
  for (const int j : {0, 37, 128, 200, 255}) {
    const double y = span - (j + 0.5) * span / 256; // the row's centre
    const auto lat = [](double v) {
      return (2 * std::atan(std::exp(v / 6378137.0)) - std::numbers::pi / 2) * 180 /
             std::numbers::pi;
    };
    const auto strip =
        s.get("/wms?SERVICE=WMS&VERSION=1.3.0&REQUEST=GetMap&LAYERS=sat&STYLES="
              "&CRS=CRS:84&BBOX=0," +
              formatCoordinate(lat(y) - 0.1) + ",90," + formatCoordinate(lat(y) + 0.1) +
              "&WIDTH=256&HEIGHT=1&FORMAT=image/png&TRANSPARENT=TRUE");
    ASSERT_EQ(strip.status, 200) << strip.body;
    const auto* p = reinterpret_cast<const std::byte*>(strip.body.data());
    const auto row = decodeImagery({p, strip.body.size()}, "image/png", 256, 1);
    ASSERT_TRUE(row);
    for (int i = 0; i < 256; i += 17)
      for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(tile[static_cast<std::size_t>((j * 256 + i) * 4 + c)],
                    row->pixels[static_cast<std::size_t>(i * row->channels + c)],
                    2)
            << "row " << j << " column " << i;
  }
}

TEST(WmtsMercator, RestTilesAndTimeAreComposedToo) {
  test::FakeUpstream up(test::gradientTile);
  WmtsServer s(up.url("/wms"));
  const auto rest = s.get("/wmts/1.0.0/sat/default/GoogleMapsCompatible/2/1/2.png");
  ASSERT_EQ(rest.status, 200) << rest.body;
  EXPECT_EQ(rest.body, s.get(mercatorTile(2, 1, 2)).body);
  const auto first = s.get("/wmts/1.0.0/daily/default/2024-03-01/GoogleMapsCompatible/1/0/0.png");
  const auto second = s.get("/wmts/1.0.0/daily/default/2024-03-02/GoogleMapsCompatible/1/0/0.png");
  ASSERT_EQ(first.status, 200) << first.body;
  ASSERT_EQ(second.status, 200) << second.body;
  EXPECT_NE(first.body, second.body);
}
