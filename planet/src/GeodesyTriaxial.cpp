#include "GeodesyTriaxial.hpp"

#include <GeographicLib/Math.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace tellus::planet {

Ecef triaxialToEcef(double a, double b, double c, double latDeg, double lonDeg, double h) noexcept {
  double sphi = 0, cphi = 0, slam = 0, clam = 0;
  GeographicLib::Math::sincosd(latDeg, sphi, cphi);
  GeographicLib::Math::sincosd(lonDeg, slam, clam);
  const double nx = cphi * clam, ny = cphi * slam, nz = sphi;
  const double n = std::sqrt(a * a * nx * nx + b * b * ny * ny + c * c * nz * nz);
  return Ecef{a * a * nx / n + h * nx, b * b * ny / n + h * ny, c * c * nz / n + h * nz};
}

Geodetic triaxialFromEcef(double a, double b, double c, const Ecef& p) noexcept {
  const double ax[3] = {a, b, c};
  const double px[3] = {p.x, p.y, p.z};
  const double rMin = std::min({a, b, c}), rMax = std::max({a, b, c});
  const double dist = std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z);
  if (!std::isfinite(dist)) {
    const double nan = std::nan("");
    return {nan, nan, nan};
  }
  // f(t0) >= 0 at t0 = |p| rMin - rMax^2 (each term is at least p_i^2 rMin^2 / (rMax^2 + t)^2);
  // near the centre t0 falls below the pole at -rMin^2 and is moved just right of it.
  double t = std::max(dist * rMin - rMax * rMax, -rMin * rMin * (1.0 - 1e-12));
  for (int i = 0; i < 200; ++i) {
    double f = -1.0, df = 0.0;
    for (int k = 0; k < 3; ++k) {
      const double d = ax[k] * ax[k] + t;
      const double u = px[k] * ax[k] / d;
      f += u * u;
      df -= 2.0 * u * u / d;
    }
    if (!(df < 0.0)) break; // p at the centre: no unique foot
    const double step = -f / df;
    t += step;
    if (std::abs(step) <= 1e-15 * std::max(std::abs(t), rMin * rMin * 1e-9)) break;
  }
  double q[3];
  for (int k = 0; k < 3; ++k)
    q[k] = px[k] * ax[k] * ax[k] / (ax[k] * ax[k] + t);
  const double gx = q[0] / (a * a), gy = q[1] / (b * b), gz = q[2] / (c * c);
  constexpr double kDeg = 180.0 / std::numbers::pi;
  Geodetic g;
  g.latDeg = std::atan2(gz, std::hypot(gx, gy)) * kDeg;
  g.lonDeg = (gx == 0.0 && gy == 0.0) ? 0.0 : std::atan2(gy, gx) * kDeg;
  const double dh = std::sqrt((px[0] - q[0]) * (px[0] - q[0]) + (px[1] - q[1]) * (px[1] - q[1]) +
                              (px[2] - q[2]) * (px[2] - q[2]));
  g.heightM = t < 0.0 ? -dh : dh;
  return g;
}

} // namespace tellus::planet
