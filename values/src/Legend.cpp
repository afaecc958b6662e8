// The legend's layout (Legend.hpp says what it draws); text and ticks in LegendText/LegendTicks.
#include "Font6x13.hpp"
#include "LegendText.hpp"

#include <tellus/values/Legend.hpp>

#include <algorithm>
#include <cmath>
#include <string>

namespace tellus::values {

namespace {

constexpr int kPad = 4;
constexpr int kTickLength = 3;
constexpr int kLabelGap = 6; ///< pixels kept free between two labels

using detail::kGlyphHeight;

void fillRect(codec::Image& image, int x0, int y0, int x1, int y1, const Rgba8& colour) {
  for (int y = std::max(y0, 0); y < std::min(y1, image.height); ++y)
    for (int x = std::max(x0, 0); x < std::min(x1, image.width); ++x) {
      const auto at = (static_cast<std::size_t>(y) * static_cast<std::size_t>(image.width) +
                       static_cast<std::size_t>(x)) *
                      4;
      std::copy(
          colour.begin(), colour.end(), image.pixels.begin() + static_cast<std::ptrdiff_t>(at));
    }
}

/** The colour of the bar at pixel `i` of `length` from its low end: index floor(f * 256). */
Rgba8 barColour(const ColourMap& map, int i, int length) {
  const double f = (i + 0.5) / length;
  const auto index = static_cast<std::size_t>(std::clamp(static_cast<int>(f * 256.0), 0, 255));
  const Rgb8& c = (*map.table)[index];
  return {c[0], c[1], c[2], 255};
}

/** Label intervals along the bar's axis already taken, to keep labels from overlapping. */
struct Occupied {
  std::vector<std::pair<int, int>> spans;
  bool fits(int a, int b) const {
    return std::none_of(spans.begin(), spans.end(), [&](const auto& s) {
      return a < s.second + kLabelGap && s.first < b + kLabelGap;
    });
  }
};

struct Bar {
  int x0, y0, x1, y1; ///< the bar's pixels [x0, x1) x [y0, y1)
  bool horizontal;
  int length() const { return horizontal ? x1 - x0 : y1 - y0; }
  /** The pixel along the axis at position t in [0, 1] (low end at left / bottom). */
  int at(double t) const {
    const int offset = std::clamp(static_cast<int>(std::lround(t * length())), 0, length() - 1);
    return horizontal ? x0 + offset : y1 - 1 - offset;
  }
};

void drawBar(codec::Image& image, const Bar& bar, const ColourScale& scale, const Rgba8& outline) {
  fillRect(image, bar.x0 - 1, bar.y0 - 1, bar.x1 + 1, bar.y1 + 1, outline);
  for (int i = 0; i < bar.length(); ++i) {
    const Rgba8 c = barColour(*scale.map, i, bar.length());
    if (bar.horizontal)
      fillRect(image, bar.x0 + i, bar.y0, bar.x0 + i + 1, bar.y1, c);
    else
      fillRect(image, bar.x0, bar.y1 - 1 - i, bar.x1, bar.y1 - i, c);
  }
}

/** One label at the axis pixel p: tries it centred (or aligned to an end), draws it if free. */
void placeLabel(codec::Image& image,
                const Bar& bar,
                int p,
                const std::string& text,
                int align,
                const Rgba8& colour,
                Occupied& taken,
                bool force) {
  const int w = legendTextWidth(text);
  if (bar.horizontal) {
    int a = align < 0 ? bar.x0 - 1 : align > 0 ? bar.x1 + 1 - w : p - w / 2;
    a = std::clamp(a, 0, std::max(0, image.width - w));
    if (!force && !taken.fits(a, a + w)) return;
    taken.spans.emplace_back(a, a + w);
    detail::drawText(image, a, bar.y1 + 1 + kTickLength + 1, text, colour);
  } else {
    int a = std::clamp(p - kGlyphHeight / 2 - 1, 0, std::max(0, image.height - kGlyphHeight));
    if (!force && !taken.fits(a, a + kGlyphHeight - 2)) return;
    taken.spans.emplace_back(a, a + kGlyphHeight - 2);
    detail::drawText(image, bar.x1 + 1 + kTickLength + 2, a, text, colour);
  }
}

void drawTicks(codec::Image& image, const Bar& bar, const ColourScale& scale, const Rgba8& fg) {
  const double lo = std::min(scale.min, scale.max), hi = std::max(scale.min, scale.max);
  Occupied taken;
  const bool up = scale.min <= scale.max;
  placeLabel(
      image, bar, bar.at(0.0), formatTickLabel(scale.min, 0.0), up ? -1 : 1, fg, taken, true);
  placeLabel(
      image, bar, bar.at(1.0), formatTickLabel(scale.max, 0.0), up ? 1 : -1, fg, taken, true);
  const int room = bar.horizontal ? 6 * 7 : kGlyphHeight + kLabelGap;
  const int maxTicks = std::clamp(bar.length() / room, 2, 10);
  if (!(lo < hi)) return;
  const std::vector<double> ticks = legendTicks(lo, hi, scale.scaling, maxTicks);
  const double step =
      ticks.size() > 1 && scale.scaling == Scaling::Linear ? ticks[1] - ticks[0] : 0.0;
  for (const double v : ticks) {
    const int p = bar.at(scalePosition(scale, static_cast<float>(v)));
    if (bar.horizontal)
      fillRect(image, p, bar.y1, p + 1, bar.y1 + 1 + kTickLength, fg);
    else
      fillRect(image, bar.x1, p, bar.x1 + 1 + kTickLength, p + 1, fg);
    placeLabel(image, bar, p, formatTickLabel(v, step), 0, fg, taken, false);
  }
}

/** "title [unit]" cut to maxWidth pixels: the title is shortened first, so the unit stays. */
std::string titleText(std::string_view title, std::string_view unit, int maxWidth) {
  if (unit.empty()) return detail::fitText(title, maxWidth);
  const std::string bracketed = "[" + std::string(unit) + "]";
  if (title.empty()) return detail::fitText(bracketed, maxWidth);
  const int room = maxWidth - legendTextWidth(bracketed) - legendTextWidth(" ");
  if (room < legendTextWidth("xxx")) return detail::fitText(bracketed, maxWidth);
  return detail::fitText(title, room) + " " + bracketed;
}

codec::Image upscale(const codec::Image& image, int f) {
  if (f == 1) return image;
  codec::Image out{image.width * f, image.height * f, 4, {}};
  out.pixels.resize(static_cast<std::size_t>(out.width) * static_cast<std::size_t>(out.height) * 4);
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x) {
      const auto from = (static_cast<std::size_t>(y / f) * static_cast<std::size_t>(image.width) +
                         static_cast<std::size_t>(x / f)) *
                        4;
      const auto to = (static_cast<std::size_t>(y) * static_cast<std::size_t>(out.width) +
                       static_cast<std::size_t>(x)) *
                      4;
      std::copy_n(image.pixels.begin() + static_cast<std::ptrdiff_t>(from),
                  4,
                  out.pixels.begin() + static_cast<std::ptrdiff_t>(to));
    }
  return out;
}

} // namespace

std::expected<codec::Image, std::string> renderLegend(const ColourScale& scale,
                                                      std::string_view unit,
                                                      std::string_view title,
                                                      const LegendOptions& options) {
  if (auto ok = checkScale(scale); !ok) return std::unexpected(ok.error());
  const int w = options.width, h = options.height, f = options.scaleFactor;
  if (w < 32 || h < 32 || w > 4096 || h > 4096)
    return std::unexpected("a legend is 32 to 4096 pixels wide and high, not " + std::to_string(w) +
                           " x " + std::to_string(h));
  if (f < 1 || f > 16) return std::unexpected("a legend's scale factor is 1 to 16");
  codec::Image image{w, h, 4, {}};
  image.pixels.resize(static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * 4);
  fillRect(image, 0, 0, w, h, options.background);
  const std::string heading = titleText(title, unit, w - 2 * kPad);
  const int top = heading.empty() ? kPad + 1 : kPad + kGlyphHeight + 3;
  if (!heading.empty()) detail::drawText(image, kPad, kPad, heading, options.foreground);
  Bar bar{};
  if (w >= h) {
    bar = {kPad + 1, top, w - kPad - 1, h - kPad - kGlyphHeight - kTickLength - 2, true};
  } else {
    const int thick = std::clamp(w / 4, 8, 24);
    bar = {kPad + 1, top, kPad + 1 + thick, h - kPad - kGlyphHeight / 2, false};
  }
  if (bar.x1 - bar.x0 < 8 || bar.y1 - bar.y0 < 4)
    return std::unexpected("the legend of " + std::to_string(w) + " x " + std::to_string(h) +
                           " pixels has no room for its bar");
  drawBar(image, bar, scale, options.foreground);
  if (options.labels) drawTicks(image, bar, scale, options.foreground);
  return upscale(image, f);
}

} // namespace tellus::values
