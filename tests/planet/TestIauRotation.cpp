// The WGCCRE rotational elements evaluated (IauRotation.hpp): the constants at J2000.0, Mars's
// 2015 model against the 2009 constants and its sidereal day, the Moon's pole against Cassini's
// laws (1.54 degree from the ecliptic pole, on the far side of it from the orbit's pole), the
// Earth's prime meridian against GMST, and the matrices' orthonormality.
#include <tellus/planet/Astronomy.hpp>
#include <tellus/planet/IauRotation.hpp>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace {

using namespace tellus::planet;

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kJ2000Unix = (astro::kJ2000Jd - astro::kUnixEpochJd) * 86400.0;
constexpr double kYear = 365.25 * 86400.0;

double angleDeg(const glm::dvec3& a, const glm::dvec3& b) {
  return std::atan2(glm::length(glm::cross(a, b)), glm::dot(a, b)) / kDeg;
}

void expectRotation(const glm::dmat3& m) {
  const glm::dmat3 mtm = glm::transpose(m) * m;
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r)
      EXPECT_NEAR(mtm[c][r], c == r ? 1.0 : 0.0, 1e-14);
  EXPECT_NEAR(glm::determinant(m), 1.0, 1e-14);
}

TEST(IauRotation, TdbDaysCountFromJ2000InTdb) {
  EXPECT_NEAR(iauDaysFromJ2000(kJ2000Unix - kTdbMinusUtcSeconds), 0.0, 1e-12);
  EXPECT_NEAR(iauDaysFromJ2000(kJ2000Unix + 86400.0 - kTdbMinusUtcSeconds), 1.0, 1e-12);
}

TEST(IauRotation, ElementsAtJ2000AreTheConstants) {
  const IauOrientation earth = evaluateIauRotation(iauEarth(), 0.0);
  EXPECT_DOUBLE_EQ(earth.poleRaDeg, 0.0);
  EXPECT_DOUBLE_EQ(earth.poleDecDeg, 90.0);
  EXPECT_DOUBLE_EQ(earth.primeMeridianDeg, 190.147);
  // Without its periodic terms the Moon is its constants; with them, the constants plus each
  // term at its argument's epoch value.
  IauRotation moonMean = iauMoon();
  moonMean.terms.clear();
  const IauOrientation mean = evaluateIauRotation(moonMean, 0.0);
  EXPECT_DOUBLE_EQ(mean.poleRaDeg, 269.9949);
  EXPECT_DOUBLE_EQ(mean.poleDecDeg, 66.5392);
  EXPECT_DOUBLE_EQ(mean.primeMeridianDeg, 38.3213);
  // E1 = 125.045 dominates: -3.8787 sin E1, 1.5419 cos E1, 3.5610 sin E1.
  const IauOrientation moon = evaluateIauRotation(iauMoon(), 0.0);
  const double e1 = 125.045 * kDeg;
  EXPECT_NEAR(moon.poleRaDeg, 269.9949 - 3.8787 * std::sin(e1), 0.3);
  EXPECT_NEAR(moon.poleDecDeg, 66.5392 + 1.5419 * std::cos(e1), 0.1);
  EXPECT_NEAR(moon.primeMeridianDeg, 38.3213 + 3.5610 * std::sin(e1), 0.3);
  EXPECT_EQ(iauMoon().terms.size(), 13u);
}

TEST(IauRotation, Mars2015ModelGivesThe2009ConstantsAtJ2000) {
  // WGCCRE 2009: alpha0 = 317.68143, delta0 = 52.88650, W = 176.630 at J2000.0; the 2015 model's
  // long-period terms (0.5042615 degree a century) carry the difference.
  const IauOrientation mars = evaluateIauRotation(iauMars(), 0.0);
  EXPECT_NEAR(mars.poleRaDeg, 317.68143, 0.003);
  EXPECT_NEAR(mars.poleDecDeg, 52.88650, 0.003);
  EXPECT_NEAR(mars.primeMeridianDeg, 176.630, 0.003);
  // And their rates: 2009's -0.1061 and -0.0609 degree a century.
  const IauOrientation later = evaluateIauRotation(iauMars(), 36525.0);
  EXPECT_NEAR(later.poleRaDeg - mars.poleRaDeg, -0.1061, 0.01);
  EXPECT_NEAR(later.poleDecDeg - mars.poleDecDeg, -0.0609, 0.02);
}

TEST(IauRotation, MarsSiderealDayIs24h37m22_66s) {
  const double sol = (24.0 * 60.0 + 37.0) * 60.0 + 22.66; // seconds
  for (const double years : {-10.0, 0.0, 24.0}) {
    const double d = years * 365.25;
    const double w0 = evaluateIauRotation(iauMars(), d).primeMeridianDeg;
    const double w1 = evaluateIauRotation(iauMars(), d + sol / 86400.0).primeMeridianDeg;
    // 0.01 s of Mars's turn is 0.00004 degree.
    EXPECT_NEAR(std::remainder(w1 - w0, 360.0), 0.0, 0.01 * 350.892 / 86400.0) << years;
  }
}

TEST(IauRotation, MoonPoleFollowsCassinisLaws) {
  // The ecliptic's pole (J2000: RA 270, dec 90 - 23.4393) and the Moon's mean ascending node.
  const glm::dvec3 eclipticPole =
      astro::equatorialDirection(270.0 * kDeg, (90.0 - 23.439291) * kDeg);
  const glm::dvec3 equinox(1.0, 0.0, 0.0);
  const glm::dvec3 eclipticY = glm::cross(eclipticPole, equinox);
  for (const double years : {-20.0, -3.3, 0.0, 4.1, 9.0, 17.5, 26.0}) {
    const double d = years * 365.25;
    const IauOrientation o = evaluateIauRotation(iauMoon(), d);
    const glm::dvec3 pole = astro::equatorialDirection(o.poleRaDeg * kDeg, o.poleDecDeg * kDeg);
    // The lunar equator is inclined 1.543 degrees to the ecliptic (with the physical libration:
    // within 0.05).
    EXPECT_NEAR(angleDeg(pole, eclipticPole), 1.543, 0.06) << years;
    // Its pole's ecliptic longitude is the orbit's ascending node + 90 degrees (the orbit's pole
    // is at node - 90): the three poles in one plane, the ecliptic's between.
    const double node = 125.04452 - 1934.136261 * (d / 36525.0); // Meeus 47.7
    const double poleLon = std::atan2(glm::dot(pole, eclipticY), glm::dot(pole, equinox)) / kDeg;
    EXPECT_NEAR(std::remainder(poleLon - (node + 90.0), 360.0), 0.0, 3.0) << years;
  }
}

TEST(IauRotation, EarthPrimeMeridianFollowsGmstWithinTheModelsDifference) {
  // The IAU Earth model against GMST with IAU 1976 precession: both x axes in the celestial
  // frame. They are 0.025 degree apart at J2000 (W's constant is rounded to 0.001 degree and
  // counts TDB, GMST UT1) and drift apart by 0.0023 degree a year (W's rate, 360.9856235, is not
  // the rate of the Earth's turn against the J2000 frame to that many digits); the linear pole
  // stays within 0.0001 degree of the precession's for decades.
  for (const double years : {-20.0, -5.0, 0.0, 10.5, 24.0, 30.0}) {
    const double t = kJ2000Unix + years * kYear;
    const glm::dmat3 iau = iauBodyFixedToCelestial(iauEarth(), t);
    const glm::dmat3 ecefToCelestial = glm::transpose(astro::celestialToEcef(t));
    EXPECT_LT(angleDeg(iau[0], ecefToCelestial[0]), 0.03 + 0.0025 * std::abs(years)) << years;
    EXPECT_LT(angleDeg(iau[2], ecefToCelestial[2]), 0.0002) << years;
  }
}

TEST(IauRotation, MatrixColumnsAreThePrimeMeridianAndThePole) {
  IauOrientation o;
  o.poleRaDeg = 40.0;
  o.poleDecDeg = 60.0;
  o.primeMeridianDeg = 0.0;
  glm::dmat3 m = iauBodyFixedToCelestial(o);
  expectRotation(m);
  EXPECT_LT(angleDeg(m[2], astro::equatorialDirection(40.0 * kDeg, 60.0 * kDeg)), 1e-12);
  // W = 0: x is the node, on the celestial equator at RA alpha0 + 90.
  EXPECT_LT(angleDeg(m[0], astro::equatorialDirection(130.0 * kDeg, 0.0)), 1e-12);
  // W = 90: x is 90 degrees east along the body's equator, rising towards the pole's side.
  o.primeMeridianDeg = 90.0 + 360.0 * 5.0;
  m = iauBodyFixedToCelestial(o);
  EXPECT_NEAR(glm::dot(m[0], m[2]), 0.0, 1e-14);
  EXPECT_NEAR(m[0].z, std::cos(60.0 * kDeg), 1e-12);
  // The body's east: d(x)/dW is y, and the turn about +z is counter-clockwise (prograde).
  for (const IauRotation* r : {&iauEarth(), &iauMoon(), &iauMars()}) {
    const double t = kJ2000Unix + 7.3 * kYear;
    const glm::dmat3 a = iauBodyFixedToCelestial(*r, t);
    const glm::dmat3 b = iauBodyFixedToCelestial(*r, t + 60.0);
    expectRotation(a);
    EXPECT_GT(glm::dot(b[0] - a[0], a[1]), 0.0);
  }
}

TEST(IauRotationExtremes, FarDatesGiveFiniteOrthonormalMatrices) {
  // 1900, 2100, the Unix epoch and a far negative time: elements finite, matrices rotations.
  for (const double t : {-2208988800.0, 4102444800.0, 0.0, -6.0e10, 6.0e10}) {
    for (const IauRotation* r : {&iauEarth(), &iauMoon(), &iauMars()}) {
      const IauOrientation o = evaluateIauRotation(*r, iauDaysFromJ2000(t));
      EXPECT_TRUE(std::isfinite(o.poleRaDeg) && std::isfinite(o.poleDecDeg) &&
                  std::isfinite(o.primeMeridianDeg));
      const glm::dmat3 m = iauBodyFixedToCelestial(*r, t);
      for (int c = 0; c < 3; ++c)
        EXPECT_TRUE(std::isfinite(m[c].x + m[c].y + m[c].z));
      expectRotation(m);
    }
  }
}

TEST(IauRotationExtremes, PrimeMeridianKeepsItsPrecisionAtLargeDayCounts) {
  // A century from J2000 the Earth's W is 1.3e7 degrees; one second later it must still move by
  // the rate's 0.004178 degree to 1e-9.
  const double d = 36525.0;
  const double w0 = evaluateIauRotation(iauEarth(), d).primeMeridianDeg;
  const double w1 = evaluateIauRotation(iauEarth(), d + 1.0 / 86400.0).primeMeridianDeg;
  EXPECT_NEAR(std::remainder(w1 - w0, 360.0), 360.9856235 / 86400.0, 1e-9);
}

} // namespace
