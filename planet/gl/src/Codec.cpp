#include "Codec.hpp"

#include <tellus/codec/Jpeg.hpp>
#include <tellus/codec/Png.hpp>

#include <fstream>
#include <iterator>

namespace tellus::planet {

bool isJpegOrPng(std::span<const std::byte> bytes) noexcept {
  return codec::sniff(bytes) != codec::Format::Unknown;
}

std::expected<RgbaImage, std::string> decodeJpegOrPng(std::span<const std::byte> bytes) {
  std::expected<codec::Image, std::string> img;
  switch (codec::sniff(bytes)) {
  case codec::Format::Jpeg:
    img = codec::decodeJpeg(bytes, {.channels = 4});
    break;
  case codec::Format::Png:
    img = codec::decodePng(bytes);
    break;
  case codec::Format::Unknown:
    return std::unexpected(std::string("neither JPEG nor PNG"));
  }
  if (!img) return std::unexpected(img.error());
  return RgbaImage{img->width, img->height, std::move(img->pixels)};
}

std::expected<RgbaImage, std::string> readImageFile(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return std::unexpected("cannot open " + file.string());
  std::vector<char> raw((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto img = decodeJpegOrPng(std::as_bytes(std::span(raw)));
  if (!img) return std::unexpected(file.string() + ": " + img.error());
  return img;
}

bool writePngRgb(const std::filesystem::path& file,
                 int width,
                 int height,
                 const std::vector<std::uint8_t>& rgba,
                 std::string* error) {
  if (width <= 0 || height <= 0 ||
      rgba.size() != static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 4) {
    if (error) *error = "bad image size";
    return false;
  }
  std::vector<std::uint8_t> rgb(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) *
                                3);
  for (std::size_t i = 0, n = rgb.size() / 3; i < n; ++i)
    for (std::size_t c = 0; c < 3; ++c)
      rgb[3 * i + c] = rgba[4 * i + c];
  const auto png = codec::encodePng(width, height, 3, rgb.data());
  if (!png) {
    if (error) *error = file.string() + ": " + png.error();
    return false;
  }
  // Written next to the target and renamed, so a reader never sees half a PNG.
  const std::filesystem::path tmp = file.string() + ".tmp";
  std::error_code ec;
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(png->data()),
              static_cast<std::streamsize>(png->size()));
    if (!out.flush()) {
      if (error) *error = tmp.string() + ": cannot write";
      out.close();
      std::filesystem::remove(tmp, ec);
      return false;
    }
  }
  std::filesystem::rename(tmp, file, ec);
  if (ec) {
    if (error) *error = file.string() + ": " + ec.message();
    std::filesystem::remove(tmp, ec);
    return false;
  }
  return true;
}

std::vector<std::byte> encodePngRgba(int width, int height, const std::vector<std::uint8_t>& rgba) {
  return codec::encodePng(width, height, 4, rgba.data()).value_or(std::vector<std::byte>{});
}

} // namespace tellus::planet
