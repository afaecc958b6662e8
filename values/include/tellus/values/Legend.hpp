#pragma once
/**
 * @file Legend.hpp
 * @brief The legend of a colour scale: a colour bar, its range's ends, "nice" ticks with labels,
 * a title and the unit, drawn into RGBA8 pixels with an embedded bitmap font.
 *
 * Used by the proxy's GetLegendGraphic (PNG) and by the renderer's on-screen legend. Layout in
 * logical pixels (multiplied by `scaleFactor` at the end, nearest neighbour, so that a 4096-pixel
 * domemaster can show it large and sharp): a title row ("title [unit]", 13 px glyphs of the X11
 * misc-fixed 6x13 font, public domain, values/src/Font6x13.cpp), then the bar. Wider than tall:
 * a horizontal bar with tick labels under it; taller than wide: a vertical bar (low at the
 * bottom) with the labels to its right. Along the bar, the pixel at fraction f in [0, 1) of its
 * length has the colour of index floor(f * 256) (the bar is the table in order, whatever the
 * scaling); a tick for value v sits at the position t(v) of ColourScale's rule.
 *
 * Ticks (legendTicks): linear: the multiples of a 1-2-5 step (1, 2, 5 x 10^k, the smallest that
 * gives at most maxTicks ticks) inside [min, max]; log: the decades 10^k inside the range (every
 * 2nd, 3rd, ... when there are more than maxTicks; 2 and 5 times them added when fewer than
 * 3 decades). The range's two ends are always labelled; a tick whose label would overlap another
 * label is drawn without one.
 */

#include <tellus/codec/Image.hpp>
#include <tellus/values/ColourScale.hpp>

#include <expected>
#include <string>
#include <string_view>
#include <vector>

namespace tellus::values {

struct LegendOptions {
  int width = 256;     ///< logical pixels (before scaleFactor), 32..4096
  int height = 56;     ///< logical pixels, 32..4096
  int scaleFactor = 1; ///< integer upscaling, 1..16 (the image is width*f x height*f)
  Rgba8 background{255, 255, 255, 255}; ///< e.g. {0, 0, 0, 160} for semi-transparent over a globe
  Rgba8 foreground{0, 0, 0, 255};       ///< text, ticks and the bar's outline
  /** false: the bar and title only, no ticks or numbers (a range taken from each map's data,
   * which a legend cannot know). */
  bool labels = true;
};

/** The legend of `scale` (which must pass checkScale) titled "title [unit]" ("title" when unit
 * is empty, "[unit]" when title is). Errors: a bad scale, sizes or factor outside the limits. */
std::expected<codec::Image, std::string> renderLegend(const ColourScale& scale,
                                                      std::string_view unit,
                                                      std::string_view title,
                                                      const LegendOptions& options = {});

/** The tick values for [min, max] (min < max; log: min > 0) as described above, ascending. */
std::vector<double> legendTicks(double min, double max, Scaling scaling, int maxTicks);

/** A tick label: the shortest of fixed notation with the step's decimals (step: the distance
 * between ticks, 0 = choose 3 significant digits) or, for |v| >= 1e6 or 0 < |v| < 1e-3,
 * scientific ("1e-4", "2.5e6"). "0" for zero, never "-0". */
std::string formatTickLabel(double value, double step);

/** Width in logical pixels of `text` in the legend font (6 per character, UTF-8 aware). */
int legendTextWidth(std::string_view text) noexcept;

} // namespace tellus::values
