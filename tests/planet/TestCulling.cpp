#include "PlanetTestSupport.hpp"

#include <tellus/planet/Culling.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <string>

using namespace tellus;
using namespace tellus::planet;
using tellus::planet::test::finite;

TEST(Culling, FrustumClassifiesSpheres) {
  const Geodesy g;
  const Camera cam(g, {0.0, 0.0, 1e6, 0.0, 0.0}, {1000, 1000}, 90.0, 1.0);
  const glm::dvec3 ahead = cam.position() + 1000.0 * cam.forward();
  EXPECT_EQ(classify(cam.frustum(), {ahead, 10.0}), FrustumResult::Inside);
  EXPECT_EQ(classify(cam.frustum(), {ahead, 2000.0}), FrustumResult::Intersecting);
  EXPECT_EQ(classify(cam.frustum(), {cam.position() - 1000.0 * cam.forward(), 10.0}),
            FrustumResult::Outside);
  // 90 degree field of view: the right plane is at 45 degrees.
  const glm::dvec3 side = cam.position() + 1000.0 * cam.forward() + 1100.0 * cam.right();
  EXPECT_EQ(classify(cam.frustum(), {side, 10.0}), FrustumResult::Outside);
  EXPECT_EQ(classify(cam.frustum(), {side, 200.0}), FrustumResult::Intersecting);
  // Behind the near plane but within the sphere's radius of it.
  EXPECT_EQ(classify(cam.frustum(), {cam.position(), 5.0}), FrustumResult::Intersecting);
}

TEST(Culling, NodesOnTheFarSideAreCulledAndTheNadirIsNot) {
  const Geodesy g;
  const HorizonOccluder occ(g);
  const Camera cam(g, {0.0, 0.0, 2e7, 0.0, 0.0}, {1024, 768});
  const NodeGeometry nadir(g, {0.0, 0.0, 36.0, 36.0});
  const NodeGeometry far(g, {144.0, 0.0, 180.0, 36.0});
  EXPECT_FALSE(isBackFacing(cam, nadir));
  EXPECT_TRUE(isBackFacing(cam, far));
  EXPECT_FALSE(occ.isOccluded(cam.position(), nadir.bounds()));
  EXPECT_TRUE(occ.isOccluded(cam.position(), far.bounds()));
  EXPECT_TRUE(cullNode(cam, nadir, occ).visible);
  EXPECT_FALSE(cullNode(cam, far, occ).visible);
  // With relief the back-face test stands down; the horizon test still culls the far side.
  const NodeGeometry farRelief(g, {144.0, 0.0, 180.0, 36.0}, -100.0, 5000.0);
  EXPECT_FALSE(isBackFacing(cam, farRelief));
  EXPECT_TRUE(HorizonOccluder(g, -11000.0).isOccluded(cam.position(), farRelief.bounds()));
}

TEST(Culling, SegmentReferenceSeesTheLimbCorrectly) {
  const Geodesy g;
  const HorizonOccluder occ(g);
  const glm::dvec3 cam{2.0 * g.equatorialRadius(), 0, 0};
  EXPECT_FALSE(occ.segmentHitsOccluder(cam, test::vec(g.toEcef(0, 0, 0))));
  EXPECT_TRUE(occ.segmentHitsOccluder(cam, test::vec(g.toEcef(0, 180, 0))));
  // The tangent point from 2a is at 60 degrees: 59 is seen, 61 is not.
  EXPECT_FALSE(occ.segmentHitsOccluder(cam, test::vec(g.toEcef(0, 59, 0))));
  EXPECT_TRUE(occ.segmentHitsOccluder(cam, test::vec(g.toEcef(0, 61, 0))));
}

namespace {

struct Sweep {
  int cameras = 0;
  int nodes = 0;
  int culled = 0;
  int visibleByReference = 0;
};

/**
 * The brute-force cross-check: sample the node's surface (at the heights it spans); if any sample
 * is inside the frustum and the segment from the camera to it misses the occluder's interior, the
 * node must not be culled.
 */
void crossCheck(const Geodesy& g,
                const Camera& cam,
                const Sector& s,
                double hMin,
                double hMax,
                const HorizonOccluder& occ,
                Sweep& sweep,
                const std::string& what) {
  const NodeGeometry node(g, s, hMin, hMax);
  const CullResult r = cullNode(cam, node, occ);
  ++sweep.nodes;
  if (!r.visible) ++sweep.culled;
  const PatchMesh m = buildPatchMesh(g, s, 17);
  bool seen = false;
  for (const auto& v : m.vertices) {
    for (const double h : {hMin, hMax}) {
      const glm::dvec3 p = m.centre + v.position + h * v.normal;
      if (test::inFrustum(cam, p) && !occ.segmentHitsOccluder(cam.position(), p)) {
        seen = true;
        break;
      }
    }
    if (seen) break;
  }
  if (seen) {
    ++sweep.visibleByReference;
    // Each test on its own, then all three.
    EXPECT_FALSE(isBackFacing(cam, node)) << what;
    EXPECT_NE(classify(cam.frustum(), node.bounds()), FrustumResult::Outside) << what;
    EXPECT_NE(classify(cam.frustum(), node.box()), FrustumResult::Outside) << what;
    EXPECT_FALSE(projectsOutsideViewport(cam, node.box())) << what;
    EXPECT_NE(classifyNode(cam, node), FrustumResult::Outside) << what;
    EXPECT_FALSE(occ.isOccluded(cam.position(), node.bounds())) << what;
    EXPECT_TRUE(r.visible) << what << " sector " << s.west << "," << s.south << "," << s.east << ","
                           << s.north << " heights " << hMin << ".." << hMax;
  }
}

void sweepCamera(const Geodesy& g, const CameraPose& pose, Sweep& sweep) {
  const TileGrid grid = test::globalGrid();
  const Camera cam(g, pose, {1024, 768}, 60.0, 0.1);
  ++sweep.cameras;
  const std::string what = "camera " + std::to_string(pose.latDeg) + "," +
                           std::to_string(pose.lonDeg) + " alt " + std::to_string(pose.altitudeM) +
                           " heading " + std::to_string(pose.headingDeg) + " tilt " +
                           std::to_string(pose.tiltDeg);
  std::vector<Sector> sectors = test::levelZeroSectors(grid);
  for (const int level : {3, 8, 14, 20})
    for (const Sector& s : test::sectorsAround(grid, pose.latDeg, pose.lonDeg, level))
      sectors.push_back(s);
  // Tiles ahead along the view: where a low camera's horizon lies.
  const Geodetic ahead = g.fromEcef({cam.position().x + 5e3 * cam.forward().x,
                                     cam.position().y + 5e3 * cam.forward().y,
                                     cam.position().z + 5e3 * cam.forward().z});
  for (const Sector& s : test::sectorsAround(grid, ahead.latDeg, ahead.lonDeg, 12))
    sectors.push_back(s);
  const HorizonOccluder flat(g, 0.0), deep(g, -11000.0);
  for (const Sector& s : sectors) {
    // The imagery-only globe on the ellipsoid (occluder: the ellipsoid).
    crossCheck(g, cam, s, 0.0, 0.0, flat, sweep, what);
    // Terrain: heights from the deepest trench to Everest, occluder below the lowest point.
    crossCheck(g, cam, s, -11000.0, 8848.0, deep, sweep, what);
  }
}

} // namespace

TEST(CullingExtremes, NeverCullsAVisibleNodeLowAltitude) {
  const Geodesy g;
  Sweep sweep;
  for (const double alt : {0.0, 0.5, 1.0, 2.0, 5.0, 10.0})
    for (const double tilt : {0.0, 60.0, 85.0, 90.0, 95.0})
      for (const double lon : {0.0, 7.5})
        sweepCamera(g, {46.5, lon, alt, 30.0, tilt}, sweep);
  EXPECT_GT(sweep.culled, 0);
  EXPECT_GT(sweep.visibleByReference, 0);
}

TEST(CullingExtremes, NeverCullsAVisibleNodeAtThePolesAndTheAntimeridian) {
  const Geodesy g;
  Sweep sweep;
  for (const double lat : {90.0, -90.0, 89.9999, -89.9999})
    for (const double alt : {0.0, 10.0, 1e4, 2e7})
      for (const double tilt : {0.0, 89.0, 90.0})
        sweepCamera(g, {lat, 0.0, alt, 0.0, tilt}, sweep);
  for (const double lon : {180.0, -180.0, 179.9999, -179.9999, -0.0})
    for (const double alt : {0.0, 3.0, 1e5, 2e7})
      for (const double tilt : {0.0, 90.0})
        for (const double heading : {90.0, 270.0})
          sweepCamera(g, {0.0, lon, alt, heading, tilt}, sweep);
  EXPECT_GT(sweep.culled, 0);
  EXPECT_GT(sweep.visibleByReference, 0);
}

TEST(CullingExtremes, NeverCullsAVisibleNodeBelowSeaLevelAndFarOut) {
  const Geodesy g;
  Sweep sweep;
  for (const double alt : {-500.0, -100.0, -1.0, 1e8, 1e9})
    for (const double tilt : {0.0, 45.0, 90.0})
      sweepCamera(g, {-20.0, 100.0, alt, 10.0, tilt}, sweep);
  EXPECT_GT(sweep.culled, 0);
  EXPECT_GT(sweep.visibleByReference, 0);
}

TEST(CullingExtremes, CameraInsideANodesBoundingSphere) {
  const Geodesy g;
  const TileGrid grid = test::globalGrid();
  int visible = 0;
  for (const double lat : {0.0, 46.5, 90.0, -90.0})
    for (const double lon : {0.0, 180.0, -180.0}) {
      // Level 16: ~61 m tiles; the camera 0-10 m above the tile's middle is inside its sphere.
      const auto key = grid.keyAt(lat, lon, 16);
      ASSERT_TRUE(key.has_value());
      const Sector s = grid.sectorOf(*key);
      const NodeGeometry node(g, s);
      const PatchMesh mesh = buildPatchMesh(g, s, 33);
      for (const double alt : {0.0, 1.0, 10.0}) {
        for (const double tilt : {0.0, 45.0, 90.0}) {
          const Camera cam(
              g, {0.5 * (s.south + s.north), 0.5 * (s.west + s.east), alt, 0.0, tilt}, {1024, 768});
          ASSERT_TRUE(node.bounds().contains(cam.position())) << lat << "," << lon << " " << alt;
          const CullResult r = cullNode(cam, node, HorizonOccluder(g));
          // The reference: a vertex of the tile in the frustum (looking straight down from the
          // ground, everything is behind the near plane; the tight box may then cull).
          bool seen = false;
          for (const auto& v : mesh.vertices)
            seen = seen || test::inFrustum(cam, mesh.centre + v.position);
          if (seen) {
            ++visible;
            EXPECT_TRUE(r.visible) << lat << "," << lon << " alt " << alt << " tilt " << tilt;
            EXPECT_EQ(r.frustum, FrustumResult::Intersecting);
          }
        }
      }
    }
  EXPECT_GE(visible, 4 * 3 * 6); // at least alt 1 and 10 at every tilt, everywhere
}

TEST(CullingExtremes, FarOutOnlyTheNearHemisphereSurvives) {
  const Geodesy g;
  const TileGrid grid = test::globalGrid();
  const Camera cam(g, {0.0, 0.0, 1e9, 0.0, 0.0}, {1024, 768}, 5.0);
  int visible = 0;
  for (const Sector& s : test::levelZeroSectors(grid)) {
    const NodeGeometry node(g, s);
    const bool v = cullNode(cam, node, HorizonOccluder(g)).visible;
    visible += v ? 1 : 0;
    // Low-latitude tiles on the far side are hidden (the tests are conservative: big level-0
    // spheres next to the limb may survive, and tiles at the pole touch the limb).
    if (s.south >= -36.0 && s.north <= 36.0 && (s.west >= 108.0 || s.east <= -108.0)) {
      EXPECT_FALSE(v) << s.west << "," << s.south;
    }
    if (s.west >= -36.0 && s.east <= 36.0) {
      EXPECT_TRUE(v) << s.west;
    }
  }
  // Exactly 30 tiles reach within 90 degrees of the nadir (six columns in each row); the tests may
  // keep the polar tiles that touch the limb (at most 20 more) but no more than that.
  EXPECT_GE(visible, 30);
  EXPECT_LE(visible, 38);
}

// The horizon test alone against the segment reference, on spheres scattered around the limb: a
// culled sphere must have no point (on its surface, where the extremes are) that the camera sees.
TEST(CullingExtremes, HorizonSpheresNearTheLimbAgainstSegments) {
  const Geodesy g;
  std::mt19937_64 rng(99);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  int culled = 0, kept = 0;
  for (const double occluderHeight : {0.0, -11000.0}) {
    const HorizonOccluder occ(g, occluderHeight);
    for (int i = 0; i < 6000; ++i) {
      // Camera altitude from 0 to 1e9 m (log-uniform above 1 m), anywhere.
      const double alt = i % 5 == 0 ? 10.0 * u01(rng) : std::pow(10.0, 9.0 * u01(rng));
      const double lat = 180.0 * u01(rng) - 90.0, lon = 360.0 * u01(rng) - 180.0;
      const glm::dvec3 cam = test::vec(g.toEcef(lat, lon, alt));
      // A sphere centred near the horizon as seen from the camera: the angle from the nadir
      // around the horizon angle acos(R / (R + alt)), at a height up to +-20 km, of any size.
      const double R = g.equatorialRadius();
      const double horizon = std::acos(R / (R + alt));
      const double angle =
          i % 3 == 0 ? 0.05 * u01(rng) : horizon * (0.5 + 1.5 * u01(rng)) + 1e-6 * u01(rng);
      const double azimuth = 2.0 * std::numbers::pi * u01(rng);
      const glm::dvec3 up = glm::normalize(cam);
      const glm::dvec3 t1 = glm::normalize(
          glm::cross(up, std::abs(up.z) < 0.9 ? glm::dvec3(0, 0, 1) : glm::dvec3(1, 0, 0)));
      const glm::dvec3 t2 = glm::cross(up, t1);
      const glm::dvec3 dir = std::cos(angle) * up +
                             std::sin(angle) * (std::cos(azimuth) * t1 + std::sin(azimuth) * t2);
      const Geodetic at = g.fromEcef({dir.x * R, dir.y * R, dir.z * R});
      const double heightScale = std::min(2e4, 10.0 * alt + 100.0);
      const glm::dvec3 centre =
          test::vec(g.toEcef(at.latDeg, at.lonDeg, heightScale * (2.0 * u01(rng) - 1.0)));
      const double radius = std::pow(10.0, 7.0 * u01(rng) - 1.0);
      const BoundingSphere sphere{centre, radius};
      if (!occ.isOccluded(cam, sphere)) {
        ++kept;
        continue;
      }
      ++culled;
      for (int k = 0; k < 200; ++k) {
        const double z = 2.0 * u01(rng) - 1.0, phi = 2.0 * std::numbers::pi * u01(rng);
        const double rr = std::sqrt(1.0 - z * z);
        // Half the samples on the side facing the camera's limb, where visibility starts.
        glm::dvec3 n{rr * std::cos(phi), rr * std::sin(phi), z};
        if (k % 2 == 0) n = glm::normalize(n + glm::normalize(cam - centre));
        const glm::dvec3 p = centre + radius * n;
        ASSERT_TRUE(occ.segmentHitsOccluder(cam, p))
            << "sphere " << i << " radius " << radius << " camera alt " << alt;
      }
    }
  }
  EXPECT_GT(culled, 500);
  EXPECT_GT(kept, 500);
}

// The exact horizon test of polar caps against the brute force: whenever a cap is culled, every
// sampled point of it, at its highest height, is hidden by the occluder; and it culls the caps
// a camera cannot see (the sphere test keeps a 36-degree cap whose sphere pokes over the horizon).
TEST(CullingExtremes, PolarCapsBehindTheHorizonAgainstSegments) {
  const Geodesy g;
  const TileGrid grid = test::globalGrid();
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> lat(-90.0, 90.0), lon(-180.0, 180.0), logAlt(0.0, 9.0);
  int culled = 0, kept = 0;
  for (int i = 0; i < 300; ++i) {
    const double la = i < 4 ? (i % 2 ? 90.0 : -90.0) : lat(rng), lo = lon(rng);
    const double alt = i < 4 ? (i < 2 ? 1.0 : 1e9) : std::pow(10.0, logAlt(rng));
    const HorizonOccluder occluder(g, i % 3 == 0 ? -500.0 : 0.0);
    const glm::dvec3 eye = test::vec(g.toEcef(la, lo, alt));
    for (int level : {0, 1, 3, 6, 12, 24}) {
      for (const bool north : {true, false}) {
        const double h = 36.0 / std::ldexp(1.0, level);
        const Sector s =
            north ? Sector{-180.0, 90.0 - h, 180.0, 90.0} : Sector{-180.0, -90.0, 180.0, -90.0 + h};
        const double top = i % 4 == 1 ? 3000.0 : 0.0;
        const NodeGeometry cap(g, s, 0.0, top);
        if (!occluder.isCapOccluded(eye, cap)) {
          ++kept;
          continue;
        }
        ++culled;
        for (int r = 0; r <= 16; ++r)
          for (int c = 0; c < 64; ++c) {
            const double pl = s.south + (s.north - s.south) * r / 16.0;
            const glm::dvec3 p = test::vec(g.toEcef(pl, -180.0 + 360.0 * c / 64.0, top));
            ASSERT_TRUE(occluder.segmentHitsOccluder(eye, p))
                << "camera " << la << " " << lo << " " << alt << " level " << level;
          }
      }
    }
  }
  EXPECT_GT(culled, 500);
  EXPECT_GT(kept, 500);
  // From 20 km at 45 degrees north the level-zero cap (from 54 degrees) lies beyond the horizon
  // (505 km away); its bounding sphere pokes over it, so the sphere test keeps it.
  const HorizonOccluder o(g);
  const glm::dvec3 eye = test::vec(g.toEcef(45.0, 10.0, 2e4));
  const NodeGeometry northCap(g, {-180.0, 54.0, 180.0, 90.0});
  EXPECT_TRUE(o.isCapOccluded(eye, northCap));
  EXPECT_FALSE(o.isOccluded(eye, northCap.bounds()));
  // Any other node: false.
  EXPECT_FALSE(o.isCapOccluded(eye, NodeGeometry(g, {0.0, 54.0, 36.0, 90.0})));
  EXPECT_FALSE(o.isCapOccluded(eye, NodeGeometry(g, {-180.0, 0.0, 180.0, 36.0})));
  (void)grid;
}
