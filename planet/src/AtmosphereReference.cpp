// The brute-force reference of AtmosphereReference.hpp: 3D vectors in double, no table.
#include <tellus/planet/AtmosphereReference.hpp>

#include <glm/glm.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>

namespace tellus::planet {

namespace {

constexpr double kPi = std::numbers::pi;

/** The two distances where o + t d (|d| = 1) meets the sphere of radius R (t0 <= t1), none when
 * it misses. Stable roots. */
std::optional<std::pair<double, double>>
sphere(const glm::dvec3& o, const glm::dvec3& d, double R) {
  const double b = glm::dot(o, d);
  const double c = glm::dot(o, o) - R * R;
  // |o|^2 - b^2 is the squared distance from the centre to the line: no cancellation there.
  const double perp2 = glm::dot(o - b * d, o - b * d);
  const double disc = R * R - perp2;
  if (disc < 0.0) return std::nullopt;
  const double q = -(b + std::copysign(std::sqrt(disc), b));
  double t0 = q != 0.0 ? c / q : 0.0, t1 = q;
  if (q == 0.0) t0 = t1 = 0.0;
  if (t0 > t1) std::swap(t0, t1);
  return std::make_pair(t0, t1);
}

double smoothstep(double a, double b, double x) {
  const double t = std::clamp((x - a) / (b - a), 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

/** The transmittance from p to the sun along s (unit), times the disc's share above the horizon. */
glm::dvec3 sunTransmittance(const AtmosphereParameters& p,
                            const glm::dvec3& x,
                            const glm::dvec3& s,
                            int steps) {
  const double r = glm::length(x);
  const double b = p.bottomRadiusM;
  const double sinH = b / r, cosH = -std::sqrt(std::max(0.0, 1.0 - sinH * sinH));
  const double muS = glm::dot(x, s) / r;
  const double vis =
      smoothstep(-sinH * p.sunAngularRadiusRad, sinH * p.sunAngularRadiusRad, muS - cosH);
  if (vis <= 0.0) return glm::dvec3(0.0);
  const auto top = sphere(x, s, p.topRadiusM());
  const double len = top ? std::max(0.0, top->second) : 0.0;
  glm::dvec3 depth(0.0);
  for (int k = 0; k <= steps; ++k) {
    const double t = len * k / steps;
    const double w = (k == 0 || k == steps) ? 0.5 : 1.0;
    depth += w * mediumAt(p, glm::length(x + t * s) - b).extinction;
  }
  return glm::exp(-depth * (len / steps)) * vis;
}

/** The end of a ray from x along d inside the shell: the ground or the top. */
double
rayEnd(const AtmosphereParameters& p, const glm::dvec3& x, const glm::dvec3& d, bool& ground) {
  // The ray enters the ground when the far root lies ahead (on the ground itself one root is 0:
  // a ray pointing down then has its other root ahead, one pointing up behind).
  const auto g = sphere(x, d, p.bottomRadiusM);
  ground = g && g->second > 1e-6;
  if (ground) return std::max(0.0, g->first);
  const auto t = sphere(x, d, p.topRadiusM());
  return t ? std::max(0.0, t->second) : 0.0;
}

glm::dvec3 multipleAt(const AtmosphereParameters& p,
                      const glm::dvec3& x,
                      const glm::dvec3& sun,
                      const AtmosphereReferenceOptions& o) {
  const int n = o.multipleDirs;
  glm::dvec3 l2(0.0), f(0.0);
  const glm::dvec3 up = glm::normalize(x);
  // A frame around up.
  const glm::dvec3 e1 = glm::normalize(std::abs(up.x) < 0.9 ? glm::cross(up, glm::dvec3(1, 0, 0))
                                                            : glm::cross(up, glm::dvec3(0, 1, 0)));
  const glm::dvec3 e2 = glm::cross(up, e1);
  for (int a = 0; a < n; ++a)
    for (int c = 0; c < n; ++c) {
      const double mu = 1.0 - 2.0 * (a + 0.5) / n, phi = 2.0 * kPi * (c + 0.5) / n;
      const double sn = std::sqrt(std::max(0.0, 1.0 - mu * mu));
      const glm::dvec3 d = sn * std::cos(phi) * e1 + sn * std::sin(phi) * e2 + mu * up;
      bool ground = false;
      const double len = rayEnd(p, x, d, ground);
      const double dt = len / o.multipleSteps;
      glm::dvec3 depth(0.0), lum(0.0), fms(0.0);
      for (int k = 0; k < o.multipleSteps; ++k) {
        const glm::dvec3 y = x + (k + 0.5) * dt * d;
        const AtmosphereMedium m = mediumAt(p, glm::length(y) - p.bottomRadiusM);
        const glm::dvec3 tr = glm::exp(-(depth + m.extinction * (0.5 * dt)));
        depth += m.extinction * dt;
        const glm::dvec3 sigmaS = m.rayleigh + glm::dvec3(m.mieScattering);
        lum += tr * sigmaS * sunTransmittance(p, y, sun, o.multipleSunSteps) * (dt / (4.0 * kPi));
        fms += tr * sigmaS * dt;
      }
      if (ground) {
        const glm::dvec3 g = x + len * d;
        const double muG = std::max(0.0, glm::dot(glm::normalize(g), sun));
        lum += glm::exp(-depth) * p.groundAlbedo / kPi * muG *
               sunTransmittance(p, g, sun, o.multipleSunSteps);
      }
      l2 += lum / double(n * n);
      f += fms / double(n * n);
    }
  return l2 / (glm::dvec3(1.0) - f);
}

} // namespace

glm::dvec3 referenceMultiple(const AtmosphereParameters& p,
                             double h,
                             double muS,
                             const AtmosphereReferenceOptions& options) {
  const double c = std::clamp(muS, -1.0, 1.0);
  const glm::dvec3 sun(std::sqrt(std::max(0.0, 1.0 - c * c)), 0.0, c);
  return multipleAt(p, glm::dvec3(0.0, 0.0, p.bottomRadiusM + std::max(h, 0.0)), sun, options);
}

AtmosphereRay referenceRay(const AtmosphereParameters& p,
                           double h,
                           double mu,
                           double muS,
                           double nu,
                           double distanceM,
                           const AtmosphereReferenceOptions& o) {
  AtmosphereRay out;
  mu = std::clamp(mu, -1.0, 1.0);
  muS = std::clamp(muS, -1.0, 1.0);
  const double sv = std::sqrt(std::max(0.0, 1.0 - mu * mu));
  const glm::dvec3 eye(0.0, 0.0, p.bottomRadiusM + std::max(h, 0.0));
  const glm::dvec3 view(sv, 0.0, mu);
  // The sun: cosine muS to the zenith, nu to the view (clamped to what is possible).
  const double ss = std::sqrt(std::max(0.0, 1.0 - muS * muS));
  const double sx = sv > 1e-9 ? std::clamp((nu - mu * muS) / sv, -ss, ss) : ss;
  const glm::dvec3 sun(sx, std::sqrt(std::max(0.0, ss * ss - sx * sx)), muS);
  nu = glm::dot(view, sun);
  const auto top = sphere(eye, view, p.topRadiusM());
  if (!top || top->second <= 0.0) return out;
  const double t0 = std::max(0.0, top->first);
  bool ground = false;
  const glm::dvec3 start = eye + t0 * view;
  double t1 = t0 + rayEnd(p, start, view, ground);
  if (distanceM < t1) {
    t1 = std::max(t0, distanceM);
    ground = false;
  }
  const int n = o.viewSteps;
  const double dt = (t1 - t0) / n;
  // Psi_ms at a few points of the ray, linear in between.
  std::vector<glm::dvec3> psi;
  const int along = std::max(2, o.multipleAlong);
  if (o.multiple)
    for (int k = 0; k < along; ++k)
      psi.push_back(multipleAt(p, eye + (t0 + (t1 - t0) * k / (along - 1)) * view, sun, o));
  glm::dvec3 depth(0.0), prev(0.0), ray(0.0), mie(0.0), ms(0.0);
  for (int k = 0; k <= n; ++k) {
    const glm::dvec3 x = eye + (t0 + dt * k) * view;
    const AtmosphereMedium m = mediumAt(p, glm::length(x) - p.bottomRadiusM);
    if (k > 0) depth += 0.5 * dt * (prev + m.extinction);
    prev = m.extinction;
    const double w = (k == 0 || k == n) ? 0.5 * dt : dt;
    const glm::dvec3 tr = glm::exp(-depth);
    const glm::dvec3 sunT = sunTransmittance(p, x, sun, o.sunSteps);
    ray += w * tr * m.rayleigh * sunT;
    mie += w * tr * m.mieScattering * sunT;
    if (o.multiple) {
      const double u = double(k) / n * (along - 1);
      const int i = std::min(static_cast<int>(u), along - 2);
      const auto at = static_cast<std::size_t>(i);
      const glm::dvec3 ps = psi[at] * (i + 1 - u) + psi[at + 1] * (u - i);
      ms += w * tr * (m.rayleigh + glm::dvec3(m.mieScattering)) * ps;
    }
  }
  out.inscatter =
      p.solarIrradiance * (ray * rayleighPhase(nu) + mie * miePhase(p.miePhaseG, nu) + ms);
  out.transmittance = ground ? glm::dvec3(0.0) : glm::exp(-depth);
  return out;
}

} // namespace tellus::planet
