#include <tellus/planet/Astronomy.hpp>
#include <tellus/planet/IauRotation.hpp>

#include <glm/geometric.hpp>

#include <cmath>
#include <numbers>

namespace tellus::planet {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kDaysPerCentury = 36525.0;

/** A WGCCRE term whose argument the report gives per Julian century, stored per day. */
IauPeriodicTerm perCentury(double e0, double e1PerCentury, double ra, double dec, double w) {
  return IauPeriodicTerm{e0, e1PerCentury / kDaysPerCentury, ra, dec, w};
}

IauRotation makeEarth() {
  IauRotation r;
  r.poleRaDeg = 0.0;
  r.poleRaDegPerCentury = -0.641;
  r.poleDecDeg = 90.0;
  r.poleDecDegPerCentury = -0.557;
  r.primeMeridianDeg = 190.147;
  r.rotationDegPerDay = 360.9856235;
  return r;
}

IauRotation makeMoon() {
  IauRotation r;
  r.poleRaDeg = 269.9949;
  r.poleRaDegPerCentury = 0.0031;
  r.poleDecDeg = 66.5392;
  r.poleDecDegPerCentury = 0.0130;
  r.primeMeridianDeg = 38.3213;
  r.rotationDegPerDay = 13.17635815;
  r.primeMeridianDegPerDay2 = -1.4e-12;
  // Archinal et al. 2011, Table 2: E1..E13 (degrees, rates per day) and their amplitudes in
  // alpha0 (sin), delta0 (cos) and W (sin).
  r.terms = {
      {125.045, -0.0529921, -3.8787, 1.5419, 3.5610},  // E1
      {250.089, -0.1059842, -0.1204, 0.0239, 0.1208},  // E2
      {260.008, 13.0120009, 0.0700, -0.0278, -0.0642}, // E3
      {176.625, 13.3407154, -0.0172, 0.0068, 0.0158},  // E4
      {357.529, 0.9856003, 0.0, 0.0, 0.0252},          // E5
      {311.589, 26.4057084, 0.0072, -0.0029, -0.0066}, // E6
      {134.963, 13.0649930, 0.0, 0.0009, -0.0047},     // E7
      {276.617, 0.3287146, 0.0, 0.0, -0.0046},         // E8
      {34.226, 1.7484877, 0.0, 0.0, 0.0028},           // E9
      {15.134, -0.1589763, -0.0052, 0.0008, 0.0052},   // E10
      {119.743, 0.0036096, 0.0, 0.0, 0.0040},          // E11
      {239.961, 0.1643573, 0.0, 0.0, 0.0019},          // E12
      {25.053, 12.9590088, 0.0043, -0.0009, -0.0044},  // E13
  };
  return r;
}

IauRotation makeMars() {
  IauRotation r;
  r.poleRaDeg = 317.269202;
  r.poleRaDegPerCentury = -0.10927547;
  r.poleDecDeg = 54.432516;
  r.poleDecDegPerCentury = -0.05827105;
  r.primeMeridianDeg = 176.049863;
  r.rotationDegPerDay = 350.891982443297;
  // Archinal et al. 2018, Table 2 (Mars): each series has its own arguments, so each term
  // carries one amplitude. Arguments: degrees + degrees per Julian century.
  r.terms = {
      perCentury(198.991226, 19139.4819985, 0.000068, 0.0, 0.0),
      perCentury(226.292679, 38280.8511281, 0.000238, 0.0, 0.0),
      perCentury(249.663391, 57420.7251593, 0.000052, 0.0, 0.0),
      perCentury(266.183510, 76560.6367950, 0.000009, 0.0, 0.0),
      perCentury(79.398797, 0.5042615, 0.419057, 0.0, 0.0),
      perCentury(122.433576, 19139.9407476, 0.0, 0.000051, 0.0),
      perCentury(43.058401, 38280.8753272, 0.0, 0.000141, 0.0),
      perCentury(57.663379, 57420.7517205, 0.0, 0.000031, 0.0),
      perCentury(79.476401, 76560.6495004, 0.0, 0.000005, 0.0),
      perCentury(166.325722, 0.5042615, 0.0, 1.591274, 0.0),
      perCentury(129.071773, 19140.0328244, 0.0, 0.0, 0.000145),
      perCentury(36.352167, 38281.0473591, 0.0, 0.0, 0.000157),
      perCentury(56.668646, 57420.9295360, 0.0, 0.0, 0.000040),
      perCentury(67.364003, 76560.2552215, 0.0, 0.0, 0.000001),
      perCentury(104.792680, 95700.4387578, 0.0, 0.0, 0.000001),
      perCentury(95.391654, 0.5042615, 0.0, 0.0, 0.584542),
  };
  return r;
}

} // namespace

double iauDaysFromJ2000(double unixSeconds) noexcept {
  constexpr double kJ2000Unix = (astro::kJ2000Jd - astro::kUnixEpochJd) * 86400.0;
  return (unixSeconds + kTdbMinusUtcSeconds - kJ2000Unix) / 86400.0;
}

IauOrientation evaluateIauRotation(const IauRotation& r, double tdbDays) noexcept {
  const double t = tdbDays / kDaysPerCentury;
  IauOrientation o;
  o.poleRaDeg = r.poleRaDeg + r.poleRaDegPerCentury * t;
  o.poleDecDeg = r.poleDecDeg + r.poleDecDegPerCentury * t;
  // W's rate times d reaches 1e7 degrees within a century of J2000 for the Earth and Mars: the
  // whole turns of the rate are taken out first so that W keeps its small-angle precision.
  const double turns = r.rotationDegPerDay * tdbDays / 360.0;
  const double wholeTurns = std::floor(turns);
  o.primeMeridianDeg = r.primeMeridianDeg +
                       std::fma(r.rotationDegPerDay, tdbDays, -360.0 * wholeTurns) +
                       r.primeMeridianDegPerDay2 * tdbDays * tdbDays;
  for (const IauPeriodicTerm& term : r.terms) {
    const double e = std::fmod(term.argumentDeg + term.argumentRateDegDay * tdbDays, 360.0) * kDeg;
    const double s = std::sin(e);
    o.poleRaDeg += term.raSinDeg * s;
    o.poleDecDeg += term.decCosDeg * std::cos(e);
    o.primeMeridianDeg += term.wSinDeg * s;
  }
  return o;
}

glm::dmat3 iauBodyFixedToCelestial(const IauOrientation& o) noexcept {
  const double ra = o.poleRaDeg * kDeg;
  const double dec = o.poleDecDeg * kDeg;
  const double w = std::fmod(o.primeMeridianDeg, 360.0) * kDeg;
  const glm::dvec3 pole = astro::equatorialDirection(ra, dec);
  // The ascending node of the body's equator on the celestial equator lies at right ascension
  // alpha0 + 90 degrees; W runs east from it along the body's equator.
  const glm::dvec3 node(-std::sin(ra), std::cos(ra), 0.0);
  const glm::dvec3 east = glm::cross(pole, node);
  const glm::dvec3 x = std::cos(w) * node + std::sin(w) * east;
  const glm::dvec3 y = glm::cross(pole, x);
  return glm::dmat3(x, y, pole);
}

glm::dmat3 iauBodyFixedToCelestial(const IauRotation& r, double unixSeconds) noexcept {
  return iauBodyFixedToCelestial(evaluateIauRotation(r, iauDaysFromJ2000(unixSeconds)));
}

const IauRotation& iauEarth() noexcept {
  static const IauRotation r = makeEarth();
  return r;
}

const IauRotation& iauMoon() noexcept {
  static const IauRotation r = makeMoon();
  return r;
}

const IauRotation& iauMars() noexcept {
  static const IauRotation r = makeMars();
  return r;
}

} // namespace tellus::planet
