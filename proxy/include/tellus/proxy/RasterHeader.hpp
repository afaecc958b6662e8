#pragma once
/**
 * @file RasterHeader.hpp
 * @brief An image file's size, channels and sample type from its header alone: JPEG (SOFn), PNG
 * (IHDR) and TIFF (the first IFD), without decoding and without the imaging module, so that
 * opening a local raster does not load OpenImageIO.
 */

#include <cstddef>
#include <expected>
#include <filesystem>
#include <optional>
#include <span>
#include <string>

namespace tellus {

enum class SampleType {
  UInt8,
  Int8,
  UInt16,
  Int16,
  UInt32,
  Int32,
  Float16,
  Float32,
  Float64,
  Other
};

const char* toString(SampleType type) noexcept;

struct RasterHeader {
  const char* format = ""; ///< "JPEG", "PNG" or "TIFF"
  int width = 0;
  int height = 0;
  int channels = 0; ///< as a decoder (OpenImageIO) presents them
  SampleType sampleType = SampleType::UInt8;
};

/**
 * What an image file's header says.
 * - a value: a JPEG (8-bit, grey or 3 components, baseline/extended/progressive), a PNG (8 or
 *   16 bits, grey, grey+alpha, RGB or RGBA, no tRNS) or a classic TIFF (grey or RGB, 8/16/32/64
 *   bits per sample);
 * - std::nullopt: some other format, or a variant of these whose decoded shape this reader does
 *   not model (palette or tRNS PNG, CMYK/YCbCr/palette TIFF, BigTIFF, 12-bit or lossless JPEG...):
 *   ask the imaging module;
 * - an error: the file cannot be read, or it is a JPEG, PNG or TIFF whose header is truncated or
 *   malformed. The message names the file and what is wrong.
 */
std::expected<std::optional<RasterHeader>, std::string>
readRasterHeader(const std::filesystem::path& file);

/** The same for a file's bytes in memory; a header that points past them is "truncated". */
std::expected<std::optional<RasterHeader>, std::string>
parseRasterHeader(std::span<const std::byte> bytes);

} // namespace tellus
