// Layers of one sample per texel (Compose.hpp): heights and values composed (bilinear, no-data
// never blended in), and pictures of them: values coloured by a scale, heights as grey, a picture's
// luminance as heights. The axes and the other samplers: ComposeSampling.hpp.
#include "compose/ComposeSampling.hpp"

#include <tellus/values/Sample.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace tellus {

using compose::forEachPixel;
using compose::over;
using compose::Quad;

namespace {

/** Bilinear height of a quad; the nearest texel where one of the four is no-data. */
std::int16_t sampleHeight(const Quad& q, std::int16_t noData) noexcept {
  std::int16_t v[4];
  bool any = false;
  for (int k = 0; k < 4; ++k) {
    v[k] = q.t[k]->heights[q.index[k]];
    any = any || v[k] == noData;
  }
  if (any) { // the valid texel of the largest weight (no-data when none is valid)
    const double w[4] = {
        (1 - q.fx) * (1 - q.fy), q.fx * (1 - q.fy), (1 - q.fx) * q.fy, q.fx * q.fy};
    int best = -1;
    for (int k = 0; k < 4; ++k) {
      if (v[k] != noData && (best < 0 || w[k] > w[best])) best = k;
    }
    return best < 0 ? noData : v[best];
  }
  const double top = v[0] + (v[1] - v[0]) * q.fx;
  const double bottom = v[2] + (v[3] - v[2]) * q.fx;
  return static_cast<std::int16_t>(std::lround(top + (bottom - top) * q.fy));
}

} // namespace

ComposeStats composeHeights(const TileGrid& grid,
                            const MapBox& box,
                            std::int32_t width,
                            std::int32_t height,
                            std::int32_t level,
                            std::int32_t firstLevel,
                            const TileLookup& tiles,
                            std::int16_t noData,
                            std::vector<std::int16_t>& heights) {
  heights.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height), noData);
  return forEachPixel(
      grid, box, width, height, level, firstLevel, tiles, [&](std::size_t pixel, const Quad& q) {
        const std::int16_t h = sampleHeight(q, noData);
        if (h != noData) heights[pixel] = h;
      });
}

namespace {

/** The value of a quad of value tiles by values/Sample.hpp's rule (bilinearValue, in double):
 * bilinear; the texel the point lies in where one of the four is NaN. */
float sampleValue(const Quad& q) noexcept {
  return static_cast<float>(values::bilinearValue(static_cast<double>(q.t[0]->values[q.index[0]]),
                                                  static_cast<double>(q.t[1]->values[q.index[1]]),
                                                  static_cast<double>(q.t[2]->values[q.index[2]]),
                                                  static_cast<double>(q.t[3]->values[q.index[3]]),
                                                  q.fx,
                                                  q.fy));
}

} // namespace

ComposeStats composeValues(const TileGrid& grid,
                           const MapBox& box,
                           std::int32_t width,
                           std::int32_t height,
                           std::int32_t level,
                           std::int32_t firstLevel,
                           const TileLookup& tiles,
                           std::vector<float>& values) {
  values.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height),
                std::numeric_limits<float>::quiet_NaN());
  return forEachPixel(
      grid, box, width, height, level, firstLevel, tiles, [&](std::size_t pixel, const Quad& q) {
        const float v = sampleValue(q);
        if (!std::isnan(v)) values[pixel] = v;
      });
}

void drawValuesAsColours(const std::vector<float>& values,
                         const values::ColourScale& scale,
                         double opacity,
                         std::vector<std::uint8_t>& canvas,
                         std::int32_t canvasChannels) {
  const double alpha = std::clamp(opacity, 0.0, 1.0);
  const auto channels = static_cast<std::size_t>(canvasChannels);
  for (std::size_t p = 0; p < values.size() && (p + 1) * channels <= canvas.size(); ++p) {
    values::Rgba8 c = values::colourOf(scale, values[p]);
    if (c[3] == 0) continue;
    c[3] = static_cast<std::uint8_t>(std::lround(alpha * 255.0));
    over(c.data(), &canvas[p * channels], canvasChannels);
  }
}

std::uint8_t heightToGrey(std::int16_t raw) noexcept {
  const std::int32_t span = kGreyRampHigh - kGreyRampLow;
  const std::int32_t v = std::clamp<std::int32_t>(raw, kGreyRampLow, kGreyRampHigh) - kGreyRampLow;
  return static_cast<std::uint8_t>((v * 255 + span / 2) / span);
}

void drawHeightsAsGrey(const std::vector<std::int16_t>& heights,
                       std::int16_t noData,
                       double opacity,
                       std::vector<std::uint8_t>& canvas,
                       std::int32_t canvasChannels) {
  const auto alpha = static_cast<std::uint8_t>(std::lround(std::clamp(opacity, 0.0, 1.0) * 255.0));
  const auto channels = static_cast<std::size_t>(canvasChannels);
  for (std::size_t p = 0; p < heights.size() && (p + 1) * channels <= canvas.size(); ++p) {
    if (heights[p] == noData) continue;
    const std::uint8_t g = heightToGrey(heights[p]);
    const std::uint8_t src[4] = {g, g, g, alpha};
    over(src, &canvas[p * channels], canvasChannels);
  }
}

std::uint8_t luminance(std::uint8_t r, std::uint8_t g, std::uint8_t b) noexcept {
  return static_cast<std::uint8_t>((299 * r + 587 * g + 114 * b + 500) / 1000);
}

void drawLuminanceAsHeights(const std::vector<std::uint8_t>& rgba,
                            std::vector<std::int16_t>& heights) {
  for (std::size_t p = 0; p < heights.size() && (p + 1) * 4 <= rgba.size(); ++p) {
    const std::uint8_t* px = &rgba[p * 4];
    if (px[3] >= 128) heights[p] = luminance(px[0], px[1], px[2]);
  }
}

} // namespace tellus
