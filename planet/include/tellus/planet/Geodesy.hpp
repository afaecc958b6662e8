#pragma once
/**
 * @file Geodesy.hpp
 * @brief Geodetic <-> Earth-centred Earth-fixed conversion for the planet renderer (GeographicLib
 * stays private behind this interface).
 *
 * Angles in degrees, heights and coordinates in metres, always double precision. Tile latitudes are
 * geodetic: on the WGS84 ellipsoid a tile edge at latitude phi is where the ellipsoid normal makes
 * the angle phi with the equator.
 *
 * Issue 26: a Geodesy is made from any planet::Body (Body.hpp): a sphere or a biaxial ellipsoid
 * through GeographicLib's Geocentric (a, f = 1 - c/a), a triaxial ellipsoid by its own conversion
 * (GeodesyTriaxial.cpp: planetographic latitude and longitude are those of the ellipsoid's normal;
 * fromEcef solves for the foot of the normal by Newton's method). Geodesy(EarthModel) is
 * Geodesy(earthBody()) or Geodesy(earthSphereBody()), bit for bit.
 *
 * The renderer's shape-dependent paths (picking, culling, the LOD's bounds, the atmosphere) read
 * equatorialRadius() and polarRadius() and treat the body as biaxial; for a triaxial body those
 * are a and c and the horizon occluder uses b (the inscribed biaxial ellipsoid), so culling stays
 * conservative while vertices (toEcef) are exact.
 */

#include <tellus/planet/Body.hpp>

#include <memory>

namespace tellus {

struct Ecef {
  double x = 0.0;
  double y = 0.0;
  double z = 0.0;
};

struct Geodetic {
  double latDeg = 0.0;
  double lonDeg = 0.0;
  double heightM = 0.0;
};

enum class EarthModel {
  Wgs84,  ///< the WGS84 ellipsoid (a = 6378137 m, f = 1/298.257223563), the default
  Sphere, ///< a sphere of radius 6371008.8 m (mean Earth radius), cheaper and up to ~21 km off
};

/** Thread safety: immutable after construction; all methods may be called concurrently. */
class Geodesy {
public:
  explicit Geodesy(EarthModel model = EarthModel::Wgs84);
  /** @throws std::invalid_argument when body.validate() says what is wrong. */
  explicit Geodesy(const planet::Body& body);
  ~Geodesy();
  Geodesy(Geodesy&&) noexcept;
  Geodesy& operator=(Geodesy&&) noexcept;

  /** Sphere for a spherical body, Wgs84 for any other (the Earth model's name only). */
  EarthModel model() const noexcept;
  const planet::Body& body() const noexcept;
  double equatorialRadius() const noexcept;    ///< a (the largest equatorial semi-axis)
  double minEquatorialRadius() const noexcept; ///< b (== a unless triaxial)
  double polarRadius() const noexcept;         ///< c

  /** Position of a point; NaN in gives NaN out; |lat| > 90 gives NaN. lon is any value (wraps). */
  Ecef toEcef(double latDeg, double lonDeg, double heightM) const noexcept;
  /** Inverse of toEcef; at the poles the longitude is 0. */
  Geodetic fromEcef(const Ecef& p) const noexcept;
  /** Unit outward surface normal (the ellipsoid normal on WGS84, the radial direction on the
   * sphere). */
  Ecef surfaceNormal(double latDeg, double lonDeg) const noexcept;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

} // namespace tellus
