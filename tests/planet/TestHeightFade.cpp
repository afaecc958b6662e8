// Heights that arrive fade in (issue 23, "No popping"; HeightField::setFade): a tile inserted at
// time t blends over what the coarser levels give, continuously over the fade time, and stays a
// pure function of the tiles held and the time (neighbours agree); without a fade nothing changes.
#include <tellus/planet/Terrain.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace tellus::planet {
namespace {

TileGrid elevationGrid() {
  GridSpec spec;
  spec.levelZeroDeltaDeg = 20.0;
  spec.tileWidth = spec.tileHeight = 8;
  spec.numLevels = 6;
  return *TileGrid::create(spec);
}

/** A tile of constant height. */
HeightTile flat(const TileKey& k, double metres) {
  const std::vector<double> raw(64, metres);
  return *heightTileFromSamples(k, 8, 8, raw, {});
}

const double kLat = 45.3, kLon = 7.7; // inside tile {0, 6, 9} and {1, 13, 18}

TEST(HeightFade, ATileBlendsOverTheCoarserLevelLinearlyInTime) {
  const TileGrid g = elevationGrid();
  HeightField f(g);
  f.setFade(0.5);
  f.setTime(1.0);
  ASSERT_TRUE(f.insert(flat({0, 6, 9}, 100.0)));
  f.setTime(2.0); // the coarse tile's fade is over
  EXPECT_DOUBLE_EQ(f.heightAt(kLat, kLon), 100.0);
  EXPECT_FALSE(f.fading());
  ASSERT_TRUE(f.insert(flat({1, 13, 18}, 300.0))); // arrives at 2.0
  EXPECT_TRUE(f.fading());
  EXPECT_DOUBLE_EQ(f.heightAt(kLat, kLon), 100.0); // not moved yet
  const Sector at{kLon - 0.01, kLat - 0.01, kLon + 0.01, kLat + 0.01};
  EXPECT_TRUE(f.fadingOver(at));
  double last = 100.0;
  for (int i = 1; i <= 5; ++i) {
    const std::uint64_t g0 = f.generation();
    f.setTime(2.0 + 0.1 * i);
    EXPECT_TRUE(f.changedSince(g0, at)) << i; // meshes over it rebuild every frame of the fade
    const double h = f.heightAt(kLat, kLon);
    EXPECT_NEAR(h, 100.0 + 200.0 * 0.2 * i, 1e-9) << i; // linear in time
    EXPECT_LE(h - last, 200.0 * 0.2 + 1e-9) << i;       // never more than a frame's share
    last = h;
  }
  EXPECT_DOUBLE_EQ(f.heightAt(kLat, kLon), 300.0);
  EXPECT_FALSE(f.fading()); // over at 2.5
  const std::uint64_t g1 = f.generation();
  f.setTime(3.0);
  EXPECT_EQ(f.generation(), g1); // nothing fading: no change
}

TEST(HeightFade, OffByDefaultAndAtFadeZero) {
  const TileGrid g = elevationGrid();
  HeightField f(g);
  f.setTime(1.0);
  ASSERT_TRUE(f.insert(flat({0, 6, 9}, 100.0)));
  ASSERT_TRUE(f.insert(flat({1, 13, 18}, 300.0)));
  EXPECT_FALSE(f.fading());
  EXPECT_DOUBLE_EQ(f.heightAt(kLat, kLon), 300.0);
  HeightField z(g);
  z.setFade(0.0);
  z.setTime(1.0);
  ASSERT_TRUE(z.insert(flat({1, 13, 18}, 300.0)));
  EXPECT_DOUBLE_EQ(z.heightAt(kLat, kLon), 300.0);
}

/** A tile over nothing fades in from 0 (the ellipsoid), and a time that does not advance (the same
 * frame, a redraw) moves nothing. */
TEST(HeightFade, FromTheEllipsoidWhereNothingIsHeldAndFrozenInOneFrame) {
  const TileGrid g = elevationGrid();
  HeightField f(g);
  f.setFade(1.0);
  f.setTime(10.0);
  ASSERT_TRUE(f.insert(flat({0, 6, 9}, 1000.0)));
  f.setTime(10.25);
  EXPECT_NEAR(f.heightAt(kLat, kLon), 250.0, 1e-9);
  const std::uint64_t g0 = f.generation();
  f.setTime(10.25);
  f.setTime(10.0); // back: ignored
  EXPECT_EQ(f.generation(), g0);
  EXPECT_NEAR(f.heightAt(kLat, kLon), 250.0, 1e-9);
}

/** While a tile fades, the range over a sector it covers still holds the coarser level's heights
 * (the blend lies between them), so culling never drops what the blend shows. */
TEST(HeightFade, RangeOverKeepsTheCoarserLevelWhileFading) {
  const TileGrid g = elevationGrid();
  HeightField f(g);
  f.setFade(1.0);
  f.setTime(0.0);
  ASSERT_TRUE(f.insert(flat({0, 6, 9}, -200.0)));
  f.setTime(5.0);
  ASSERT_TRUE(f.insert(flat({1, 13, 18}, 300.0)));
  const Sector inside{7.6, 45.1, 7.8, 45.5};
  auto [lo, hi] = f.rangeOver(inside);
  EXPECT_LE(lo, -200.0);
  EXPECT_GE(hi, 300.0);
  f.setTime(7.0); // faded in: the fine level alone
  std::tie(lo, hi) = f.rangeOver(inside);
  EXPECT_EQ(lo, 300.0);
  EXPECT_EQ(hi, 300.0);
}

/** Extremes: a fading tile at the pole and on the antimeridian blends the same at -180 and 180
 * and at every longitude of the pole. */
TEST(HeightFadeExtremes, PoleAndAntimeridian) {
  const TileGrid g = elevationGrid();
  HeightField f(g);
  f.setFade(1.0);
  f.setTime(0.0);
  const std::int64_t rows = g.rowCount(1), cols = g.colCount(1);
  // The antimeridian's two sides and the tile at longitude 0, where a pole's point is read.
  for (const std::int64_t c : {std::int64_t{0}, cols / 4, cols / 2 - 1})
    ASSERT_TRUE(f.insert(flat({0, rows / 2 - 1, c}, 50.0)));
  f.setTime(2.0);
  for (const std::int64_t c : {std::int64_t{0}, cols / 2, cols - 1})
    ASSERT_TRUE(f.insert(flat({1, rows - 1, c}, 150.0)));
  f.setTime(2.5);
  EXPECT_NEAR(f.heightAt(90.0, 0.0), 100.0, 1e-9);
  EXPECT_EQ(f.heightAt(90.0, 0.0), f.heightAt(90.0, 123.0));
  EXPECT_EQ(f.heightAt(89.0, -180.0), f.heightAt(89.0, 180.0));
  EXPECT_NEAR(f.heightAt(89.0, 180.0), 100.0, 1e-9);
}

} // namespace
} // namespace tellus::planet
