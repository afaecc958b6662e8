// The astronomy of the scene's time against Meeus's worked examples ("Astronomical Algorithms",
// 2nd ed.): sidereal time (12.a), the sun (25.a) and precession (21.b).
#include <tellus/planet/Astronomy.hpp>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace {

using namespace tellus::planet::astro;

constexpr double kDeg = std::numbers::pi / 180.0;

double unixOfJd(double jd) {
  return (jd - kUnixEpochJd) * 86400.0;
}

TEST(Astronomy, JulianDateOfKnownInstants) {
  EXPECT_DOUBLE_EQ(julianDate(0.0), 2440587.5);
  EXPECT_DOUBLE_EQ(julianDate(946728000.0), kJ2000Jd); // 2000-01-01T12:00:00Z
  EXPECT_NEAR(julianCenturies(946728000.0), 0.0, 1e-15);
}

TEST(Astronomy, SiderealTimeOfMeeus12a) {
  // 1987 April 10, 0h UT: 13h10m46.3668s.
  const double expected = (13.0 + 10.0 / 60.0 + 46.3668 / 3600.0) * 15.0 * kDeg;
  EXPECT_NEAR(greenwichMeanSiderealTime(unixOfJd(2446895.5)), expected, 1e-8);
}

TEST(Astronomy, SunOfMeeus25a) {
  // 1992 October 13.0 TD: apparent RA 13h13m31.4s, declination -7 47' 01", R 0.99766 AU.
  const SunPlace p = sunPlace(unixOfJd(2448908.5));
  EXPECT_NEAR(
      p.rightAscensionRad, (13.0 + 13.0 / 60.0 + 31.4 / 3600.0) * 15.0 * kDeg, 0.002 * kDeg);
  EXPECT_NEAR(p.declinationRad, -(7.0 + 47.0 / 60.0 + 1.0 / 3600.0) * kDeg, 0.002 * kDeg);
  EXPECT_NEAR(p.distanceAu, 0.99766, 1e-5);
}

TEST(Astronomy, PrecessionOfMeeus21b) {
  // Theta Persei (J2000.0 place moved by its proper motion) to 2028 November 13.19 TD.
  const glm::dvec3 v0 = equatorialDirection(41.054063 * kDeg, 49.227750 * kDeg);
  const glm::dvec3 v = precessionFromJ2000(unixOfJd(2462088.69)) * v0;
  const double ra = std::atan2(v.y, v.x), dec = std::asin(v.z);
  EXPECT_NEAR(ra, 41.547214 * kDeg, 1e-7); // 0.02 arc second
  EXPECT_NEAR(dec, 49.348483 * kDeg, 1e-7);
}

TEST(Astronomy, SunOverheadNearTheTropicAtTheJuneSolsticeNoonInGreenwich) {
  // 2024-06-20T12:00Z: the subsolar point is near 23.44 N and near 0 E (the equation of time
  // is about -1.6 min then: 0.4 degree).
  const glm::dvec3 s = sunDirectionEcef(1718884800.0);
  EXPECT_NEAR(glm::length(s), 1.0, 1e-12);
  EXPECT_NEAR(std::asin(s.z) / kDeg, 23.43, 0.05);
  EXPECT_NEAR(std::atan2(s.y, s.x) / kDeg, 0.4, 0.3);
}

} // namespace
