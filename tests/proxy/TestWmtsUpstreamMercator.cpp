// A Web Mercator (EPSG:3857) WMTS set mapped onto the World Wind grid (WmtsMercator.hpp): how it
// is recognised (CRS and matrix geometry, never the name), which zoom and which tiles a grid tile
// needs at the equator, 60 N, 80 N, the pole and the antimeridian (checked against the Mercator
// formulas written here in their forward form, y = R ln tan(pi/4 + phi/2)), and what a grid tile
// costs in upstream tiles at several latitudes.

#include "../../proxy/src/upstream/WmtsMercator.hpp"

#include <tellus/proxy/WmtsUpstream.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <sstream>

using namespace tellus;

namespace {

std::string mercatorDocument() {
  std::ifstream in(std::string(TELLUS_TEST_SOURCE_DIR) + "/data/wmts/webmercator-minimal.xml",
                   std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

const WmtsCapabilities& caps() {
  static const WmtsCapabilities c = [] {
    auto parsed = parseWmtsCapabilities(mercatorDocument());
    EXPECT_TRUE(parsed) << (parsed ? "" : parsed.error());
    return parsed ? *parsed : WmtsCapabilities{};
  }();
  return c;
}

GridSpec wwGrid(std::int32_t levels) {
  return GridSpec{Sector{}, 36.0, 512, 512, levels};
}

WmtsChoice choice(const std::string& set) {
  WmtsChoice c;
  c.layer = "Latitude_Bands";
  c.format = "image/png";
  c.tileMatrixSet = set;
  return c;
}

constexpr double kR = 6378137.0;
constexpr double kHalf = std::numbers::pi * kR;

/** The sector of World Wind tile (level, row, col) of a 36-degree grid. */
Sector sectorOf(int level, int row, int col) {
  const double span = 36.0 / (1 << level);
  return Sector{
      -180.0 + col * span, -90.0 + row * span, -180.0 + (col + 1) * span, -90.0 + (row + 1) * span};
}

struct Range {
  std::int64_t r0, r1, c0, c1;
  friend bool operator==(const Range&, const Range&) = default;
};

/** The rows and columns of the source tiles one grid tile needs, as wmtsSourceTiles says. */
Range rangeOf(const WmtsTiles& t, int level, int row, int col) {
  const auto tiles =
      wmtsSourceTiles(t, TileKey{level, row, col}, sectorOf(level, row, col), 512, 512, "");
  Range r{INT64_MAX, INT64_MIN, INT64_MAX, INT64_MIN};
  for (const auto& s : tiles) {
    r.r0 = std::min(r.r0, s.row);
    r.r1 = std::max(r.r1, s.row);
    r.c0 = std::min(r.c0, s.col);
    r.c1 = std::max(r.c1, s.col);
  }
  // Every tile of the rectangle, once.
  EXPECT_EQ(tiles.size(), static_cast<std::size_t>((r.r1 - r.r0 + 1) * (r.c1 - r.c0 + 1)));
  return r;
}

/** The same from the forward formulas: the tiles under the bilinear footprints of the first and
 * last pixel centres (inside the Mercator square) of the 512 x 512 grid tile, at zoom z. */
Range expectedRange(int level, int row, int col, int z) {
  const Sector s = sectorOf(level, row, col);
  const double px = (s.east - s.west) / 512.0;
  const double p = 2.0 * kHalf / (256.0 * std::ldexp(1.0, z)); // metres per source pixel
  const double maxLat =
      2.0 * std::atan(std::exp(std::numbers::pi)) * 180.0 / std::numbers::pi - 90.0;
  const auto y = [](double lat) {
    return kR * std::log(std::tan(std::numbers::pi / 4.0 + lat * std::numbers::pi / 360.0));
  };
  const auto x = [](double lon) { return lon * std::numbers::pi / 180.0 * kR; };
  double top = s.north - 0.5 * px, bottom = s.south + 0.5 * px;
  while (top > maxLat)
    top -= px;
  const double u0 = std::floor((x(s.west + 0.5 * px) + kHalf) / p - 0.5);
  const double u1 = std::ceil((x(s.east - 0.5 * px) + kHalf) / p - 0.5);
  const double v0 = std::floor((kHalf - y(top)) / p - 0.5);
  const double v1 = std::ceil((kHalf - y(bottom)) / p - 0.5);
  const double last = 256.0 * std::ldexp(1.0, z) - 1.0;
  const auto tile = [&](double v) {
    return static_cast<std::int64_t>(std::clamp(v, 0.0, last) / 256.0);
  };
  return Range{tile(v0), tile(v1), tile(u0), tile(u1)};
}

} // namespace

TEST(WmtsMercatorMapping, RecognisedByCrsAndGeometryNotByName) {
  // The GoogleMapsCompatible set, and the same matrices named "Renamed" in EPSG:900913.
  for (const char* set : {"GoogleMapsCompatible_Level7", "Renamed"}) {
    auto t = bindWmtsLayer(caps(), choice(set), wwGrid(3));
    ASSERT_TRUE(t) << set << ": " << t.error();
    EXPECT_TRUE(t->mercator) << set;
    ASSERT_EQ(t->levels.size(), 3u);
    for (const auto& lv : t->levels)
      EXPECT_GE(lv.composeFrom, 0) << set << ": every level of a Mercator set is composed";
  }
  // Web Mercator's numbers in another projected CRS: refused.
  auto utm = bindWmtsLayer(caps(), choice("NotMercator"), wwGrid(1));
  ASSERT_FALSE(utm);
  EXPECT_NE(utm.error().find("only Web Mercator"), std::string::npos) << utm.error();
  // EPSG:3857 with a corner that is not the square's: refused, naming the matrix and the corner.
  auto bad = bindWmtsLayer(caps(), choice("BadCorner"), wwGrid(1));
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().find("matrix '0' has its top-left corner at"), std::string::npos)
      << bad.error();
  EXPECT_NE(bad.error().find("10018754"), std::string::npos) << bad.error();
  // Finer than the set's finest zoom (7): level 3 would need zoom 8.
  auto deep = bindWmtsLayer(caps(), choice("GoogleMapsCompatible_Level7"), wwGrid(4));
  ASSERT_FALSE(deep);
  EXPECT_NE(deep.error().find("set grid.levels to at most 3"), std::string::npos) << deep.error();
}

TEST(WmtsMercatorMapping, CrsSpellingsOfWebMercator) {
  for (const char* crs : {"urn:ogc:def:crs:EPSG::3857",
                          "urn:ogc:def:crs:EPSG:6.18.3:3857",
                          "EPSG:3857",
                          "epsg:900913",
                          "EPSG:3785",
                          "ESRI:102100",
                          "EPSG:102113",
                          "OSGEO:41001",
                          "http://www.opengis.net/def/crs/EPSG/0/3857"})
    EXPECT_TRUE(wmtsmercator::isMercatorCrs(crs)) << crs;
  for (const char* crs : {"urn:ogc:def:crs:EPSG::4326",
                          "urn:ogc:def:crs:OGC:1.3:CRS84",
                          "EPSG:32633",
                          "3857",
                          "EPSG:38570",
                          "GoogleMapsCompatible",
                          ""})
    EXPECT_FALSE(wmtsmercator::isMercatorCrs(crs)) << crs;
}

TEST(WmtsMercatorMapping, ZoomIsTheCoarsestWhosePixelIsAsFineAtEveryLatitude) {
  auto t = bindWmtsLayer(caps(), choice("GoogleMapsCompatible_Level7"), wwGrid(3));
  ASSERT_TRUE(t) << t.error();
  // Level L's pixel is 36 / 2^L / 512 degrees; zoom z's spans 360 / (256 2^z) degrees of longitude
  // (and cos(lat) times that of latitude: finer): z = L + 5 is the coarsest at most as large.
  for (int level = 0; level < 3; ++level) {
    const double pixel = 36.0 / std::ldexp(1.0, level) / 512.0;
    const int z = level + 5;
    EXPECT_LE(360.0 / (256.0 * std::ldexp(1.0, z)), pixel);
    EXPECT_GT(360.0 / (256.0 * std::ldexp(1.0, z - 1)), pixel);
    EXPECT_EQ(t->levels[static_cast<std::size_t>(level)].matrix, std::to_string(z));
  }
}

TEST(WmtsMercatorMapping, CoveringTilesAtTheEquatorSixtyEightyNorthThePoleAndTheAntimeridian) {
  auto t = bindWmtsLayer(caps(), choice("GoogleMapsCompatible_Level7"), wwGrid(3));
  ASSERT_TRUE(t) << t.error();
  // Level 2: 9-degree tiles from zoom 7 (128 x 128 tiles of 2.8125 degrees of longitude).
  struct Case {
    const char* where;
    int row, col;
    Range tiles;
  };
  const Case cases[] = {
      {"0-9 N, 0-9 E", 10, 20, {60, 63, 64, 67}},
      {"54-63 N (60 N)", 16, 20, {34, 41, 64, 67}},
      {"72-81 N (80 N)", 18, 20, {12, 26, 64, 67}},
      {"81-90 N (up to 85.0511 N, then nothing)", 19, 20, {0, 12, 64, 67}},
      {"0-9 N, 171-180 E (the antimeridian: no column past 127)", 10, 39, {60, 63, 124, 127}},
      {"81-90 N, 180-171 W", 19, 0, {0, 12, 0, 3}},
  };
  for (const Case& c : cases) {
    EXPECT_EQ(rangeOf(*t, 2, c.row, c.col), c.tiles) << c.where;
    EXPECT_EQ(expectedRange(2, c.row, c.col, 7), c.tiles) << c.where << " (the forward formulas)";
  }
  // The URLs name the zoom's matrix, WMTS rows from the top.
  const auto tiles = wmtsSourceTiles(*t, TileKey{2, 10, 39}, sectorOf(2, 10, 39), 512, 512, "");
  ASSERT_FALSE(tiles.empty());
  EXPECT_EQ(tiles.front().url,
            "https://wmts.example/merc/Latitude_Bands/default/2014-02-07/"
            "GoogleMapsCompatible_Level7/7/60/124.png");
  // South of -85.0511 as north of it: a level-2 tile wholly beyond the square needs nothing.
  auto deep = bindWmtsLayer(caps(), choice("GoogleMapsCompatible_Level7"), wwGrid(3));
  ASSERT_TRUE(deep);
  // (Level 2 tile row 0 spans 90-81 S: it needs the bottom rows only.)
  EXPECT_EQ(rangeOf(*deep, 2, 0, 20), (Range{115, 127, 64, 67}));
}

TEST(WmtsMercatorMapping, TilesFetchedPerGridTileGrowTowardThePoles) {
  // What docs/CONFIG.md quotes: 512 px grid tiles of a 36-degree grid from 256 px
  // GoogleMapsCompatible tiles, at level 2 (9-degree tiles, zoom 7), by latitude.
  auto t = bindWmtsLayer(caps(), choice("GoogleMapsCompatible_Level7"), wwGrid(3));
  ASSERT_TRUE(t) << t.error();
  std::size_t previous = 0;
  for (int row = 10; row < 20; ++row) { // 0-9 N up to 81-90 N
    const auto n =
        wmtsSourceTiles(*t, TileKey{2, row, 20}, sectorOf(2, row, 20), 512, 512, "").size();
    std::printf("[ cost     ] %2d-%2d N: %zu upstream tiles\n", (row - 10) * 9, (row - 9) * 9, n);
    if (row < 19) {
      EXPECT_GE(n, previous) << "rows grow as 1 / cos(latitude)";
    }
    previous = n;
  }
  // At the equator 4 x 4; at 72-81 N 15 rows of 4.
  EXPECT_EQ(wmtsSourceTiles(*t, TileKey{2, 10, 20}, sectorOf(2, 10, 20), 512, 512, "").size(), 16u);
  EXPECT_EQ(wmtsSourceTiles(*t, TileKey{2, 18, 20}, sectorOf(2, 18, 20), 512, 512, "").size(), 60u);
}
