#pragma once
/**
 * @file Ephemeris.hpp
 * @brief Where the built-in bodies are and how they are turned (issue 26): the Earth's and Mars's
 * heliocentric positions, each body's centre from the Earth's, the rotation into each body's
 * fixed frame, and the sun's direction in that frame, the one the lighting needs.
 *
 * Planets: JPL's "Keplerian Elements for Approximate Positions of the Major Planets" (E. M.
 * Standish, Table 1, valid 1800-2050): elements and their rates per Julian century at J2000.0,
 * Kepler's equation, the J2000 ecliptic turned to the J2000 equator by the obliquity 23.43928
 * degrees. Standish's stated errors over 1800-2050: the Earth-Moon barycentre 20" in right
 * ascension, 8" in declination, 6000 km; Mars 40" in right ascension, 25000 km (under 0.05% of
 * its distance from the Earth at any time). Outside 1800-2050 the errors grow (tests check 1900 and
 * 2100 stay finite and plausible, not accurate). The table gives the Earth-Moon barycentre: the
 * Earth is moved from it by the Moon's geocentric position (Moon.hpp) over 1 + 81.30057 (the
 * Earth/Moon mass ratio of DE430).
 *
 * Frames: positions in metres in the J2000.0 celestial frame of Astronomy.hpp (the ecliptic
 * elements are ICRF-aligned to well under the theory's error), geometric (no light time: Mars is
 * up to 22 light minutes away, 0.01 degree of its heliocentric motion; no aberration: 20" for the
 * sun seen from the Earth). Body-fixed frames: the Earth's is ECEF (astro::celestialToEcef, as
 * Geodesy and the sun's lighting use; not the IAU Earth elements), the Moon's and Mars's are the
 * WGCCRE frames of IauRotation.hpp (x to the prime meridian, z to the north pole).
 *
 * Time: UTC as POSIX seconds; TDB taken as UTC + 69.184 s (IauRotation.hpp).
 *
 * Pure functions, double precision, safe from any thread.
 */

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

#include <optional>
#include <string_view>

namespace tellus::planet::astro {

inline constexpr double kAstronomicalUnitM = 149597870700.0; ///< IAU 2012, exact
inline constexpr double kEarthMoonMassRatio = 81.30056907;   ///< DE430

/** A body whose place and rotation are built in. */
enum class EphemerisBody { earth, moon, mars };
/** "earth", "moon" or "mars" (lower case); nothing for any other name. */
std::optional<EphemerisBody> ephemerisBodyByName(std::string_view name) noexcept;
const char* ephemerisBodyName(EphemerisBody body) noexcept;

/** Heliocentric positions, J2000.0 celestial frame, metres. */
glm::dvec3 earthMoonBarycentreHeliocentric(double unixSeconds) noexcept;
glm::dvec3 earthHeliocentric(double unixSeconds) noexcept;
glm::dvec3 marsHeliocentric(double unixSeconds) noexcept;

/** The body's centre from the Earth's centre, J2000.0 celestial frame, metres (zero for the
 * Earth). */
glm::dvec3 bodyPositionCelestial(EphemerisBody body, double unixSeconds) noexcept;

/** Rotation J2000.0 celestial -> the body's fixed frame at this instant (orthonormal, det 1). */
glm::dmat3 celestialToBodyFixed(EphemerisBody body, double unixSeconds) noexcept;

/** Unit direction from the body's centre to the sun's, in the body's fixed frame. For the Earth
 * it agrees with sunDirectionEcef() within 0.02 degree (1950-2050); for the Moon it is the
 * Earth-sun vector less the Moon's geocentric position. */
glm::dvec3 sunDirectionInBody(EphemerisBody body, double unixSeconds) noexcept;

} // namespace tellus::planet::astro
