#include "MoonTerms.hpp"

#include <tellus/planet/Astronomy.hpp>
#include <tellus/planet/IauRotation.hpp>
#include <tellus/planet/Moon.hpp>

#include <glm/mat3x3.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <numbers>

namespace tellus::planet::astro {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;
constexpr double kArcSec = kDeg / 3600.0;

/** Degrees reduced to [0, 360) and turned into radians. */
double reducedRad(double deg) noexcept {
  deg = std::fmod(deg, 360.0);
  return (deg < 0.0 ? deg + 360.0 : deg) * kDeg;
}

double wrapTwoPi(double a) noexcept {
  a = std::fmod(a, 2.0 * kPi);
  return a < 0.0 ? a + 2.0 * kPi : a;
}

/** The mean arguments of chapter 47 (47.1 to 47.5), degrees. */
struct LunarArguments {
  double lp, d, m, mp, f;
};

LunarArguments lunarArguments(double t) noexcept {
  const double t2 = t * t, t3 = t2 * t, t4 = t3 * t;
  LunarArguments a;
  a.lp = 218.3164477 + 481267.88123421 * t - 0.0015786 * t2 + t3 / 538841.0 - t4 / 65194000.0;
  a.d = 297.8501921 + 445267.1114034 * t - 0.0018819 * t2 + t3 / 545868.0 - t4 / 113065000.0;
  a.m = 357.5291092 + 35999.0502909 * t - 0.0001536 * t2 + t3 / 24490000.0;
  a.mp = 134.9633964 + 477198.8675055 * t + 0.0087414 * t2 + t3 / 69699.0 - t4 / 14712000.0;
  a.f = 93.2720950 + 483202.0175233 * t - 0.0036539 * t2 - t3 / 3526000.0 + t4 / 863310000.0;
  return a;
}

/** The Earth's eccentricity factor of terms in M (47.6): E^|m|. */
double eccentricityFactor(int m, double e) noexcept {
  const int k = std::abs(m);
  return k == 0 ? 1.0 : (k == 1 ? e : e * e);
}

/** Ecliptic longitude/latitude (mean equinox of date) and distance to equatorial, same units. */
glm::dvec3 eclipticToEquatorial(double lon, double lat, double dist, double eps) noexcept {
  const double cb = std::cos(lat);
  const double x = dist * cb * std::cos(lon);
  const double y = dist * cb * std::sin(lon);
  const double z = dist * std::sin(lat);
  const double ce = std::cos(eps), se = std::sin(eps);
  return {x, ce * y - se * z, se * y + ce * z};
}

} // namespace

double ttCenturies(double unixSeconds) noexcept {
  return julianCenturies(unixSeconds + kTdbMinusUtcSeconds);
}

Nutation nutationTt(double t) noexcept {
  const double t2 = t * t, t3 = t2 * t;
  // Meeus 22: D, M, M', F and the longitude of the Moon's ascending node, degrees.
  const double d = 297.85036 + 445267.111480 * t - 0.0019142 * t2 + t3 / 189474.0;
  const double m = 357.52772 + 35999.050340 * t - 0.0001603 * t2 - t3 / 300000.0;
  const double mp = 134.96298 + 477198.867398 * t + 0.0086972 * t2 + t3 / 56250.0;
  const double f = 93.27191 + 483202.017538 * t - 0.0036825 * t2 + t3 / 327270.0;
  const double om = 125.04452 - 1934.136261 * t + 0.0020708 * t2 + t3 / 450000.0;
  double psi = 0.0, eps = 0.0;
  for (const detail::NutationTerm& n : detail::kNutationTerms) {
    const double arg = reducedRad(n.d * d + n.m * m + n.mp * mp + n.f * f + n.omega * om);
    psi += (n.psi + n.psiT * t) * std::sin(arg);
    eps += (n.eps + n.epsT * t) * std::cos(arg);
  }
  Nutation out;
  out.longitudeRad = psi * 1e-4 * kArcSec;
  out.obliquityRad = eps * 1e-4 * kArcSec;
  // 22.2: 23 26' 21.448" - 46.8150" T - 0.00059" T^2 + 0.001813" T^3.
  out.meanObliquityRad =
      (23.0 + 26.0 / 60.0) * kDeg + (21.448 - 46.8150 * t - 0.00059 * t2 + 0.001813 * t3) * kArcSec;
  return out;
}

MoonPlace moonPlaceTt(double t) noexcept {
  const LunarArguments a = lunarArguments(t);
  const double e = 1.0 - 0.002516 * t - 0.0000074 * t * t;
  double sumL = 0.0, sumR = 0.0, sumB = 0.0;
  for (const detail::MoonLongitudeDistanceTerm& k : detail::kMoonLongitudeDistanceTerms) {
    const double arg = reducedRad(k.d * a.d + k.m * a.m + k.mp * a.mp + k.f * a.f);
    const double ef = eccentricityFactor(k.m, e);
    sumL += k.sinLongitude * ef * std::sin(arg);
    sumR += k.cosDistance * ef * std::cos(arg);
  }
  for (const detail::MoonLatitudeTerm& k : detail::kMoonLatitudeTerms) {
    const double arg = reducedRad(k.d * a.d + k.m * a.m + k.mp * a.mp + k.f * a.f);
    sumB += k.sinLatitude * eccentricityFactor(k.m, e) * std::sin(arg);
  }
  // Venus (A1), Jupiter (A2) and the Earth's flattening (L' - F, A3 ...).
  const double a1 = reducedRad(119.75 + 131.849 * t);
  const double a2 = reducedRad(53.09 + 479264.290 * t);
  const double a3 = reducedRad(313.45 + 481266.484 * t);
  const double lp = reducedRad(a.lp), f = reducedRad(a.f), mp = reducedRad(a.mp);
  sumL += 3958.0 * std::sin(a1) + 1962.0 * std::sin(lp - f) + 318.0 * std::sin(a2);
  sumB += -2235.0 * std::sin(lp) + 382.0 * std::sin(a3) + 175.0 * std::sin(a1 - f) +
          175.0 * std::sin(a1 + f) + 127.0 * std::sin(lp - mp) - 115.0 * std::sin(lp + mp);

  MoonPlace p;
  p.longitudeRad = wrapTwoPi(lp + sumL * 1e-6 * kDeg);
  p.latitudeRad = sumB * 1e-6 * kDeg;
  p.distanceM = (385000.56 + sumR * 1e-3) * 1000.0;
  const Nutation n = nutationTt(t);
  p.apparentLongitudeRad = wrapTwoPi(p.longitudeRad + n.longitudeRad);
  const double eps = n.trueObliquity();
  const glm::dvec3 q = eclipticToEquatorial(p.apparentLongitudeRad, p.latitudeRad, 1.0, eps);
  p.rightAscensionRad = wrapTwoPi(std::atan2(q.y, q.x));
  p.declinationRad = std::asin(std::clamp(q.z, -1.0, 1.0));
  return p;
}

MoonPlace moonPlace(double unixSeconds) noexcept {
  return moonPlaceTt(ttCenturies(unixSeconds));
}

glm::dvec3 moonPositionCelestial(double unixSeconds) noexcept {
  const double t = ttCenturies(unixSeconds);
  const MoonPlace p = moonPlaceTt(t);
  const glm::dvec3 ofDate = eclipticToEquatorial(
      p.longitudeRad, p.latitudeRad, p.distanceM, nutationTt(t).meanObliquityRad);
  // Mean equator of date back to J2000.0: the transpose of the precession.
  return glm::transpose(precessionFromJ2000(unixSeconds)) * ofDate;
}

glm::dvec3 moonPositionEcef(double unixSeconds) noexcept {
  return celestialToEcef(unixSeconds) * moonPositionCelestial(unixSeconds);
}

} // namespace tellus::planet::astro
