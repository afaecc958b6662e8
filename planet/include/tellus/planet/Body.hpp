#pragma once
/**
 * @file Body.hpp
 * @brief A body the renderer can show (issue 26): its name, its shape (a sphere, a biaxial or a
 * triaxial ellipsoid), its rotation (IAU WGCCRE elements), its atmosphere (optional) and the IAU
 * planetary CRS code that WMS servers for it use. Geodesy is made from a Body (Geodesy.hpp).
 *
 * Shape: radii a >= b (equatorial; a along the prime meridian's x axis) and c (polar). a == b: a
 * biaxial ellipsoid (or a sphere when c == a too). Latitudes on every body are planetographic (the
 * angle of the ellipsoid's normal with the equator), as on the Earth; the two are the same on a
 * sphere.
 *
 * Built in:
 * - earth: WGS84 (a = b = 6378137 m, c = a (1 - 1/298.257223563)); earthSphereBody(), also named
 *   "earth": the sphere of 6371008.8 m that EarthModel::Sphere names;
 * - moon: the sphere of 1737400 m (IAU 2015, IAU_2015:30100);
 * - mars: 3396190 m by 3376200 m (IAU 2015, IAU_2015:49900).
 * Rotation elements: IauRotation.hpp's built-in ones (iauEarth, iauMoon, iauMars: WGCCRE, with
 * the Moon's and Mars's periodic terms).
 *
 * Mars's atmosphere: Rayleigh 19.918e-3, 13.57e-3, 5.75e-3 per km at 680, 550, 440 nm with a
 * scale height of 10.44 km, Mie 53.62e-3 per km (single-scattering albedo 0.98979, g = 0.85) with
 * a scale height of 3.1 km, a 77 km thick shell, no ozone: the parameters of P. Collienne,
 * R. Wolff, A. Gerndt and T. Kuhlen, "Physically Based Rendering of the Martian Atmosphere"
 * (GI VR/AR workshop 2013), as OpenSpace's Mars asset uses them. The sun's irradiance is the
 * Earth's scaled by 1 / 1.524^2 (Mars's mean distance in AU).
 */

#include <tellus/planet/Atmosphere.hpp>
#include <tellus/planet/IauRotation.hpp>

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace tellus::planet {

struct Body {
  std::string name;
  double radiusA = 0.0; ///< largest equatorial semi-axis, metres (along x)
  double radiusB = 0.0; ///< other equatorial semi-axis, metres (along y); == radiusA: biaxial
  double radiusC = 0.0; ///< polar semi-axis, metres
  IauRotation rotation;
  std::optional<AtmosphereParameters> atmosphere; ///< nullopt: no atmosphere (no sky pass)
  /** The IAU planetary CRS code of the body's geographic CRS (IAU_2015:30100 for the Moon,
   * IAU_2015:49900 for Mars); 0: none (the Earth uses EPSG:4326). */
  int iauCrsCode = 0;
  /** The largest |height| of its relief above or below the ellipsoid, metres (Everest + the
   * geoid: 11 km; the Moon: 11 km; Mars: Olympus Mons, 22 km above the areoid, + the areoid's
   * departure: 26 km): the renderer's terrain test (RendererOptions::terrainReliefBoundM). */
  double reliefBoundM = 11000.0;

  bool isSphere() const noexcept { return radiusA == radiusB && radiusA == radiusC; }
  bool isTriaxial() const noexcept { return radiusA != radiusB; }
  /** "": usable; otherwise what is wrong (radii finite and positive, a >= b, name not empty, the
   * atmosphere's parameters valid). */
  std::string validate() const;
};

Body earthBody();       ///< WGS84
Body earthSphereBody(); ///< the Earth as a sphere of its mean radius (EarthModel::Sphere)
Body moonBody();
Body marsBody();
/** Mars's atmosphere (see the file comment), bottom radius = its equatorial radius. */
AtmosphereParameters marsAtmosphere();

/** A built-in body by name ("earth" (WGS84), "moon", "mars"); nullopt for others. */
std::optional<Body> builtinBody(std::string_view name);
/** The names builtinBody knows, in that order. */
std::vector<std::string> builtinBodyNames();

} // namespace tellus::planet
