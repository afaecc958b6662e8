#pragma once
/**
 * @file TextOverlay.hpp
 * @brief The statistics line of `tellus view` as pixels: a 5 x 7 bitmap font of our own (digits,
 * letters, a little punctuation; anything else is a blank cell), white on a dark strip. Pure CPU;
 * the renderer blits the result into the window after the globe.
 */

#include <cstdint>
#include <string_view>
#include <vector>

namespace tellus::planet {

struct TextImage {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgba; ///< rows from the bottom (GL's order)
};

/** Each character is a 6 x 9 cell (a 5 x 7 glyph, one column and two rows of spacing) times
 * `scale`, with a margin of one cell-height quarter around the line. Lower-case and upper-case
 * letters share the upper-case shapes. */
TextImage rasterizeText(std::string_view text, int scale);

/** Whether the font has a glyph for c (others are drawn as blanks). */
bool hasGlyph(char c) noexcept;

} // namespace tellus::planet
