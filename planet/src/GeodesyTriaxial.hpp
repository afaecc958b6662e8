#pragma once
/**
 * @file GeodesyTriaxial.hpp
 * @brief Planetographic <-> body-fixed conversion on a triaxial ellipsoid x^2/a^2 + y^2/b^2 +
 * z^2/c^2 = 1 (issue 26), private to Geodesy.
 *
 * Latitude and longitude are those of the ellipsoid's outward normal n = (cos lat cos lon,
 * cos lat sin lon, sin lat); the height is along n. Forward: the surface point whose normal is n is
 * (a^2 nx, b^2 ny, c^2 nz) / sqrt(a^2 nx^2 + b^2 ny^2 + c^2 nz^2). Reverse: the foot q of the
 * normal through p is q_i = p_i a_i^2 / (a_i^2 + t) with t the root of
 * f(t) = sum (p_i a_i / (a_i^2 + t))^2 - 1; f is convex and decreasing for t > -c_min^2, so
 * Newton's method from t0 = |p| r_min - r_max^2 (where f >= 0) rises monotonically to the root.
 */

#include <tellus/planet/Geodesy.hpp>

namespace tellus::planet {

Ecef triaxialToEcef(double a, double b, double c, double latDeg, double lonDeg, double h) noexcept;
Geodetic triaxialFromEcef(double a, double b, double c, const Ecef& p) noexcept;

} // namespace tellus::planet
