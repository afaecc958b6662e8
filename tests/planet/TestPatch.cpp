#include "PlanetTestSupport.hpp"

#include <tellus/planet/Patch.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <stdexcept>

using namespace tellus;
using namespace tellus::planet;
using tellus::planet::test::finite;
using tellus::planet::test::vec;

TEST(Patch, CornersCentreAndNormals) {
  const Geodesy g;
  const Sector s{0.0, 0.0, 36.0, 36.0};
  const NodeGeometry node(g, s);
  EXPECT_EQ(node.corners()[SW], vec(g.toEcef(0, 0, 0)));
  EXPECT_EQ(node.corners()[SE], vec(g.toEcef(0, 36, 0)));
  EXPECT_EQ(node.corners()[NE], vec(g.toEcef(36, 36, 0)));
  EXPECT_EQ(node.corners()[NW], vec(g.toEcef(36, 0, 0)));
  EXPECT_EQ(node.centre(), vec(g.toEcef(18, 18, 0)));
  EXPECT_EQ(node.cornerNormals()[NE], vec(g.surfaceNormal(36, 36)));
  EXPECT_EQ(node.distinctCornerCount(), 4);
  // The corner (0,0) is 18 deg of lat and lon from the middle: angle acos(cos18 cos18).
  const double expected =
      std::acos(std::cos(18.0 * std::numbers::pi / 180) * std::cos(18.0 * std::numbers::pi / 180));
  EXPECT_NEAR(node.normalConeHalfAngleRad(), expected, 1e-9);
}

TEST(Patch, PolarNodesHaveThreeDistinctCorners) {
  const Geodesy g;
  const NodeGeometry north(g, {-180.0, 54.0, -144.0, 90.0});
  EXPECT_TRUE(north.touchesNorthPole());
  EXPECT_EQ(north.distinctCornerCount(), 3);
  EXPECT_EQ(north.corners()[NE], north.corners()[NW]);
  EXPECT_NEAR(north.corners()[NE].z, g.polarRadius(), 1e-6);
  EXPECT_NEAR(north.cornerNormals()[NW].z, 1.0, 1e-15);
  const NodeGeometry south(g, {144.0, -90.0, 180.0, -54.0});
  EXPECT_TRUE(south.touchesSouthPole());
  EXPECT_EQ(south.distinctCornerCount(), 3);
  EXPECT_EQ(south.corners()[SW], south.corners()[SE]);
  const NodeGeometry both(g, {0.0, -90.0, 180.0, 90.0});
  EXPECT_EQ(both.distinctCornerCount(), 2);
}

TEST(Patch, MeshGridCoordinatesAndSharedEdges) {
  const Geodesy g;
  const Sector west{144.0, -36.0, 180.0, 0.0};
  const Sector east{-180.0, -36.0, -144.0, 0.0}; // across the antimeridian
  const PatchMesh a = buildPatchMesh(g, west, 17);
  const PatchMesh b = buildPatchMesh(g, east, 17);
  ASSERT_EQ(a.vertices.size(), 17u * 17u);
  EXPECT_EQ(a.centre, NodeGeometry(g, west).centre());
  for (int r = 0; r < 17; ++r) {
    // The east column at 180 and the west column at -180 are the same points.
    const glm::dvec3 pa = a.centre + a.at(r, 16).position;
    const glm::dvec3 pb = b.centre + b.at(r, 0).position;
    EXPECT_LT(glm::length(pa - pb), 1e-8) << "row " << r;
    EXPECT_DOUBLE_EQ(a.at(r, 16).uvGlobal.x, 1.0);
    EXPECT_DOUBLE_EQ(b.at(r, 0).uvGlobal.x, 0.0);
    EXPECT_DOUBLE_EQ(a.at(r, 16).uvGlobal.y, b.at(r, 0).uvGlobal.y);
  }
  EXPECT_EQ(a.at(0, 0).uvNode, glm::dvec2(0, 0));
  EXPECT_EQ(a.at(16, 16).uvNode, glm::dvec2(1, 1));
  EXPECT_DOUBLE_EQ(a.at(0, 0).uvGlobal.y, (-36.0 + 90.0) / 180.0);
  EXPECT_DOUBLE_EQ(a.at(16, 8).uvGlobal.y, 0.5);
  for (const auto& v : a.vertices)
    EXPECT_NEAR(glm::length(v.normal), 1.0, 1e-14);
  // Positions are relative to the centre: the vertex at the middle is the centre itself.
  EXPECT_LT(glm::length(a.at(8, 8).position), 1e-9);
}

TEST(Patch, PolarMeshRowIsThePole) {
  const Geodesy g;
  const PatchMesh m = buildPatchMesh(g, {0.0, 54.0, 36.0, 90.0}, 9);
  for (int c = 1; c < 9; ++c) {
    EXPECT_EQ(m.at(8, c).position, m.at(8, 0).position);
    EXPECT_NE(m.at(8, c).uvNode, m.at(8, 0).uvNode); // texture coordinates still fan out
  }
  EXPECT_NE(m.at(7, 0).position, m.at(7, 1).position);
}

TEST(Patch, RejectsInvalidInput) {
  const Geodesy g;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(NodeGeometry(g, {10, 0, 10, 5}), std::invalid_argument);    // west == east
  EXPECT_THROW(NodeGeometry(g, {170, 0, -170, 5}), std::invalid_argument); // crosses 180
  EXPECT_THROW(NodeGeometry(g, {0, 0, 10, 91}), std::invalid_argument);
  EXPECT_THROW(NodeGeometry(g, {nan, 0, 10, 5}), std::invalid_argument);
  EXPECT_THROW(NodeGeometry(g, {0, 0, 10, 5}, 10.0, -10.0), std::invalid_argument);
  for (const int n : {0, 1, 2, 4, 6, 16, 1026, 2049})
    EXPECT_THROW(buildPatchMesh(g, {0, 0, 10, 5}, n), std::invalid_argument) << n;
  for (const int n : {3, 5, 9, 33})
    EXPECT_NO_THROW(buildPatchMesh(g, {0, 0, 10, 5}, n)) << n;
}

namespace {
// Every vertex of a fine grid, at the lowest, highest and a middle height, lies in the sphere; and
// the sphere is not absurdly large (at most 30 % over the farthest sampled point).
void checkContainment(const Geodesy& g, const Sector& s, double hMin, double hMax) {
  const NodeGeometry node(g, s, hMin, hMax);
  const BoundingSphere& b = node.bounds();
  ASSERT_TRUE(finite(b.centre) && std::isfinite(b.radius) && b.radius > 0.0);
  const PatchMesh m = buildPatchMesh(g, s, 65);
  double farthest = 0.0;
  for (const auto& v : m.vertices)
    for (const double h : {hMin, 0.5 * (hMin + hMax), hMax}) {
      const glm::dvec3 p = m.centre + v.position + h * v.normal;
      const double d = glm::length(p - b.centre);
      // The west half box holds the western half of the patch, the east one the rest.
      const std::size_t side = v.uvNode.x <= 0.5 ? 0 : 1;
      ASSERT_TRUE(node.halfBoxes()[side].contains(p))
          << "half box " << side << ", sector " << s.west << "," << s.south << "," << s.east << ","
          << s.north << " h " << h;
      ASSERT_TRUE(node.box().contains(p)) << "box, sector " << s.west << "," << s.south << ","
                                          << s.east << "," << s.north << " h " << h;
      farthest = std::max(farthest, d);
      ASSERT_LE(d, b.radius) << "sector " << s.west << "," << s.south << "," << s.east << ","
                             << s.north << " h " << h;
    }
  EXPECT_LE(b.radius, 1.3 * farthest + 1e-3);
}
} // namespace

TEST(Patch, BoundingSphereContainsLevelZeroTiles) {
  const Geodesy wgs, sphere(EarthModel::Sphere);
  const TileGrid grid = test::globalGrid();
  for (const Sector& s : test::levelZeroSectors(grid)) {
    checkContainment(wgs, s, 0.0, 0.0);
    checkContainment(wgs, s, -11000.0, 9000.0);
    checkContainment(sphere, s, 0.0, 0.0);
  }
}

TEST(PatchExtremes, BoundingSphereContainsRandomSectorsDownToLevel24) {
  const Geodesy g;
  const TileGrid grid = test::globalGrid();
  std::mt19937_64 rng(2024);
  for (int i = 0; i < 400; ++i) {
    const int level = static_cast<int>(rng() % 25);
    const auto rows = static_cast<std::uint64_t>(grid.rowCount(level));
    const auto cols = static_cast<std::uint64_t>(grid.colCount(level));
    // Bias towards the poles and the antimeridian every other time.
    std::int64_t row = static_cast<std::int64_t>(rng() % rows);
    std::int64_t col = static_cast<std::int64_t>(rng() % cols);
    if (i % 4 == 1) row = 0;
    if (i % 4 == 2) row = grid.rowCount(level) - 1;
    if (i % 4 == 3) col = (i % 8 == 3) ? 0 : grid.colCount(level) - 1;
    const Sector s = grid.sectorOf({level, row, col});
    checkContainment(g, s, i % 2 == 0 ? 0.0 : -500.0, i % 2 == 0 ? 0.0 : 8848.0);
  }
}

TEST(PatchExtremes, Level24CornersDistinctAndFinite) {
  const Geodesy g;
  const TileGrid grid = test::globalGrid();
  const int level = 24;
  const std::int64_t lastRow = grid.rowCount(level) - 1;
  const std::int64_t lastCol = grid.colCount(level) - 1;
  const std::int64_t midRow = lastRow / 2, midCol = lastCol / 2;
  for (const std::int64_t row : {std::int64_t{0}, std::int64_t{1}, midRow, lastRow - 1, lastRow})
    for (const std::int64_t col : {std::int64_t{0}, midCol, lastCol}) {
      const Sector s = grid.sectorOf({level, row, col});
      const NodeGeometry node(g, s);
      for (const auto& c : node.corners())
        ASSERT_TRUE(finite(c));
      ASSERT_TRUE(finite(node.centre()));
      const bool pole = row == 0 || row == lastRow;
      EXPECT_EQ(node.distinctCornerCount(), pole ? 3 : 4) << row << "," << col;
      // ~0.24 m tiles: the east-west and north-south edges are that long (or shrink towards 0
      // next to the pole, but stay non-zero off it).
      const double ns = glm::length(node.corners()[NW] - node.corners()[SW]);
      EXPECT_GT(ns, 0.2);
      EXPECT_LT(ns, 0.3);
      if (row == midRow) {
        const double ew = glm::length(node.corners()[SE] - node.corners()[SW]);
        EXPECT_GT(ew, 0.2);
        EXPECT_LT(ew, 0.3);
      }
    }
}

namespace {

// The smallest geodetic height and the smallest norm against an occluder of semi-axes (a + h,
// a + h, b + h) over points sampled on both triangulations of every cell of a cols x rows grid.
struct SampledChords {
  double lowestHeightM = 0.0;
  double smallestOccluderNorm = std::numeric_limits<double>::infinity();
};
SampledChords
sampleChords(const Geodesy& g, const Sector& s, int cols, int rows, double occluderHeightM) {
  const double a = g.equatorialRadius() + occluderHeightM, b = g.polarRadius() + occluderHeightM;
  const auto point = [&](int r, int c) {
    double lat = edgeLerp(s.south, s.north, r, rows), lon = edgeLerp(s.west, s.east, c, cols);
    if (std::abs(lat) == 90.0) lon = 0.0;
    return vec(g.toEcef(lat, lon, 0.0));
  };
  SampledChords out;
  constexpr int k = 4; // barycentric steps
  for (int r = 0; r + 1 < rows; ++r)
    for (int c = 0; c + 1 < cols; ++c) {
      const glm::dvec3 sw = point(r, c), se = point(r, c + 1), nw = point(r + 1, c),
                       ne = point(r + 1, c + 1);
      for (const auto& t : {std::array{sw, se, ne},
                            std::array{sw, ne, nw},
                            std::array{sw, se, nw},
                            std::array{se, ne, nw}})
        for (int i = 0; i <= k; ++i)
          for (int j = 0; i + j <= k; ++j) {
            const glm::dvec3 p = (t[0] * static_cast<double>(k - i - j) +
                                  t[1] * static_cast<double>(i) + t[2] * static_cast<double>(j)) /
                                 static_cast<double>(k);
            out.lowestHeightM = std::min(out.lowestHeightM, g.fromEcef({p.x, p.y, p.z}).heightM);
            out.smallestOccluderNorm = std::min(out.smallestOccluderNorm,
                                                glm::length(glm::dvec3{p.x / a, p.y / a, p.z / b}));
          }
    }
  return out;
}

} // namespace

// A level-zero tile's triangles sag ~600 m under the ellipsoid: the horizon occluder must lie
// that much lower, or it would hide what shows over a sagging triangle nearer the camera.
TEST(Patch, ChordDepthOfALevelZeroTile) {
  const Geodesy g;
  // The equator's 36-degree tile with 33 points a side: cells of 1.125 degrees, the deepest
  // point the middle of a diagonal, a half-diagonal of ~0.795 degrees from its ends.
  const double depth = gridChordDepthM(g, {0.0, 0.0, 36.0, 36.0}, 33, 33);
  const double halfDiag = std::acos(std::cos(1.125 * std::numbers::pi / 180.0) *
                                    std::cos(1.125 * std::numbers::pi / 180.0)) /
                          2.0;
  EXPECT_NEAR(depth, g.equatorialRadius() * (1.0 - std::cos(halfDiag)), 5.0);
  EXPECT_GT(depth, 600.0);
  // Four times the points a side: a sixteenth of the depth.
  EXPECT_NEAR(
      gridChordDepthM(g, {0.0, 0.0, 36.0, 36.0}, 129, 129), depth / 16.0, depth / 16.0 * 0.02);
}

TEST(PatchExtremes, ChordDepthBoundsEverySampledTrianglePoint) {
  // Level zero at the equator, across the antimeridian's west edge, a polar wedge (its pole row
  // is one point: degenerate triangles), a polar cap's grid (129 columns round the pole, 33
  // rows), a deep tile, and the sphere.
  struct Case {
    Sector s;
    int cols, rows;
  };
  for (const EarthModel model : {EarthModel::Wgs84, EarthModel::Sphere}) {
    const Geodesy geo(model);
    for (const Case& c : {Case{{0.0, 0.0, 36.0, 36.0}, 33, 33},
                          Case{{-180.0, -36.0, -144.0, 0.0}, 33, 33},
                          Case{{-180.0, 54.0, -144.0, 90.0}, 33, 33},
                          Case{{-180.0, -90.0, 180.0, -54.0}, 129, 33},
                          Case{{10.0, 45.0, 10.0 + 36.0 / 1024, 45.0 + 36.0 / 1024}, 17, 17}}) {
      const double depth = gridChordDepthM(geo, c.s, c.cols, c.rows);
      ASSERT_TRUE(std::isfinite(depth));
      EXPECT_GE(depth, 0.0);
      // Every point on the triangles lies on or outside the occluder that far down ...
      const SampledChords at = sampleChords(geo, c.s, c.cols, c.rows, -depth);
      EXPECT_GE(at.smallestOccluderNorm, 1.0 - 1e-12) << c.s.west << " " << c.s.south;
      // ... the bound is tight (a sampled point within 1 % of it, or 1 cm) ...
      EXPECT_LE(at.lowestHeightM, -depth * 0.99 + 0.01) << c.s.west << " " << c.s.south;
      // ... and an occluder at the ellipsoid itself would not lie under them.
      if (depth > 1.0) {
        EXPECT_LT(sampleChords(geo, c.s, c.cols, c.rows, 0.0).smallestOccluderNorm, 1.0);
      }
    }
  }
}
