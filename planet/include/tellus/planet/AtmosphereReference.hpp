#pragma once
/**
 * @file AtmosphereReference.hpp
 * @brief A brute-force reference for the atmosphere's tables and shader (issue 23): the
 * scattering integral along one view ray marched in double, with no table.
 *
 * What it includes, exactly:
 * - single scattering (Rayleigh and Mie with their phase functions, ozone absorbing), exact up to
 *   the quadrature: a trapezoid of `viewSteps` along the view ray (entering the shell first when
 *   the eye is above it; ending at the ground, the top or `distanceM`), and at each step the
 *   sun's transmittance integrated along the sun's direction with `sunSteps` steps (not from a
 *   table), times the share of the sun's disc above the horizon (the same smoothed-linear share
 *   the tables use, Bruneton 2017);
 * - multiple scattering of every order as Hillaire's (2020) isotropic source Psi_ms =
 *   L_2nd / (1 - f_ms), with L_2nd and f_ms integrated by brute force over the sphere of
 *   directions at `multipleAlong` points of the view ray (linear in between), each direction
 *   marched with exact sun transmittances, the ground's Lambertian bounce included.
 * It does not include Hillaire's approximation's own error against true multiple scattering (the
 * paper measures it against a path tracer: a few percent for the Earth), polarisation, or a
 * shadowing terrain. The transmittance it returns is exp(-optical depth) from the eye to the
 * ray's end (1 when the ray misses the shell, 0 when it ends on the ground without distanceM).
 * Geometry in 3D vectors (not Bruneton's r-mu algebra), so it checks that algebra too.
 * Slow by design: about 10-40 ms a ray with the defaults.
 */

#include <tellus/planet/Atmosphere.hpp>

namespace tellus::planet {

struct AtmosphereReferenceOptions {
  int viewSteps = 600;
  int sunSteps = 200;
  bool multiple = true;
  int multipleAlong = 10;
  int multipleDirs = 8; ///< per axis of the sphere (8 x 8 equal-area directions)
  int multipleSteps = 24;
  int multipleSunSteps = 60;
};

/** The sky along a view ray from altitude h (m above the bottom; above the top allowed), view
 * zenith cosine mu, sun zenith cosine muS, view-sun cosine nu (clamped to what mu and muS allow),
 * to distanceM (infinity: the sky). Radiance in the solar irradiance's units, no sun disc. */
AtmosphereRay referenceRay(const AtmosphereParameters& p,
                           double h,
                           double mu,
                           double muS,
                           double nu,
                           double distanceM,
                           const AtmosphereReferenceOptions& options = {});

/** Psi_ms at altitude h with the sun at muS, by brute force (a sun of irradiance 1). */
glm::dvec3 referenceMultiple(const AtmosphereParameters& p,
                             double h,
                             double muS,
                             const AtmosphereReferenceOptions& options = {});

} // namespace tellus::planet
