#pragma once
/**
 * @file ImagingApi.hpp
 * @brief The function table of the imaging module (libtellus_imaging.so), the one place where
 * OpenImageIO is linked.
 *
 * Loading OpenImageIO and its ~260 libraries costs a process about 121 MiB of RSS (a 25 MiB ustring
 * table made by a static initialiser, libopenvdb, gdal, ...; bench/RESULTS.md), so `tellus serve`
 * does not link it: the proxy dlopen()s this module the first time a tile really has to be decoded
 * or encoded (proxy/src/imaging/ImagingLoader.cpp). The module exports one C symbol,
 * `tellus_imaging_table`, which returns this table.
 *
 * Rules of the boundary: plain C types only; what a function produces (bytes, pixels, error text)
 * is written into memory the caller hands out through a `TellusImagingSink`, so nothing allocated
 * on one side is freed on the other; no exception crosses it (every entry point catches). A change
 * to any signature or meaning bumps TELLUS_IMAGING_ABI_VERSION; the loader refuses a module of
 * another version.
 */

#include <cstddef>
#include <cstdint>

/// Bumped whenever the table below changes in any way.
#define TELLUS_IMAGING_ABI_VERSION 2u

/// The one symbol the module exports.
#define TELLUS_IMAGING_TABLE_SYMBOL "tellus_imaging_table"

extern "C" {

/** Where a module function puts what it produces; the memory belongs to the caller. */
struct TellusImagingSink {
  void* context;
  /** Storage for `size` bytes, valid until the call returns; NULL when it cannot be had. */
  void* (*allocate)(void* context, std::size_t size);
  /** Why the call failed (UTF-8, `length` bytes, not NUL-terminated). May be called once. */
  void (*fail)(void* context, const char* message, std::size_t length);
};

/** Result codes of every function. */
enum TellusImagingStatus : std::int32_t {
  TELLUS_IMAGING_OK = 0,
  TELLUS_IMAGING_FAILED = 1,      ///< the reason went to the sink's fail()
  TELLUS_IMAGING_NO_CODEC = 2,    ///< decode_image: OpenImageIO has no reader for the format
  TELLUS_IMAGING_OPEN_FAILED = 3, ///< decode_image: the header does not parse (text in fail())
  TELLUS_IMAGING_SHAPE = 4,       ///< decode_image: size or channel count differ (see the result)
  TELLUS_IMAGING_READ_FAILED = 5, ///< decode_image: the pixels do not decode (text in fail())
};

/** How read_raster() hands out samples. */
enum TellusImagingSampleType : std::int32_t {
  TELLUS_IMAGING_UINT8 = 1,   ///< 8-bit images, 0..255
  TELLUS_IMAGING_INT16 = 2,   ///< 16-bit signed (heights in metres)
  TELLUS_IMAGING_FLOAT32 = 3, ///< everything else, raw values (16-bit unsigned as 0..65535)
};

struct TellusImagingRasterInfo {
  std::int32_t width;
  std::int32_t height;
  std::int32_t channels;    ///< all of the file's channels (probe) or those read (read_raster)
  std::int32_t sampleType;  ///< TellusImagingSampleType (read_raster)
  std::int32_t fileFormat;  ///< probe: 1 uint8, 2 int16, 3 uint16, 4 float, 0 something else
  std::int32_t reserved[3]; ///< zero
};

struct TellusImagingDecodeResult {
  std::int32_t width;
  std::int32_t height;
  std::int32_t channels;
};

struct TellusImagingTable {
  std::uint32_t abiVersion; ///< TELLUS_IMAGING_ABI_VERSION of the module
  std::uint32_t size;       ///< sizeof(TellusImagingTable) as the module was built

  /**
   * Encodes 8-bit pixels (row-major, top row first) as "jpeg" (channels 1 or 3, quality 90),
   * "png" or "tiff" (1, 3 or 4; TIFF zip-compressed). The encoded bytes go to one allocate().
   */
  std::int32_t (*encodeImage)(const char* format,
                              std::int32_t width,
                              std::int32_t height,
                              std::int32_t channels,
                              const std::uint8_t* pixels,
                              const TellusImagingSink* out);

  /** Encodes Int16 heights as a zip-compressed single-channel TIFF. */
  std::int32_t (*encodeHeightsTiff)(std::int32_t width,
                                    std::int32_t height,
                                    const std::int16_t* heights,
                                    const TellusImagingSink* out);

  /**
   * Draws a width x height RGBA8 image filled with `rgba` (0..1 each) and, when `textLength` > 0
   * and the DejaVu Sans Mono font is installed, the text in black; the pixels go to one
   * allocate() of width * height * 4 bytes.
   */
  std::int32_t (*drawBlank)(std::int32_t width,
                            std::int32_t height,
                            const float* rgba,
                            const char* text,
                            std::size_t textLength,
                            const TellusImagingSink* out);

  /** Reads an image file's header: size, all channels, the file's sample format. */
  std::int32_t (*probeRaster)(const char* path,
                              TellusImagingRasterInfo* info,
                              const TellusImagingSink* errors);

  /**
   * Reads the first min(channels, maxChannels) channels of a whole image file. `info` is filled in
   * before the one allocate() of width * height * channels samples of `info->sampleType`.
   */
  std::int32_t (*readRaster)(const char* path,
                             std::int32_t maxChannels,
                             TellusImagingRasterInfo* info,
                             const TellusImagingSink* out);

  /**
   * Decodes a whole "jpeg", "png" or "tiff" image from memory on the calling thread and checks
   * that it is expectedWidth x expectedHeight with 1..16 channels (TELLUS_IMAGING_SHAPE with what
   * it is otherwise, before any pixel is decoded). OpenImageIO's error text, if any, goes to
   * fail().
   */
  std::int32_t (*decodeImage)(const void* bytes,
                              std::size_t size,
                              const char* format,
                              std::int32_t expectedWidth,
                              std::int32_t expectedHeight,
                              TellusImagingDecodeResult* result,
                              const TellusImagingSink* errors);

  // ---- version 2: composing maps from tiles (GetMap for any box)

  /**
   * Decodes a whole "jpeg", "png" or "tiff" image from memory into samples the caller can sample
   * from, on the calling thread:
   * - sampleType TELLUS_IMAGING_UINT8: imagery, 3 channels (RGB; grey is copied to all three) or
   *   4 (RGBA) when the file has alpha; 16-bit files are scaled to 0..255;
   * - sampleType TELLUS_IMAGING_INT16: heights, the first channel as signed 16-bit values (a
   *   16-bit unsigned PNG's values are reinterpreted bit for bit; the caller knows its offset).
   * Checks the size like decodeImage (TELLUS_IMAGING_SHAPE). `info` is filled in (width, height,
   * channels given out, sampleType) before the one allocate() of width * height * channels
   * samples.
   */
  std::int32_t (*decodePixels)(const void* bytes,
                               std::size_t size,
                               const char* format,
                               std::int32_t sampleType,
                               std::int32_t expectedWidth,
                               std::int32_t expectedHeight,
                               TellusImagingRasterInfo* info,
                               const TellusImagingSink* out);

  /** Encodes one channel of 16-bit unsigned samples as a 16-bit greyscale PNG. */
  std::int32_t (*encodePng16)(std::int32_t width,
                              std::int32_t height,
                              const std::uint16_t* samples,
                              const TellusImagingSink* out);
};

/** The exported entry point (TELLUS_IMAGING_TABLE_SYMBOL). Never NULL. */
using TellusImagingTableFn = const TellusImagingTable* (*)();

} // extern "C"
