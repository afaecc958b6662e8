#pragma once
// JPEG tiles and maps as Y, Cb and Cr planes at 4:2:0 (libjpeg-turbo's raw data interface): the
// composer's fast path for JPEG maps made of JPEG tiles. It skips what the RGB path does twice
// (chroma up-sampling and YCbCr -> RGB on decode, RGB -> YCbCr and chroma down-sampling on encode)
// and resamples 1.5 samples per pixel instead of 3. Bilinear resampling is linear, so this is the
// RGB path's map up to rounding (and clamping of out-of-gamut RGB, which the RGB path does and this
// one does not need to).

#include <array>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <span>
#include <string>
#include <vector>

namespace tellus::codec {

enum class YccDecode {
  Ok,
  NotYcc420, ///< not a single-scan 4:2:0 YCbCr JPEG of that size (multiples of 16): use RGB
  Failed,    ///< does not decode (`message` says why)
};

/**
 * Decodes a 4:2:0 YCbCr JPEG of width x height (both multiples of 16) into planes: `y` (width *
 * height), `cb` and `cr` ((width / 2) * (height / 2)), rows from the top. With a `region` (x0, y0,
 * x1, y1 in luma texels, rows from the top) only the 16 x 16 blocks around it are decoded (and the
 * rows below it are not read); the rest of the planes is left as it was. Warnings of a damaged
 * stream are ignored, as in decodeJpegInto (cached tiles were validated).
 */
YccDecode decodeJpegYcc(std::span<const std::byte> bytes,
                        int width,
                        int height,
                        const std::array<std::int32_t, 4>* region,
                        std::uint8_t* y,
                        std::uint8_t* cb,
                        std::uint8_t* cr,
                        std::string& message);

/**
 * Whether decodeJpegYcc decodes `region` of this JPEG from the restart segments around it alone
 * (a tile written with restart markers every few MCUs, kTileRestartInterval (Jpeg.hpp), and a
 * region that does not need every segment from the top); else the whole stream is entropy-decoded
 * down to the region's last row. For tests and benchmarks.
 */
bool decodesFromSegments(std::span<const std::byte> bytes,
                         int width,
                         int height,
                         const std::array<std::int32_t, 4>& region);

/**
 * Baseline JPEG of `quality` (1-100), 4:2:0 (what encodeJpeg writes from RGB) from planes: `y`
 * width * height, `cb` and `cr` ((width + 1) / 2) * ((height + 1) / 2), rows from the top, dense.
 * The edges are extended by repetition to whole blocks.
 */
std::expected<std::vector<std::byte>, std::string> encodeJpegYcc(int width,
                                                                 int height,
                                                                 const std::uint8_t* y,
                                                                 const std::uint8_t* cb,
                                                                 const std::uint8_t* cr,
                                                                 int quality = 90);

/** JFIF's RGB -> YCbCr of one colour (rounded, clamped): the background of a map. */
std::array<std::uint8_t, 3> rgbToYcc(std::uint8_t r, std::uint8_t g, std::uint8_t b) noexcept;

} // namespace tellus::codec
