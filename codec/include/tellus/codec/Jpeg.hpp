#pragma once
/**
 * @file Jpeg.hpp
 * @brief Baseline JPEG (libjpeg-turbo) to and from 8-bit pixels.
 *
 * Two kinds of decode:
 * - decodeJpeg: any size up to kMaxSide, into a new Image (textures, image files, tests);
 * - decodeJpegInto / checkJpeg: a tile of a known size into the caller's storage (reused: resizing
 *   to the size it has neither allocates nor clears), optionally only a region of it (composing a
 *   map decodes only the part of each tile it samples: libjpeg-turbo's crop and skip).
 * Warnings of a damaged stream (corrupt data, a premature end that libjpeg pads with grey) are
 * ignored by the decodes, which give what is there (cached tiles were validated), and fail
 * checkJpeg, which is the validation of fetched tiles.
 */

#include <tellus/codec/Image.hpp>

#include <cstddef>
#include <cstdint>
#include <expected>
#include <span>
#include <string>
#include <vector>

namespace tellus::codec {

/**
 * The restart interval (in MCUs) of the JPEG tiles tellus writes itself (tiles rendered from local
 * rasters, tiles cut from metatiles): a 512-pixel 4:2:0 tile is then 8 x 32 segments of 64 x 16
 * pixels that can be entropy-decoded on their own, so composing a map decodes only the segments
 * around the part of a tile it samples (decodeJpegYcc). Costs about 2.5 bytes per segment (600
 * bytes for a 512-pixel tile) and ~5 % more CPU to decode a whole tile.
 */
inline constexpr int kTileRestartInterval = 4;

/** A JPEG's frame header, read without decoding the image. */
struct JpegInfo {
  int width = 0;
  int height = 0;
  int components = 0; ///< as stored: 1 grey, 3 YCbCr (or RGB), 4 CMYK / YCCK
  int mcuWidth = 0;   ///< the iMCU in pixels: 16 x 16 for 4:2:0, 8 x 8 for 4:4:4 and grey
  int mcuHeight = 0;
  bool progressive = false;
  int restartInterval = 0; ///< MCUs between restart markers (0: none)
};

/** The header alone (SOI up to the first scan); an error when it is not a JPEG or damaged. */
std::expected<JpegInfo, std::string> probeJpeg(std::span<const std::byte> bytes);

struct JpegDecodeOptions {
  /** 1 grey (luma), 3 RGB (grey expanded), 4 RGBA (alpha 255), 0 as stored (grey 1, colour 3). */
  int channels = 3;
  /** libjpeg's smooth chroma up-sampling (its default). Off: every pixel comes from its own 8 x 8
   * blocks only ("box" up-sampling), so equal blocks give equal pixels. */
  bool fancyUpsampling = true;
};

/** A whole JPEG of any size up to kMaxSide (a larger or empty image is an error). */
std::expected<Image, std::string> decodeJpeg(std::span<const std::byte> bytes,
                                             const JpegDecodeOptions& options = {});

/** RGB (grey is expanded) into `pixels` (resized to width * height * 3); the JPEG must be width x
 * height, grey or colour. With a `region` only the blocks around it are decoded (whole iMCU
 * columns, the rows above skipped, none below read) and the rest of `pixels` is left as it was;
 * the pixels inside are exactly the whole decode's. Returns 3. */
std::expected<int, std::string> decodeJpegInto(std::span<const std::byte> bytes,
                                               int width,
                                               int height,
                                               std::vector<std::uint8_t>& pixels,
                                               const Region* region = nullptr);

/** Validation of a fetched tile: the whole JPEG decodes without even a warning (a truncated or
 * corrupt stream) at width x height. `scratch` is storage the call may reuse. */
std::expected<void, std::string> checkJpeg(std::span<const std::byte> bytes,
                                           int width,
                                           int height,
                                           std::vector<std::uint8_t>& scratch);

struct JpegEncodeOptions {
  int quality = 90;        ///< 1-100 (clamped); tiles and maps are written at 90
  int restartInterval = 0; ///< a restart marker every so many MCUs (0: none)
  /** The luma's sampling factors for colour (chroma 1 x 1): 2 x 2 is 4:2:0 (libjpeg's default,
   * 0 x 0 here), 2 x 1 4:2:2, 1 x 1 4:4:4. */
  int lumaSamplingH = 0;
  int lumaSamplingV = 0;
};

/** Baseline JPEG from grey (1) or RGB (3) pixels, rows packed, the top row first. */
std::expected<Bytes, std::string> encodeJpeg(int width,
                                             int height,
                                             int channels,
                                             const std::uint8_t* pixels,
                                             const JpegEncodeOptions& options = {});

} // namespace tellus::codec
