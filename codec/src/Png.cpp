// PNG pictures through libpng's simplified API (png_image), which keeps libpng's longjmp inside
// libpng and reports failures in the png_image's message: no setjmp here.

#include <tellus/codec/Png.hpp>

#include <cstring>
#include <png.h>

namespace tellus::codec {

namespace {

png_image emptyImage() noexcept {
  png_image image;
  std::memset(&image, 0, sizeof image);
  image.version = PNG_IMAGE_VERSION;
  return image;
}

std::string sizeText(png_uint_32 width, png_uint_32 height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

/** The simplified API's two writes: the size first (a null buffer), then the bytes. */
std::expected<Bytes, std::string>
writePng(png_image& image, const void* pixels, const void* colormap) {
  png_alloc_size_t size = 0;
  if (!png_image_write_to_memory(&image, nullptr, &size, 0, pixels, 0, colormap))
    return std::unexpected(std::string("cannot encode PNG: ") + image.message);
  Bytes out(size);
  if (!png_image_write_to_memory(&image, out.data(), &size, 0, pixels, 0, colormap))
    return std::unexpected(std::string("cannot encode PNG: ") + image.message);
  out.resize(size);
  return out;
}

} // namespace

std::expected<Image, std::string> decodePng(std::span<const std::byte> bytes) {
  png_image image = emptyImage();
  if (!png_image_begin_read_from_memory(&image, bytes.data(), bytes.size()))
    return std::unexpected(std::string("the PNG does not decode: ") + image.message);
  image.format = PNG_FORMAT_RGBA;
  if (image.width == 0 || image.height == 0 || image.width > kMaxSide || image.height > kMaxSide) {
    const auto w = image.width, h = image.height;
    png_image_free(&image);
    return std::unexpected("the PNG is " + sizeText(w, h) + ": too large or empty");
  }
  Image img;
  img.width = static_cast<int>(image.width);
  img.height = static_cast<int>(image.height);
  img.channels = 4;
  img.pixels.resize(PNG_IMAGE_SIZE(image));
  if (!png_image_finish_read(&image, nullptr, img.pixels.data(), 0, nullptr))
    return std::unexpected(std::string("the PNG does not decode: ") + image.message);
  return img;
}

std::expected<int, std::string> decodePngInto(std::span<const std::byte> bytes,
                                              int width,
                                              int height,
                                              std::vector<std::uint8_t>& pixels) {
  png_image image = emptyImage();
  if (!png_image_begin_read_from_memory(&image, bytes.data(), bytes.size()))
    return std::unexpected(std::string("the PNG does not decode: ") + image.message);
  if (static_cast<int>(image.width) != width || static_cast<int>(image.height) != height) {
    png_image_free(&image);
    return std::unexpected("the PNG is not " + std::to_string(width) + "x" +
                           std::to_string(height));
  }
  const bool alpha = (image.format & PNG_FORMAT_FLAG_ALPHA) != 0;
  image.format = alpha ? PNG_FORMAT_RGBA : PNG_FORMAT_RGB;
  pixels.resize(PNG_IMAGE_SIZE(image));
  if (!png_image_finish_read(&image, nullptr, pixels.data(), 0, nullptr))
    return std::unexpected(std::string("the PNG does not decode: ") + image.message);
  return alpha ? 4 : 3;
}

std::expected<void, std::string> checkPng(std::span<const std::byte> bytes,
                                          int width,
                                          int height,
                                          std::vector<std::uint8_t>& scratch) {
  png_image image = emptyImage();
  if (!png_image_begin_read_from_memory(&image, bytes.data(), bytes.size()))
    return std::unexpected(std::string("PNG does not decode: ") + image.message);
  if (static_cast<int>(image.width) != width || static_cast<int>(image.height) != height) {
    const auto w = image.width, h = image.height;
    png_image_free(&image);
    return std::unexpected("PNG is " + sizeText(w, h) + ", expected " + std::to_string(width) +
                           "x" + std::to_string(height));
  }
  image.format = PNG_FORMAT_RGBA;
  scratch.resize(PNG_IMAGE_SIZE(image));
  if (!png_image_finish_read(&image, nullptr, scratch.data(), 0, nullptr))
    return std::unexpected(std::string("PNG does not decode: ") + image.message);
  return {};
}

std::expected<Bytes, std::string>
encodePng(int width, int height, int channels, const std::uint8_t* pixels) {
  if (width <= 0 || height <= 0 || (channels != 1 && channels != 3 && channels != 4) || !pixels)
    return std::unexpected("bad image shape for PNG");
  png_image image = emptyImage();
  image.width = static_cast<png_uint_32>(width);
  image.height = static_cast<png_uint_32>(height);
  image.format = channels == 1 ? PNG_FORMAT_GRAY : channels == 3 ? PNG_FORMAT_RGB : PNG_FORMAT_RGBA;
  return writePng(image, pixels, nullptr);
}

std::expected<Bytes, std::string>
encodePngPalette(int width,
                 int height,
                 const std::vector<std::array<std::uint8_t, 4>>& palette,
                 const std::uint8_t* indices) {
  if (width <= 0 || height <= 0 || palette.empty() || palette.size() > 256 || !indices)
    return std::unexpected("bad image shape for a paletted PNG");
  png_image image = emptyImage();
  image.width = static_cast<png_uint_32>(width);
  image.height = static_cast<png_uint_32>(height);
  image.format = PNG_FORMAT_RGBA_COLORMAP;
  image.colormap_entries = static_cast<png_uint_32>(palette.size());
  return writePng(image, indices, palette.data());
}

} // namespace tellus::codec
