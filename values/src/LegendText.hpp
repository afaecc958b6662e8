#pragma once
// The legend's text: UTF-8 strings drawn in the 6x13 bitmap font into RGBA8 pixels.

#include <tellus/codec/Image.hpp>
#include <tellus/values/ColourScale.hpp>

#include <string_view>

namespace tellus::values::detail {

/** The code points of UTF-8 text (an invalid byte becomes U+FFFD, drawn as '?'). */
std::u32string decodeUtf8(std::string_view text);

/** Draws text with its cell's top-left corner at (x, y), clipped to the image (4 channels). */
void drawText(codec::Image& image, int x, int y, std::string_view text, const Rgba8& colour);

/** The text cut to at most `maxWidth` pixels (whole characters, "..." not added). */
std::string fitText(std::string_view text, int maxWidth);

} // namespace tellus::values::detail
