#include "PlanetTestSupport.hpp"

#include <tellus/planet/Culling.hpp>
#include <tellus/planet/Lod.hpp>
#include <tellus/planet/Pick.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>

using namespace tellus;
using namespace tellus::planet;

TEST(Lod, LevelZeroDoesNotSplitFrom20000Km) {
  const Geodesy g;
  const TileGrid grid = test::globalGrid();
  const Camera cam(g, {0.0, 0.0, 2e7, 0.0, 0.0}, {1024, 768}, 45.0);
  const LodParams params{512, 512, 1.0};
  int visible = 0;
  double worst = 0.0;
  for (const Sector& s : test::levelZeroSectors(grid)) {
    const NodeGeometry node(g, s);
    if (!cullNode(cam, node, HorizonOccluder(g)).visible) continue;
    ++visible;
    const LodResult r = evaluateLod(cam, node, params);
    EXPECT_FALSE(r.split) << s.west << "," << s.south;
    EXPECT_FALSE(r.cornerBehindCamera);
    worst = std::max(worst, r.worstRatioSquared);
  }
  EXPECT_GE(visible, 8);
  // The globe is ~480 px across: a 36-degree tile at the nadir spans roughly 170-200 px.
  EXPECT_GT(worst, 0.09);
  EXPECT_LT(worst, 0.2);
  // With 128 px tiles the nadir tile must split.
  const NodeGeometry nadir(g, {0.0, 0.0, 36.0, 36.0});
  EXPECT_TRUE(evaluateLod(cam, nadir, {128, 128, 1.0}).split);
}

TEST(Lod, ThresholdIsTheKnob) {
  const Geodesy g;
  const Camera cam(g, {10.0, 10.0, 2e7, 0.0, 0.0}, {1024, 768}, 45.0);
  const NodeGeometry node(g, {0.0, 0.0, 36.0, 36.0});
  const double ratio = evaluateLod(cam, node, {512, 512, 1.0}).worstRatioSquared;
  ASSERT_GT(ratio, 0.0);
  const double edgeOverTile = std::sqrt(ratio); // the longest edge in tile sizes
  // The corner test alone (perspectiveAware off) splits exactly at the longest edge.
  EXPECT_TRUE(evaluateLod(cam, node, {512, 512, edgeOverTile * 0.99, false}).split);
  EXPECT_FALSE(evaluateLod(cam, node, {512, 512, edgeOverTile * 1.01, false}).split);
  // The local texels (the default): the camera is above this tile's interior, where a texel is
  // larger than the corners show, so it splits at a higher threshold, and exactly at its largest
  // sampled texel.
  const LodResult local = evaluateLod(cam, node, {512, 512, edgeOverTile * 1.01});
  EXPECT_TRUE(local.split);
  const double texel = std::sqrt(local.worstTexelRatioSquared) * edgeOverTile * 1.01; // pixels
  EXPECT_GT(texel, edgeOverTile * 1.01);
  EXPECT_TRUE(evaluateLod(cam, node, {512, 512, texel * 0.99}).split);
  EXPECT_FALSE(evaluateLod(cam, node, {512, 512, texel * 1.01}).split);
  // Doubling the threshold quarters the squared ratios.
  EXPECT_NEAR(evaluateLod(cam, node, {512, 512, 2.0}).worstRatioSquared, ratio / 4.0, 1e-12);
  EXPECT_NEAR(evaluateLod(cam, node, {512, 512, 2.0 * texel}).worstTexelRatioSquared, 0.25, 1e-9);
  // Invalid parameters split nothing.
  EXPECT_FALSE(evaluateLod(cam, node, {0, 512, 1.0}).split);
  EXPECT_FALSE(evaluateLod(cam, node, {512, 512, 0.0}).split);
  EXPECT_FALSE(evaluateLod(cam, node, {512, 512, std::nan("")}).split);
}

TEST(Lod, DeepZoomSplitsUntilTexelsMatchPixels) {
  const Geodesy g;
  const TileGrid grid = test::globalGrid();
  const Camera cam(g, {46.5, 8.0, 1000.0, 0.0, 0.0}, {1024, 768}, 45.0);
  const LodParams params{512, 512, 1.0};
  // From 1 km the view is ~830 m tall: at 512 px per tile, tiles of ~1.1 km (level ~13) suffice.
  int firstKept = -1;
  for (int level = 0; level <= 24; ++level) {
    const auto key = grid.keyAt(46.5, 8.0, level);
    ASSERT_TRUE(key.has_value());
    const LodResult r = evaluateLod(cam, NodeGeometry(g, grid.sectorOf(*key)), params);
    if (!r.split) {
      firstKept = level;
      break;
    }
  }
  EXPECT_GE(firstKept, 11);
  EXPECT_LE(firstKept, 14);
}

TEST(Lod, CornersBehindTheCameraSplit) {
  const Geodesy g;
  const TileGrid grid = test::globalGrid();
  // Standing on the ground looking at the horizon: the tile underfoot straddles the camera.
  const Camera cam(g, {46.5, 8.0, 1.0, 0.0, 90.0}, {1024, 768});
  const auto key = grid.keyAt(46.5, 8.0, 12);
  ASSERT_TRUE(key.has_value());
  const LodResult r = evaluateLod(cam, NodeGeometry(g, grid.sectorOf(*key)), {512, 512, 1.0});
  EXPECT_TRUE(r.cornerBehindCamera);
  EXPECT_TRUE(r.split);
}

TEST(LodExtremes, PoleTopDownHasThreeCornersAndNoNaN) {
  const Geodesy g;
  const TileGrid grid = test::globalGrid();
  const Camera cam(g, {90.0, 0.0, 2e7, 0.0, 0.0}, {1024, 768}, 45.0);
  int polar = 0;
  for (const Sector& s : test::levelZeroSectors(grid)) {
    const NodeGeometry node(g, s);
    if (!cullNode(cam, node, HorizonOccluder(g)).visible) continue;
    const LodResult r = evaluateLod(cam, node, {512, 512, 1.0});
    EXPECT_TRUE(std::isfinite(r.worstRatioSquared));
    EXPECT_FALSE(r.split);
    if (node.touchesNorthPole()) {
      ++polar;
      EXPECT_EQ(node.distinctCornerCount(), 3);
    }
  }
  EXPECT_EQ(polar, 10);
}

TEST(LodExtremes, AntimeridianIsSymmetric) {
  const Geodesy g;
  for (const double camLon : {180.0, -180.0}) {
    const Camera cam(g, {0.0, camLon, 1e6, 0.0, 0.0}, {1024, 1024}, 45.0);
    // Mirror images across the antimeridian.
    const NodeGeometry west(g, {179.0, 0.0, 180.0, 1.0});
    const NodeGeometry east(g, {-180.0, 0.0, -179.0, 1.0});
    const LodResult a = evaluateLod(cam, west, {256, 256, 1.0});
    const LodResult b = evaluateLod(cam, east, {256, 256, 1.0});
    EXPECT_GT(a.worstRatioSquared, 0.0);
    EXPECT_NEAR(a.worstRatioSquared, b.worstRatioSquared, 1e-9 * a.worstRatioSquared);
    EXPECT_EQ(a.split, b.split);
    EXPECT_TRUE(cullNode(cam, west, HorizonOccluder(g)).visible);
    EXPECT_TRUE(cullNode(cam, east, HorizonOccluder(g)).visible);
  }
}

TEST(LodExtremes, OutputsFiniteOverACameraSweep) {
  const Geodesy g;
  const TileGrid grid = test::globalGrid();
  const HorizonOccluder occ(g);
  int evaluated = 0;
  for (const double lat : {-90.0, -45.0, -0.0, 0.0, 89.99999, 90.0})
    for (const double lon : {-180.0, -0.0, 0.0, 180.0})
      for (const double alt : {-500.0, 0.0, 1.0, 10.0, 1e5, 1e9})
        for (const double tilt : {0.0, 90.0}) {
          const Camera cam(g, {lat, lon, alt, 45.0, tilt}, {640, 480});
          std::vector<Sector> sectors = test::levelZeroSectors(grid);
          for (const int level : {10, 24})
            for (const Sector& s : test::sectorsAround(grid, lat, lon, level))
              sectors.push_back(s);
          for (const Sector& s : sectors) {
            const NodeGeometry node(g, s);
            ASSERT_TRUE(test::finite(node.bounds().centre));
            ASSERT_TRUE(std::isfinite(node.bounds().radius));
            ASSERT_TRUE(std::isfinite(node.normalConeHalfAngleRad()));
            const LodResult r = evaluateLod(cam, node, {512, 512, 1.0});
            ASSERT_TRUE(std::isfinite(r.worstRatioSquared));
            ASSERT_GE(r.worstRatioSquared, 0.0);
            (void)cullNode(cam, node, occ);
            ++evaluated;
          }
        }
  EXPECT_GT(evaluated, 10000);
}

namespace {

/** The largest texel side (east-west or north-south, pixels) of a node's on-screen points, by
 * brute force over a 96 x 96 grid of its points (one texel's finite step projected). */
double largestVisibleTexel(const Camera& cam, const Geodesy& g, const Sector& s) {
  const double a = g.equatorialRadius(), b = g.polarRadius();
  const double dLon = (s.east - s.west) / 512.0, dLat = (s.north - s.south) / 512.0;
  const double w = cam.viewport().width, h = cam.viewport().height;
  auto px = [&](double lat, double lon, glm::dvec2& out) {
    const glm::dvec4 c = cam.toClip(surfaceFrame(a, b, lat, lon).position);
    if (!(c.w >= cam.nearM())) return false;
    out = {c.x / c.w * 0.5 * w, c.y / c.w * 0.5 * h};
    return std::abs(c.x) <= c.w && std::abs(c.y) <= c.w;
  };
  double worst = 0.0;
  constexpr int n = 96;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) {
      const double lat = s.south + (s.north - s.south) * i / n;
      const double lon = s.west + (s.east - s.west) * j / n;
      glm::dvec2 p{0.0}, e{0.0}, q{0.0};
      if (!px(lat, lon, p)) continue;
      px(lat, lon + (j < n ? dLon : -dLon), e); // sets e wherever it is in front of the camera
      px(lat + (i < n ? dLat : -dLat), lon, q);
      worst = std::max({worst, glm::length(e - p), glm::length(q - p)});
    }
  return worst;
}

} // namespace

// Issue 29: a tilted view's nodes along the screen's border reach off screen, toward the camera
// and sideways, where perspective stretches texels most. Only their visible part counts now: a
// node splits when its largest visible texel exceeds the threshold, and not otherwise.
TEST(Lod, OnlyTheVisiblePartCounts) {
  const Geodesy g;
  const TileGrid grid = test::globalGrid();
  const Camera cam(g, {46.5, 9.0, 5000.0, 0.0, 70.0}, {1280, 720}, 35.98);
  const double t = 2.0;
  int decided = 0, coarser = 0;
  // Ground points along the bottom, the sides and the centre of the screen.
  for (const auto& [x, y] : std::array<std::array<double, 2>, 6>{
           {{0.5, 0.99}, {0.02, 0.98}, {0.98, 0.9}, {0.02, 0.5}, {0.5, 0.5}, {0.7, 0.3}}}) {
    const auto hit = pickGlobe(cam, g, (x - 0.5) * 1280.0, (0.5 - y) * 720.0);
    ASSERT_TRUE(hit.has_value());
    const double lat = hit->latDeg, lon = hit->lonDeg;
    for (int level = 4; level <= 14; ++level) {
      const auto key = grid.keyAt(lat, lon, level);
      ASSERT_TRUE(key.has_value());
      const Sector s = grid.sectorOf(*key);
      const double visible = largestVisibleTexel(cam, g, s);
      const NodeGeometry node(g, s);
      const bool split = evaluateLod(cam, node, {512, 512, t}).split;
      LodParams whole{512, 512, t};
      whole.onScreenOnly = false;
      const bool splitWhole = evaluateLod(cam, node, whole).split;
      // The sampled extremes may miss the brute force's by a few per cent (curvature).
      if (visible > 1.03 * t) {
        EXPECT_TRUE(split) << level << " " << x << "," << y << " " << visible;
        ++decided;
      } else if (visible < 0.97 * t) {
        EXPECT_FALSE(split) << level << " " << x << "," << y << " " << visible;
        ++decided;
        if (splitWhole) ++coarser;
      }
      EXPECT_TRUE(splitWhole || !split); // never finer than the whole-node test
    }
  }
  EXPECT_GE(decided, 50);
  EXPECT_GE(coarser, 3); // nodes the whole-node test split for off-screen texels
}
