#pragma once
/**
 * @file ColourScale.hpp
 * @brief Values to colours: a colour map over a range, linear or log, and the EXACT index rule
 * that the proxy (here, on the CPU) and the renderer (on the GPU) both follow.
 *
 * The rule, for a value v (a float from ValueFormat's decode) and a scale {map, min, max,
 * scaling, outOfRange}:
 *
 *   1. v is NaN (no data)                      -> transparent (RGBA 0,0,0,0).
 *   2. linear: t = (v - min) / (max - min)
 *      log:    t = (log10(v) - log10(min)) / (log10(max) - log10(min)); v <= 0 (and -inf) is
 *              below the range (t = -inf); min and max must be > 0 (checkScale).
 *      min == max: t = -inf below, +inf above, 0.5 at v == min (the table's middle colour).
 *      +inf is above the range, -inf below.
 *   3. t < 0 or t > 1 is out of range: OutOfRange::Transparent -> transparent; Clamp -> goes on.
 *      (v == max gives t == 1: inside.)
 *   4. index = clamp(floor(t * 256), 0, 255); colour = map.table[index], alpha 255. No
 *      interpolation between entries (nearest bin).
 *
 * The CPU computes t in double. The GPU's shader computes the same formula in float32 (a 256x1
 * texture read with texelFetch at that index): float rounding moves t * 256 by at most ~3e-5 for
 * values of the range's magnitude, so the two agree exactly except where t * 256 lies within 1e-4
 * of an integer, where they may differ by one bin (one table entry). Which value a pixel shows
 * between texels is Sample.hpp's rule, on both sides.
 *
 * Range from the data: rangeFromData gives min/max or percentiles of the finite values (for a
 * log scale only of the positive ones), which the caller puts into the scale; a scale itself
 * always holds a fixed range.
 */

#include <tellus/codec/Image.hpp>
#include <tellus/values/ColourMap.hpp>
#include <tellus/values/ValueFormat.hpp>

#include <array>
#include <cstdint>
#include <expected>
#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace tellus::values {

enum class Scaling { Linear, Log };
enum class OutOfRange { Clamp, Transparent };

struct ColourScale {
  const ColourMap* map = nullptr; ///< from colourMaps() / findColourMap (never owned)
  double min = 0.0;               ///< the value at the table's low end (t = 0)
  double max = 1.0;               ///< the value at the high end (t = 1)
  Scaling scaling = Scaling::Linear;
  OutOfRange outOfRange = OutOfRange::Clamp;
};

/** An RGBA8 colour, straight (not premultiplied) alpha. */
using Rgba8 = std::array<std::uint8_t, 4>;

/** What is wrong with a scale: no map, a non-finite min or max, log with min or max <= 0;
 * nothing otherwise. */
std::expected<void, std::string> checkScale(const ColourScale& scale);

/** Step 2 of the rule: t for v (NaN for NaN; +-inf outside a degenerate range as stated). */
double scalePosition(const ColourScale& scale, float v) noexcept;

/** Steps 1-4: the table index of v, or -1 when v is transparent. */
int colourIndex(const ColourScale& scale, float v) noexcept;

/** The colour of v under the rule (transparent = {0, 0, 0, 0}). */
Rgba8 colourOf(const ColourScale& scale, float v) noexcept;

/** The raster coloured: a 4-channel codec::Image of the raster's size. The scale must pass
 * checkScale (else an error). */
std::expected<codec::Image, std::string> apply(const ValueRaster& raster, const ColourScale& scale);

struct ValueRange {
  double min = 0.0;
  double max = 0.0;
};

/** The range of the finite values (positiveOnly: of those > 0, for log scales): the lowPercent
 * and highPercent percentiles (0 and 100 = min and max; nearest rank on the sorted values).
 * nullopt when no value qualifies or the percentiles are not 0 <= low <= high <= 100. */
std::optional<ValueRange> rangeFromData(std::span<const float> values,
                                        double lowPercent = 0.0,
                                        double highPercent = 100.0,
                                        bool positiveOnly = false);

/** "linear", "log"; "clamp", "transparent"; and back (nullopt for other names). */
std::string_view scalingName(Scaling scaling) noexcept;
std::optional<Scaling> parseScaling(std::string_view name) noexcept;
std::string_view outOfRangeName(OutOfRange outOfRange) noexcept;
std::optional<OutOfRange> parseOutOfRange(std::string_view name) noexcept;

} // namespace tellus::values
