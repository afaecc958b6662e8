// The dome's GL-free camera model (issue #7): the fisheye map, the LOD measured in the fisheye's
// pixels, culling against the cone, the tilt.
#include "PlanetTestSupport.hpp"

#include <tellus/planet/Culling.hpp>
#include <tellus/planet/Lod.hpp>
#include <tellus/planet/Quadtree.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

using namespace tellus;
using namespace tellus::planet;

namespace {

constexpr double kPi = std::numbers::pi;

double deg(double r) {
  return r * 180.0 / kPi;
}

/** The direction at theta from the camera's axis, phi from its right towards its up. */
glm::dvec3 direction(const Camera& c, double thetaDeg, double phiDeg) {
  const double t = thetaDeg * kPi / 180.0, p = phiDeg * kPi / 180.0;
  return std::cos(t) * c.forward() + std::sin(t) * (std::cos(p) * c.right() + std::sin(p) * c.up());
}

} // namespace

TEST(Dome, FisheyeMapsAnglesToRadiiLinearly) {
  const Geodesy g;
  for (const double fov : {180.0, 220.0}) {
    const int n = 1000;
    const Camera cam(g, {10.0, 20.0, 3e6, 30.0, 40.0}, n, Fisheye{fov, 0.0});
    EXPECT_TRUE(cam.isFisheye());
    EXPECT_NEAR(cam.pixelsPerRadian(), n / (fov * kPi / 180.0), 1e-9);
    EXPECT_NEAR(deg(cam.fisheyeHalfAngleRad()), fov / 2.0, 1e-12);
    for (const double theta : {0.0, 10.0, 45.0, 89.0, 90.0, 100.0, 110.0})
      for (const double phi : {0.0, 30.0, 135.0, 260.0}) {
        glm::dvec2 px{};
        ASSERT_TRUE(cam.projectPx(cam.position() + 1e5 * direction(cam, theta, phi), px));
        const double r = theta / fov * n; // theta = FOV / 2 lands on the circle (n / 2)
        EXPECT_NEAR(std::hypot(px.x, px.y), r, 1e-6) << theta << " " << phi;
        if (theta > 0.0) {
          EXPECT_NEAR(px.x, r * std::cos(phi * kPi / 180.0), 1e-6);
          EXPECT_NEAR(px.y, r * std::sin(phi * kPi / 180.0), 1e-6);
        }
      }
    // Straight behind has no direction in the map; nearer than the near plane neither.
    glm::dvec2 px{};
    EXPECT_FALSE(cam.projectPx(cam.position() - 1e5 * cam.forward(), px));
    EXPECT_FALSE(cam.projectPx(cam.position() + 0.01 * cam.forward(), px));
  }
}

TEST(Dome, TiltTurnsTheAxisUp) {
  const Geodesy g;
  const CameraPose pose{45.0, 7.0, 1e6, 30.0, 20.0};
  for (const double tilt : {0.0, 30.0, 70.0, 160.0}) {
    const Camera dome(g, pose, 512, Fisheye{180.0, tilt});
    CameraPose turned = pose;
    turned.tiltDeg += tilt; // turning the axis up is the pose's tilt, for tilts the pose allows
    const Camera flat(g, turned, {512, 512}, 45.0);
    for (int i = 0; i < 3; ++i) {
      EXPECT_NEAR(dome.forward()[i], flat.forward()[i], 1e-12) << tilt;
      EXPECT_NEAR(dome.up()[i], flat.up()[i], 1e-12) << tilt;
      EXPECT_NEAR(dome.right()[i], flat.right()[i], 1e-12) << tilt;
    }
  }
  // Tilted past the zenith and below the nadir: still an orthonormal frame.
  const Camera back(g, pose, 512, Fisheye{220.0, -60.0});
  EXPECT_NEAR(glm::dot(back.forward(), back.up()), 0.0, 1e-12);
  EXPECT_NEAR(glm::length(back.right()), 1.0, 1e-12);
}

TEST(Dome, RejectsBadFisheyes) {
  const Geodesy g;
  EXPECT_THROW(Camera(g, CameraPose{}, 512, Fisheye{0.0, 0.0}), std::invalid_argument);
  EXPECT_THROW(Camera(g, CameraPose{}, 512, Fisheye{360.0, 0.0}), std::invalid_argument);
  EXPECT_THROW(Camera(g, CameraPose{}, 512, Fisheye{180.0, std::nan("")}), std::invalid_argument);
  EXPECT_THROW(Camera(g, CameraPose{}, 0, Fisheye{}), std::invalid_argument);
}

// The same node seen from the same place, once at the dome's centre and once at its rim (the axis
// tilted 90 degrees, so the node lies 90 degrees off it, below the centre): along the radius (its
// north-south edges here) the fisheye has N / FOV pixels per radian everywhere, so the split
// decision is the same; around the axis (east-west here) the map stretches by theta / sin(theta),
// pi / 2 at the rim of a 180-degree dome, and the LOD measures that too (what the pixels show).
TEST(Dome, RimAndCentreAgreeAlongTheRadius) {
  const Geodesy g;
  const CameraPose pose{0.0, 0.0, 1e6, 0.0, 0.0}; // straight down, north up
  const NodeGeometry node(g, {-0.25, -0.25, 0.25, 0.25});
  const Camera centre(g, pose, 1024, Fisheye{180.0, 0.0});
  const Camera rim(g, pose, 1024, Fisheye{180.0, 90.0});
  glm::dvec2 pc{}, pr{};
  ASSERT_TRUE(centre.projectPx(test::vec(g.toEcef(0.0, 0.0, 0.0)), pc));
  ASSERT_TRUE(rim.projectPx(test::vec(g.toEcef(0.0, 0.0, 0.0)), pr));
  EXPECT_NEAR(std::hypot(pc.x, pc.y), 0.0, 1e-6);
  EXPECT_NEAR(pr.y, -512.0, 1e-6); // on the circle, below the centre

  // North-south alone decides (east-west texels never count: a huge tile width).
  LodParams ns{1 << 30, 8, 1.0};
  const LodResult c0 = evaluateLod(centre, node, ns);
  const LodResult r0 = evaluateLod(rim, node, ns);
  ASSERT_GT(c0.worstRatioSquared, 0.0);
  EXPECT_NEAR(std::sqrt(r0.worstRatioSquared / c0.worstRatioSquared), 1.0, 0.02);
  // A tile height just above and just below the edge's length in pixels: the same decision.
  const double edgePx = std::sqrt(c0.worstRatioSquared) * ns.tileHeightPx;
  for (const double f : {0.9, 1.1}) {
    ns.tileHeightPx = static_cast<int>(std::lround(edgePx * f));
    const bool splitsAtCentre = evaluateLod(centre, node, ns).split;
    EXPECT_EQ(splitsAtCentre, f < 1.0);
    EXPECT_EQ(evaluateLod(rim, node, ns).split, splitsAtCentre) << f;
  }
  // East-west alone: pi / 2 longer at the rim.
  const LodParams ew{8, 1 << 30, 1.0};
  const double ratio = std::sqrt(evaluateLod(rim, node, ew).worstRatioSquared /
                                 evaluateLod(centre, node, ew).worstRatioSquared);
  EXPECT_NEAR(ratio, kPi / 2.0, 0.03);
}

// The texel-to-pixel guarantee on the dome: a node the LOD leaves unsplit shows no texel larger
// than the threshold in fisheye pixels, sampled over its surface (both axes, anywhere in the cone).
TEST(Dome, TexelToPixelHoldsOnTheDome) {
  const Geodesy g;
  const TileGrid grid = test::globalGrid();
  for (const double fov : {180.0, 220.0})
    for (const CameraPose pose : {CameraPose{0.0, 0.0, 1e6, 0.0, 0.0},
                                  CameraPose{45.0, 7.0, 2e5, 30.0, 90.0},
                                  CameraPose{-30.0, 100.0, 5e4, 0.0, 60.0}}) {
      const Camera cam(g, pose, 1024, Fisheye{fov, 0.0});
      QuadtreeParams qp;
      qp.lod = {256, 256, 1.0};
      qp.maxSplitsPerFrame = 1 << 20;
      Quadtree tree(g, grid, qp);
      for (int i = 0; i < 40; ++i)
        if (tree.update(cam).splitsDeferred == 0 && tree.stats().created == 0) break;
      ASSERT_GT(tree.drawList().size(), 0u);
      double worst = 0.0;
      for (const Node* n : tree.drawList()) {
        const Sector& s = n->sector();
        const double texLon = (s.east - s.west) / 256.0, texLat = (s.north - s.south) / 256.0;
        for (int a = 0; a <= 8; ++a)
          for (int b = 0; b <= 8; ++b) {
            const double lat = s.south + (s.north - s.south) * a / 8.0;
            const double lon = s.west + (s.east - s.west) * b / 8.0;
            if (std::abs(lat) > 89.0) continue;
            glm::dvec2 p{}, e{}, q{};
            const glm::dvec3 at = test::vec(g.toEcef(lat, lon, 0.0));
            const glm::dvec3 d = at - cam.position();
            const double theta = std::acos(glm::dot(glm::normalize(d), cam.forward()));
            if (theta > cam.fisheyeHalfAngleRad()) continue; // not on the dome
            // Hidden behind the globe: not shown.
            if (glm::dot(d, glm::normalize(at)) > 0.0) continue;
            if (!cam.projectPx(at, p) ||
                !cam.projectPx(test::vec(g.toEcef(lat, lon + texLon, 0.0)), e) ||
                !cam.projectPx(test::vec(g.toEcef(lat + texLat, lon, 0.0)), q))
              continue;
            const double m = std::max(glm::length(e - p), glm::length(q - p));
            worst = std::max(worst, m);
          }
      }
      EXPECT_LE(worst, 1.03) << fov << " " << pose.latDeg << " " << pose.altitudeM;
      EXPECT_GT(worst, 0.3) << fov; // the test saw texels near the limit
    }
}

TEST(Dome, CullingKeepsTheConeAndDropsWhatIsBehind) {
  const Geodesy g(EarthModel::Sphere);
  const TileGrid grid = test::globalGrid();
  const CameraPose down{0.0, 0.0, 2e5, 0.0, 0.0}, up{0.0, 0.0, 2e5, 0.0, 180.0};
  const NodeGeometry nadir(g, {-0.5, -0.5, 0.5, 0.5});
  EXPECT_EQ(classifyNode(Camera(g, down, 512, Fisheye{180.0, 0.0}), nadir), FrustumResult::Inside);
  EXPECT_EQ(classifyNode(Camera(g, up, 512, Fisheye{180.0, 0.0}), nadir), FrustumResult::Outside);
  EXPECT_EQ(classifyNode(Camera(g, up, 512, Fisheye{220.0, 0.0}), nadir), FrustumResult::Outside);
  // Looking up from 200 km the limb is 14.1 degrees below the horizontal: a 220-degree dome
  // (20 degrees below) sees the ground next to the limb, a 180-degree one sees none.
  const double dip = deg(std::acos(g.equatorialRadius() / (g.equatorialRadius() + 2e5)));
  EXPECT_NEAR(dip, 14.1, 0.1);
  const HorizonOccluder occ(g);
  for (const double fov : {180.0, 220.0}) {
    const Camera cam(g, up, 512, Fisheye{fov, 0.0});
    int visible = 0;
    for (std::int64_t r = 0; r < grid.rowCount(5); ++r)
      for (std::int64_t c = 0; c < grid.colCount(5); ++c) {
        const Sector s = grid.sectorOf({5, r, c});
        if (std::abs(s.south) > 40.0 || std::abs(s.west) > 40.0) continue;
        const NodeGeometry n(g, s);
        const CullResult cr = cullNode(cam, n, occ);
        // Brute force: a sample of the node within the cone and not behind the globe must keep it.
        bool seen = false;
        for (int a = 0; a <= 4 && !seen; ++a)
          for (int b = 0; b <= 4 && !seen; ++b) {
            const glm::dvec3 p = test::vec(g.toEcef(s.south + (s.north - s.south) * a / 4.0,
                                                    s.west + (s.east - s.west) * b / 4.0,
                                                    0.0));
            const glm::dvec3 d = glm::normalize(p - cam.position());
            seen = std::acos(glm::dot(d, cam.forward())) <= cam.fisheyeHalfAngleRad() &&
                   !occ.segmentHitsOccluder(cam.position(), p);
          }
        if (seen) {
          EXPECT_TRUE(cr.visible) << fov << " " << s.south << "," << s.west;
        }
        visible += cr.visible ? 1 : 0;
      }
    if (fov == 180.0)
      EXPECT_EQ(visible, 0);
    else
      EXPECT_GT(visible, 0);
  }
}

// Tile selection runs once with the fisheye camera: its draw list covers the whole dome, more than
// a 90-degree face's and every drawn node reaches into the cone.
TEST(Dome, OneUpdateCoversTheDome) {
  const Geodesy g;
  const TileGrid grid = test::globalGrid();
  const CameraPose pose{45.0, 7.0, 5e5, 0.0, 90.0};
  const Camera dome(g, pose, 1024, Fisheye{180.0, 0.0});
  Quadtree tree(g, grid, {});
  for (int i = 0; i < 30; ++i)
    tree.update(dome);
  for (const Node* n : tree.drawList())
    EXPECT_NE(classifyCone(dome, n->geometry().bounds()), FrustumResult::Outside);
  // Behind the camera (looking north, the ground to the south) is drawn by no node.
  const NodeGeometry south(g, {40.0, 6.0, 40.5, 6.5});
  EXPECT_EQ(classifyNode(dome, south), FrustumResult::Outside);
  bool northSeen = false;
  for (const Node* n : tree.drawList()) {
    const Sector& s = n->sector();
    northSeen = northSeen || (s.south <= 50.0 && s.north >= 50.0 && s.west <= 7.0 && s.east >= 7.0);
  }
  EXPECT_TRUE(northSeen);
}
