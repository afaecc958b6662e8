// The atmosphere's tables, computed on the CPU in double (Atmosphere.hpp): transmittance
// (Bruneton 2017), Hillaire's (2020) multiple-scattering table Psi_ms, the single-scattering
// table with Psi_ms folded in. Own implementation of the papers'
// integrals: trapezoids along each ray, rows shared out to worker threads.
#include "AtmosphereGeometry.hpp"

#include <tellus/planet/Atmosphere.hpp>

#include <glm/glm.hpp>

#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <thread>

namespace tellus::planet {

namespace {

constexpr double kPi = std::numbers::pi;

std::size_t sz(int i) {
  return static_cast<std::size_t>(i);
}

void put(std::vector<float>& t, int index, const glm::dvec3& v) {
  const std::size_t i = sz(index);
  t[3 * i] = static_cast<float>(v.x);
  t[3 * i + 1] = static_cast<float>(v.y);
  t[3 * i + 2] = static_cast<float>(v.z);
}

/** Runs job(i) for i in [0, n) on `threads` threads. */
void parallelFor(int n, int threads, const std::function<void(int)>& job) {
  std::atomic<int> next{0};
  auto work = [&] {
    for (int i = next++; i < n; i = next++)
      job(i);
  };
  std::vector<std::jthread> pool;
  for (int t = 1; t < threads; ++t)
    pool.emplace_back(work);
  work();
}

double smoothstep(double a, double b, double x) {
  const double t = std::clamp((x - a) / (b - a), 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

/** The lookups of the scattering table's inner loop at one altitude, with everything that
 * depends on the altitude alone done once: the same values as toSun() and
 * AtmosphereTables::multipleScattering(), about 4x faster. */
struct AltitudeRow {
  double r = 0.0, dMin = 0.0, dMax = 0.0, c = 0.0, sinH = 0.0, cosH = 0.0;
  int ty0 = 0, ty1 = 0, my0 = 0, my1 = 0;
  double tfy = 0.0, mfy = 0.0;
};

void rowAxis(double u, int n, int& i0, int& i1, double& f) {
  const double x = u * n - 0.5;
  const double fl = std::floor(x);
  f = x - fl;
  i0 = std::clamp(static_cast<int>(fl), 0, n - 1);
  i1 = std::clamp(static_cast<int>(fl) + 1, 0, n - 1);
}

glm::dvec3 rowTexel(const std::vector<float>& t, int w, int y0, int y1, double fy, double u) {
  int x0, x1;
  double fx;
  rowAxis(u, w, x0, x1, fx);
  auto at = [&](int x, int y) {
    const std::size_t i = 3 * (sz(y) * sz(w) + sz(x));
    return glm::dvec3(t[i], t[i + 1], t[i + 2]);
  };
  return (at(x0, y0) * (1 - fx) + at(x1, y0) * fx) * (1 - fy) +
         (at(x0, y1) * (1 - fx) + at(x1, y1) * fx) * fy;
}

} // namespace

std::string AtmosphereParameters::validate() const {
  auto finite3 = [](const glm::dvec3& v) {
    return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z) && v.x >= 0.0 &&
           v.y >= 0.0 && v.z >= 0.0;
  };
  if (!(bottomRadiusM > 0.0 && std::isfinite(bottomRadiusM)))
    return "the bottom radius must be positive";
  if (!(topAltitudeM > 0.0 && topAltitudeM < bottomRadiusM))
    return "the top altitude must be positive and below the bottom radius";
  if (!finite3(rayleighScattering) || !finite3(ozoneAbsorption) || !finite3(solarIrradiance))
    return "Rayleigh scattering, ozone absorption and the solar irradiance must be >= 0";
  if (!finite3(groundAlbedo) || groundAlbedo.x > 1.0 || groundAlbedo.y > 1.0 ||
      groundAlbedo.z > 1.0)
    return "the ground albedo must be in [0, 1]";
  if (!(rayleighScaleHeightM > 0.0 && mieScaleHeightM > 0.0 && ozoneHalfWidthM > 0.0))
    return "scale heights and the ozone layer's half width must be positive";
  if (!(mieScattering >= 0.0 && mieExtinction >= mieScattering && std::isfinite(mieExtinction)))
    return "Mie extinction must be >= Mie scattering >= 0";
  if (!(miePhaseG > -1.0 && miePhaseG < 1.0)) return "the Mie phase g must be in (-1, 1)";
  if (!std::isfinite(ozoneCentreM)) return "the ozone layer's centre must be finite";
  if (!(sunAngularRadiusRad > 0.0 && sunAngularRadiusRad < 0.1))
    return "the sun's angular radius must be in (0, 0.1) rad";
  if (!(muSMin > -1.0 && muSMin < 0.0)) return "muSMin must be in (-1, 0)";
  return "";
}

AtmosphereMedium mediumAt(const AtmosphereParameters& p, double altitudeM) noexcept {
  AtmosphereMedium m;
  const double h = std::max(altitudeM, 0.0);
  const double dr = std::exp(-h / p.rayleighScaleHeightM);
  const double dm = std::exp(-h / p.mieScaleHeightM);
  const double dz = std::max(0.0, 1.0 - std::abs(h - p.ozoneCentreM) / p.ozoneHalfWidthM);
  m.rayleigh = p.rayleighScattering * dr;
  m.mieScattering = p.mieScattering * dm;
  m.mieExtinction = p.mieExtinction * dm;
  m.ozone = p.ozoneAbsorption * dz;
  m.extinction = m.rayleigh + glm::dvec3(m.mieExtinction) + m.ozone;
  return m;
}

AtmosphereTables AtmosphereTables::precompute(const AtmosphereParameters& p,
                                              const AtmosphereTableSizes& sizes,
                                              int threads) {
  const auto start = std::chrono::steady_clock::now();
  AtmosphereTables t;
  t.p_ = p;
  t.s_ = sizes;
  if (threads <= 0)
    threads = std::clamp(static_cast<int>(std::thread::hardware_concurrency()), 1, 8);
  t.computeTransmittance();
  t.computeMultiple(threads);
  t.computeScattering(threads);
  t.seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return t;
}

std::expected<AtmosphereTables, std::string>
AtmosphereTables::fromData(const AtmosphereParameters& p,
                           const AtmosphereTableSizes& sizes,
                           std::vector<float> transmittance,
                           std::vector<float> scattering,
                           std::vector<float> mie,
                           std::vector<float> multiple,
                           double seconds) {
  auto n = [](int a, int b, int c = 1) { return sz(a) * sz(b) * sz(c) * 3; };
  const std::size_t s4 =
      n(sizes.scatteringNu * sizes.scatteringMuS, sizes.scatteringMu, sizes.scatteringR);
  if (transmittance.size() != n(sizes.transmittanceW, sizes.transmittanceH) ||
      scattering.size() != s4 || mie.size() != s4 ||
      multiple.size() != n(sizes.multipleW, sizes.multipleH))
    return std::unexpected(std::string("atmosphere tables of the wrong sizes"));
  AtmosphereTables t;
  t.p_ = p;
  t.s_ = sizes;
  t.transmittance_ = std::move(transmittance);
  t.scattering_ = std::move(scattering);
  t.mie_ = std::move(mie);
  t.multiple_ = std::move(multiple);
  t.seconds_ = seconds;
  return t;
}

void AtmosphereTables::computeTransmittance() {
  const atmo::Shell s(p_);
  const int w = s_.transmittanceW, hgt = s_.transmittanceH;
  transmittance_.assign(sz(w * hgt * 3), 0.0f);
  constexpr int kSteps = 500;
  for (int j = 0; j < hgt; ++j)
    for (int i = 0; i < w; ++i) {
      double h, mu;
      atmo::transmittanceTexel(s, w, hgt, i, j, h, mu);
      const double len = atmo::distanceToTop(s, h, mu);
      glm::dvec3 depth(0.0);
      for (int k = 0; k <= kSteps; ++k) {
        const double d = len * k / kSteps;
        const double wgt = (k == 0 || k == kSteps) ? 0.5 : 1.0;
        depth += wgt * mediumAt(p_, atmo::along(s, h, mu, d).h).extinction;
      }
      put(transmittance_, j * w + i, glm::exp(-depth * (len / kSteps)));
    }
}

/** The transmittance to the sun from (h, mu_s), times the share of the sun's disc above the
 * horizon (Bruneton 2017: linear across the disc, smoothed). */
static glm::dvec3
toSun(const AtmosphereTables& t, const atmo::Shell& s, double alpha, double h, double muS) {
  const double sinH = s.b / (s.b + h);
  const double cosH = -std::sqrt(std::max(0.0, 1.0 - sinH * sinH));
  return t.transmittanceToTop(h, muS) * smoothstep(-sinH * alpha, sinH * alpha, muS - cosH);
}

void AtmosphereTables::computeMultiple(int threads) {
  // Hillaire 2020, section 5.5: L_2nd and f_ms over 8 x 8 directions of the sphere (equal areas),
  // 20 steps each; Psi_ms = L_2nd / (1 - f_ms). A sun of irradiance 1.
  const atmo::Shell s(p_);
  const int w = s_.multipleW, hgt = s_.multipleH;
  multiple_.assign(sz(w * hgt * 3), 0.0f);
  constexpr int kDirs = 8, kSteps = 20;
  parallelFor(hgt * w, threads, [&](int cell) {
    const int j = cell / w, i = cell % w;
    {
      const double h = p_.topAltitudeM * j / (hgt - 1);
      const double muS = -1.0 + 2.0 * i / (w - 1);
      const glm::dvec3 sun(std::sqrt(std::max(0.0, 1.0 - muS * muS)), 0.0, muS);
      glm::dvec3 l2(0.0), f(0.0);
      for (int a = 0; a < kDirs; ++a)
        for (int b = 0; b < kDirs; ++b) {
          const double mu = 1.0 - 2.0 * (a + 0.5) / kDirs;
          const double phi = 2.0 * kPi * (b + 0.5) / kDirs;
          const double sn = std::sqrt(std::max(0.0, 1.0 - mu * mu));
          const glm::dvec3 dir(sn * std::cos(phi), sn * std::sin(phi), mu);
          const double nu = glm::dot(dir, sun);
          const bool ground = atmo::hitsGround(s, h, mu);
          const double len =
              ground ? atmo::distanceToBottom(s, h, mu) : atmo::distanceToTop(s, h, mu);
          const double dt = len / kSteps;
          glm::dvec3 depth(0.0), lum(0.0), fms(0.0);
          for (int k = 0; k < kSteps; ++k) { // midpoints
            const double d = (k + 0.5) * dt;
            const atmo::RayPoint q = atmo::along(s, h, mu, d);
            const AtmosphereMedium m = mediumAt(p_, q.h);
            const glm::dvec3 tr = glm::exp(-(depth + m.extinction * (0.5 * dt)));
            depth += m.extinction * dt;
            const glm::dvec3 sigmaS = m.rayleigh + glm::dvec3(m.mieScattering);
            const double muSq = atmo::clampCos(((s.b + h) * muS + d * nu) / q.r);
            lum += tr * sigmaS * toSun(*this, s, p_.sunAngularRadiusRad, q.h, muSq) *
                   (dt / (4.0 * kPi));
            fms += tr * sigmaS * dt;
          }
          if (ground) { // the ground's bounce, Lambertian
            const double muSg = atmo::clampCos(((s.b + h) * muS + len * nu) / s.b);
            lum += glm::exp(-depth) * p_.groundAlbedo / kPi * std::max(muSg, 0.0) *
                   toSun(*this, s, p_.sunAngularRadiusRad, 0.0, muSg);
          }
          l2 += lum / double(kDirs * kDirs);
          f += fms / double(kDirs * kDirs);
        }
      put(multiple_, j * w + i, l2 / (glm::dvec3(1.0) - f));
    }
  });
}

void AtmosphereTables::computeScattering(int threads) {
  const atmo::Shell s(p_);
  const int nNu = s_.scatteringNu, nMuS = s_.scatteringMuS, nMu = s_.scatteringMu,
            nR = s_.scatteringR, n = s_.samples;
  const int w = nNu * nMuS;
  const std::size_t count = sz(w * nMu * nR);
  scattering_.assign(count * 3, 0.0f);
  mie_.assign(count * 3, 0.0f);
  const int half = nMu / 2;
  parallelFor(nR * nMu, threads, [&](int row) {
    const int l = row / nMu, j = row % nMu;
    const double rho = s.H * l / (nR - 1);
    const double r = std::sqrt(rho * rho + s.b * s.b);
    const double h = rho * rho / (r + s.b);
    const bool ground = j < half;
    const double x = ground ? double(half - 1 - j) / (half - 1) : double(j - half) / (half - 1);
    double mu, len;
    if (ground) {
      const double d = h + x * (rho - h);
      mu = d <= 0.0 ? -1.0 : atmo::clampCos(-(rho * rho + d * d) / (2.0 * r * d));
      len = atmo::distanceToBottom(s, h, mu);
    } else {
      const double d = (s.a - h) + x * (rho + s.H - (s.a - h));
      mu = d <= 0.0 ? 1.0 : atmo::clampCos((s.H * s.H - rho * rho - d * d) / (2.0 * r * d));
      len = atmo::distanceToTop(s, h, mu);
    }
    // The ray's samples (trapezoid), shared by every (mu_s, nu) of this row.
    struct Sample {
      double d, h, r, weight;
      glm::dvec3 tr, rayleigh;
      double mie;
    };
    std::vector<Sample> pts(sz(n + 1));
    glm::dvec3 depth(0.0), prev(0.0);
    const double dt = len / n;
    for (int k = 0; k <= n; ++k) {
      const double d = dt * k;
      const atmo::RayPoint q = atmo::along(s, h, mu, d);
      const AtmosphereMedium m = mediumAt(p_, q.h);
      if (k > 0) depth += 0.5 * dt * (prev + m.extinction);
      prev = m.extinction;
      pts[sz(k)] = {d,
                    q.h,
                    q.r,
                    (k == 0 || k == n) ? 0.5 * dt : dt,
                    glm::exp(-depth),
                    m.rayleigh,
                    m.mieScattering};
    }
    std::vector<AltitudeRow> rows(pts.size());
    for (std::size_t q = 0; q < pts.size(); ++q) {
      AltitudeRow& ar = rows[q];
      const double hq = pts[q].h;
      const double rq = atmo::rhoOf(s, hq);
      ar.r = s.b + hq;
      ar.dMin = s.a - hq;
      ar.dMax = rq + s.H;
      ar.c = (s.a - hq) * (s.t + ar.r);
      ar.sinH = s.b / ar.r;
      ar.cosH = -std::sqrt(std::max(0.0, 1.0 - ar.sinH * ar.sinH));
      rowAxis(atmo::unitToCoord(std::clamp(rq / s.H, 0.0, 1.0), s_.transmittanceH),
              s_.transmittanceH,
              ar.ty0,
              ar.ty1,
              ar.tfy);
      rowAxis(atmo::unitToCoord(std::clamp(hq / p_.topAltitudeM, 0.0, 1.0), s_.multipleH),
              s_.multipleH,
              ar.my0,
              ar.my1,
              ar.mfy);
    }
    for (int i = 0; i < nMuS; ++i) {
      const double muS = atmo::unitToMuS(s, p_.muSMin, double(i) / (nMuS - 1));
      for (int k = 0; k < nNu; ++k) {
        const double wide = std::sqrt(std::max(0.0, (1.0 - mu * mu) * (1.0 - muS * muS)));
        const double nu = std::clamp(-1.0 + 2.0 * k / (nNu - 1), mu * muS - wide, mu * muS + wide);
        const double pr = rayleighPhase(nu);
        glm::dvec3 ray(0.0), mie(0.0);
        for (std::size_t q = 0; q < pts.size(); ++q) {
          const Sample& sm = pts[q];
          const AltitudeRow& ar = rows[q];
          const double muSq = atmo::clampCos((r * muS + sm.d * nu) / sm.r);
          // distanceToTop(h, muSq), transmittanceUv's u, toSun's disc share (AtmosphereGeometry)
          const double disc = ar.r * ar.r * muSq * muSq + ar.c;
          double dTop = 0.0;
          if (disc >= 0.0) {
            const double qq = std::sqrt(disc);
            dTop = muSq <= 0.0 ? std::max(0.0, qq - ar.r * muSq)
                               : std::max(0.0, ar.c / (qq + ar.r * muSq));
          }
          const double xMu = ar.dMax > ar.dMin ? (dTop - ar.dMin) / (ar.dMax - ar.dMin) : 0.0;
          const double u = atmo::unitToCoord(std::clamp(xMu, 0.0, 1.0), s_.transmittanceW);
          const double alpha = p_.sunAngularRadiusRad;
          const glm::dvec3 sun =
              rowTexel(transmittance_, s_.transmittanceW, ar.ty0, ar.ty1, ar.tfy, u) *
              smoothstep(-ar.sinH * alpha, ar.sinH * alpha, muSq - ar.cosH);
          const double um =
              atmo::unitToCoord(std::clamp((muSq + 1.0) / 2.0, 0.0, 1.0), s_.multipleW);
          const glm::dvec3 ms = rowTexel(multiple_, s_.multipleW, ar.my0, ar.my1, ar.mfy, um);
          const glm::dvec3 sigmaS = sm.rayleigh + glm::dvec3(sm.mie);
          ray += sm.weight * sm.tr * (sm.rayleigh * sun + sigmaS * ms / pr);
          mie += sm.weight * sm.tr * sm.mie * sun;
        }
        const int idx = (l * nMu + j) * w + k * nMuS + i;
        put(scattering_, idx, ray * p_.solarIrradiance);
        put(mie_, idx, mie * p_.solarIrradiance);
      }
    }
  });
}

} // namespace tellus::planet
