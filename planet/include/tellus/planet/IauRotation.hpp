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
 * The elements are data; the evaluation (body-fixed <-> celestial) is declared at the end of this
 * file and lives in IauRotation.cpp, with the built-in Earth, Moon and Mars:
 *   - Earth: WGCCRE 2009/2015, alpha0 = 0.00 - 0.641 T, delta0 = 90.00 - 0.557 T,
 *     W = 190.147 + 360.9856235 d. A low-accuracy model of the Earth: its prime meridian and
 *     GMST with IAU 1976 precession (Astronomy.hpp's ECEF) are 0.025 degree apart at J2000 and
 *     drift apart by 0.0023 degree a year. ECEF stays the Earth's fixed frame everywhere
 *     (Ephemeris.hpp); this is for symmetry and comparison.
 *   - Moon: WGCCRE 2009 (Archinal et al. 2011, Celest. Mech. Dyn. Astr. 109:101, Table 2, kept
 *     unchanged in the 2015 report): the mean Earth/polar axis frame, 13 periodic terms E1..E13
 *     and the -1.4e-12 d^2 term; about 150 m on the surface against the DE421 libration.
 *   - Mars: WGCCRE 2015 (Archinal et al. 2018, Table 2, the model of Konopliv et al. 2016 that
 *     pck00011.tpc carries): alpha0 = 317.269202 - 0.10927547 T, delta0 = 54.432516 - 0.05827105 T,
 *     W = 176.049863 + 350.891982443297 d, with their periodic terms (arguments in degrees plus a
 *     rate per Julian century, stored here per day). The 2009 constants (317.68143, 52.88650,
 *     176.630) are what these give at J2000 to 0.002 degree.
 *
 * Time: d and T count TDB from J2000.0, taken here as UTC + 69.184 s (TT - UTC since 2017; TDB -
 * TT < 2 ms). Earlier and later the difference from the real Delta T is seconds to minutes: the
 * Moon turns 0.00015 degree a second, Mars 0.004, the Earth 0.004, all inside the models'
 * accuracies for the renderer's 0.01 degree except the Earth's and Mars's turn beyond a few
 * decades from now (the Earth uses ECEF, which takes UT1 as UTC, instead).
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

/** A body's orientation at an instant: its north pole's right ascension and declination in the
 * J2000.0 celestial frame and the prime meridian's angle W, degrees (W not wrapped). */
struct IauOrientation {
  double poleRaDeg = 0.0;
  double poleDecDeg = 90.0;
  double primeMeridianDeg = 0.0;
};

/** TDB - UTC taken throughout (TT - UTC = 32.184 s + 37 leap seconds since 2017). */
inline constexpr double kTdbMinusUtcSeconds = 69.184;

/** Days of TDB from J2000.0 at a UTC instant (POSIX seconds): the WGCCRE d. */
double iauDaysFromJ2000(double unixSeconds) noexcept;

/** The elements evaluated at `tdbDays` (d; T = d / 36525). */
IauOrientation evaluateIauRotation(const IauRotation& r, double tdbDays) noexcept;

/** The rotation body-fixed -> J2000.0 celestial of an orientation: its columns are the body's x
 * (the prime meridian on the equator), y (90 degrees east) and z (the north pole) in the
 * celestial frame. Orthonormal, determinant 1; its transpose turns celestial into body-fixed. */
glm::dmat3 iauBodyFixedToCelestial(const IauOrientation& o) noexcept;

/** The same for elements at a UTC instant (POSIX seconds). */
glm::dmat3 iauBodyFixedToCelestial(const IauRotation& r, double unixSeconds) noexcept;

/** The built-in elements (see the file comment for their sources). */
const IauRotation& iauEarth() noexcept;
const IauRotation& iauMoon() noexcept;
const IauRotation& iauMars() noexcept;

} // namespace tellus::planet
