#pragma once
/**
 * @file ValueFormat.hpp
 * @brief Layers of values: how an upstream's raw samples become numbers (decode), and the value
 * at a point (sample).
 *
 * tellus::values is the GL-free core of value layers (issue 24): a raster of measured numbers
 * (heights in metres, a sea-surface temperature in degrees Celsius, a vegetation index) that tellus
 * colours itself, instead of a picture someone else coloured. The proxy colours them for GetMap
 * and answers GetFeatureInfo and GetLegendGraphic with them; the renderer does the same on the
 * GPU with the same rule (ColourScale.hpp). The module depends on codec only (Image, PNG); zlib
 * is PRIVATE (Deflate TIFFs).
 *
 * Headers: ValueFormat.hpp (formats, decode, point sampling), Sample.hpp (the sampling rule),
 * ColourMap.hpp (the tables), ColourScale.hpp (value -> colour, the exact index rule, raster ->
 * RGBA), Legend.hpp (the colour bar with ticks and unit).
 *
 * The cache keeps the upstream's bytes as sent; decoding happens when the values are used.
 *
 * value = raw * scale + offset, as a float; a raw sample equal to noData (compared before scale
 * and offset, exactly, in the sample's own type converted to double) and a Float32 NaN become
 * NaN. Infinite Float32 samples stay infinite (ColourScale treats them as out of range).
 *
 * Thread safety: every function may be called from any thread at once (no shared state).
 */

#include <cstddef>
#include <cstdint>
#include <expected>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace tellus::values {

/** The type of one raw sample. */
enum class Encoding { Int16, UInt16, Float32 };

/** How the samples are packed in the upstream's bytes. */
enum class Container {
  Bil,  ///< raw samples, row-major from the top, no header (application/bil*, World Wind's BIL16)
  Tiff, ///< a one-band baseline TIFF (image/tiff): see decodeTiff for what is read
  Png,  ///< a 16-bit greyscale PNG (image/png); Int16: the bits read as two's complement
};

enum class ByteOrder { Little, Big };

/** How raw samples become values, and what they mean. */
struct ValueFormat {
  Container container = Container::Bil;
  Encoding encoding = Encoding::Int16;
  ByteOrder byteOrder = ByteOrder::Little; ///< Bil only (TIFF says its own; PNG is big-endian)
  double scale = 1.0;                      ///< value = raw * scale + offset
  double offset = 0.0;
  std::optional<double> noData; ///< the raw sample that means "no data" (before scale/offset)
  std::string unit;             ///< e.g. "m", "°C" (UTF-8); shown by legends and feature info
};

/** Decoded values: width * height floats, row-major from the top (north) row, NaN = no data. */
struct ValueRaster {
  int width = 0;
  int height = 0;
  std::vector<float> values;

  float at(int x, int y) const noexcept {
    return values[static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                  static_cast<std::size_t>(x)];
  }
};

/** The largest width or height decode accepts (a hostile header cannot make it allocate more
 * than kMaxSide^2 floats, 256 MiB). */
inline constexpr int kMaxSide = 8192;

/** Decodes bytes as `format` says. width and height: the tile's expected size (> 0 required for
 * Bil, which has no header; for Tiff and Png 0 means "any", otherwise the picture must be that
 * size). Errors (never a read past `bytes`): "the BIL tile has N bytes, not M", "the TIFF is
 * truncated ...", "the TIFF ... is not supported (...)", "the PNG is W x H, not w x h", "... is
 * larger than 8192 pixels". */
std::expected<ValueRaster, std::string>
decode(std::span<const std::byte> bytes, const ValueFormat& format, int width = 0, int height = 0);

/** The value at (x, y) in pixel coordinates, where pixel (i, j) covers [i, i+1) x [j, j+1) and its
 * centre is (i + 0.5, j + 0.5), by the one sampling rule of Sample.hpp (axisTexels,
 * bilinearValue): bilinear between the four nearest centres (clamped at the edges); when any of
 * those four is NaN, the value of the pixel (x, y) lies in (NaN if that one is no data). NaN
 * outside [0, width] x [0, height] or for an empty raster. */
float sample(const ValueRaster& raster, double x, double y) noexcept;

/** "int16", "uint16", "float32" and back (nullopt for another name). */
std::string_view encodingName(Encoding encoding) noexcept;
std::optional<Encoding> parseEncoding(std::string_view name) noexcept;
/** "bil", "tiff", "png" and back. */
std::string_view containerName(Container container) noexcept;
std::optional<Container> parseContainer(std::string_view name) noexcept;

/** The container a MIME type names: application/bil* -> Bil, image/tiff -> Tiff, image/png ->
 * Png (parameters after ';' ignored); nullopt otherwise. */
std::optional<Container> containerForMimeType(std::string_view mimeType) noexcept;

} // namespace tellus::values
