#pragma once
// What the container readers hand to decode(): the raw samples as floats (Int16 and UInt16 are
// exact in a float, Float32 is one) and the sample type they had.

#include <tellus/values/ValueFormat.hpp>

#include <cstddef>
#include <expected>
#include <span>
#include <string>
#include <vector>

namespace tellus::values::detail {

struct RawSamples {
  int width = 0;
  int height = 0;
  Encoding encoding = Encoding::Int16;
  std::vector<float> samples; ///< width * height, row-major from the top
};

/** A one-band baseline TIFF: little- or big-endian ("II"/"MM", not BigTIFF), 16-bit signed or
 * unsigned integer or 32-bit IEEE float samples (BitsPerSample + SampleFormat), SamplesPerPixel
 * 1, Compression none (1) or Deflate (8, 32946) with Predictor none (1) or horizontal (2, integer
 * samples), in strips or tiles. Anything else is refused by name ("the TIFF's compression 5 (LZW)
 * is not supported"); every offset and count is checked against the bytes before it is read. */
std::expected<RawSamples, std::string> readTiff(std::span<const std::byte> bytes);

} // namespace tellus::values::detail
