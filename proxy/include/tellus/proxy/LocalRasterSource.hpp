#pragma once
/**
 * @file LocalRasterSource.hpp
 * @brief An upstream that is a georeferenced image on disk (the embedded default's Blue Marble and
 * ETOPO heights, offline demos): tiles are resampled from it and encoded in memory.
 */

#include <tellus/cache/TileGrid.hpp>
#include <tellus/proxy/RasterHeader.hpp>

#include <cstddef>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace tellus {

/** Where an image lies: the outer edges of its pixels in degrees (pixel-is-area). */
struct RasterGeoref {
  double west = -180.0;
  double north = 90.0;
  double pixelWidthDeg = 1.0;  ///< > 0
  double pixelHeightDeg = 1.0; ///< > 0 (rows go south)
};

/**
 * Reads an ESRI world file (.jgw, .pgw, .tfw, .wld: six lines, pixel centres) and turns it into the
 * pixel-edge georeference. Rotation terms must be 0.
 */
std::expected<RasterGeoref, std::string> readWorldFile(const std::filesystem::path& path);

/** The world file next to an image: "x.jpg" -> "x.jgw", "x.tif" -> "x.tfw", "x.png" -> "x.pgw",
 * or "x.wld"; the first that exists. */
std::filesystem::path worldFileFor(const std::filesystem::path& image);

/**
 * @brief A georeferenced image, resampled bilinearly into tiles.
 *
 * open() reads the world file and the image's header only (tellus/proxy/RasterHeader.hpp): it
 * does not decode and does not load the imaging module (OpenImageIO). The pixels are decoded once,
 * by the imaging module, on the first renderTile() or sample() (or load()), and kept as they are
 * stored: 8-bit images as uint8, Int16 heights as int16, anything else as float.
 *
 * Thread safety: const methods may be called concurrently (the pixels are loaded once, by the first
 * caller, while the others wait). Copies share the pixels.
 */
class LocalRasterSource {
public:
  /** Opens an image (JPEG, PNG, TIFF, or any other format the imaging module reads) with its world
   * file. Errors name the file and what is wrong. */
  static std::expected<LocalRasterSource, std::string> open(const std::filesystem::path& image);

  int width() const noexcept { return width_; }
  int height() const noexcept { return height_; }
  /** The channels used: the file's, at most 4. */
  int channels() const noexcept { return channels_; }
  /** The file's sample type (from its header). */
  SampleType sampleType() const noexcept { return sampleType_; }
  const RasterGeoref& georef() const noexcept { return georef_; }
  /** The area the image covers. */
  Sector coverage() const noexcept;

  /** Decodes the pixels now if that has not happened (renderTile and sample do it on first use).
   * A failure is remembered: every later call returns the same error. */
  std::expected<void, std::string> load() const;
  /** Whether the pixels have been decoded (for tests and diagnostics). */
  bool loaded() const noexcept;

  /**
   * Resamples the box (west, south, east, north in degrees) into width x height pixels and encodes
   * them: "image/jpeg", "image/png" (RGB, or RGBA with transparent outside the coverage),
   * "application/bil16" (channel 0 as little-endian Int16, rounded, `noData` outside) or
   * "image/tiff" (Int16). Sampling is at pixel centres; longitudes wrap when the image spans 360
   * degrees. For the two heights formats a source sample equal to `noData` (or NaN) is no data:
   * it is never mixed into a bilinear sample (the nearest of the four taps with data is taken, as
   * sample() says), and a pixel with no tap of data is `noData`. Errors name what failed.
   */
  std::expected<std::vector<std::byte>, std::string> renderTile(const Sector& box,
                                                                int width,
                                                                int height,
                                                                std::string_view mimeType,
                                                                std::int16_t noData = -32768) const;

  /** Bilinear sample of one channel at a position (NaN outside the coverage, or when the pixels
   * cannot be decoded). Taps equal to `noData` or NaN are no data and never mixed in: where any of
   * the four is, the answer is the tap of largest weight that has data, NaN when none has. */
  double sample(double latDeg,
                double lonDeg,
                int channel,
                double noData = std::numeric_limits<double>::quiet_NaN()) const noexcept;

private:
  struct Pixels;
  LocalRasterSource() = default;
  /** The decoded pixels, or why they cannot be had. */
  std::expected<const Pixels*, std::string> pixels() const;
  int width_ = 0;
  int height_ = 0;
  int channels_ = 0;
  SampleType sampleType_ = SampleType::UInt8;
  RasterGeoref georef_{};
  /// The file and, once loaded, its samples: row-major, north row first.
  std::shared_ptr<Pixels> pixels_;
};

} // namespace tellus
