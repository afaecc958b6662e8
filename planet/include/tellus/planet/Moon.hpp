#pragma once
/**
 * @file Moon.hpp
 * @brief Where the Moon is (issue 26): Meeus's lunar theory, "Astronomical Algorithms" (2nd ed.,
 * 1998) chapter 47, with the full tables 47.A and 47.B (60 terms each, a truncation of
 * Chapront's ELP-2000/82), and the IAU 1980 nutation of chapter 22 (table 22.A, 63 terms).
 *
 * Accuracy (Meeus): about 10 arc seconds in longitude and 4 in latitude; the distance to about
 * 10 km (against JPL's DE441 in TestMoon: 3.4" and 9.5 km in 2025). Meeus's example 47.a is
 * matched to its printed digits. Nutation: Meeus's 63 terms of the IAU 1980 series, within a
 * few thousandths of an arc second of the full one.
 *
 * Time: the theory runs on TT (Meeus's TD). The `unixSeconds` functions take UTC (POSIX seconds)
 * and add 69.184 s (TT - UTC since 2017, kTdbMinusUtcSeconds): in 1992 that was 58.184 s, a 6
 * arc-second error in the Moon's longitude, and decades from now Delta T is unknown anyway; the
 * `*Tt` functions take Julian centuries of TT from J2000.0 for exact comparisons.
 *
 * Frames: the ecliptic place is referred to the mean ecliptic and equinox of date (geometric:
 * no nutation; the apparent longitude adds it), the apparent right ascension and declination to
 * the true equator and equinox of date. Positions in metres are geometric (the Moon is 1.3 light
 * seconds away: 0.7 arc second of its motion, neglected), geocentric, in Astronomy.hpp's frames:
 * "celestial" (J2000.0 mean equator and equinox, reached from the mean equator of date by the
 * transposed IAU 1976 precession) and ECEF (astro::celestialToEcef, which neglects nutation, as
 * the sun's ECEF direction does: at most 17 arc seconds).
 *
 * Pure functions, double precision, safe from any thread.
 */

#include <glm/vec3.hpp>

namespace tellus::planet::astro {

/** Julian centuries of TT from J2000.0 at a UTC instant (TT = UTC + 69.184 s). */
double ttCenturies(double unixSeconds) noexcept;

/** Nutation and the obliquity of the ecliptic (Meeus ch. 22), radians. */
struct Nutation {
  double longitudeRad = 0.0;     ///< Delta psi
  double obliquityRad = 0.0;     ///< Delta epsilon
  double meanObliquityRad = 0.0; ///< epsilon0 (Meeus 22.2)
  double trueObliquity() const noexcept { return meanObliquityRad + obliquityRad; }
};
Nutation nutationTt(double ttCenturies) noexcept;

/** The Moon's geocentric place (ecliptic: mean ecliptic and equinox of date). */
struct MoonPlace {
  double longitudeRad = 0.0;         ///< geometric ecliptic longitude, [0, 2 pi)
  double latitudeRad = 0.0;          ///< ecliptic latitude
  double distanceM = 0.0;            ///< centre to centre, metres
  double apparentLongitudeRad = 0.0; ///< longitude + nutation in longitude, [0, 2 pi)
  double rightAscensionRad = 0.0;    ///< apparent, true equator and equinox of date, [0, 2 pi)
  double declinationRad = 0.0;       ///< apparent, true equator of date
};
MoonPlace moonPlaceTt(double ttCenturies) noexcept;
MoonPlace moonPlace(double unixSeconds) noexcept;

/** The Moon's centre from the Earth's, J2000.0 celestial frame, metres. */
glm::dvec3 moonPositionCelestial(double unixSeconds) noexcept;
/** The Moon's centre from the Earth's in ECEF, metres. */
glm::dvec3 moonPositionEcef(double unixSeconds) noexcept;

} // namespace tellus::planet::astro
