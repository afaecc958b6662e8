#pragma once
/**
 * @file Astronomy.hpp
 * @brief The scene's time in the sky: Julian date, sidereal time, precession and the sun's
 * direction, for lighting, the night side and the stars (issue 23).
 *
 * Time is UTC as seconds since 1970-01-01T00:00:00Z (POSIX, leap seconds not counted), a double:
 * 1 us resolution for centuries around today. UT1 and TT are taken as UTC: UT1 - UTC < 0.9 s
 * (0.004 degree of the Earth's turn) and TT - UTC ~ 69 s (the sun moves 0.0008 degree along the
 * ecliptic in that time), both under the 0.01 degree the renderer asks for.
 *
 * Frames: "celestial" is the mean equator and equinox of J2000.0 (the frame of star catalogues,
 * ICRS to 0.02 arc second); ECEF is the Earth-fixed frame of Geodesy (x to 0 N 0 E, z to the
 * north pole). celestialToEcef() = Rz(-GMST) * P (IAU 1976 precession, Meeus ch. 21); nutation
 * (at most 17 arc seconds), the equation of the equinoxes and polar motion are neglected.
 *
 * The sun: the NOAA solar calculator's algorithm (Meeus, "Astronomical Algorithms" ch. 25, the
 * low-accuracy method: about 0.01 degree from 1950 to 2050), apparent right ascension and
 * declination of date turned into ECEF by GMST.
 *
 * Pure functions, double precision, safe from any thread.
 */

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

namespace tellus::planet::astro {

inline constexpr double kUnixEpochJd = 2440587.5; ///< Julian date of 1970-01-01T00:00:00Z
inline constexpr double kJ2000Jd = 2451545.0;     ///< Julian date of J2000.0 (2000-01-01T12:00 TT)

/** Julian date of a UTC instant given as POSIX seconds. */
double julianDate(double unixSeconds) noexcept;
/** Julian centuries since J2000.0. */
double julianCenturies(double unixSeconds) noexcept;
/** Greenwich mean sidereal time (IAU 1982, Meeus 12.4) in radians, in [0, 2 pi). */
double greenwichMeanSiderealTime(double unixSeconds) noexcept;
/** Precession from the J2000.0 mean equator and equinox to the mean equator and equinox of date
 * (IAU 1976: zeta, z, theta of Meeus 21.2): v_date = P * v_J2000. */
glm::dmat3 precessionFromJ2000(double unixSeconds) noexcept;
/** Rotation from the J2000.0 celestial frame to ECEF at this instant: Rz(-GMST) * P. */
glm::dmat3 celestialToEcef(double unixSeconds) noexcept;
/** Unit vector of a right ascension and declination (radians) in their equatorial frame. */
glm::dvec3 equatorialDirection(double raRad, double decRad) noexcept;

/** The sun's apparent place of date. */
struct SunPlace {
  double rightAscensionRad = 0.0; ///< [0, 2 pi)
  double declinationRad = 0.0;    ///< [-pi/2, pi/2]
  double distanceAu = 0.0;        ///< Earth-sun distance, astronomical units
};
SunPlace sunPlace(double unixSeconds) noexcept;
/** Unit direction from the Earth's centre to the sun in ECEF. */
glm::dvec3 sunDirectionEcef(double unixSeconds) noexcept;

} // namespace tellus::planet::astro
