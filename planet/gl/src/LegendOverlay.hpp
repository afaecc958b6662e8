#pragma once
/**
 * @file LegendOverlay.hpp
 * @brief The legends of the visible layers of values (issue 24), drawn over the frame: each the
 * picture values::renderLegend makes of the layer's colour scale as drawn now (its map, its range
 * also when it comes from the data, its unit and title), light on an opaque dark ground, copied
 * into the scene's framebuffer after the scene (so `render --legend` writes it into the PNG, and
 * `view` shows it). Upscaled by an integer factor of the output's size (legendScaleFactor: the
 * font stays sharp and readable on a 4096-pixel domemaster), stacked from the bottom-left corner
 * of a perspective view, or centred at the bottom of a domemaster's circle with every corner
 * inside it (legendPlacement). A legend's picture is made again only when what it shows changes.
 *
 * legendPlacement and legendScaleFactor are GL-free; LegendOverlay draws (main thread, context
 * current).
 */

#include "GlObjects.hpp"

#include <tellus/values/ColourScale.hpp>
#include <tellus/values/Legend.hpp>

#include <string>
#include <vector>

namespace tellus::planet {

/** One legend: the scale as drawn, the values' unit and the layer's title. */
struct LegendEntry {
  values::ColourScale scale;
  std::string unit;
  std::string title;
};

/** A legend's place in the frame: pixels, (x, y) its bottom-left corner from the frame's
 * bottom-left (GL's order). */
struct LegendRect {
  int x = 0, y = 0, width = 0, height = 0;
};

/** The logical size of one legend (before the scale factor) and its margin to the frame's edge
 * and to the next legend. */
inline constexpr int kLegendWidth = 256;
inline constexpr int kLegendHeight = 56;
inline constexpr int kLegendMargin = 8;

/** The integer upscaling for a width x height frame: one per 1024 pixels of its smaller side
 * (rounded, at least 1, at most 16): 1 for a 1024 x 768 window, 4 for a 4096 domemaster. */
int legendScaleFactor(int width, int height) noexcept;

/** The places of `count` legends of legendWidth x legendHeight pixels (margin: the gap, pixels):
 * a perspective frame stacks them up from its bottom-left corner; a domemaster (the circle of
 * diameter min(width, height) at the frame's centre) stacks them up from the bottom of the
 * circle, centred, each with all four corners inside the circle. Legends that do not fit are
 * left out (fewer rects). */
std::vector<LegendRect> legendPlacement(
    int width, int height, bool dome, int legendWidth, int legendHeight, int margin, int count);

/** The legend's picture for an entry (values::renderLegend with the overlay's colours and
 * sizes), rows from the top. */
std::expected<codec::Image, std::string> legendImage(const LegendEntry& entry, int scaleFactor);

class LegendOverlay {
public:
  /** Copies the entries' legends into framebuffer `fbo` (width x height; left bound). */
  void draw(const std::vector<LegendEntry>& entries, GLuint fbo, int width, int height, bool dome);

private:
  struct Made {
    std::string key; ///< what the picture shows (scale, unit, title, factor)
    GlTexture texture{NoCreate};
    GlFramebuffer fbo{NoCreate};
    int width = 0, height = 0;
  };
  std::vector<Made> made_;
};

} // namespace tellus::planet
