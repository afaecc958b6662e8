#pragma once
// The periodic terms of Meeus's lunar theory ("Astronomical Algorithms", 2nd ed., ch. 47, tables
// 47.A and 47.B, from the ELP-2000/82 truncation of Chapront-Touze and Chapront) and of the
// IAU 1980 nutation (table 22.A). Data only; Moon.cpp and Nutation.cpp sum them.

#include <array>
#include <cstdint>

namespace tellus::planet::astro::detail {

/** Multiples of D, M, M', F and the coefficients of sin (longitude, 1e-6 degree) and cos
 * (distance, 1e-3 km) of their sum. */
struct MoonLongitudeDistanceTerm {
  std::int8_t d, m, mp, f;
  std::int32_t sinLongitude, cosDistance;
};
/** Multiples of D, M, M', F and the coefficient of sin (latitude, 1e-6 degree) of their sum. */
struct MoonLatitudeTerm {
  std::int8_t d, m, mp, f;
  std::int32_t sinLatitude;
};
/** Multiples of D, M, M', F, Omega; Delta psi = (a + b T) sin, Delta epsilon = (c + d T) cos,
 * in 0.0001 arc second. */
struct NutationTerm {
  std::int8_t d, m, mp, f, omega;
  double psi, psiT, eps, epsT;
};

extern const std::array<MoonLongitudeDistanceTerm, 60> kMoonLongitudeDistanceTerms;
extern const std::array<MoonLatitudeTerm, 60> kMoonLatitudeTerms;
extern const std::array<NutationTerm, 63> kNutationTerms;

} // namespace tellus::planet::astro::detail
