// Geodesy, culling and LOD on every body (issue 26): the Earth's tests, parameterised by body
// (the Earth, the Moon, Mars and a triaxial one), with the extremes at the poles, at the
// 180-degree meridian and at 1 m and 1e9 m above the surface.
#include "PlanetTestSupport.hpp"

#include <tellus/planet/Body.hpp>
#include <tellus/planet/Culling.hpp>
#include <tellus/planet/Lod.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>

using namespace tellus;
using namespace tellus::planet;

namespace {

/** A Vesta-like triaxial ellipsoid (Archinal et al. 2018 give Vesta 286.3 x 278.6 x 223.2 km). */
Body triaxialBody() {
  Body b;
  b.name = "vesta";
  b.radiusA = 286300.0;
  b.radiusB = 278600.0;
  b.radiusC = 223200.0;
  return b;
}

Body bodyNamed(const std::string& name) {
  if (name == "vesta") return triaxialBody();
  return *builtinBody(name);
}

double dist(const Ecef& a, const Ecef& b) {
  return std::hypot(a.x - b.x, a.y - b.y, a.z - b.z);
}

class BodyGeodesy : public ::testing::TestWithParam<std::string> {};
class BodyGeodesyExtremes : public ::testing::TestWithParam<std::string> {};
class BodyLod : public ::testing::TestWithParam<std::string> {};
class BodyLodExtremes : public ::testing::TestWithParam<std::string> {};

const auto kBodies = ::testing::Values("earth", "moon", "mars", "vesta");

} // namespace

TEST(Body, BuiltInsHaveThePublishedRadii) {
  EXPECT_EQ(builtinBodyNames(), (std::vector<std::string>{"earth", "moon", "mars"}));
  const Body moon = moonBody();
  EXPECT_TRUE(moon.isSphere());
  EXPECT_EQ(moon.radiusA, 1737400.0);
  EXPECT_FALSE(moon.atmosphere.has_value());
  EXPECT_EQ(moon.iauCrsCode, 30100);
  const Body mars = marsBody();
  EXPECT_EQ(mars.radiusA, 3396190.0);
  EXPECT_EQ(mars.radiusC, 3376200.0);
  EXPECT_FALSE(mars.isTriaxial());
  ASSERT_TRUE(mars.atmosphere.has_value());
  EXPECT_EQ(mars.atmosphere->validate(), "");
  EXPECT_EQ(mars.atmosphere->bottomRadiusM, mars.radiusA);
  EXPECT_EQ(mars.iauCrsCode, 49900);
  EXPECT_TRUE(earthBody().atmosphere.has_value());
  EXPECT_FALSE(builtinBody("pluto").has_value());
}

TEST(Body, BadShapesAreRefusedWithAReason) {
  Body b = triaxialBody();
  b.radiusB = b.radiusA + 1.0;
  EXPECT_NE(b.validate().find("must not exceed radius a"), std::string::npos);
  EXPECT_THROW(Geodesy{b}, std::invalid_argument);
  b = triaxialBody();
  b.radiusC = -1.0;
  EXPECT_NE(b.validate().find("finite and positive"), std::string::npos);
  b.radiusC = std::nan("");
  EXPECT_THROW(Geodesy{b}, std::invalid_argument);
  b = triaxialBody();
  b.name.clear();
  EXPECT_NE(b.validate(), "");
}

TEST(Body, EarthModelsAreTheEarthBodiesBitForBit) {
  const Geodesy wgs(EarthModel::Wgs84), wgsBody(earthBody());
  const Geodesy sphere(EarthModel::Sphere), sphereBody(earthSphereBody());
  EXPECT_EQ(wgsBody.model(), EarthModel::Wgs84);
  EXPECT_EQ(sphereBody.model(), EarthModel::Sphere);
  EXPECT_EQ(wgs.body().name, "earth");
  EXPECT_EQ(sphere.body().name, "earth");
  for (const double lat : {-90.0, -33.3, 0.0, 45.0, 89.9})
    for (const double lon : {-180.0, 0.0, 12.5, 180.0}) {
      const Ecef a = wgs.toEcef(lat, lon, 123.0), b = wgsBody.toEcef(lat, lon, 123.0);
      EXPECT_EQ(a.x, b.x);
      EXPECT_EQ(a.y, b.y);
      EXPECT_EQ(a.z, b.z);
      const Ecef c = sphere.toEcef(lat, lon, 0.0), d = sphereBody.toEcef(lat, lon, 0.0);
      EXPECT_EQ(c.x, d.x);
      EXPECT_EQ(c.z, d.z);
    }
  EXPECT_EQ(wgs.polarRadius(), Geodesy(earthBody()).polarRadius());
}

TEST_P(BodyGeodesy, AxesMatchTheRadii) {
  const Body body = bodyNamed(GetParam());
  const Geodesy g(body);
  EXPECT_EQ(g.equatorialRadius(), body.radiusA);
  EXPECT_EQ(g.minEquatorialRadius(), body.radiusB);
  EXPECT_NEAR(g.toEcef(0, 0, 0).x, body.radiusA, 1e-6);
  EXPECT_NEAR(g.toEcef(0, 90, 0).y, body.radiusB, 1e-6);
  EXPECT_NEAR(g.toEcef(90, 0, 0).z, body.radiusC, 1e-6);
  EXPECT_NEAR(g.toEcef(-90, 0, 0).z, -body.radiusC, 1e-6);
  // The height is along the normal: 1000 m up moves the point 1000 m.
  EXPECT_NEAR(dist(g.toEcef(30, 40, 1000.0), g.toEcef(30, 40, 0.0)), 1000.0, 1e-6);
}

TEST_P(BodyGeodesy, RoundTripIsSubMillimetre) {
  const Body body = bodyNamed(GetParam());
  const Geodesy g(body);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> lat(-90, 90), lon(-180, 180),
      h(-0.01 * body.radiusC, 3.0 * body.radiusA);
  for (int i = 0; i < 2000; ++i) {
    const double la = lat(rng), lo = lon(rng), he = h(rng);
    const Geodetic back = g.fromEcef(g.toEcef(la, lo, he));
    ASSERT_NEAR(back.latDeg, la, 1e-10) << la << " " << lo << " " << he;
    ASSERT_NEAR(back.lonDeg, lo, 1e-10);
    ASSERT_NEAR(back.heightM, he, 1e-6);
  }
}

TEST_P(BodyGeodesy, NormalIsPerpendicularToTheSurface) {
  const Geodesy g(bodyNamed(GetParam()));
  for (const double lat : {-60.0, -10.0, 0.0, 25.0, 70.0})
    for (const double lon : {-150.0, -20.0, 0.0, 45.0, 100.0}) {
      const Ecef n = g.surfaceNormal(lat, lon);
      const Ecef east = g.toEcef(lat, lon + 1e-6, 0.0), west = g.toEcef(lat, lon - 1e-6, 0.0);
      const Ecef north = g.toEcef(lat + 1e-6, lon, 0.0), south = g.toEcef(lat - 1e-6, lon, 0.0);
      const double te[3] = {east.x - west.x, east.y - west.y, east.z - west.z};
      const double tn[3] = {north.x - south.x, north.y - south.y, north.z - south.z};
      const double le = std::hypot(te[0], te[1], te[2]), ln = std::hypot(tn[0], tn[1], tn[2]);
      EXPECT_NEAR((te[0] * n.x + te[1] * n.y + te[2] * n.z) / le, 0.0, 1e-7);
      EXPECT_NEAR((tn[0] * n.x + tn[1] * n.y + tn[2] * n.z) / ln, 0.0, 1e-7);
    }
}

TEST_P(BodyGeodesyExtremes, PolesMeridian180AndAltitudes) {
  const Body body = bodyNamed(GetParam());
  const Geodesy g(body);
  for (const double h : {0.0, 1.0, 1e9})
    for (const double lat : {-90.0, 90.0}) {
      const Geodetic p = g.fromEcef(g.toEcef(lat, 77.0, h));
      EXPECT_NEAR(p.latDeg, lat, 1e-12);
      EXPECT_EQ(p.lonDeg, 0.0); // at the poles the longitude is 0
      EXPECT_NEAR(p.heightM, h, 1e-9 * std::max(1.0, h));
    }
  for (const double h : {1.0, 1e9})
    for (const double lon : {180.0, -180.0, 179.999999999, -179.999999999}) {
      const Ecef e = g.toEcef(12.0, lon, h);
      const Geodetic p = g.fromEcef(e);
      EXPECT_NEAR(std::abs(p.lonDeg), std::abs(lon), 1e-9);
      EXPECT_NEAR(p.heightM, h, h == 1.0 ? 1e-6 : 1e-3);
      EXPECT_NEAR(p.latDeg, 12.0, 1e-11);
    }
  // 1 m above the surface is 1 m above it, to a micrometre, everywhere.
  for (const double lat : {-89.9999, -45.0, 0.0, 45.0, 89.9999}) {
    const Geodetic p = g.fromEcef(g.toEcef(lat, -179.5, 1.0));
    EXPECT_NEAR(p.heightM, 1.0, 1e-6);
  }
  const Ecef bad = g.toEcef(90.5, 0.0, 0.0);
  EXPECT_TRUE(std::isnan(bad.x));
}

TEST_P(BodyLod, LevelZeroFromThreeRadiiAndTheHorizon) {
  const Geodesy g(bodyNamed(GetParam()));
  const double r = g.equatorialRadius();
  const TileGrid grid = test::globalGrid();
  const Camera cam(g, {0.0, 0.0, 3.0 * r, 0.0, 0.0}, {1024, 768}, 45.0);
  const HorizonOccluder occ(g);
  int visible = 0;
  for (const Sector& s : test::levelZeroSectors(grid)) {
    const NodeGeometry node(g, s);
    if (!cullNode(cam, node, occ).visible) continue;
    ++visible;
    EXPECT_FALSE(evaluateLod(cam, node, {512, 512, 1.0}).split);
  }
  // The same view at every scale: the near hemisphere's tiles, never the far side's.
  EXPECT_GE(visible, 6);
  EXPECT_LE(visible, 30);
  const NodeGeometry farSide(g, {-180.0, -18.0, -144.0, 18.0});
  EXPECT_FALSE(cullNode(cam, farSide, occ).visible);
  // From 1 km the tile under the camera splits for 256-pixel tiles.
  const Camera low(g, {0.0, 0.0, 1000.0, 0.0, 0.0}, {1024, 768}, 45.0);
  EXPECT_TRUE(evaluateLod(low, NodeGeometry(g, {0.0, 0.0, 36.0, 36.0}), {256, 256, 1.0}).split);
  // The occluder is the body's (its inscribed biaxial ellipsoid on a triaxial one).
  EXPECT_EQ(occ.equatorialRadiusM, g.minEquatorialRadius());
  EXPECT_EQ(occ.polarRadiusM, g.polarRadius());
}

TEST_P(BodyLodExtremes, FiniteOverACameraSweep) {
  const Geodesy g(bodyNamed(GetParam()));
  const TileGrid grid = test::globalGrid();
  const HorizonOccluder occ(g);
  int evaluated = 0;
  for (const double lat : {-90.0, 0.0, 90.0})
    for (const double lon : {-180.0, 0.0, 180.0})
      for (const double alt : {1.0, 1e5, 1e9}) {
        const Camera cam(g, {lat, lon, alt, 45.0, 0.0}, {640, 480});
        const glm::dvec3 at = cam.position();
        EXPECT_NEAR(g.fromEcef({at.x, at.y, at.z}).heightM, alt, std::max(1e-6, alt * 1e-12));
        std::vector<Sector> sectors = test::levelZeroSectors(grid);
        for (const Sector& s : test::sectorsAround(grid, lat, lon, 16))
          sectors.push_back(s);
        for (const Sector& s : sectors) {
          const NodeGeometry node(g, s);
          ASSERT_TRUE(test::finite(node.bounds().centre));
          const LodResult r = evaluateLod(cam, node, {512, 512, 1.0});
          ASSERT_TRUE(std::isfinite(r.worstRatioSquared));
          (void)cullNode(cam, node, occ);
          ++evaluated;
        }
      }
  EXPECT_GT(evaluated, 500);
}

INSTANTIATE_TEST_SUITE_P(Bodies, BodyGeodesy, kBodies);
INSTANTIATE_TEST_SUITE_P(Bodies, BodyGeodesyExtremes, kBodies);
INSTANTIATE_TEST_SUITE_P(Bodies, BodyLod, kBodies);
INSTANTIATE_TEST_SUITE_P(Bodies, BodyLodExtremes, kBodies);
