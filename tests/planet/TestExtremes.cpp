// Issue #8's extremes, GL-free (suites ...Extremes: labels unit + extremes): the Earth model's
// figure (sphere against WGS84, measured), the camera at the exact poles, on the antimeridian, at
// -0.0, 1 m and 0.1 m above the ellipsoid and 1e9 m out, and the deepest level the cache grid
// allows. The rendered counterparts are in TestExtremesGl.cpp.

#include "PlanetTestSupport.hpp"

#include <tellus/cache/TileGrid.hpp>
#include <tellus/planet/Camera.hpp>
#include <tellus/planet/Geodesy.hpp>
#include <tellus/planet/GpuVertex.hpp>
#include <tellus/planet/Patch.hpp>
#include <tellus/planet/Terrain.hpp>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <numbers>
#include <vector>

using namespace tellus;
using namespace tellus::planet;
using tellus::planet::test::finite;
using tellus::planet::test::vec;

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

double angleRad(const glm::dvec3& a, const glm::dvec3& b) {
  // atan2 of |a x b| and a.b: accurate for tiny angles, where acos is not.
  return std::atan2(glm::length(glm::cross(a, b)), glm::dot(a, b));
}

bool finiteMatrix(const glm::dmat4& m) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(m[c][r])) return false;
  return true;
}

bool sameMatrix(const glm::dmat4& a, const glm::dmat4& b) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!(a[c][r] == b[c][r])) return false; // -0.0 == 0.0
  return true;
}

bool sameVec(const glm::dvec3& a, const glm::dvec3& b) {
  return a.x == b.x && a.y == b.y && a.z == b.z;
}

/** Everything the camera gives is finite and its frame orthonormal. */
void expectSaneCamera(const Camera& cam) {
  ASSERT_TRUE(finite(cam.position()) && finite(cam.forward()) && finite(cam.up()) &&
              finite(cam.right()));
  EXPECT_NEAR(glm::length(cam.forward()), 1.0, 1e-12);
  EXPECT_NEAR(glm::length(cam.up()), 1.0, 1e-12);
  EXPECT_NEAR(glm::length(cam.right()), 1.0, 1e-12);
  EXPECT_NEAR(glm::dot(cam.forward(), cam.up()), 0.0, 1e-12);
  EXPECT_NEAR(glm::dot(cam.forward(), cam.right()), 0.0, 1e-12);
  EXPECT_NEAR(glm::dot(glm::cross(cam.right(), cam.up()), -cam.forward()), 1.0, 1e-12);
  EXPECT_TRUE(finiteMatrix(cam.view()) && finiteMatrix(cam.projection()) &&
              finiteMatrix(cam.viewProjection()));
  for (const Plane& p : cam.frustum().planes)
    EXPECT_TRUE(finite(p.n) && std::isfinite(p.d));
  for (const auto& g : cam.viewportGround()) {
    if (g.hit) {
      EXPECT_TRUE(std::isfinite(g.latDeg) && std::isfinite(g.lonDeg));
    }
  }
}

} // namespace

// The figure the issue asks for: the same latitude/longitude placed on the sphere (mean radius
// 6,371,008.8 m, geocentric = geodetic latitude) and on WGS84 lie up to ~21.6 km apart, almost all
// of it horizontal (geodetic against geocentric latitude, 0.19 degrees at 45 degrees: 21.4 km at
// 45.1 degrees; the largest distance, 21.8 km, is at 48.2 degrees, where more is radial); 7.1 km
// (radial) at the equator and 14.3 km at the poles. Printed for docs/ACCURACY.md.
TEST(EarthModelExtremes, SphereMisplacesImageryByUpToAbout21Km) {
  const Geodesy wgs84(EarthModel::Wgs84);
  const Geodesy sphere(EarthModel::Sphere);
  double worst = 0.0, worstLat = 0.0, worstHorizontal = 0.0, worstHorizontalLat = 0.0;
  for (int i = -9000; i <= 9000; ++i) { // every 0.01 degree
    const double lat = i / 100.0;
    const glm::dvec3 w = vec(wgs84.toEcef(lat, 0.0, 0.0));
    const glm::dvec3 s = vec(sphere.toEcef(lat, 0.0, 0.0));
    const double d = glm::length(w - s);
    // Horizontal: the arc on the sphere between the two directions seen from the centre.
    const double h = angleRad(w, s) * sphere.equatorialRadius();
    if (d > worst) worst = d, worstLat = lat;
    if (h > worstHorizontal) worstHorizontal = h, worstHorizontalLat = lat;
  }
  // Longitude plays no part (both are surfaces of revolution about the same axis).
  for (const double lon : {-180.0, -97.3, 33.0, 179.9999}) {
    const double d =
        glm::length(vec(wgs84.toEcef(worstLat, lon, 0.0)) - vec(sphere.toEcef(worstLat, lon, 0.0)));
    EXPECT_NEAR(d, worst, 1e-6) << lon;
  }
  const double equator =
      glm::length(vec(wgs84.toEcef(0.0, 0.0, 0.0)) - vec(sphere.toEcef(0.0, 0.0, 0.0)));
  const double pole =
      glm::length(vec(wgs84.toEcef(90.0, 0.0, 0.0)) - vec(sphere.toEcef(90.0, 0.0, 0.0)));
  std::printf("sphere against WGS84, the same lat/lon: largest distance %.1f m at latitude %.2f; "
              "largest horizontal part %.1f m at latitude %.2f; equator %.1f m, poles %.1f m\n",
              worst,
              worstLat,
              worstHorizontal,
              worstHorizontalLat,
              equator,
              pole);
  EXPECT_GT(worst, 21000.0);
  EXPECT_LT(worst, 22000.0);
  EXPECT_NEAR(std::abs(worstLat), 48.2, 0.5); // where the radial part (3.6 km) adds most
  EXPECT_NEAR(worstHorizontal, 21397.0, 10.0);
  EXPECT_NEAR(std::abs(worstHorizontalLat), 45.1, 0.2);
  EXPECT_NEAR(equator, 6378137.0 - 6371008.8, 1e-6);
  EXPECT_NEAR(pole, 6371008.8 - 6356752.314245, 1e-5);
}

// Exact poles and 0.0001 degrees off them, looking straight down and tilted, at every heading: the
// frame is orthonormal and finite, the eye sits at the asked height on the asked latitude, it looks
// along the ellipsoid normal tilted by the asked angle, and nothing flips between 89.9999 and 90
// (the heading is measured from the meridian of the longitude given, on and off the pole).
TEST(CameraExtremes, ExactPolesLookingDownAndTilted) {
  const Geodesy g;
  for (const double lat : {90.0, -90.0, 89.9999, -89.9999})
    for (const double lon : {0.0, 77.0, -180.0})
      for (const double alt : {0.1, 1.0, 1e3, 1e6})
        for (const double heading : {0.0, 90.0, 200.0})
          for (const double tilt : {0.0, 30.0, 80.0}) {
            SCOPED_TRACE(std::to_string(lat) + "," + std::to_string(lon) + "," +
                         std::to_string(alt) + "," + std::to_string(heading) + "," +
                         std::to_string(tilt));
            const Camera cam(g, {lat, lon, alt, heading, tilt}, {256, 256});
            expectSaneCamera(cam);
            const Geodetic at = g.fromEcef({cam.position().x, cam.position().y, cam.position().z});
            EXPECT_NEAR(at.latDeg, lat, 1e-9);
            EXPECT_NEAR(at.heightM, alt, 1e-8 + alt * 1e-12);
            const Ecef n = g.surfaceNormal(lat, lon);
            EXPECT_NEAR(angleRad(cam.forward(), -vec(n)) / kDeg, tilt, 1e-9);
            // Straight down, the middle of the view is the point below the eye.
            const auto& centre = cam.viewportGround()[8];
            if (tilt == 0.0) {
              ASSERT_TRUE(centre.hit);
              EXPECT_NEAR(centre.latDeg, lat, 1e-9);
            }
            // Continuity through the pole: the same pose 0.0001 degrees off looks the same way.
            if (std::abs(lat) == 90.0) {
              const double off = lat > 0 ? 89.9999 : -89.9999;
              const Camera near(g, {off, lon, alt, heading, tilt}, {256, 256});
              EXPECT_LT(angleRad(cam.forward(), near.forward()), 3e-6);
              EXPECT_LT(angleRad(cam.up(), near.up()), 3e-6);
            }
          }
}

// lon 180 and -180 are one place: bit for bit the same camera (but for the sign of zero); 179.9999
// and -179.9999 are mirror images; a camera looking across the line sees ground on the other side.
TEST(CameraExtremes, AntimeridianFromBothSidesAndAcross) {
  const Geodesy g;
  for (const double lat : {0.0, 45.0, -89.9999})
    for (const double alt : {1.0, 1e5, 1e9})
      for (const double tilt : {0.0, 70.0}) {
        const Camera east(g, {lat, 180.0, alt, 90.0, tilt}, {256, 192});
        const Camera west(g, {lat, -180.0, alt, 90.0, tilt}, {256, 192});
        expectSaneCamera(east);
        EXPECT_TRUE(sameVec(east.position(), west.position()));
        EXPECT_TRUE(sameVec(east.forward(), west.forward()));
        EXPECT_TRUE(sameMatrix(east.view(), west.view()));
        EXPECT_TRUE(sameMatrix(east.viewProjection(), west.viewProjection()));
        // Mirror images in the x-z plane.
        const Camera a(g, {lat, 179.9999, alt, 90.0, tilt}, {256, 192});
        const Camera b(g, {lat, -179.9999, alt, 270.0, tilt}, {256, 192});
        expectSaneCamera(a);
        EXPECT_NEAR(a.position().x, b.position().x, 1e-9 * glm::length(a.position()));
        EXPECT_NEAR(a.position().y, -b.position().y, 1e-9 * glm::length(a.position()));
        EXPECT_NEAR(a.forward().y, -b.forward().y, 1e-12);
      }
  // Low and tilted, looking east from 179.9999: the view's centre is on the ground west of
  // -179.99 (the other side), as a longitude in [-180, 180].
  const Camera across(g, {0.0, 179.9999, 100.0, 90.0, 80.0}, {256, 192});
  const auto& centre = across.viewportGround()[8];
  ASSERT_TRUE(centre.hit);
  EXPECT_LT(centre.lonDeg, -179.99);
  EXPECT_GE(centre.lonDeg, -180.0);
}

// -0.0 is 0.0 for every input of the pose: the same camera, matrix for matrix.
TEST(CameraExtremes, NegativeZeroIsZero) {
  const Geodesy g;
  const Camera zero(g, {0.0, 0.0, 1e6, 0.0, 0.0}, {128, 128});
  const Camera neg(g, {-0.0, -0.0, 1e6, -0.0, -0.0}, {128, 128});
  EXPECT_TRUE(sameVec(zero.position(), neg.position()));
  EXPECT_TRUE(sameVec(zero.forward(), neg.forward()));
  EXPECT_TRUE(sameVec(zero.up(), neg.up()));
  EXPECT_TRUE(sameMatrix(zero.viewProjection(), neg.viewProjection()));
  EXPECT_EQ(zero.viewportGround()[8].latDeg, neg.viewportGround()[8].latDeg);
  EXPECT_EQ(zero.viewportGround()[8].lonDeg, neg.viewportGround()[8].lonDeg);
  const Ecef a = g.toEcef(-0.0, -0.0, -0.0), b = g.toEcef(0.0, 0.0, 0.0);
  EXPECT_TRUE(a.x == b.x && a.y == b.y && a.z == b.z);
  const Ecef na = g.surfaceNormal(-0.0, -0.0), nb = g.surfaceNormal(0.0, 0.0);
  EXPECT_TRUE(na.x == nb.x && na.y == nb.y && na.z == nb.z);
  // A tile edge at -0.0: NodeGeometry and the mesh treat it as 0.
  const NodeGeometry n1(g, Sector{-0.0, -0.0, 1.0, 1.0}), n2(g, Sector{0.0, 0.0, 1.0, 1.0});
  for (int c = 0; c < 4; ++c)
    EXPECT_TRUE(sameVec(n1.corners()[static_cast<std::size_t>(c)],
                        n2.corners()[static_cast<std::size_t>(c)]));
}

// 1 m and 0.1 m above the ellipsoid (no terrain yet), with the near plane the renderer uses
// (nearDistanceFor): every ground point the view shows (the ground through the viewport's corners,
// edge midpoints and centre) lies beyond the near plane, at a reversed-Z depth (near / w) inside
// (0, 1), and the frame is finite looking down and tilted. With a fixed 0.1 m near plane the ground
// 0.1 m below the eye was on it (the LOD saw "corners behind the camera" and split to level 30)
// and, tilted, in front of it (clipped: a hole at the bottom of the view).
TEST(CameraExtremes, OneMetreAndATenthOfAMetreAboveTheEllipsoid) {
  const Geodesy g;
  for (const double alt : {1.0, 0.1, 0.01})
    for (const double tilt : {0.0, 30.0, 45.0, 89.0})
      for (const double lat : {-33.9, 89.9999}) {
        SCOPED_TRACE("altitude " + std::to_string(alt) + " tilt " + std::to_string(tilt) +
                     " latitude " + std::to_string(lat));
        const double near = nearDistanceFor(alt);
        EXPECT_GT(near, 0.0);
        EXPECT_LE(near, 0.1);
        const Camera cam(g, {lat, 18.4, alt, 30.0, tilt}, {256, 256}, 45.0, near);
        expectSaneCamera(cam);
        const auto& centre = cam.viewportGround()[8];
        ASSERT_TRUE(centre.hit);
        const glm::dvec3 below = vec(g.toEcef(centre.latDeg, centre.lonDeg, 0.0));
        const double distance = glm::length(below - cam.position());
        // Flat ground within the curvature's share (at 89 degrees the ground curves away).
        EXPECT_NEAR(distance, alt / std::cos(tilt * kDeg), (tilt > 80.0 ? 1e-3 : 1e-6) * distance);
        int hits = 0;
        for (const auto& gp : cam.viewportGround()) {
          if (!gp.hit) continue;
          ++hits;
          const glm::dvec4 clip = cam.toClip(vec(g.toEcef(gp.latDeg, gp.lonDeg, 0.0)));
          EXPECT_GT(clip.w, 1.5 * cam.nearM()) << "ground at the near plane";
          const double depth = clip.z / clip.w;
          EXPECT_GT(depth, 0.0);
          EXPECT_LT(depth, 1.0) << "ground clipped by the near plane";
        }
        EXPECT_GE(hits, tilt < 60.0 ? 9 : 3);
      }
  // Far from the ground the near plane stays at 0.1 m; under the ellipsoid too (nothing below).
  EXPECT_EQ(nearDistanceFor(1e6), 0.1);
  EXPECT_EQ(nearDistanceFor(0.25), 0.1);
  EXPECT_NEAR(nearDistanceFor(0.1),
              0.05 / std::sqrt(1.0 + 2.0 * std::pow(std::tan(22.5 * kDeg), 2)),
              1e-15);
  EXPECT_EQ(nearDistanceFor(-500.0), 0.1);
  EXPECT_EQ(nearDistanceFor(0.0), 0.1);
  EXPECT_EQ(nearDistanceFor(std::nan("")), 0.1);
  EXPECT_EQ(nearDistanceFor(1e-9), 1e-3); // the floor: below 2 mm the ground is clipped again
}

// 1e9 m out: the Earth's angular radius is asin(a / (a + h)); the limb point projects that far
// from the centre of the view (the rendered disc is checked in TestExtremesGl.cpp).
TEST(CameraExtremes, BillionMetresOutTheLimbProjectsWhereTheAngleSays) {
  const Geodesy g;
  const double alt = 1e9, a = g.equatorialRadius();
  const Camera cam(g, {0.0, 0.0, alt, 0.0, 0.0}, {256, 256}, 45.0);
  expectSaneCamera(cam);
  // The tangent point on the equator seen from (a + h, 0, 0): its angle from the centre.
  const double d = a + alt;
  const double half = std::asin(a / d);
  const glm::dvec3 limb(a * a / d, a * std::sqrt(1.0 - (a / d) * (a / d)), 0.0);
  const glm::dvec4 c = cam.toClip(limb);
  ASSERT_GT(c.w, 0.0);
  const double px = c.x / c.w * 128.0; // pixels from the centre
  const double focal = 128.0 / std::tan(22.5 * kDeg);
  EXPECT_NEAR(std::abs(px), focal * std::tan(half), 1e-6);
  std::printf("1e9 m: the Earth's radius is %.4f px in a 256 px, 45 degree view\n",
              focal * std::tan(half));
}

// The deepest level the cache grid allows (kMaxLevel = 30 for World Wind's 36, 45 and 20 degree
// level zeros; tiles of 3.7, 4.7 and 2.1 mm): every tile corner is distinct in double, neighbours
// share their edges bit for bit, and the mesh's positions, normals and texture coordinates are
// finite, in range and strictly ordered (also once narrowed to float, as the GL layer sends the
// centre-relative positions).
TEST(PatchExtremes, DeepestLevelTheGridAllowsHasDistinctCornersAndFiniteMeshes) {
  const Geodesy g;
  for (const double delta : {36.0, 45.0, 20.0}) {
    SCOPED_TRACE("level-zero delta " + std::to_string(delta));
    // The deepest level TileGrid::create accepts for this level zero.
    int levels = kMaxLevel + 1;
    for (; levels > 1; --levels) {
      GridSpec spec;
      spec.levelZeroDeltaDeg = delta;
      spec.numLevels = levels;
      if (TileGrid::create(spec)) break;
    }
    EXPECT_EQ(levels, kMaxLevel + 1);
    GridSpec spec;
    spec.levelZeroDeltaDeg = delta;
    spec.numLevels = levels;
    const TileGrid grid = *TileGrid::create(spec);
    const int level = levels - 1;
    const std::int64_t rows = grid.rowCount(level), cols = grid.colCount(level);
    for (const std::int64_t row : {std::int64_t{0}, std::int64_t{1}, rows / 2, rows - 2, rows - 1})
      for (const std::int64_t col : {std::int64_t{0}, std::int64_t{1}, cols / 2, cols - 1}) {
        SCOPED_TRACE("row " + std::to_string(row) + " col " + std::to_string(col));
        const Sector s = grid.sectorOf({level, row, col});
        ASSERT_LT(s.south, s.north);
        ASSERT_LT(s.west, s.east);
        const NodeGeometry node(g, s);
        const bool pole = row == 0 || row == rows - 1;
        EXPECT_EQ(node.distinctCornerCount(), pole ? 3 : 4);
        int distinctPairs = 0;
        for (int i = 0; i < 4; ++i) {
          ASSERT_TRUE(finite(node.corners()[static_cast<std::size_t>(i)]));
          ASSERT_TRUE(finite(node.cornerNormals()[static_cast<std::size_t>(i)]));
          for (int j = i + 1; j < 4; ++j)
            distinctPairs += !sameVec(node.corners()[static_cast<std::size_t>(i)],
                                      node.corners()[static_cast<std::size_t>(j)]);
        }
        EXPECT_EQ(distinctPairs, pole ? 5 : 6);
        EXPECT_TRUE(finite(node.centre()) && node.bounds().radius > 0.0 &&
                    std::isfinite(node.bounds().radius));
        // The east neighbour (across the antimeridian for the last column) shares the edge.
        const Sector e = grid.sectorOf({level, row, (col + 1) % cols});
        const NodeGeometry east(g, e);
        EXPECT_TRUE(sameVec(node.corners()[SE], east.corners()[SW]) || col == cols - 1);
        if (col == cols - 1) { // 180 and -180: the same point, up to rounding of sin(180)
          EXPECT_LT(glm::length(node.corners()[SE] - east.corners()[SW]), 1e-9);
        }

        // The renderer's mesh (buildTerrainMesh, bare ellipsoid): finite, unit normals, and the
        // high/low float pairs the GL layer sends rebuild each position within 1e-7 m and keep
        // adjacent vertices apart.
        {
          const TerrainMesh tm = buildTerrainMesh(
              g, s, 33, [](double, double) { return 0.0; }, std::array<EdgeAdapt, 4>{});
          ASSERT_EQ(tm.vertices.size(), std::size_t{33 * 33});
          // What the GL layer uploads on its OpenGL 3.3 path (packVertices, FloatPairs).
          std::vector<float> packed;
          packVertices(tm.vertices, VertexPositions::FloatPairs, packed);
          ASSERT_EQ(packed.size(), tm.vertices.size() * kFloatsPerVertex);
          for (const float f : packed)
            ASSERT_TRUE(std::isfinite(f));
          glm::dvec3 previous(0.0);
          for (std::size_t i = 0; i < tm.vertices.size(); ++i) {
            const TerrainVertex& v = tm.vertices[i];
            ASSERT_TRUE(finite(v.position));
            ASSERT_NEAR(glm::length(glm::dvec3(v.normal)), 1.0, 1e-6);
            const float* f = packed.data() + i * kFloatsPerVertex;
            const glm::dvec3 hi(f[0], f[1], f[2]);
            const glm::dvec3 lo(f[3], f[4], f[5]);
            const glm::dvec3 back = hi + lo;
            ASSERT_LT(glm::length(back - v.position), 1e-7);
            const bool poleRow = (row == 0 && i < 33) || (row == rows - 1 && i >= 33 * 32);
            if (i % 33 != 0 && !poleRow) {
              ASSERT_GT(glm::length(back - previous), 0.0) << "adjacent vertices collapse";
            }
            previous = back;
          }
        }
        for (const int n : {3, 33}) {
          const PatchMesh mesh = buildPatchMesh(g, s, n);
          ASSERT_TRUE(finite(mesh.centre));
          for (int r = 0; r < n; ++r)
            for (int c = 0; c < n; ++c) {
              const PatchVertex& v = mesh.at(r, c);
              ASSERT_TRUE(finite(v.position) && finite(v.normal));
              ASSERT_TRUE(std::isfinite(v.uvNode.x) && std::isfinite(v.uvNode.y) &&
                          std::isfinite(v.uvGlobal.x) && std::isfinite(v.uvGlobal.y));
              ASSERT_NEAR(glm::length(v.normal), 1.0, 1e-12);
              ASSERT_TRUE(v.uvNode.x >= 0.0 && v.uvNode.x <= 1.0 && v.uvNode.y >= 0.0 &&
                          v.uvNode.y <= 1.0);
              ASSERT_TRUE(v.uvGlobal.x >= 0.0 && v.uvGlobal.x <= 1.0 && v.uvGlobal.y >= 0.0 &&
                          v.uvGlobal.y <= 1.0);
              if (c > 0) {
                const PatchVertex& w = mesh.at(r, c - 1);
                ASSERT_GT(v.uvNode.x, w.uvNode.x);
                ASSERT_GT(v.uvGlobal.x, w.uvGlobal.x);
                const bool poleRow = (row == 0 && r == 0) || (row == rows - 1 && r == n - 1);
                if (!poleRow) {
                  ASSERT_FALSE(sameVec(v.position, w.position));
                  const glm::vec3 fv(v.position), fw(w.position); // what the GPU gets
                  ASSERT_FALSE(fv == fw) << "adjacent vertices collapse in float";
                }
              }
              if (r > 0) {
                const PatchVertex& w = mesh.at(r - 1, c);
                ASSERT_GT(v.uvNode.y, w.uvNode.y);
                ASSERT_GT(v.uvGlobal.y, w.uvGlobal.y);
                ASSERT_FALSE(sameVec(v.position, w.position));
              }
            }
        }
      }
  }
}

// The GL layer's vertex path at the extremes (GpuVertex.hpp): the camera-relative position the
// vertex shader computes in float from the high/low pairs ((high - eyeHigh) + (low - eyeLow)),
// emulated step by step on the CPU, against the double difference, for a camera 1 m and 0.1 m
// above vertices of the deepest level at the exact poles, on both sides of the antimeridian, at
// -0.0 and at the equator; and the fp64 path's bytes round-trip exactly.
TEST(GpuVertexExtremes, EyeRelativeFloatPairsStaySubMillimetreAtTheDeepestLevel) {
  const Geodesy g;
  GridSpec spec;
  spec.levelZeroDeltaDeg = 36.0;
  spec.numLevels = kMaxLevel + 1;
  const TileGrid grid = *TileGrid::create(spec);
  const int level = kMaxLevel;
  const std::int64_t rows = grid.rowCount(level), cols = grid.colCount(level);
  struct Case {
    const char* name;
    std::int64_t row, col;
  };
  for (const Case& c : {Case{"south pole", 0, cols / 3},
                        Case{"north pole", rows - 1, 7},
                        Case{"antimeridian west", rows / 3, 0},
                        Case{"antimeridian east", rows / 3, cols - 1},
                        Case{"equator at -0.0 / 0.0", rows / 2, cols / 2}}) {
    SCOPED_TRACE(c.name);
    const Sector s = grid.sectorOf({level, c.row, c.col});
    const TerrainMesh tm = buildTerrainMesh(
        g, s, 33, [](double, double) { return 0.0; }, std::array<EdgeAdapt, 4>{});
    std::vector<float> pairs, doubles;
    packVertices(tm.vertices, VertexPositions::FloatPairs, pairs);
    packVertices(tm.vertices, VertexPositions::Doubles, doubles);
    ASSERT_EQ(doubles.size(), pairs.size());
    for (const double above : {1.0, 0.1}) {
      // The eye above the node's centre vertex, off the grid's points.
      const TerrainVertex& mid = tm.vertices[16 * 33 + 16];
      const glm::dvec3 eye = mid.position + glm::dvec3(mid.normal) * above;
      double worst = 0.0;
      for (std::size_t i = 0; i < tm.vertices.size(); ++i) {
        const float* f = pairs.data() + i * kFloatsPerVertex;
        const glm::dvec3 exact = tm.vertices[i].position - eye;
        const glm::dvec3 gpu(eyeRelativeFloatPairs(f, eye));
        ASSERT_TRUE(finite(gpu));
        worst = std::max(worst, glm::length(gpu - exact));
        double back[3];
        std::memcpy(back, doubles.data() + i * kFloatsPerVertex, sizeof back);
        ASSERT_EQ(back[0], tm.vertices[i].position.x);
        ASSERT_EQ(back[1], tm.vertices[i].position.y);
        ASSERT_EQ(back[2], tm.vertices[i].position.z);
        // Normal and texture coordinates: finite and in range in both formats.
        for (int k = 6; k < 11; ++k)
          ASSERT_TRUE(std::isfinite(f[k]));
        ASSERT_TRUE(f[9] >= 0.0f && f[9] <= 1.0f && f[10] >= 0.0f && f[10] <= 1.0f);
      }
      // Vertices of a ~0.6 m node lie within a metre of the eye: float's own resolution there is
      // ~1e-7 m; a path that put an Earth-sized coordinate in one float would be off by ~0.25 m.
      EXPECT_LT(worst, 1e-5) << "at " << above << " m";
    }
    // -0.0 in the uv transform and an exact ancestor transform 30 levels up stay finite.
    const auto u = uvUniform(
        ancestorUv(NodeKey{level, c.row, c.col, 1}, NodeKey{0, c.row >> level, c.col >> level, 1}));
    for (const float x : u)
      EXPECT_TRUE(std::isfinite(x));
  }
}
