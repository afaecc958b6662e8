#include <tellus/planet/Geodesy.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <random>

using namespace tellus;

namespace {
double dist(const Ecef& a, const Ecef& b) {
  return std::hypot(a.x - b.x, a.y - b.y, a.z - b.z);
}
} // namespace

TEST(Geodesy, Wgs84AxesAndPoles) {
  const Geodesy g;
  EXPECT_EQ(g.model(), EarthModel::Wgs84);
  EXPECT_DOUBLE_EQ(g.equatorialRadius(), 6378137.0);
  EXPECT_NEAR(g.polarRadius(), 6356752.314245, 1e-6);
  const Ecef e = g.toEcef(0, 0, 0);
  EXPECT_DOUBLE_EQ(e.x, 6378137.0);
  EXPECT_EQ(e.y, 0.0);
  EXPECT_EQ(e.z, 0.0);
  const Ecef n = g.toEcef(90, 0, 0);
  EXPECT_NEAR(n.x, 0.0, 1e-9);
  EXPECT_NEAR(n.z, g.polarRadius(), 1e-6);
  const Ecef up = g.surfaceNormal(90, 123);
  EXPECT_NEAR(up.z, 1.0, 1e-15);
}

TEST(Geodesy, RoundTripIsSubMillimetre) {
  const Geodesy g;
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> lat(-90, 90), lon(-180, 180), h(-11000, 1e7);
  for (int i = 0; i < 2000; ++i) {
    const double la = lat(rng), lo = lon(rng), he = h(rng);
    const Geodetic back = g.fromEcef(g.toEcef(la, lo, he));
    EXPECT_NEAR(back.latDeg, la, 1e-11);
    EXPECT_NEAR(back.heightM, he, 1e-6);
    if (std::abs(la) < 89.999) {
      EXPECT_NEAR(back.lonDeg, lo, 1e-9);
    }
  }
}

TEST(Geodesy, SphereDiffersFromTheEllipsoidByKilometres) {
  const Geodesy wgs(EarthModel::Wgs84), sphere(EarthModel::Sphere);
  double worst = 0;
  for (double lat = -90; lat <= 90; lat += 0.5)
    worst = std::max(worst, dist(wgs.toEcef(lat, 30, 0), sphere.toEcef(lat, 30, 0)));
  EXPECT_GT(worst, 7000.0);
  EXPECT_LT(worst, 25000.0);
}

TEST(GeodesyExtremes, AntimeridianSignedZeroAndNonFinite) {
  const Geodesy g;
  const Ecef a = g.toEcef(12.5, 180.0, 0), b = g.toEcef(12.5, -180.0, 0);
  EXPECT_EQ(a.x, b.x);
  EXPECT_EQ(a.z, b.z);
  EXPECT_EQ(std::abs(a.y), 0.0);
  EXPECT_EQ(std::abs(b.y), 0.0);
  const Ecef z1 = g.toEcef(-0.0, -0.0, 0), z2 = g.toEcef(0.0, 0.0, 0);
  EXPECT_EQ(z1.x, z2.x);
  for (const Ecef p : {g.toEcef(NAN, 0, 0),
                       g.toEcef(0, NAN, 0),
                       g.toEcef(0, 0, NAN),
                       g.toEcef(90.5, 0, 0),
                       g.toEcef(0, INFINITY, 0),
                       g.toEcef(-INFINITY, 0, 0),
                       g.toEcef(0, 0, INFINITY)}) {
    EXPECT_TRUE(std::isnan(p.x) && std::isnan(p.y) && std::isnan(p.z));
  }
  EXPECT_TRUE(std::isnan(g.surfaceNormal(NAN, 0).x));
  // 1e9 m above the north pole, 1 m above the equator: both exact to the millimetre.
  EXPECT_NEAR(g.toEcef(90, 0, 1e9).z, g.polarRadius() + 1e9, 1e-3);
  EXPECT_NEAR(g.toEcef(0, 0, 1).x, 6378138.0, 1e-6);
  // Two points 1 mm apart at the deepest tile level stay 1 mm apart in ECEF.
  const double d = dist(g.toEcef(45, 7, 0), g.toEcef(45 + 1e-3 / 111132.954, 7, 0));
  EXPECT_NEAR(d, 1e-3, 1e-5);
}
