#include <tellus/planet/Astronomy.hpp>
#include <tellus/planet/Ephemeris.hpp>
#include <tellus/planet/IauRotation.hpp>
#include <tellus/planet/Moon.hpp>

#include <glm/geometric.hpp>

#include <cmath>
#include <numbers>

namespace tellus::planet::astro {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;
constexpr double kObliquityJ2000Deg = 23.43928; // Standish's J2000 ecliptic -> ICRF equator

/** Keplerian elements at J2000.0 and their rates per Julian century (Standish, Table 1). */
struct Elements {
  double a, e, inclination, meanLongitude, perihelionLongitude, nodeLongitude; // au, -, degrees
};
struct ElementsWithRates {
  Elements at;
  Elements rate;
};

constexpr ElementsWithRates kEarthMoonBarycentre{
    {1.00000261, 0.01671123, -0.00001531, 100.46457166, 102.93768193, 0.0},
    {0.00000562, -0.00004392, -0.01294668, 35999.37244981, 0.32327364, 0.0}};
constexpr ElementsWithRates kMars{
    {1.52371034, 0.09339410, 1.84969142, -4.55343205, -23.94362959, 49.55953891},
    {0.00001847, 0.00007882, -0.00813131, 19140.30268499, 0.44441088, -0.29257343}};

/** Julian centuries of TDB from J2000.0. */
double tdbCenturies(double unixSeconds) noexcept {
  return iauDaysFromJ2000(unixSeconds) / 36525.0;
}

/** Solves Kepler's equation E - e sin E = M (radians) by Newton's method from E = M + e sin M. */
double eccentricAnomaly(double meanAnomaly, double e) noexcept {
  double ecc = meanAnomaly + e * std::sin(meanAnomaly);
  for (int i = 0; i < 12; ++i) {
    const double step = (ecc - e * std::sin(ecc) - meanAnomaly) / (1.0 - e * std::cos(ecc));
    ecc -= step;
    if (std::abs(step) < 1e-15) break;
  }
  return ecc;
}

/** Heliocentric position of the elements at `t` centuries, J2000 equatorial, metres. */
glm::dvec3 heliocentric(const ElementsWithRates& el, double t) noexcept {
  const double a = el.at.a + el.rate.a * t;
  const double e = el.at.e + el.rate.e * t;
  const double inc = (el.at.inclination + el.rate.inclination * t) * kDeg;
  const double lon = el.at.meanLongitude + el.rate.meanLongitude * t;
  const double peri = el.at.perihelionLongitude + el.rate.perihelionLongitude * t;
  const double node = (el.at.nodeLongitude + el.rate.nodeLongitude * t) * kDeg;
  const double omega = peri * kDeg - node;                             // argument of perihelion
  const double meanAnomaly = std::remainder(lon - peri, 360.0) * kDeg; // (-pi, pi]
  const double ecc = eccentricAnomaly(meanAnomaly, e);
  // In the orbit's plane, x towards the perihelion.
  const double xp = a * (std::cos(ecc) - e);
  const double yp = a * std::sqrt(1.0 - e * e) * std::sin(ecc);
  const double co = std::cos(omega), so = std::sin(omega);
  const double cn = std::cos(node), sn = std::sin(node);
  const double ci = std::cos(inc), si = std::sin(inc);
  const glm::dvec3 ecliptic((co * cn - so * sn * ci) * xp + (-so * cn - co * sn * ci) * yp,
                            (co * sn + so * cn * ci) * xp + (-so * sn + co * cn * ci) * yp,
                            (so * si) * xp + (co * si) * yp);
  const double ce = std::cos(kObliquityJ2000Deg * kDeg), se = std::sin(kObliquityJ2000Deg * kDeg);
  const glm::dvec3 equatorial(
      ecliptic.x, ce * ecliptic.y - se * ecliptic.z, se * ecliptic.y + ce * ecliptic.z);
  return equatorial * kAstronomicalUnitM;
}

} // namespace

std::optional<EphemerisBody> ephemerisBodyByName(std::string_view name) noexcept {
  if (name == "earth") return EphemerisBody::earth;
  if (name == "moon") return EphemerisBody::moon;
  if (name == "mars") return EphemerisBody::mars;
  return std::nullopt;
}

const char* ephemerisBodyName(EphemerisBody body) noexcept {
  switch (body) {
  case EphemerisBody::earth:
    return "earth";
  case EphemerisBody::moon:
    return "moon";
  case EphemerisBody::mars:
    return "mars";
  }
  return "earth";
}

glm::dvec3 earthMoonBarycentreHeliocentric(double unixSeconds) noexcept {
  return heliocentric(kEarthMoonBarycentre, tdbCenturies(unixSeconds));
}

glm::dvec3 earthHeliocentric(double unixSeconds) noexcept {
  return earthMoonBarycentreHeliocentric(unixSeconds) -
         moonPositionCelestial(unixSeconds) / (1.0 + kEarthMoonMassRatio);
}

glm::dvec3 marsHeliocentric(double unixSeconds) noexcept {
  return heliocentric(kMars, tdbCenturies(unixSeconds));
}

glm::dvec3 bodyPositionCelestial(EphemerisBody body, double unixSeconds) noexcept {
  switch (body) {
  case EphemerisBody::earth:
    return glm::dvec3(0.0);
  case EphemerisBody::moon:
    return moonPositionCelestial(unixSeconds);
  case EphemerisBody::mars:
    return marsHeliocentric(unixSeconds) - earthHeliocentric(unixSeconds);
  }
  return glm::dvec3(0.0);
}

glm::dmat3 celestialToBodyFixed(EphemerisBody body, double unixSeconds) noexcept {
  switch (body) {
  case EphemerisBody::earth:
    return celestialToEcef(unixSeconds);
  case EphemerisBody::moon:
    return glm::transpose(iauBodyFixedToCelestial(iauMoon(), unixSeconds));
  case EphemerisBody::mars:
    return glm::transpose(iauBodyFixedToCelestial(iauMars(), unixSeconds));
  }
  return celestialToEcef(unixSeconds);
}

glm::dvec3 sunDirectionInBody(EphemerisBody body, double unixSeconds) noexcept {
  // The sun from the body's centre: minus the body's heliocentric position.
  glm::dvec3 sun;
  switch (body) {
  case EphemerisBody::mars:
    sun = -marsHeliocentric(unixSeconds);
    break;
  case EphemerisBody::moon:
    sun = -earthHeliocentric(unixSeconds) - moonPositionCelestial(unixSeconds);
    break;
  case EphemerisBody::earth:
  default:
    sun = -earthHeliocentric(unixSeconds);
    break;
  }
  return glm::normalize(celestialToBodyFixed(body, unixSeconds) * sun);
}

} // namespace tellus::planet::astro
