#pragma once
/**
 * @file AtmosphereGeometry.hpp
 * @brief The shell's geometry and Bruneton's (2017) maps between (altitude, mu, mu_s, nu) and
 * texture coordinates, in double. shaders/atmosphere.frag has the same functions, line for line,
 * in float: keep both in step. Private to the planet module (Atmosphere*.cpp).
 *
 * Everything takes the altitude h = r - bottom instead of r: r^2 - bottom^2 = h (2 bottom + h)
 * and top^2 - r^2 = (topAlt - h)(top + r) keep their precision in float at h = 1 m, where r^2 -
 * bottom^2 would cancel. Distances to the boundaries use the root form that does not cancel.
 */

#include <tellus/planet/Atmosphere.hpp>

#include <algorithm>
#include <cmath>

namespace tellus::planet::atmo {

/** The shell's constants. */
struct Shell {
  double b = 0.0; ///< bottom radius
  double t = 0.0; ///< top radius
  double a = 0.0; ///< top altitude (t - b)
  double H = 0.0; ///< sqrt(t^2 - b^2): the horizontal distance from the ground to the top
  explicit Shell(const AtmosphereParameters& p)
      : b(p.bottomRadiusM), t(p.topRadiusM()), a(p.topAltitudeM),
        H(std::sqrt(p.topAltitudeM * (2.0 * p.bottomRadiusM + p.topAltitudeM))) {}
};

inline double clampCos(double mu) noexcept {
  return std::clamp(mu, -1.0, 1.0);
}

/** sqrt(r^2 - b^2): the distance to the horizon. */
inline double rhoOf(const Shell& s, double h) noexcept {
  return std::sqrt(std::max(0.0, h * (2.0 * s.b + h)));
}

/** The distance from altitude h along mu to the top sphere (0 above it, or when missed). */
inline double distanceToTop(const Shell& s, double h, double mu) noexcept {
  const double r = s.b + h;
  const double c = (s.a - h) * (s.t + r); // t^2 - r^2
  const double disc = r * r * mu * mu + c;
  if (disc < 0.0) return 0.0;
  const double q = std::sqrt(disc);
  if (mu <= 0.0) return std::max(0.0, q - r * mu);
  const double den = q + r * mu;
  return den > 0.0 ? std::max(0.0, c / den) : 0.0;
}

/** Whether the ray from h along mu reaches the bottom sphere. */
inline bool hitsGround(const Shell& s, double h, double mu) noexcept {
  const double r = s.b + h;
  return mu < 0.0 && r * r * mu * mu - h * (2.0 * s.b + h) >= 0.0;
}

/** The distance from h along mu to the bottom sphere (valid where hitsGround). */
inline double distanceToBottom(const Shell& s, double h, double mu) noexcept {
  const double r = s.b + h;
  const double c = h * (2.0 * s.b + h); // r^2 - b^2
  const double q = std::sqrt(std::max(0.0, r * r * mu * mu - c));
  const double den = q - r * mu; // > 0 for mu < 0
  return den > 0.0 ? std::max(0.0, c / den) : 0.0;
}

/** A coordinate in [0, 1] onto the texel centres of an n-texel axis (and back). */
inline double unitToCoord(double x, int n) noexcept {
  return 0.5 / n + x * (1.0 - 1.0 / n);
}

/** The altitude and cosine along a ray: at distance d from (h, mu), the altitude and the new
 * cosine of the same direction, and the cosine of another direction (cosine c0, with cosine nu to
 * the ray) there. */
struct RayPoint {
  double h = 0.0;
  double mu = 0.0;
  double r = 0.0;
};
inline RayPoint along(const Shell& s, double h, double mu, double d) noexcept {
  const double r = s.b + h;
  // r_d^2 - b^2 = d^2 + 2 r mu d + (r^2 - b^2)
  const double e = std::max(0.0, d * d + 2.0 * r * mu * d + h * (2.0 * s.b + h));
  const double rd = std::sqrt(e + s.b * s.b);
  return {e / (rd + s.b), clampCos((r * mu + d) / rd), rd};
}

/** Transmittance table coordinates (u along mu, v along r). */
inline void transmittanceUv(
    const Shell& s, int w, int hgt, double h, double mu, double& u, double& v) noexcept {
  const double rho = rhoOf(s, h);
  const double d = distanceToTop(s, h, mu);
  const double dMin = s.a - h, dMax = rho + s.H;
  const double xMu = dMax > dMin ? (d - dMin) / (dMax - dMin) : 0.0;
  u = unitToCoord(std::clamp(xMu, 0.0, 1.0), w);
  v = unitToCoord(std::clamp(rho / s.H, 0.0, 1.0), hgt);
}

/** The inverse at texel (i, j): altitude and mu. */
inline void
transmittanceTexel(const Shell& s, int w, int hgt, int i, int j, double& h, double& mu) noexcept {
  const double xMu = static_cast<double>(i) / (w - 1), xR = static_cast<double>(j) / (hgt - 1);
  const double rho = s.H * xR;
  const double r = std::sqrt(rho * rho + s.b * s.b);
  h = rho * rho / (r + s.b);
  const double dMin = s.a - h, dMax = rho + s.H;
  const double d = dMin + xMu * (dMax - dMin);
  mu = d <= 0.0 ? 1.0 : clampCos((s.H * s.H - rho * rho - d * d) / (2.0 * r * d));
}

/** The mu_s map of the scattering and irradiance tables (Bruneton 2017): distance-based, with
 * muSMin at 0. */
inline double muSToUnit(const Shell& s, double muSMin, double muS) noexcept {
  const double dMin = s.a, dMax = s.H;
  const double d = distanceToTop(s, 0.0, muS);
  const double a = (d - dMin) / (dMax - dMin);
  const double A = (distanceToTop(s, 0.0, muSMin) - dMin) / (dMax - dMin);
  return std::max(1.0 - a / A, 0.0) / (1.0 + a);
}
inline double unitToMuS(const Shell& s, double muSMin, double x) noexcept {
  const double dMin = s.a, dMax = s.H;
  const double A = (distanceToTop(s, 0.0, muSMin) - dMin) / (dMax - dMin);
  const double a = (A - x * A) / (1.0 + x * A);
  const double d = dMin + std::min(a, A) * (dMax - dMin);
  return d <= 0.0 ? 1.0 : clampCos((s.H * s.H - d * d) / (2.0 * s.b * d));
}

/** The scattering table's (u_r, u_mu, u_mu_s) (u_nu = (nu + 1) / 2 is interpolated between
 * slices by hand). ground: the ray reaches the bottom (the lower half of the mu axis). */
inline void scatteringUvw(const Shell& s,
                          const AtmosphereTableSizes& z,
                          double muSMin,
                          double h,
                          double mu,
                          double muS,
                          bool ground,
                          double& ur,
                          double& umu,
                          double& umus) noexcept {
  const double rho = rhoOf(s, h);
  ur = unitToCoord(std::clamp(rho / s.H, 0.0, 1.0), z.scatteringR);
  const int half = z.scatteringMu / 2;
  if (ground) {
    const double d = distanceToBottom(s, h, mu);
    const double dMin = h, dMax = rho;
    const double x = dMax > dMin ? (d - dMin) / (dMax - dMin) : 0.0;
    umu = 0.5 - 0.5 * unitToCoord(std::clamp(x, 0.0, 1.0), half);
  } else {
    const double d = distanceToTop(s, h, mu);
    const double dMin = s.a - h, dMax = rho + s.H;
    const double x = dMax > dMin ? (d - dMin) / (dMax - dMin) : 0.0;
    umu = 0.5 + 0.5 * unitToCoord(std::clamp(x, 0.0, 1.0), half);
  }
  umus = unitToCoord(std::clamp(muSToUnit(s, muSMin, muS), 0.0, 1.0), z.scatteringMuS);
}

} // namespace tellus::planet::atmo
