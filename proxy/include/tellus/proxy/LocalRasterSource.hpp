#pragma once
/**
 * @file LocalRasterSource.hpp
 * @brief An upstream that is a georeferenced image on disk (the embedded default's Blue Marble and
 * ETOPO heights, offline demos): tiles are resampled from it and encoded in memory.
 */

#include <tellus/cache/TileGrid.hpp>

#include <cstddef>
#include <cstdint>
#include <expected>
#include <filesystem>
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
 * @brief A whole image held in memory as float samples, resampled bilinearly into tiles.
 *
 * Thread safety: const methods may be called concurrently (the image is immutable after open).
 */
class LocalRasterSource {
public:
  /** Opens an image (any format OpenImageIO reads) with its world file. */
  static std::expected<LocalRasterSource, std::string> open(const std::filesystem::path& image);

  int width() const noexcept { return width_; }
  int height() const noexcept { return height_; }
  int channels() const noexcept { return channels_; }
  const RasterGeoref& georef() const noexcept { return georef_; }
  /** The area the image covers. */
  Sector coverage() const noexcept;

  /**
   * Resamples the box (west, south, east, north in degrees) into width x height pixels and encodes
   * them: "image/jpeg", "image/png" (RGB, or RGBA with transparent outside the coverage),
   * "application/bil16" (channel 0 as little-endian Int16, rounded, `noData` outside) or
   * "image/tiff" (Int16). Sampling is at pixel centres; longitudes wrap when the image spans 360
   * degrees. Errors name what failed.
   */
  std::expected<std::vector<std::byte>, std::string> renderTile(const Sector& box,
                                                                int width,
                                                                int height,
                                                                std::string_view mimeType,
                                                                std::int16_t noData = -32768) const;

  /** Bilinear sample of one channel at a position (NaN outside the coverage). */
  double sample(double latDeg, double lonDeg, int channel) const noexcept;

private:
  LocalRasterSource() = default;
  int width_ = 0;
  int height_ = 0;
  int channels_ = 0;
  RasterGeoref georef_{};
  /// Row-major, north row first; 8-bit images as 0..255, others as raw values (heights in metres).
  std::shared_ptr<const std::vector<float>> pixels_;
};

} // namespace tellus
