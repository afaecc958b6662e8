#include "ImagingLoader.hpp"

#include <tellus/proxy/ImageCodec.hpp>

#include <cstring>

namespace tellus {

// JPEG, PNG and TIFF go through the imaging module (OpenImageIO), loaded on the first call; BIL16
// is written here and never loads it.

std::expected<std::vector<std::byte>, std::string> encodeImage(
    std::string_view mimeType, int width, int height, int channels, const std::uint8_t* pixels) {
  if (width <= 0 || height <= 0 || (channels != 1 && channels != 3 && channels != 4)) {
    return std::unexpected("bad image shape");
  }
  const bool png = mimeType == "image/png";
  if (!png && mimeType != "image/jpeg")
    return std::unexpected("cannot encode " + std::string(mimeType));
  if (!png && channels == 4) { // JPEG has no alpha: drop it
    const auto n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
    std::vector<std::uint8_t> rgb(n * 3);
    for (std::size_t i = 0; i < n; ++i)
      std::memcpy(&rgb[i * 3], &pixels[i * 4], 3);
    return encodeImage(mimeType, width, height, 3, rgb.data());
  }
  auto api = imaging::table();
  if (!api) return std::unexpected(api.error());
  imaging::BytesSink out;
  if ((*api)->encodeImage(png ? "png" : "jpeg", width, height, channels, pixels, out.get()) !=
      TELLUS_IMAGING_OK)
    return std::unexpected(out.error());
  return std::move(out.bytes);
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
  if (mimeType != "application/bil16")
    return std::unexpected("cannot encode heights as " + std::string(mimeType));
  std::vector<std::byte> out(n * 2);
  for (std::size_t k = 0; k < n; ++k) { // little-endian whatever the host
    const auto u = static_cast<std::uint16_t>(heights[k]);
    out[2 * k] = static_cast<std::byte>(u & 0xFF);
    out[2 * k + 1] = static_cast<std::byte>(u >> 8);
  }
  return out;
}

std::expected<std::vector<std::byte>, std::string> blankImage(std::string_view mimeType,
                                                              int width,
                                                              int height,
                                                              std::optional<std::uint32_t> bgcolor,
                                                              bool transparent,
                                                              std::string_view text) {
  if (width <= 0 || height <= 0) return std::unexpected("bad image shape");
  const std::uint32_t c = bgcolor.value_or(0xFFFFFF);
  const float rgba[4] = {static_cast<float>((c >> 16) & 0xFF) / 255.0f,
                         static_cast<float>((c >> 8) & 0xFF) / 255.0f,
                         static_cast<float>(c & 0xFF) / 255.0f,
                         transparent ? 0.0f : 1.0f};
  auto api = imaging::table();
  if (!api) return std::unexpected(api.error());
  imaging::BytesSink px;
  if ((*api)->drawBlank(width, height, rgba, text.data(), text.size(), px.get()) !=
      TELLUS_IMAGING_OK)
    return std::unexpected(px.error());
  return encodeImage(mimeType == "image/png" ? "image/png" : "image/jpeg",
                     width,
                     height,
                     4,
                     reinterpret_cast<const std::uint8_t*>(px.bytes.data()));
}

} // namespace tellus
