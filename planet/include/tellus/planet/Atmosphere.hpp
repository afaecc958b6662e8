#pragma once
/**
 * @file Atmosphere.hpp
 * @brief A planet's atmosphere (issue 23): its physical parameters, the precomputed tables the
 * renderer samples, and a CPU lookup that computes exactly what shaders/atmosphere.frag computes
 * (same parametrisation, same interpolation, in double), so the tables are tested without GL.
 *
 * The model and the tables follow
 * - E. Bruneton and F. Neyret, "Precomputed Atmospheric Scattering", EGSR 2008, and
 *   E. Bruneton's 2017 revision of it ("A Qualitative and Quantitative Evaluation of 8 Clear Sky
 *   Models", IEEE TVCG 2017, and its documented reimplementation): a spherical shell between
 *   bottomRadiusM and bottomRadiusM + topAltitudeM with exponential Rayleigh and Mie layers and a
 *   tent-shaped ozone layer; a 2D transmittance table over (r, mu) and a 4D single-scattering
 *   table over (r, mu, mu_s, nu) packed into a 3D texture (nu slices side by side along x), with
 *   Bruneton's non-linear maps from (r, mu, mu_s, nu) to texture coordinates (distances to the
 *   shell's boundaries, so that the horizon gets its own texels);
 * - S. Hillaire, "A Scalable and Production Ready Sky and Atmosphere Rendering Technique", EGSR
 *   2020, section 5.5: multiple scattering of every order as an isotropic source
 *   Psi_ms(r, mu_s) = L_2nd / (1 - f_ms) from a small 2D table (the infinite geometric series of
 *   the second order's transfer), added at each sample of the single-scattering integral with the
 *   local scattering coefficient. It replaces Bruneton's iterated orders (too slow to compute on
 *   the CPU at start-up) and is what the scattering table's Rayleigh channel holds besides the
 *   single Rayleigh term.
 *
 * Units: metres, radians, radiance in the units of solarIrradiance (the sun's irradiance at the
 * top of the atmosphere, per colour channel; the tables already contain it). Everything here is
 * double; the GL pass narrows the tables to 16-bit floats (their relative error, 5e-4, is far
 * below the tables' interpolation error).
 *
 * Geometry: the shell is a sphere. A body that is an ellipsoid (WGS84) is made a sphere by
 * stretching its polar axis by equatorial / polar radius (AtmosphereFrame): the ellipsoid becomes
 * the bottom sphere exactly and the atmosphere follows the surface at every latitude; the 0.34%
 * stretch of the scattering itself is negligible.
 *
 * Threads: the tables are immutable after precompute() (which uses worker threads itself).
 */

#include <glm/vec3.hpp>

#include <cstddef>
#include <expected>
#include <string>
#include <vector>

namespace tellus::planet {

/** The physical description of one atmosphere. Defaults: the Earth as in Bruneton's 2017
 * demonstration (sea-level coefficients per metre, at 680, 550 and 440 nm for R, G, B). */
struct AtmosphereParameters {
  double bottomRadiusM = 6378137.0;                            ///< the body's (equatorial) radius
  double topAltitudeM = 60000.0;                               ///< the shell's top above the bottom
  glm::dvec3 rayleighScattering{5.802e-6, 13.558e-6, 33.1e-6}; ///< at the bottom, 1/m
  double rayleighScaleHeightM = 8000.0;
  double mieScattering = 3.996e-6; ///< at the bottom, 1/m (grey)
  double mieExtinction = 4.44e-6;  ///< at the bottom, 1/m (scattering + absorption)
  double mieScaleHeightM = 1200.0;
  double miePhaseG = 0.8; ///< Cornette-Shanks asymmetry, (-1, 1)
  /** Ozone absorption at the tent's peak, 1/m; the tent rises linearly from
   * ozoneCentreM - ozoneHalfWidthM to its peak at ozoneCentreM and falls to 0 at + half width. */
  glm::dvec3 ozoneAbsorption{0.650e-6, 1.881e-6, 0.085e-6};
  double ozoneCentreM = 25000.0;
  double ozoneHalfWidthM = 15000.0;
  double sunAngularRadiusRad = 0.004675;
  /** The sun's irradiance at the top of the atmosphere per channel (Bruneton's demo's values for
   * 680, 550, 440 nm, W m^-2 nm^-1). */
  glm::dvec3 solarIrradiance{1.474, 1.8504, 1.91198};
  glm::dvec3 groundAlbedo{0.1, 0.1, 0.1}; ///< for the multiple scattering's ground bounce
  /** The sun's lowest cosine the tables cover (Bruneton: 102 degrees from the zenith for the
   * Earth); below it the sky is black. */
  double muSMin = -0.2;

  double topRadiusM() const noexcept { return bottomRadiusM + topAltitudeM; }
  /** "": valid; otherwise what is wrong (every number finite, positive where it must be). */
  std::string validate() const;
};

/** The extinction and scattering at one altitude. */
struct AtmosphereMedium {
  glm::dvec3 rayleigh{0.0}; ///< scattering = extinction, 1/m
  double mieScattering = 0.0;
  double mieExtinction = 0.0;
  glm::dvec3 ozone{0.0};      ///< absorption, 1/m
  glm::dvec3 extinction{0.0}; ///< the sum, 1/m
};
AtmosphereMedium mediumAt(const AtmosphereParameters& p, double altitudeM) noexcept;

/** The Rayleigh phase function 3/(16 pi) (1 + nu^2), per steradian. */
double rayleighPhase(double nu) noexcept;
/** The Cornette-Shanks phase function with asymmetry g, per steradian. */
double miePhase(double g, double nu) noexcept;

/** The tables' sizes (Bruneton's 2017 defaults for the scattering table). */
struct AtmosphereTableSizes {
  int transmittanceW = 256; ///< mu
  int transmittanceH = 64;  ///< r
  int scatteringR = 32;
  int scatteringMu = 128; ///< even: half for rays that reach the ground, half for those that do not
  int scatteringMuS = 32;
  int scatteringNu = 8;
  int multipleW = 128; ///< Psi_ms: mu_s (linear in [-1, 1]: 0.016 apart, twilight gets rows)
  int multipleH = 32;  ///< r
  int samples = 32;    ///< integration steps along one ray of the scattering table
};

/** What the sky contributes along one view ray: radiance added (the inscatter, per channel) and
 * the transmittance of what lies behind. */
struct AtmosphereRay {
  glm::dvec3 inscatter{0.0};
  glm::dvec3 transmittance{1.0};
};

/**
 * The precomputed tables, row-major float RGB (RGBA for none): index = ((z * h) + y) * w + x.
 * - transmittance: transmittanceW x transmittanceH, the transmittance from (r, mu) to the top;
 * - scattering: (scatteringNu * scatteringMuS) x scatteringMu x scatteringR: the Rayleigh single
 *   scattering plus the multiple scattering divided by the Rayleigh phase of the texel's nu;
 * - mie: the same layout, the Mie single scattering (phase functions applied at lookup);
 * - multiple: multipleW x multipleH, Psi_ms for a sun of irradiance 1.
 * (Bruneton's ground irradiance table is not made: the globe's sunlight is shaders/planet.frag's
 * own, and nothing read the table.)
 */
class AtmosphereTables {
public:
  /** Computes every table on worker threads (threads 0: the hardware's, at most 8). */
  static AtmosphereTables precompute(const AtmosphereParameters& p,
                                     const AtmosphereTableSizes& sizes = {},
                                     int threads = 0);
  /** Tables read back from disk (AtmosphereCache.hpp); each vector's size must be what `sizes`
   * gives (else an error). seconds: what reading them took. */
  static std::expected<AtmosphereTables, std::string> fromData(const AtmosphereParameters& p,
                                                               const AtmosphereTableSizes& sizes,
                                                               std::vector<float> transmittance,
                                                               std::vector<float> scattering,
                                                               std::vector<float> mie,
                                                               std::vector<float> multiple,
                                                               double seconds);

  const AtmosphereParameters& parameters() const noexcept { return p_; }
  const AtmosphereTableSizes& sizes() const noexcept { return s_; }
  const std::vector<float>& transmittanceTable() const noexcept { return transmittance_; }
  const std::vector<float>& scatteringTable() const noexcept { return scattering_; }
  const std::vector<float>& mieTable() const noexcept { return mie_; }
  const std::vector<float>& multipleTable() const noexcept { return multiple_; }
  /** Seconds the tables took to compute, or to read (fromData). */
  double precomputeSeconds() const noexcept { return seconds_; }

  /** The transmittance from altitude h (m above the bottom) along mu to the top (1 above it
   * when the ray misses the shell; 0 along a ray that reaches the ground). */
  glm::dvec3 transmittanceToTop(double h, double mu) const noexcept;
  /** Psi_ms at (h, mu_s), sun irradiance 1. */
  glm::dvec3 multipleScattering(double h, double muS) const noexcept;

  /** The sky along a view ray from an eye at altitude h (any: below 0 is taken as 0, above the top
   * the ray is moved to where it enters), mu = cos(view zenith), muS = cos(sun zenith), nu =
   * cos(view-sun angle); distanceM = where the ray hits a surface (aerial perspective), or
   * infinity for the sky. What shaders/atmosphere.frag computes, in double. No sun disk. */
  AtmosphereRay ray(double h, double mu, double muS, double nu, double distanceM) const noexcept;

private:
  struct Scattered {
    glm::dvec3 rayleigh{0.0};
    glm::dvec3 mie{0.0};
  };
  Scattered
  lookupScattering(double h, double mu, double muS, double nu, bool ground) const noexcept;
  void computeTransmittance();
  void computeMultiple(int threads);
  void computeScattering(int threads);

  AtmosphereParameters p_;
  AtmosphereTableSizes s_;
  std::vector<float> transmittance_, scattering_, mie_, multiple_;
  double seconds_ = 0.0;
};

} // namespace tellus::planet
