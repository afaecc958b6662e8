#pragma once
// JPEG (libjpeg-turbo) and 8-bit PNG (libpng) in the proxy itself, for the images it makes and
// reads most: tiles rendered from local rasters, composed maps and the tiles they are made of.
// OpenImageIO (the imaging module) is left with TIFF, 16-bit PNG, rasters and text.

#include <array>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <span>
#include <string>
#include <vector>

namespace tellus::codecs {

/** RGB (grey is expanded) into `pixels` (width * height * 3); with a `region` (x0, y0, x1, y1,
 * rows from the top) only the blocks around it are decoded and the rest is left as it was.
 * Returns 3. Warnings of a damaged stream are ignored (cached tiles were validated). */
std::expected<int, std::string> decodeJpegInto(std::span<const std::byte> bytes,
                                               int width,
                                               int height,
                                               std::vector<std::uint8_t>& pixels,
                                               const std::array<std::int32_t, 4>* region);

/** Validation of a fetched tile: the whole JPEG decodes without even a warning (a truncated or
 * corrupt stream) at width x height. `scratch` is storage the call may reuse. */
std::expected<void, std::string> checkJpeg(std::span<const std::byte> bytes,
                                           int width,
                                           int height,
                                           std::vector<std::uint8_t>& scratch);

/** The same for a PNG (any bit depth, palette or alpha). */
std::expected<void, std::string> checkPng(std::span<const std::byte> bytes,
                                          int width,
                                          int height,
                                          std::vector<std::uint8_t>& scratch);

/**
 * The restart interval (in MCUs) of the JPEG tiles tellus writes itself (tiles rendered from local
 * rasters, tiles cut from metatiles): a 512-pixel 4:2:0 tile is then 8 x 32 segments of 64 x 16
 * pixels that can be entropy-decoded on their own, so composing a map decodes only the segments
 * around the part of a tile it samples (decodeJpegYcc). Costs about 2.5 bytes per segment (600
 * bytes for a 512-pixel tile) and ~5 % more CPU to decode a whole tile.
 */
inline constexpr int kTileRestartInterval = 4;

/** Baseline JPEG of `quality` (1-100; tiles are written at 90), from grey (1) or RGB (3) pixels;
 * a restart marker every `restartInterval` MCUs (0: none). */
std::expected<std::vector<std::byte>, std::string> encodeJpeg(int width,
                                                              int height,
                                                              int channels,
                                                              const std::uint8_t* pixels,
                                                              int restartInterval = 0,
                                                              int quality = 90);

/** 8-bit RGB, or RGBA when the PNG has alpha (palettes and 16-bit samples are converted);
 * returns the channels. */
std::expected<int, std::string> decodePngInto(std::span<const std::byte> bytes,
                                              int width,
                                              int height,
                                              std::vector<std::uint8_t>& pixels);

/** 8-bit grey (1), RGB (3) or RGBA (4) PNG. */
std::expected<std::vector<std::byte>, std::string>
encodePng(int width, int height, int channels, const std::uint8_t* pixels);

/** A paletted PNG (8-bit indices, up to 256 RGBA entries; tRNS when an entry is not opaque). */
std::expected<std::vector<std::byte>, std::string>
encodePngPalette(int width,
                 int height,
                 const std::vector<std::array<std::uint8_t, 4>>& palette,
                 const std::uint8_t* indices);

} // namespace tellus::codecs
