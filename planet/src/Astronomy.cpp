#include <tellus/planet/Astronomy.hpp>

#include <cmath>
#include <numbers>

namespace tellus::planet::astro {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;
constexpr double kArcSec = kDeg / 3600.0;

/** Rotation of a vector about z by `a` (counter-clockwise seen from +z). */
glm::dmat3 rotZ(double a) noexcept {
  const double c = std::cos(a), s = std::sin(a);
  // glm is column-major: columns are the images of x, y and z.
  return glm::dmat3(c, s, 0.0, -s, c, 0.0, 0.0, 0.0, 1.0);
}

/** Rotation of a vector about y by `a`. */
glm::dmat3 rotY(double a) noexcept {
  const double c = std::cos(a), s = std::sin(a);
  return glm::dmat3(c, 0.0, -s, 0.0, 1.0, 0.0, s, 0.0, c);
}

double wrapTwoPi(double a) noexcept {
  a = std::fmod(a, 2.0 * kPi);
  return a < 0.0 ? a + 2.0 * kPi : a;
}

} // namespace

double julianDate(double unixSeconds) noexcept {
  return kUnixEpochJd + unixSeconds / 86400.0;
}

double julianCenturies(double unixSeconds) noexcept {
  // (unix - J2000's unix) / seconds per century: no large Julian date is formed first.
  constexpr double kJ2000Unix = (kJ2000Jd - kUnixEpochJd) * 86400.0;
  return (unixSeconds - kJ2000Unix) / (86400.0 * 36525.0);
}

double greenwichMeanSiderealTime(double unixSeconds) noexcept {
  const double t = julianCenturies(unixSeconds);
  const double days = t * 36525.0;
  // Meeus 12.4; the day count's whole turns taken out before multiplying keeps the degrees small.
  const double turns = 0.98564736629 * days; // 360.98564736629 = 360 + 0.98564736629 deg/day
  const double deg =
      280.46061837 + 360.0 * std::fmod(days, 1.0) + turns + t * t * (0.000387933 - t / 38710000.0);
  return wrapTwoPi(deg * kDeg);
}

glm::dmat3 precessionFromJ2000(double unixSeconds) noexcept {
  const double t = julianCenturies(unixSeconds);
  const double zeta = (2306.2181 + (0.30188 + 0.017998 * t) * t) * t * kArcSec;
  const double z = (2306.2181 + (1.09468 + 0.018203 * t) * t) * t * kArcSec;
  const double theta = (2004.3109 - (0.42665 + 0.041833 * t) * t) * t * kArcSec;
  // Meeus 21.4 as rotations: v_date = Rz(z) Ry(-theta) Rz(zeta) v_J2000.
  return rotZ(z) * rotY(-theta) * rotZ(zeta);
}

glm::dmat3 celestialToEcef(double unixSeconds) noexcept {
  return rotZ(-greenwichMeanSiderealTime(unixSeconds)) * precessionFromJ2000(unixSeconds);
}

glm::dvec3 equatorialDirection(double raRad, double decRad) noexcept {
  const double c = std::cos(decRad);
  return {c * std::cos(raRad), c * std::sin(raRad), std::sin(decRad)};
}

SunPlace sunPlace(double unixSeconds) noexcept {
  const double t = julianCenturies(unixSeconds);
  const double l0 = 280.46646 + t * (36000.76983 + 0.0003032 * t);
  const double m = (357.52911 + t * (35999.05029 - 0.0001537 * t)) * kDeg;
  const double e = 0.016708634 - t * (0.000042037 + 0.0000001267 * t);
  const double c = std::sin(m) * (1.914602 - t * (0.004817 + 0.000014 * t)) +
                   std::sin(2.0 * m) * (0.019993 - 0.000101 * t) + std::sin(3.0 * m) * 0.000289;
  const double trueLongitude = l0 + c;
  const double trueAnomaly = m + c * kDeg;
  const double omega = (125.04 - 1934.136 * t) * kDeg;
  const double lambda = (trueLongitude - 0.00569 - 0.00478 * std::sin(omega)) * kDeg;
  const double eps0 =
      23.0 + (26.0 + (21.448 - t * (46.815 + t * (0.00059 - t * 0.001813))) / 60.0) / 60.0;
  const double eps = (eps0 + 0.00256 * std::cos(omega)) * kDeg;
  SunPlace p;
  p.rightAscensionRad = wrapTwoPi(std::atan2(std::cos(eps) * std::sin(lambda), std::cos(lambda)));
  p.declinationRad = std::asin(std::sin(eps) * std::sin(lambda));
  p.distanceAu = 1.000001018 * (1.0 - e * e) / (1.0 + e * std::cos(trueAnomaly));
  return p;
}

glm::dvec3 sunDirectionEcef(double unixSeconds) noexcept {
  const SunPlace p = sunPlace(unixSeconds);
  // Of date already: only the Earth's turn remains.
  return rotZ(-greenwichMeanSiderealTime(unixSeconds)) *
         equatorialDirection(p.rightAscensionRad, p.declinationRad);
}

} // namespace tellus::planet::astro
