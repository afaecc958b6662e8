// The tables' lookups on the CPU: bilinear and trilinear filtering with OpenGL's conventions
// (texel centres at (i + 0.5) / n, clamp to edge), and the sky along a ray as
// shaders/atmosphere.frag computes it (Bruneton 2017's GetSkyRadiance and GetSkyRadianceToPoint,
// written anew from the paper's equations). Keep in step with the shader.
#include "AtmosphereGeometry.hpp"

#include <tellus/planet/Atmosphere.hpp>

#include <glm/glm.hpp>

#include <cmath>
#include <limits>
#include <numbers>

namespace tellus::planet {

namespace {

std::size_t sz(int i) {
  return static_cast<std::size_t>(i);
}

glm::dvec3 texel(const std::vector<float>& t, std::size_t i) {
  return {t[3 * i], t[3 * i + 1], t[3 * i + 2]};
}

void axis(double u, int n, int& i0, int& i1, double& f) {
  const double x = u * n - 0.5;
  const double fl = std::floor(x);
  f = x - fl;
  const int i = static_cast<int>(fl);
  i0 = std::clamp(i, 0, n - 1);
  i1 = std::clamp(i + 1, 0, n - 1);
}

glm::dvec3 bilinear(const std::vector<float>& t, int w, int h, double u, double v) {
  int x0, x1, y0, y1;
  double fx, fy;
  axis(u, w, x0, x1, fx);
  axis(v, h, y0, y1, fy);
  auto at = [&](int x, int y) { return texel(t, sz(y) * sz(w) + sz(x)); };
  return (at(x0, y0) * (1 - fx) + at(x1, y0) * fx) * (1 - fy) +
         (at(x0, y1) * (1 - fx) + at(x1, y1) * fx) * fy;
}

glm::dvec3
trilinear(const std::vector<float>& t, int w, int h, int d, double u, double v, double s) {
  int z0, z1;
  double fz;
  axis(s, d, z0, z1, fz);
  const std::size_t slice = sz(w) * sz(h);
  auto plane = [&](int z) {
    int x0, x1, y0, y1;
    double fx, fy;
    axis(u, w, x0, x1, fx);
    axis(v, h, y0, y1, fy);
    auto at = [&](int x, int y) { return texel(t, sz(z) * slice + sz(y) * sz(w) + sz(x)); };
    return (at(x0, y0) * (1 - fx) + at(x1, y0) * fx) * (1 - fy) +
           (at(x0, y1) * (1 - fx) + at(x1, y1) * fx) * fy;
  };
  return plane(z0) * (1 - fz) + plane(z1) * fz;
}

/** The tables' smallest value taken in a logarithm (their zeros: night, rays of no length). */
constexpr double kFloor = 1e-20;

/** Catmull-Rom between p1 (f = 0) and p2 (f = 1), held between them (no overshoot where a row
 * is at kFloor). */
glm::dvec3 catmullRom(const glm::dvec3& p0,
                      const glm::dvec3& p1,
                      const glm::dvec3& p2,
                      const glm::dvec3& p3,
                      double f) {
  const double f2 = f * f, f3 = f2 * f;
  const glm::dvec3 v =
      0.5 * (2.0 * p1 + (p2 - p0) * f + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * f2 +
             (-p0 + 3.0 * p1 - 3.0 * p2 + p3) * f3);
  return glm::clamp(v, glm::min(p1, p2), glm::max(p1, p2));
}

} // namespace

double rayleighPhase(double nu) noexcept {
  return 3.0 / (16.0 * std::numbers::pi) * (1.0 + nu * nu);
}

double miePhase(double g, double nu) noexcept {
  const double k = 3.0 / (8.0 * std::numbers::pi) * (1.0 - g * g) / (2.0 + g * g);
  return k * (1.0 + nu * nu) / std::pow(std::max(1e-12, 1.0 + g * g - 2.0 * g * nu), 1.5);
}

glm::dvec3 AtmosphereTables::transmittanceToTop(double h, double mu) const noexcept {
  const atmo::Shell s(p_);
  double u, v;
  atmo::transmittanceUv(s, s_.transmittanceW, s_.transmittanceH, h, mu, u, v);
  return bilinear(transmittance_, s_.transmittanceW, s_.transmittanceH, u, v);
}

glm::dvec3 AtmosphereTables::multipleScattering(double h, double muS) const noexcept {
  const double u = atmo::unitToCoord(std::clamp((muS + 1.0) / 2.0, 0.0, 1.0), s_.multipleW);
  const double v = atmo::unitToCoord(std::clamp(h / p_.topAltitudeM, 0.0, 1.0), s_.multipleH);
  return bilinear(multiple_, s_.multipleW, s_.multipleH, u, v);
}

AtmosphereTables::Scattered AtmosphereTables::lookupScattering(
    double h, double mu, double muS, double nu, bool ground) const noexcept {
  const atmo::Shell s(p_);
  double ur, umu, umus;
  atmo::scatteringUvw(s, s_, p_.muSMin, h, mu, muS, ground, ur, umu, umus);
  const double x = std::clamp((nu + 1.0) / 2.0, 0.0, 1.0) * (s_.scatteringNu - 1);
  const double slice = std::min(std::floor(x), static_cast<double>(s_.scatteringNu - 2));
  const double f = x - slice;
  const int w = s_.scatteringNu * s_.scatteringMuS;
  Scattered out;
  auto tri = [&](const std::vector<float>& t, double u) {
    return trilinear(t, w, s_.scatteringMu, s_.scatteringR, u, umu, ur);
  };
  // Along mu_s: Catmull-Rom through the logarithms of the four nearest rows (held between the
  // two middle ones), not linear: in twilight the sky falls by orders of magnitude across a few
  // rows, and a linear blend's kink at each row showed as bands parallel to the terminator.
  const int n = s_.scatteringMuS;
  const double xm = umus * n - 0.5;
  const double im = std::floor(xm);
  const double fm = xm - im;
  auto along = [&](const std::vector<float>& t, double sl) {
    glm::dvec3 p[4];
    for (int k = 0; k < 4; ++k) {
      const int c = std::clamp(static_cast<int>(im) + k - 1, 0, n - 1);
      p[k] = glm::log(glm::max(tri(t, (sl + (c + 0.5) / n) / s_.scatteringNu), glm::dvec3(kFloor)));
    }
    return glm::exp(catmullRom(p[0], p[1], p[2], p[3], fm));
  };
  out.rayleigh = along(scattering_, slice) * (1.0 - f) + along(scattering_, slice + 1.0) * f;
  out.mie = along(mie_, slice) * (1.0 - f) + along(mie_, slice + 1.0) * f;
  return out;
}

AtmosphereRay
AtmosphereTables::ray(double h, double mu, double muS, double nu, double distanceM) const noexcept {
  const atmo::Shell s(p_);
  AtmosphereRay out;
  h = std::max(h, 0.0);
  mu = atmo::clampCos(mu);
  if (h > p_.topAltitudeM) { // move the eye to where the ray enters the shell
    const double r = s.b + h;
    const double p2 = r * r * std::max(0.0, 1.0 - mu * mu); // squared distance ray-centre
    if (mu >= 0.0 || p2 >= s.t * s.t) return out;           // misses: nothing
    const double q = std::sqrt(s.t * s.t - p2);
    const double entry = -r * mu - q;
    muS = atmo::clampCos((r * muS + entry * nu) / s.t);
    mu = -q / s.t;
    h = p_.topAltitudeM;
    distanceM -= entry;
    if (distanceM <= 0.0) return out;
  }
  const bool ground = atmo::hitsGround(s, h, mu);
  const double pr = rayleighPhase(nu), pm = miePhase(p_.miePhaseG, nu);
  const Scattered near = lookupScattering(h, mu, muS, nu, ground);
  const bool toPoint = std::isfinite(distanceM);
  glm::dvec3 rayleigh = near.rayleigh, mie = near.mie;
  if (toPoint) {
    const atmo::RayPoint q = atmo::along(s, h, mu, distanceM);
    const double muSd = atmo::clampCos(((s.b + h) * muS + distanceM * nu) / q.r);
    // The transmittance between the eye and the point: a ratio of two table values, taken along
    // the direction that points up so that neither reaches the ground.
    if (ground) {
      out.transmittance = glm::min(glm::dvec3(1.0),
                                   transmittanceToTop(q.h, -q.mu) /
                                       glm::max(transmittanceToTop(h, -mu), glm::dvec3(1e-30)));
    } else {
      out.transmittance = glm::min(glm::dvec3(1.0),
                                   transmittanceToTop(h, mu) /
                                       glm::max(transmittanceToTop(q.h, q.mu), glm::dvec3(1e-30)));
    }
    const Scattered far = lookupScattering(q.h, q.mu, muSd, nu, ground);
    rayleigh = glm::max(glm::dvec3(0.0), rayleigh - out.transmittance * far.rayleigh);
    mie = glm::max(glm::dvec3(0.0), mie - out.transmittance * far.mie);
    // Bruneton's guard for aerial perspective: the difference of two Mie values near the
    // terminator is unreliable (both tiny); fade it out over the last 0.01 of mu_s.
    const double x = std::clamp(muS / 0.01, 0.0, 1.0);
    mie *= x * x * (3.0 - 2.0 * x);
  } else {
    out.transmittance = ground ? glm::dvec3(0.0) : transmittanceToTop(h, mu);
  }
  out.inscatter = rayleigh * pr + mie * pm;
  return out;
}

} // namespace tellus::planet
