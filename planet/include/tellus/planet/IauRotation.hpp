#pragma once
/**
 * @file IauRotation.hpp
 * @brief A body's rotation as the IAU Working Group on Cartographic Coordinates and Rotational
 * Elements (WGCCRE) gives it (issue 26): the direction of its north pole and the angle of its
 * prime meridian, each a constant plus a rate (and, for the Moon, periodic terms).
 *
 * WGCCRE (Archinal et al. 2018, "Report of the IAU WGCCRE: 2015", Celest. Mech. Dyn. Astr. 130:22):
 *   alpha0 = a0 + a1 T,  delta0 = d0 + d1 T,  W = w0 + w1 d  (+ the body's periodic terms)
 * with T in Julian centuries and d in days of TDB from J2000.0 (JD 2451545.0). alpha0 and delta0
 * are the pole's right ascension and declination in the ICRF (the J2000.0 celestial frame of
 * Astronomy.hpp); W is the angle, along the body's equator, from the node of that equator on the
 * ICRF equator to the prime meridian.
 *
 * Pure data here; the evaluation (body-fixed <-> celestial) lives beside it (IauRotation.cpp).
 */

#include <glm/mat3x3.hpp>

#include <vector>

namespace tellus::planet {

/** One periodic term of the WGCCRE series: amplitudes (degrees) of sin/cos of an argument
 * E = e0 + e1 d (degrees, d in days from J2000.0), added to alpha0 (sin), delta0 (cos) and W
 * (sin). */
struct IauPeriodicTerm {
  double argumentDeg = 0.0;        ///< e0
  double argumentRateDegDay = 0.0; ///< e1
  double raSinDeg = 0.0;           ///< added to alpha0: raSinDeg * sin(E)
  double decCosDeg = 0.0;          ///< added to delta0: decCosDeg * cos(E)
  double wSinDeg = 0.0;            ///< added to W: wSinDeg * sin(E)
};

/** A body's rotational elements (WGCCRE). */
struct IauRotation {
  double poleRaDeg = 0.0;               ///< a0
  double poleRaDegPerCentury = 0.0;     ///< a1
  double poleDecDeg = 90.0;             ///< d0
  double poleDecDegPerCentury = 0.0;    ///< d1
  double primeMeridianDeg = 0.0;        ///< w0
  double rotationDegPerDay = 0.0;       ///< w1 (negative for retrograde rotators)
  double primeMeridianDegPerDay2 = 0.0; ///< w2 * d^2 where the report has one (the Moon)
  std::vector<IauPeriodicTerm> terms;   ///< periodic terms (empty for most bodies)
};

} // namespace tellus::planet
