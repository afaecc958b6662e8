#pragma once
/**
 * @file ImageCodec.hpp
 * @brief Encoding pixels into the formats tellus serves (OpenImageIO stays inside proxy/src).
 */

#include <tellus/proxy/Wms.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace tellus {

/** Encodes 8-bit pixels (channels 1, 3 or 4, row-major, top row first) as "image/jpeg" (alpha is
 * dropped), "image/png" or "image/tiff" (zip-compressed, through the imaging module). `tile`: a
 * JPEG is written as tellus's cached tiles are (with restart markers, see
 * tellus/codec/Jpeg.hpp's kTileRestartInterval), for a tile rather than a map. `jpegQuality`:
 * 1-100.
 */
std::expected<std::vector<std::byte>, std::string> encodeImage(std::string_view mimeType,
                                                               int width,
                                                               int height,
                                                               int channels,
                                                               const std::uint8_t* pixels,
                                                               bool tile = false,
                                                               int jpegQuality = 90);

/** Encodes 16-bit signed heights as "application/bil16" (little-endian), "image/tiff" (Int16) or
 * "image/png" (16-bit greyscale holding height + 32768, so -32768 is 0 and sea level 32768). */
std::expected<std::vector<std::byte>, std::string>
encodeHeights(std::string_view mimeType, int width, int height, const std::int16_t* heights);

/** Encodes values as "application/bil32": Float32, little-endian (as World Wind reads BIL and
 * as tellus writes BIL16), row-major from the top row, no header. */
std::vector<std::byte> encodeBil32(int width, int height, const float* values);

/**
 * A map without data, in any GetMap format: for WMS EXCEPTIONS=BLANK and INIMAGE, and for a map
 * where there is no tile. A picture (`heights` false) is BGCOLOR (default white), fully
 * transparent when `transparent` and the format has alpha (PNG, 8-bit PNG, 32-bit PNG; a 32-bit
 * PNG is opaque otherwise); `text`, if any, is drawn in black with the DejaVu Sans Mono font when
 * it is installed (INIMAGE; else the image stays plain; only drawing text loads the imaging
 * module). Heights (`heights`: BIL16, Int16 TIFF or 16-bit PNG, see mapIsHeights) are `noData`
 * everywhere, and `text` is not drawn: text drawn into heights would be terrain. A map of values
 * (application/bil32) is `valueNoData` everywhere, without text either.
 */
std::expected<std::vector<std::byte>, std::string> blankMap(MapFormat format,
                                                            bool heights,
                                                            int width,
                                                            int height,
                                                            std::optional<std::uint32_t> bgcolor,
                                                            bool transparent,
                                                            std::string_view text = {},
                                                            std::int16_t noData = -32768,
                                                            float valueNoData = kNoValue);

/** Decoded imagery: 8-bit RGB (channels 3) or RGBA (4), row-major, top row first. */
struct DecodedImage {
  int width = 0;
  int height = 0;
  int channels = 0;
  std::vector<std::uint8_t> pixels;
};

/** Decodes an imagery tile ("image/jpeg", "image/png", "image/tiff") that must be width x height.
 */
std::expected<DecodedImage, std::string>
decodeImagery(std::span<const std::byte> bytes, std::string_view mimeType, int width, int height);

/**
 * decodeImagery into the caller's storage (reused when it has the size already); the channels.
 * With a `region` (x0, y0, x1, y1 in texels, rows from the top), only those pixels are sure to be
 * decoded (JPEG decodes the whole blocks around them and skips the rest); the others are left as
 * the storage had them.
 */
std::expected<int, std::string>
decodeImageryInto(std::span<const std::byte> bytes,
                  std::string_view mimeType,
                  int width,
                  int height,
                  std::vector<std::uint8_t>& pixels,
                  const std::array<std::int32_t, 4>* region = nullptr);

/**
 * Decodes an elevation tile into raw 16-bit signed values, row-major, top row first:
 * "application/bil16" (little-endian, read here without the imaging module), "image/tiff"
 * (Int16) or "image/png" (16-bit; the values minus 32768, as encodeHeights writes them).
 */
std::expected<std::vector<std::int16_t>, std::string>
decodeHeights(std::span<const std::byte> bytes, std::string_view mimeType, int width, int height);

} // namespace tellus
