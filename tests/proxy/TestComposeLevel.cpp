// The level a composed map is made from (issue 29): from the request's own pixel, along both axes
// in the request's CRS, the coarsest level whose texels are at most kMaxUpsampling (sqrt 2) times
// the pixel. On World Wind's imagery grid (36-degree level zero, 512-px tiles, 22 levels), which
// bench/fetch serves to CesiumJS's 256-px geographic tiles through `tellus serve`.

#include <tellus/proxy/Compose.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <random>

using namespace tellus;

namespace {

TileGrid worldWind() {
  return *TileGrid::create(GridSpec{Sector{}, 36.0, 512, 512, 22});
}

double texel(const TileGrid& g, std::int32_t level) {
  return g.deltaDeg(level) / 512.0;
}

/** The rule, checked from the outside: level `l` for a pixel of px x py degrees. */
void expectTheRule(const TileGrid& g, std::int32_t l, double px, double py, std::int32_t first) {
  const double bound = kMaxUpsampling * (1 + 1e-9);
  if (l < g.numLevels() - 1) {
    EXPECT_LE(texel(g, l), px * bound) << px;
    EXPECT_LE(texel(g, l), py * bound) << py;
  }
  if (l > first) { // the level above is too coarse along one axis at least
    EXPECT_TRUE(texel(g, l - 1) > px * bound || texel(g, l - 1) > py * bound) << px << " " << py;
  }
}

/** CesiumJS's geographic tile (x, y) at `level`: 2 x 1 tiles of 180 degrees at level 0. */
Sector cesiumTile(std::int32_t level, std::int64_t x, std::int64_t y) {
  const double size = 180.0 / std::ldexp(1.0, level);
  const auto fx = static_cast<double>(x), fy = static_cast<double>(y);
  return Sector{
      -180.0 + fx * size, 90.0 - (fy + 1) * size, -180.0 + (fx + 1) * size, 90.0 - fy * size};
}

} // namespace

// At the equator: CesiumJS's 256-px tiles of level n (pixels 10 * 2^-n times level zero's 0.07
// degree texels) are composed from level n - 3, whose texels are 0.8 of their pixels: never the
// level below (0.4 of a pixel, four times the texels), never two levels finer; a tile needs at
// most 2 x 2 tiles of 512 px. Maps of exactly a level's resolution take that level; up to sqrt 2
// finer still take it; past that the next.
TEST(ComposeLevel, AtTheEquatorTheNearerOfTheTwoLevels) {
  const auto g = worldWind();
  for (std::int32_t n = 4; n <= 23; ++n) {
    const Sector tile = cesiumTile(n, std::int64_t{1} << n, (std::int64_t{1} << n) / 2);
    const std::int32_t l = composeLevel(g, tile, 256, 256, 0);
    EXPECT_EQ(l, std::min(n - 3, 21)) << n;
    const double pixel = (tile.east - tile.west) / 256;
    expectTheRule(g, l, pixel, pixel, 0);
    const auto tiles = composeTiles(g, tile, 256, 256, l, 100);
    ASSERT_TRUE(tiles.has_value());
    EXPECT_LE(tiles->size(), 4u) << n;
  }
  EXPECT_EQ(composeLevel(g, Sector{0, 0, 36, 36}, 512, 512, 0), 0);
  EXPECT_EQ(composeLevel(g, Sector{0, 0, 36, 36}, 724, 724, 0), 0); // magnified 1.414 times
  EXPECT_EQ(composeLevel(g, Sector{0, 0, 36, 36}, 725, 725, 0), 1); // 1.416: level 1, 0.71
  EXPECT_EQ(composeLevel(g, Sector{0, 0, 18, 18}, 512, 512, 0), 1);
  EXPECT_EQ(composeLevel(g, Sector{0, 0, 18, 18}, 363, 363, 0), 1); // level 0 would be 1.41
  EXPECT_EQ(composeLevel(g, Sector{0, 0, 18, 18}, 362, 362, 0), 0); // 1.414: level 0
  // The finer axis decides.
  EXPECT_EQ(composeLevel(g, Sector{0, 0, 36, 36}, 64, 2048, 0), 2);
}

// At 80 degrees in Web Mercator: a pixel spans cos(80) = 0.17 times as many degrees of latitude as
// of longitude, so the latitude axis decides, row by row (the map's bands): each row at the
// coarsest level within sqrt 2 of its extent in latitude, about 2.5 levels finer than the
// longitude alone would ask for.
TEST(ComposeLevel, At80DegreesInMercatorTheLatitudeAxisDecides) {
  const auto g = worldWind();
  // A GoogleMapsCompatible tile of zoom 10 around 80 N (256 px, 39 km).
  const double size = 2 * mercator::kMaxY / 1024.0;
  const double y0 = std::floor(mercator::yOfLatitude(80.0) / size) * size;
  const MapBox box = mercatorBox(Sector{0.0, y0, size, y0 + size});
  const double pixelX = (box.east - box.west) / 256;
  const auto bands = composeBands(g, box, 256, 256, 0);
  ASSERT_FALSE(bands.empty());
  for (const ComposeBand& b : bands) {
    for (std::int32_t j = b.box.rowBegin; j < b.box.rowEnd; ++j) {
      const double pixelY = box.rowEdgeLatitude(j, 256) - box.rowEdgeLatitude(j + 1, 256);
      expectTheRule(g, b.level, pixelX, pixelY, 0);
    }
  }
  const std::int32_t byLongitude = composeLevel(g, Sector{0, 0, box.east, box.east}, 256, 256, 0);
  EXPECT_GE(composeLevel(g, box, 256, 256, 0), byLongitude + 2);
  EXPECT_LE(composeLevel(g, box, 256, 256, 0), byLongitude + 3);
}

// Across the antimeridian the level is the pixel's, as anywhere else (the columns wrap; the box's
// east may pass 180), and the tiles are those either side of it.
TEST(ComposeLevel, AcrossTheAntimeridianAsAnywhere) {
  const auto g = worldWind();
  const MapBox across = Sector{174.375, -5.625, 185.625, 5.625};
  const MapBox inside = Sector{4.375, -5.625, 15.625, 5.625};
  EXPECT_EQ(composeLevel(g, across, 256, 256, 0), composeLevel(g, inside, 256, 256, 0));
  const std::int32_t l = composeLevel(g, across, 256, 256, 0);
  EXPECT_EQ(l, 1); // 0.044 degree pixels: level 1's 0.035 (level 0's 0.070 is 1.6 times)
  const auto tiles = composeTiles(g, across, 256, 256, l, 100);
  ASSERT_TRUE(tiles.has_value());
  bool east = false, west = false;
  for (const ComposeTile& t : *tiles) {
    east = east || t.key.col == g.colCount(l) - 1;
    west = west || t.key.col == 0;
  }
  EXPECT_TRUE(east && west);
}

// Deep: the rule holds down to the deepest level, and a map finer than it takes the deepest.
// Coarse: a map coarser than level zero takes level zero (or the first level it is given).
TEST(ComposeLevel, DeepestAndCoarsestLevels) {
  const auto g = worldWind();
  EXPECT_EQ(composeLevel(g, Sector{0, 0, 1e-5, 1e-5}, 256, 256, 0), 21); // 3.9e-8 deg pixels
  EXPECT_EQ(composeLevel(g, Sector{0, 0, 1e-6, 1e-6}, 256, 256, 0), 21); // finer than level 21
  EXPECT_EQ(composeLevel(g, Sector{0, 0, 2e-5, 2e-5}, 256, 256, 0), 20);
  EXPECT_EQ(composeLevel(g, Sector{-180, -90, 180, 90}, 256, 128, 0), 0);
  EXPECT_EQ(composeLevel(g, cesiumTile(0, 0, 0), 256, 256, 0), 0);
  EXPECT_EQ(composeLevel(g, Sector{-180, -90, 180, 90}, 256, 128, 3), 3);
  EXPECT_EQ(composeLevel(g, Sector{0, 0, 1e-6, 1e-6}, 256, 256, 30), 21);
}

// Any pixel, any aspect: the rule from the outside, on 2,000 random maps.
TEST(ComposeLevel, TheRuleOnRandomMaps) {
  const auto g = worldWind();
  std::mt19937 rng(29);
  std::uniform_real_distribution<double> log2Size(-24.0, 8.0), aspect(-3.0, 3.0);
  std::uniform_int_distribution<std::int32_t> pixels(16, 2048), first(0, 3);
  for (int k = 0; k < 2000; ++k) {
    const double w = std::exp2(log2Size(rng));
    const double h = std::min(170.0, w * std::exp2(aspect(rng)));
    const std::int32_t width = pixels(rng), height = pixels(rng), f = first(rng);
    const std::int32_t l = composeLevel(g, Sector{0, -h / 2, w, h / 2}, width, height, f);
    expectTheRule(g, l, w / width, h / height, f);
  }
}
