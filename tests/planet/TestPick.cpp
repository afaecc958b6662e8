// The point on the globe under a pixel (planet/Pick.hpp; issue 24): the centre pixel of a nadir
// view is the pose's point, a pixel's ray projects back onto that pixel, the sky misses, a fisheye
// stops at its circle; extremes at the poles, across the antimeridian, 1 m and 1e9 m up.

#include <tellus/planet/Pick.hpp>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <utility>

using namespace tellus;
using namespace tellus::planet;

namespace {

double lonDiff(double a, double b) {
  return std::remainder(a - b, 360.0);
}

TEST(Pick, CentreOfANadirViewIsThePosesPoint) {
  const Geodesy wgs;
  const Camera cam(wgs, {47.3, 8.5, 5000.0, 0.0, 0.0}, {640, 480});
  const auto g = pickGlobe(cam, wgs, 0.0, 0.0);
  ASSERT_TRUE(g);
  EXPECT_NEAR(g->latDeg, 47.3, 1e-9);
  EXPECT_NEAR(lonDiff(g->lonDeg, 8.5), 0.0, 1e-9);
}

TEST(Pick, APickedPointProjectsBackOntoItsPixel) {
  const Geodesy wgs;
  const Camera cam(wgs, {-20.0, 130.0, 3.0e5, 40.0, 30.0}, {800, 600}, 60.0);
  for (const auto& [dx, dy] : std::array<std::pair<double, double>, 4>{
           {{0.5, -0.5}, {300.5, 200.5}, {-399.5, -250.5}, {10.0, 100.0}}}) {
    const auto g = pickGlobe(cam, wgs, dx, dy);
    ASSERT_TRUE(g) << dx << "," << dy;
    const Ecef e = wgs.toEcef(g->latDeg, g->lonDeg, 0.0);
    glm::dvec2 px;
    ASSERT_TRUE(cam.projectPx({e.x, e.y, e.z}, px));
    EXPECT_NEAR(px.x, dx, 1e-6);
    EXPECT_NEAR(px.y, dy, 1e-6);
  }
}

TEST(Pick, TheSkyMissesAndARaisedSurfaceIsMetFirst) {
  const Geodesy wgs;
  const Camera cam(wgs, {0.0, 0.0, 1.0e4, 0.0, 90.0}, {100, 100}); // looking at the horizon
  EXPECT_FALSE(pickGlobe(cam, wgs, 0.0, 49.5));                    // above it
  const Camera down(wgs, {0.0, 0.0, 1.0e4, 0.0, 0.0}, {100, 100});
  EXPECT_NEAR(*rayEllipsoidDistance(wgs, down.position(), down.forward(), 0.0), 1.0e4, 1e-6);
  EXPECT_NEAR(*rayEllipsoidDistance(wgs, down.position(), down.forward(), 4000.0), 6.0e3, 1e-6);
}

TEST(Pick, AFisheyeStopsAtItsCircle) {
  const Geodesy wgs;
  const Camera dome(wgs, {10.0, 10.0, 1.0e7, 0.0, 0.0}, 512, Fisheye{180.0, 0.0});
  EXPECT_TRUE(pickGlobe(dome, wgs, 0.0, 0.0));
  EXPECT_TRUE(pixelRay(dome, 255.0, 0.0));
  EXPECT_FALSE(pixelRay(dome, 200.0, 200.0)); // outside the inscribed circle
  const auto g = pickGlobe(dome, wgs, 0.0, 0.0);
  EXPECT_NEAR(g->latDeg, 10.0, 1e-9);
}

TEST(PickExtremes, PolesAntimeridianOneMetreAndABillionMetres) {
  const Geodesy wgs;
  for (const double lat : {90.0, -90.0, 89.9999}) {
    const Camera cam(wgs, {lat, 0.0, 1000.0, 0.0, 0.0}, {64, 64});
    const auto g = pickGlobe(cam, wgs, 0.0, 0.0);
    ASSERT_TRUE(g);
    EXPECT_NEAR(g->latDeg, lat, 1e-9);
  }
  const Camera anti(wgs, {0.0, 180.0, 1.0e5, 0.0, 0.0}, {64, 64});
  const auto east = pickGlobe(anti, wgs, 20.0, 0.0), west = pickGlobe(anti, wgs, -20.0, 0.0);
  ASSERT_TRUE(east && west);
  EXPECT_GT(lonDiff(east->lonDeg, 180.0), 0.0);
  EXPECT_LT(lonDiff(west->lonDeg, 180.0), 0.0);
  const Camera low(wgs, {45.0, 45.0, 1.0, 0.0, 0.0}, {64, 64});
  EXPECT_NEAR(*rayEllipsoidDistance(wgs, low.position(), low.forward()), 1.0, 1e-6);
  const Camera far(wgs, {45.0, 45.0, 1.0e9, 0.0, 0.0}, {64, 64});
  const auto g = pickGlobe(far, wgs, 0.0, 0.0);
  ASSERT_TRUE(g);
  EXPECT_NEAR(g->latDeg, 45.0, 1e-7);
  EXPECT_NEAR(*rayEllipsoidDistance(wgs, far.position(), far.forward()), 1.0e9, 1e-3);
}

} // namespace
