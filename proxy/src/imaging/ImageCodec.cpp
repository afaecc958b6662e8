#include "imaging/ImagingLoader.hpp"

#include <tellus/codec/Bil16.hpp>
#include <tellus/codec/Jpeg.hpp>
#include <tellus/codec/Png.hpp>
#include <tellus/codec/Quantize.hpp>
#include <tellus/proxy/ImageCodec.hpp>

#include <algorithm>
#include <bit>
#include <cstring>

namespace tellus {

// Formats by MIME type: JPEG, 8-bit PNG and BIL16 through the codec module (tellus::codec:
// libjpeg-turbo, libpng); TIFF and 16-bit PNG through the imaging module (OpenImageIO), loaded on
// the first call that needs it.

std::expected<std::vector<std::byte>, std::string> encodeImage(std::string_view mimeType,
                                                               int width,
                                                               int height,
                                                               int channels,
                                                               const std::uint8_t* pixels,
                                                               bool tile,
                                                               int jpegQuality) {
  if (width <= 0 || height <= 0 || (channels != 1 && channels != 3 && channels != 4)) {
    return std::unexpected("bad image shape");
  }
  if (mimeType == "image/tiff") { // a picture as TIFF: through the imaging module
    auto api = imaging::table();
    if (!api) return std::unexpected(api.error());
    imaging::BytesSink out;
    if ((*api)->encodeImage("tiff", width, height, channels, pixels, out.get()) !=
        TELLUS_IMAGING_OK)
      return std::unexpected(out.error());
    return std::move(out.bytes);
  }
  const bool png = mimeType == "image/png";
  if (!png && mimeType != "image/jpeg")
    return std::unexpected("cannot encode " + std::string(mimeType));
  if (!png && channels == 4) { // JPEG has no alpha: drop it
    const auto n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
    std::vector<std::uint8_t> rgb(n * 3);
    for (std::size_t i = 0; i < n; ++i)
      std::memcpy(&rgb[i * 3], &pixels[i * 4], 3);
    return encodeImage(mimeType, width, height, 3, rgb.data(), tile, jpegQuality);
  }
  if (png) return codec::encodePng(width, height, channels, pixels);
  return codec::encodeJpeg(
      width,
      height,
      channels,
      pixels,
      {.quality = jpegQuality, .restartInterval = tile ? codec::kTileRestartInterval : 0});
}

std::expected<std::vector<std::byte>, std::string>
encodeHeights(std::string_view mimeType, int width, int height, const std::int16_t* heights) {
  if (width <= 0 || height <= 0) return std::unexpected("bad image shape");
  const auto n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  if (mimeType == "image/tiff") {
    auto api = imaging::table();
    if (!api) return std::unexpected(api.error());
    imaging::BytesSink out;
    if ((*api)->encodeHeightsTiff(width, height, heights, out.get()) != TELLUS_IMAGING_OK)
      return std::unexpected(out.error());
    return std::move(out.bytes);
  }
  if (mimeType == "image/png") {
    std::vector<std::uint16_t> shifted(n);
    for (std::size_t k = 0; k < n; ++k)
      shifted[k] = static_cast<std::uint16_t>(static_cast<std::int32_t>(heights[k]) + 32768);
    auto api = imaging::table();
    if (!api) return std::unexpected(api.error());
    imaging::BytesSink out;
    if ((*api)->encodePng16(width, height, shifted.data(), out.get()) != TELLUS_IMAGING_OK)
      return std::unexpected(out.error());
    return std::move(out.bytes);
  }
  if (mimeType != "application/bil16")
    return std::unexpected("cannot encode heights as " + std::string(mimeType));
  return codec::encodeBil16(width, height, heights);
}

std::vector<std::byte> encodeBil32(int width, int height, const float* values) {
  const auto n =
      static_cast<std::size_t>(std::max(width, 0)) * static_cast<std::size_t>(std::max(height, 0));
  std::vector<std::byte> out(n * 4);
  for (std::size_t k = 0; k < n; ++k) {
    const auto bits = std::bit_cast<std::uint32_t>(values[k]);
    for (std::size_t b = 0; b < 4; ++b)
      out[k * 4 + b] = static_cast<std::byte>(bits >> (8 * b)); // little-endian on any host
  }
  return out;
}

std::expected<std::vector<std::byte>, std::string> blankMap(MapFormat format,
                                                            bool heights,
                                                            int width,
                                                            int height,
                                                            std::optional<std::uint32_t> bgcolor,
                                                            bool transparent,
                                                            std::string_view text,
                                                            std::int16_t noData,
                                                            float valueNoData) {
  if (width <= 0 || height <= 0) return std::unexpected("bad image shape");
  const auto n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  if (format == MapFormat::Bil32) {
    const std::vector<float> values(n, valueNoData);
    return encodeBil32(width, height, values.data());
  }
  if (heights) {
    const std::vector<std::int16_t> values(n, noData);
    return encodeHeights(
        format == MapFormat::Png ? "image/png" : toString(format), width, height, values.data());
  }
  const bool alpha = format == MapFormat::Png32 ||
                     (transparent && (format == MapFormat::Png || format == MapFormat::Png8 ||
                                      format == MapFormat::Tiff));
  const std::uint32_t c = bgcolor.value_or(0xFFFFFF);
  const std::uint8_t rgba[4] = {static_cast<std::uint8_t>(c >> 16),
                                static_cast<std::uint8_t>(c >> 8),
                                static_cast<std::uint8_t>(c),
                                static_cast<std::uint8_t>(transparent && alpha ? 0 : 255)};
  std::vector<std::uint8_t> px(n * 4);
  if (text.empty()) {
    for (std::size_t i = 0; i < n; ++i)
      std::memcpy(&px[i * 4], rgba, 4);
  } else {
    const float f[4] = {rgba[0] / 255.0f, rgba[1] / 255.0f, rgba[2] / 255.0f, rgba[3] / 255.0f};
    auto api = imaging::table();
    if (!api) return std::unexpected(api.error());
    imaging::BytesSink drawn;
    if ((*api)->drawBlank(width, height, f, text.data(), text.size(), drawn.get()) !=
        TELLUS_IMAGING_OK)
      return std::unexpected(drawn.error());
    if (drawn.bytes.size() != px.size()) return std::unexpected("the drawn image has a bad size");
    std::memcpy(px.data(), drawn.bytes.data(), px.size());
  }
  if (format == MapFormat::Png8) {
    const codec::PalettedImage p = codec::quantize(px.data(), 4, n);
    return codec::encodePngPalette(width, height, p.palette, p.indices.data());
  }
  if (!alpha) { // RGB: no alpha channel in an opaque format
    for (std::size_t i = 0; i < n; ++i)
      std::memmove(&px[i * 3], &px[i * 4], 3);
  }
  return encodeImage(format == MapFormat::Jpeg   ? "image/jpeg"
                     : format == MapFormat::Tiff ? "image/tiff"
                                                 : "image/png",
                     width,
                     height,
                     alpha ? 4 : 3,
                     px.data());
}

namespace {

/** Collects decoded samples into a vector of T (the caller's, so its storage can be reused:
 * resizing to the size it already has neither allocates nor clears). */
template <class T> class SamplesSink final : public imaging::Sink {
public:
  explicit SamplesSink(std::vector<T>& out) : samples(out) {}
  std::vector<T>& samples;

private:
  void* allocate(std::size_t size) override {
    samples.resize((size + sizeof(T) - 1) / sizeof(T));
    return samples.data();
  }
};

const char* formatOf(std::string_view mimeType) noexcept {
  if (mimeType == "image/jpeg") return "jpeg";
  if (mimeType == "image/png") return "png";
  if (mimeType == "image/tiff") return "tiff";
  return nullptr;
}

std::string decodeError(std::int32_t status,
                        const TellusImagingRasterInfo& info,
                        const std::string& text,
                        int width,
                        int height) {
  if (status == TELLUS_IMAGING_SHAPE)
    return "the tile is " + std::to_string(info.width) + "x" + std::to_string(info.height) +
           ", not " + std::to_string(width) + "x" + std::to_string(height);
  if (status == TELLUS_IMAGING_NO_CODEC) return "no decoder for the tile's format";
  return text.empty() ? std::string("the tile does not decode")
                      : "the tile does not decode: " + text;
}

} // namespace

std::expected<int, std::string> decodeImageryInto(std::span<const std::byte> bytes,
                                                  std::string_view mimeType,
                                                  int width,
                                                  int height,
                                                  std::vector<std::uint8_t>& pixels,
                                                  const std::array<std::int32_t, 4>* region) {
  if (mimeType == "image/jpeg") return codec::decodeJpegInto(bytes, width, height, pixels, region);
  if (mimeType == "image/png") return codec::decodePngInto(bytes, width, height, pixels);
  const char* format = formatOf(mimeType);
  if (!format) return std::unexpected("cannot decode " + std::string(mimeType) + " as imagery");
  auto api = imaging::table();
  if (!api) return std::unexpected(api.error());
  SamplesSink<std::uint8_t> out(pixels);
  TellusImagingRasterInfo info{};
  const auto status = (*api)->decodePixels(
      bytes.data(), bytes.size(), format, TELLUS_IMAGING_UINT8, width, height, &info, out.get());
  if (status != TELLUS_IMAGING_OK)
    return std::unexpected(decodeError(status, info, out.error(), width, height));
  return info.channels;
}

std::expected<DecodedImage, std::string>
decodeImagery(std::span<const std::byte> bytes, std::string_view mimeType, int width, int height) {
  DecodedImage img;
  auto channels = decodeImageryInto(bytes, mimeType, width, height, img.pixels);
  if (!channels) return std::unexpected(channels.error());
  img.width = width;
  img.height = height;
  img.channels = *channels;
  return img;
}

std::expected<std::vector<std::int16_t>, std::string>
decodeHeights(std::span<const std::byte> bytes, std::string_view mimeType, int width, int height) {
  if (width <= 0 || height <= 0) return std::unexpected("bad image shape");
  const auto n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  if (mimeType == "application/bil16") return codec::decodeBil16(bytes, width, height);
  const char* format = formatOf(mimeType);
  if (!format || mimeType == "image/jpeg")
    return std::unexpected("cannot decode " + std::string(mimeType) + " as heights");
  auto api = imaging::table();
  if (!api) return std::unexpected(api.error());
  std::vector<std::int16_t> samples;
  SamplesSink<std::int16_t> out(samples);
  TellusImagingRasterInfo info{};
  const auto status = (*api)->decodePixels(
      bytes.data(), bytes.size(), format, TELLUS_IMAGING_INT16, width, height, &info, out.get());
  if (status != TELLUS_IMAGING_OK)
    return std::unexpected(decodeError(status, info, out.error(), width, height));
  if (mimeType == "image/png") { // stored as height + 32768
    for (auto& h : out.samples)
      h = static_cast<std::int16_t>(static_cast<std::int32_t>(static_cast<std::uint16_t>(h)) -
                                    32768);
  }
  out.samples.resize(n);
  return std::move(out.samples);
}

} // namespace tellus
