// The dome's GL-free camera model (issue #7): the fisheye map, the LOD measured in the fisheye's
// pixels, culling against the cone, the tilt; the direct method's vertex map (the shader's,
// mirrored in DomeDirect.hpp) and the error of its straight edges.
#include "PlanetTestSupport.hpp"

#include <tellus/planet/Culling.hpp>
#include <tellus/planet/DomeDirect.hpp>
#include <tellus/planet/Lod.hpp>
#include <tellus/planet/Quadtree.hpp>

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
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

// The direct method's map (what shaders/planet.vert computes with TELLUS_FISHEYE) is the camera's
// fisheye: the same pixels as projectPx, in units of the circle's radius.
TEST(DomeDirect, MapIsTheFisheyeOfProjectPx) {
  const Geodesy g;
  for (const double fov : {180.0, 220.0})
    for (const double tilt : {0.0, 35.0, -60.0}) {
      const Camera cam(g, {10.0, 20.0, 3e6, 30.0, 40.0}, 1000, Fisheye{fov, tilt});
      const double alpha = cam.fisheyeHalfAngleRad(), radiusPx = 500.0;
      for (const double theta : {0.0, 1e-7, 10.0, 89.0, 90.0, 109.0, 150.0, 178.0})
        for (const double phi : {0.0, 30.0, 135.0, 260.0}) {
          const glm::dvec3 w = cam.position() + 1e5 * direction(cam, theta, phi);
          const FisheyeMapped m = fisheyeMap(toDomeFrame(cam, w), alpha);
          EXPECT_NEAR(deg(m.theta), theta, 1e-9);
          EXPECT_NEAR(m.dist, 1e5, 1e-6);
          glm::dvec2 px{};
          ASSERT_TRUE(cam.projectPx(w, px));
          EXPECT_NEAR(m.xy.x * radiusPx, px.x, 1e-6) << theta << " " << phi;
          EXPECT_NEAR(m.xy.y * radiusPx, px.y, 1e-6) << theta << " " << phi;
        }
    }
}

TEST(DomeDirect, MapAtTheAxisNearlyBehindAndMinusZero) {
  const double alpha = kPi / 2.0;
  // On the axis: the centre, theta 0; -0.0 the same, no NaN.
  for (const glm::dvec3 q :
       {glm::dvec3(0.0, 0.0, -5.0), glm::dvec3(-0.0, -0.0, -5.0), glm::dvec3(-0.0, 0.0, -1e7)}) {
    const FisheyeMapped m = fisheyeMap(q, alpha);
    EXPECT_EQ(m.theta, 0.0);
    EXPECT_EQ(m.xy.x, 0.0);
    EXPECT_EQ(m.xy.y, 0.0);
  }
  // Next to the axis the limit (q.xy / |q|) and the general branch (theta / |q.xy|) agree: no jump
  // where the shader switches (|q.xy| = 1e-6 |q|).
  for (const double lateral : {1e-9, 0.999e-6, 1.001e-6, 1e-5}) {
    const FisheyeMapped m = fisheyeMap({lateral * 3.0, -lateral * 4.0, -1.0}, alpha);
    const double r = 5.0 * lateral; // |q.xy| at distance ~1: theta = atan(5 lateral)
    EXPECT_NEAR(m.xy.x, 0.6 * std::atan(r) / alpha, 1e-15) << lateral;
    EXPECT_NEAR(m.xy.y, -0.8 * std::atan(r) / alpha, 1e-15) << lateral;
  }
  // Nearly straight behind: theta near pi from atan2 (acos would lose it), the direction kept down
  // to 1e-6 rad off it (twice the rim's radius for a 180-degree dome: clipped); nearer still,
  // finite and fading to the centre (its direction is lost).
  for (const double off : {1e-3, 1.001e-6, 1e-9, 1e-300}) {
    const FisheyeMapped m = fisheyeMap({0.0, off, 1.0}, alpha);
    EXPECT_NEAR(m.theta, kPi - std::atan(off), 1e-15) << off;
    EXPECT_EQ(m.xy.x, 0.0);
    if (off > 1e-6) {
      EXPECT_NEAR(m.xy.y, m.theta / alpha, 1e-12) << off;
    } else {
      EXPECT_TRUE(std::isfinite(m.xy.y) && m.xy.y >= 0.0 && m.xy.y < 2.0) << off;
    }
  }
  // Exactly behind: theta pi (the clip distance drops it).
  EXPECT_EQ(fisheyeMap({0.0, 0.0, 1.0}, alpha).theta, kPi);
  EXPECT_EQ(fisheyeMap({-0.0, 0.0, 1.0}, alpha).theta, kPi);
}

// The tilt turns the axis up: the pose's own forward direction lands tilt degrees below the
// image's centre.
TEST(DomeDirect, TiltPutsThePosesForwardBelowTheCentre) {
  const Geodesy g;
  const CameraPose pose{45.0, 7.0, 1e6, 30.0, 60.0};
  const Camera flat(g, pose, {512, 512}, 45.0);
  for (const double tilt : {0.0, 20.0, 90.0}) {
    const Camera dome(g, pose, 1024, Fisheye{180.0, tilt});
    const FisheyeMapped m =
        fisheyeMap(toDomeFrame(dome, dome.position() + 1e4 * flat.forward()), kPi / 2.0);
    EXPECT_NEAR(deg(m.theta), tilt, 1e-9);
    EXPECT_NEAR(m.xy.x, 0.0, 1e-12);
    EXPECT_NEAR(m.xy.y, -tilt / 90.0, 1e-12);
  }
}

// A chord of the theta = 90 degree ring at the rim of a 180-degree dome, ends at azimuths +-phi:
// its middle (the 3D midpoint, at theta 90 as well) lies on the circle, the drawn edge's middle
// at cos(phi) of the radius: (1 - cos phi) R, the sagitta L^2 / (8 R) of a drawn edge L = 2 phi R.
// A segment symmetric about the axis is drawn exactly; one at the centre nearly so.
TEST(DomeDirect, EdgeErrorIsTheSagitta) {
  const Geodesy g;
  const Camera cam(g, {0.0, 0.0, 1e6, 0.0, 0.0}, 1024, Fisheye{180.0, 0.0});
  const double R = 512.0;
  auto at = [&](double x, double y, double z) { // dome frame -> world
    return cam.position() + x * cam.right() + y * cam.up() - z * cam.forward();
  };
  for (const double phi : {0.01, 0.05, 0.2}) {
    const double d = 1e5;
    const double e = directEdgeErrorPx(cam,
                                       at(d * std::cos(phi), d * std::sin(phi), 0.0),
                                       at(d * std::cos(phi), -d * std::sin(phi), 0.0));
    EXPECT_NEAR(e, (1.0 - std::cos(phi)) * R, 1e-6 * R) << phi;
    const double L = 2.0 * phi * R;
    EXPECT_NEAR(e, L * L / (8.0 * R), 0.01 * L * L / (8.0 * R) + 1e-9) << phi;
  }
  EXPECT_NEAR(directEdgeErrorPx(cam, at(-300.0, 0.0, -1e4), at(300.0, 0.0, -1e4)), 0.0, 1e-9);
  // 16 px at the centre, seen at a slant (ends at different distances): well under a pixel.
  EXPECT_LT(directEdgeErrorPx(cam, at(-500.0, 100.0, -1e4), at(0.0, 100.0, -1.1e4)), 0.05);
}

TEST(DomeDirect, EdgeErrorOutsideTheConeAndWhereTheMapFails) {
  const Geodesy g;
  const Camera cam(g, {0.0, 0.0, 1e6, 0.0, 0.0}, 1024, Fisheye{180.0, 0.0});
  auto at = [&](double x, double y, double z) {
    return cam.position() + x * cam.right() + y * cam.up() - z * cam.forward();
  };
  // Wholly behind the clip angle: drawn nowhere, no error.
  EXPECT_EQ(directEdgeErrorPx(cam, at(-10.0, 0.0, 100.0), at(10.0, 0.0, 100.0)), 0.0);
  // A 90-degree dome: both ends beyond the rim at opposite sides, the segment passing across the
  // axis: its middle is in the cone, the clipped straight edge would drop it (a hole): infinite.
  const Camera narrow(g, {0.0, 0.0, 1e6, 0.0, 0.0}, 1024, Fisheye{90.0, 0.0});
  auto atNarrow = [&](double x, double y, double z) {
    return narrow.position() + x * narrow.right() + y * narrow.up() - z * narrow.forward();
  };
  EXPECT_EQ(
      directEdgeErrorPx(narrow, atNarrow(-1000.0, 0.0, -500.0), atNarrow(1000.0, 0.0, -500.0)),
      std::numeric_limits<double>::infinity());
  // An end straight behind the eye: it cannot be mapped.
  EXPECT_EQ(directEdgeErrorPx(cam, at(0.0, 0.0, 100.0), at(0.0, 0.0, -100.0)),
            std::numeric_limits<double>::infinity());
  // An end nearer than the near distance.
  EXPECT_EQ(directEdgeErrorPx(cam, at(0.0, 0.0, -0.01), at(10.0, 0.0, -100.0)),
            std::numeric_limits<double>::infinity());
}

namespace {

/** The tree settled for a view, and the largest error over every cell of every drawn node (the
 * brute force the sampled estimate stands for). */
struct FrameError {
  double sampled = 0.0, full = 0.0, ms = 0.0;
  std::size_t nodes = 0;
};
FrameError frameError(const Geodesy& g, const TileGrid& grid, const Camera& cam, int meshSize) {
  QuadtreeParams qp;
  qp.lod = {grid.spec().tileWidth, grid.spec().tileHeight, 1.0};
  qp.maxSplitsPerFrame = 1 << 20;
  Quadtree tree(g, grid, qp);
  for (int i = 0; i < 60; ++i)
    if (tree.update(cam).splitsDeferred == 0 && tree.stats().created == 0) break;
  FrameError f;
  f.nodes = tree.drawList().size();
  const auto t0 = std::chrono::steady_clock::now();
  f.sampled = directChordErrorPx(cam, tree.drawList(), meshSize);
  f.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  for (const Node* node : tree.drawList()) {
    const int n = node->meshSize(meshSize), rows = meshSize; // a cap has more columns
    const Sector& s = node->sector();
    auto v = [&](int r, int c) {
      return test::vec(
          g.toEcef(edgeLerp(s.south, s.north, r, rows), edgeLerp(s.west, s.east, c, n), 0.0));
    };
    for (int r = 0; r + 1 < rows; ++r)
      for (int c = 0; c + 1 < n; ++c)
        for (const auto& [a, b] : {std::pair{v(r, c), v(r, c + 1)},
                                   {v(r, c), v(r + 1, c)},
                                   {v(r, c), v(r + 1, c + 1)},
                                   {v(r, c + 1), v(r + 1, c)}})
          f.full = std::max(f.full, directEdgeErrorPx(cam, a, b));
  }
  return f;
}

} // namespace

// The frame's estimate over the views a dome flies, a 1024-pixel domemaster with the default mesh
// (33 x 33) and 512-pixel tiles (triangles of at most ~16 px where the LOD is met): sub-pixel, and
// within a few percent of the brute force over every cell. Near the ground with a shallow dataset
// (3 levels: the LOD cannot split, triangles hundreds of pixels across) it is large: those frames
// are drawn with the cube method.
TEST(DomeDirect, FrameErrorSubPixelWhereTheLodHoldsLargeWhereItCannot) {
  const Geodesy g;
  GridSpec deepSpec;
  deepSpec.numLevels = 20;
  const TileGrid deep = *TileGrid::create(deepSpec);
  GridSpec shallowSpec;
  shallowSpec.numLevels = 3;
  const TileGrid shallow = *TileGrid::create(shallowSpec);
  struct View {
    CameraPose pose;
    double fov, tilt;
  };
  for (const View& v : {View{{45.5, 7.5, 5e5, 0.0, 90.0}, 180.0, 0.0},
                        View{{20.0, 10.0, 2e6, 0.0, 0.0}, 180.0, 0.0},
                        View{{45.0, 7.0, 8e5, 30.0, 60.0}, 200.0, 20.0},
                        View{{30.0, 40.0, 3000.0, 20.0, 90.0}, 220.0, 0.0},
                        View{{30.0, 40.0, 30.0, 20.0, 80.0}, 220.0, 30.0}}) {
    const Camera cam(g, v.pose, 1024, Fisheye{v.fov, v.tilt});
    const FrameError f = frameError(g, deep, cam, 33);
    EXPECT_LT(f.sampled, 0.5) << v.pose.altitudeM;
    EXPECT_LT(f.full, 0.5) << v.pose.altitudeM;
    std::printf(
        "view alt %.0f fov %.0f: %zu nodes, sampled %.4f px (%.3f ms), every cell %.4f px\n",
        v.pose.altitudeM,
        v.fov,
        f.nodes,
        f.sampled,
        f.ms,
        f.full);
    EXPECT_GE(f.sampled, 0.9 * f.full) << v.pose.altitudeM;
    if (v.pose.altitudeM < 1e5) {
      const FrameError s = frameError(g, shallow, cam, 33);
      EXPECT_GT(s.sampled, 5.0) << v.pose.altitudeM;
    }
  }
}
