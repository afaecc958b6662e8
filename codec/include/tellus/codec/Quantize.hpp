#pragma once
// Colour quantisation for 8-bit (paletted) PNG maps, WMS FORMAT "image/png; mode=8bit".

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace tellus::codec {

/** At most 256 colours (RGBA) and one index per pixel. */
struct PalettedImage {
  std::vector<std::array<std::uint8_t, 4>> palette;
  std::vector<std::uint8_t> indices;
};

/**
 * Median cut over a histogram of 5 bits per channel: pixels whose alpha is below 128 share one
 * fully transparent entry (index 0), the others get the weighted mean colour of their box. An image
 * with at most 256 distinct 5-bit colours keeps each as its own entry. `channels` is 3 or 4.
 */
PalettedImage quantize(const std::uint8_t* pixels, int channels, std::size_t count);

} // namespace tellus::codec
