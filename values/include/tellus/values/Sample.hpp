#pragma once
/**
 * @file Sample.hpp
 * @brief THE value-sampling rule of value layers: one pure function that every reader of values
 * between texel centres follows (issue 24): the proxy's composed maps (proxy Compose.cpp,
 * composeValues), the value at a point (values::sample: GetFeatureInfo, `tellus height`, the
 * value under `view`'s cursor) and the renderer's shader (shaders/planet.frag, valueAt: the same
 * four texelFetch, weights and NaN rule in float32).
 *
 * The rule, for a point at texel coordinates (x, y) of a raster whose texel (i, j) covers
 * [i, i+1) x [j, j+1) and has its centre at (i + 0.5, j + 0.5):
 *
 *   1. gx = clamp(x - 0.5, 0, width - 1), gy likewise; i0 = floor(gx), i1 = min(i0 + 1, width - 1)
 *      (j0, j1 likewise); fx = gx - i0, fy = gy - j0 (in [0, 1)). At the raster's edges the outer
 *      half texel takes the edge texels' values (clamp to edge).
 *   2. No texel of the four is NaN: bilinear of the values (not of colours),
 *      top = v00 * (1 - fx) + v10 * fx, bottom = v01 * (1 - fx) + v11 * fx,
 *      value = top * (1 - fy) + bottom * fy. The colour is then the value's colour (ColourScale).
 *   3. Any of the four is NaN (no data): the value of the texel the point lies in, i.e. of the
 *      largest weight, ties to the second texel (fx >= 0.5 -> i1; fy >= 0.5 -> j1); NaN when
 *      that one is no data. So no data never spreads and never shrinks: a point is no data
 *      exactly when its own texel is, as with nearest sampling, and a value beside no data is its
 *      own texel's (no value is made up from fewer than four texels).
 *
 * The CPU computes it in double (Real = double); the GPU in float32 (Real = float mirrors it):
 * the two differ by float rounding, a few ulps of the values' magnitude.
 *
 * Edges between tiles: the proxy's four texels may come from up to four tiles (it samples across
 * tile edges), while a renderer texture holds one node's tile without its neighbours' texels, so
 * within half a texel of a tile's edge the renderer clamps to the edge (step 1) where the proxy
 * interpolates with the next tile: there they differ by at most half the difference between the
 * two texels across the edge (docs/design/values-renderer.md gives the measured figures).
 */

#include <cmath>

namespace tellus::values {

/** Step 1 on one axis: texel coordinate x of a raster `size` texels wide (size >= 1) -> the two
 * texel indices and the second's weight. */
template <class Real> struct AxisTexels {
  int i0 = 0;
  int i1 = 0;
  Real f = 0; ///< the weight of i1, in [0, 1)
};

template <class Real> AxisTexels<Real> axisTexels(Real x, int size) noexcept {
  Real g = x - Real(0.5);
  const Real last = static_cast<Real>(size - 1);
  g = g < Real(0) ? Real(0) : (g > last ? last : g); // NaN x stays NaN: caller checks
  AxisTexels<Real> a;
  a.i0 = static_cast<int>(std::floor(g));
  a.i1 = a.i0 + 1 < size ? a.i0 + 1 : size - 1;
  a.f = g - static_cast<Real>(a.i0);
  return a;
}

/** Steps 2 and 3: the value between four texels v00 (i0, j0), v10 (i1, j0), v01 (i0, j1), v11
 * (i1, j1) with the second texels' weights fx, fy in [0, 1]. */
template <class Real>
Real bilinearValue(Real v00, Real v10, Real v01, Real v11, Real fx, Real fy) noexcept {
  if (std::isnan(v00) || std::isnan(v10) || std::isnan(v01) || std::isnan(v11)) {
    const bool right = fx >= Real(0.5), down = fy >= Real(0.5);
    return down ? (right ? v11 : v01) : (right ? v10 : v00);
  }
  const Real top = v00 * (Real(1) - fx) + v10 * fx;
  const Real bottom = v01 * (Real(1) - fx) + v11 * fx;
  return top * (Real(1) - fy) + bottom * fy;
}

} // namespace tellus::values
