#pragma once
/**
 * @file Png.hpp
 * @brief PNG (libpng) to and from 8-bit pixels, paletted PNGs, and the exact samples of grey PNGs.
 *
 * Pictures go through libpng's simplified API (png_image): any PNG (palette, grey, 16-bit, alpha,
 * interlaced) is converted to the 8-bit layout asked for, as libpng converts (16-bit samples are
 * reduced with its sRGB rules). Elevation tiles need the stored numbers instead: decodePngGrey
 * reads 8- or 16-bit grey samples as they are, with no conversion at all.
 */

#include <tellus/codec/Image.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <span>
#include <string>
#include <vector>

namespace tellus::codec {

/** A whole PNG of any size up to kMaxSide, as RGBA (4 channels). */
std::expected<Image, std::string> decodePng(std::span<const std::byte> bytes);

/** A tile that must be width x height into `pixels` (the caller's, reused): RGBA when the PNG has
 * alpha (an alpha channel or a tRNS chunk), else RGB. Returns the channels (3 or 4). */
std::expected<int, std::string> decodePngInto(std::span<const std::byte> bytes,
                                              int width,
                                              int height,
                                              std::vector<std::uint8_t>& pixels);

/** Validation of a fetched tile: the whole PNG (any bit depth, palette or alpha) decodes at width
 * x height. `scratch` is storage the call may reuse. */
std::expected<void, std::string> checkPng(std::span<const std::byte> bytes,
                                          int width,
                                          int height,
                                          std::vector<std::uint8_t>& scratch);

/** The samples of a grey PNG, exactly as stored: 0-255 (bitDepth 8) or 0-65535 (16). */
struct GreySamples {
  int width = 0;
  int height = 0;
  int bitDepth = 0;
  std::vector<std::uint16_t> samples; ///< row-major, the top row first
};

/** An 8- or 16-bit greyscale PNG of width x height (no palette, no alpha, no other depth). Errors:
 * "not a PNG", "the PNG is corrupt", "the PNG is W x H, not w x h", "the PNG is not 8- or 16-bit
 * greyscale" (in that order of checks). */
std::expected<GreySamples, std::string>
decodePngGrey(std::span<const std::byte> bytes, int width, int height);

/** 8-bit grey (1), RGB (3) or RGBA (4) PNG of packed rows, the top row first (libpng's default
 * compression and filters). */
std::expected<Bytes, std::string>
encodePng(int width, int height, int channels, const std::uint8_t* pixels);

/** A paletted PNG (8-bit indices, 1 to 256 RGBA entries; a tRNS chunk when an entry is not
 * opaque): WMS's "image/png; mode=8bit" (see Quantize.hpp for the palette). */
std::expected<Bytes, std::string>
encodePngPalette(int width,
                 int height,
                 const std::vector<std::array<std::uint8_t, 4>>& palette,
                 const std::uint8_t* indices);

} // namespace tellus::codec
