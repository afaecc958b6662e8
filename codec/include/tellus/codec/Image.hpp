#pragma once
/**
 * @file Image.hpp
 * @brief The codec module's plain types: decoded pixels, encoded bytes, a region, a sniffed format.
 *
 * tellus::codec is the inner module for pixels: JPEG (libjpeg-turbo), PNG (libpng) and BIL16
 * decode and encode, used alike by the proxy (tiles, composed maps, metatile splits) and by the
 * renderer's GL layer (node textures, elevation tiles, screenshots). It depends on no other
 * tellus module; its public headers hold no third-party type (the libraries are PRIVATE to it).
 *
 * Headers: Jpeg.hpp (decode, encode, validation, header probe), JpegYcc.hpp (the composer's
 * 4:2:0 planes), JpegSplit.hpp (a metatile cut into tiles in the DCT domain), Png.hpp (8-bit
 * pictures, paletted output, 8/16-bit grey samples), Bil16.hpp (raw heights), Quantize.hpp (the
 * palette of an 8-bit PNG).
 *
 * Error policy: every function returns a value (std::expected with a message, or a status enum);
 * nothing throws past the module and nothing aborts on bad bytes. libjpeg's error exits go through
 * one wrapper (src/JpegSession.hpp); libpng's simplified API reports through its png_image, and the
 * one low-level libpng reader (grey samples) has its own setjmp scope in src/PngGrey.cpp.
 *
 * Formats the module does not handle (TIFF, Int16 TIFF heights, 16-bit PNG heights written for
 * WMS, text drawn into images) stay with OpenImageIO, which the proxy loads on demand (imaging/).
 *
 * Thread safety: every function may be called from any thread at once (no shared state but
 * thread_local scratch in JpegYcc).
 */

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace tellus::codec {

/** Decoded 8-bit pixels: `channels` samples per pixel (1 grey, 3 RGB, 4 RGBA), row-major, the top
 * row first, rows packed (width * channels bytes). */
struct Image {
  int width = 0;
  int height = 0;
  int channels = 0;
  std::vector<std::uint8_t> pixels;
};

/** Encoded bytes (a JPEG, a PNG, a BIL16 tile). */
using Bytes = std::vector<std::byte>;

/** A rectangle of pixels: x0, y0, x1, y1 (ends exclusive), rows from the top. Values outside the
 * image are clamped to it. */
using Region = std::array<std::int32_t, 4>;

/** What bytes look like by their first bytes (magic numbers), nothing decoded. */
enum class Format { Unknown, Jpeg, Png };

/** JPEG: FF D8 FF; PNG: 89 'P' 'N' 'G' and at least the 8-byte signature's length. */
Format sniff(std::span<const std::byte> bytes) noexcept;

/** The largest width or height decodeJpeg and decodePng accept when no size is expected (a
 * texture or an image file; JPEG itself stops at 65,500). */
inline constexpr int kMaxSide = 65536;

} // namespace tellus::codec
