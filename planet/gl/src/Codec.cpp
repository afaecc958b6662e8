// libjpeg reports errors by longjmp: decodeJpegRaw keeps no object with a destructor alive across
// the libjpeg calls (the output buffer is sized by the caller once the header is read).

#include "Codec.hpp"

#include <csetjmp>
#include <cstdio> // jpeglib.h needs FILE
#include <cstring>
#include <fstream>
#include <iterator>
#include <jpeglib.h>
#include <png.h>

namespace tellus::planet {

namespace {

struct JpegError {
  jpeg_error_mgr mgr; // first: libjpeg hands out a pointer to it
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX];
};

extern "C" void planetJpegErrorExit(j_common_ptr c) {
  auto* e = reinterpret_cast<JpegError*>(c->err);
  (*c->err->format_message)(c, e->message);
  std::longjmp(e->jump, 1);
}

extern "C" void planetJpegMessage(j_common_ptr, int) {} // warnings: decode what is there

/** Step 1 reads the header (dst null: width/height out); step 2 decodes into dst (RGBA). */
bool decodeJpegRaw(const unsigned char* bytes,
                   unsigned long size,
                   unsigned char* dst,
                   unsigned char* row,
                   int* width,
                   int* height,
                   char* message) {
  jpeg_decompress_struct cinfo;
  JpegError err;
  cinfo.err = jpeg_std_error(&err.mgr);
  err.mgr.error_exit = planetJpegErrorExit;
  err.mgr.emit_message = planetJpegMessage;
  err.message[0] = '\0';
  if (setjmp(err.jump)) {
    jpeg_destroy_decompress(&cinfo);
    std::memcpy(message, err.message, sizeof err.message);
    return false;
  }
  jpeg_create_decompress(&cinfo);
  jpeg_mem_src(&cinfo, bytes, size);
  jpeg_read_header(&cinfo, TRUE);
  if (dst == nullptr) {
    *width = static_cast<int>(cinfo.image_width);
    *height = static_cast<int>(cinfo.image_height);
    jpeg_destroy_decompress(&cinfo);
    return true;
  }
  cinfo.out_color_space = JCS_RGB;
  jpeg_start_decompress(&cinfo);
  const auto w = static_cast<std::size_t>(cinfo.output_width);
  while (cinfo.output_scanline < cinfo.output_height) {
    const std::size_t y = cinfo.output_scanline;
    JSAMPROW r = row;
    jpeg_read_scanlines(&cinfo, &r, 1);
    unsigned char* out = dst + y * w * 4;
    for (std::size_t x = 0; x < w; ++x) {
      out[4 * x + 0] = row[3 * x + 0];
      out[4 * x + 1] = row[3 * x + 1];
      out[4 * x + 2] = row[3 * x + 2];
      out[4 * x + 3] = 255;
    }
  }
  jpeg_finish_decompress(&cinfo);
  jpeg_destroy_decompress(&cinfo);
  return true;
}

std::expected<RgbaImage, std::string> decodeJpeg(std::span<const std::byte> bytes) {
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
  const auto size = static_cast<unsigned long>(bytes.size());
  char message[JMSG_LENGTH_MAX] = {};
  int w = 0, h = 0;
  if (!decodeJpegRaw(data, size, nullptr, nullptr, &w, &h, message))
    return std::unexpected(std::string("JPEG: ") + message);
  if (w <= 0 || h <= 0 || w > 65536 || h > 65536)
    return std::unexpected(std::string("JPEG: bad size"));
  RgbaImage img;
  img.width = w;
  img.height = h;
  img.pixels.resize(static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * 4);
  std::vector<unsigned char> row(static_cast<std::size_t>(w) * 3);
  if (!decodeJpegRaw(data, size, img.pixels.data(), row.data(), &w, &h, message))
    return std::unexpected(std::string("JPEG: ") + message);
  return img;
}

std::expected<RgbaImage, std::string> decodePng(std::span<const std::byte> bytes) {
  png_image image;
  std::memset(&image, 0, sizeof image);
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_memory(&image, bytes.data(), bytes.size()))
    return std::unexpected(std::string("PNG: ") + image.message);
  image.format = PNG_FORMAT_RGBA;
  if (image.width == 0 || image.height == 0 || image.width > 65536 || image.height > 65536) {
    png_image_free(&image);
    return std::unexpected(std::string("PNG: bad size"));
  }
  RgbaImage img;
  img.width = static_cast<int>(image.width);
  img.height = static_cast<int>(image.height);
  img.pixels.resize(PNG_IMAGE_SIZE(image));
  if (!png_image_finish_read(&image, nullptr, img.pixels.data(), 0, nullptr)) {
    const std::string m = image.message;
    png_image_free(&image);
    return std::unexpected("PNG: " + m);
  }
  return img;
}

} // namespace

namespace codec {

namespace {
bool isJpeg(std::span<const std::byte> bytes) noexcept {
  return bytes.size() >= 3 && bytes[0] == std::byte{0xFF} && bytes[1] == std::byte{0xD8} &&
         bytes[2] == std::byte{0xFF};
}
bool isPng(std::span<const std::byte> bytes) noexcept {
  return bytes.size() >= 8 && bytes[0] == std::byte{0x89} && bytes[1] == std::byte{'P'} &&
         bytes[2] == std::byte{'N'} && bytes[3] == std::byte{'G'};
}
} // namespace

bool isJpegOrPng(std::span<const std::byte> bytes) noexcept {
  return isJpeg(bytes) || isPng(bytes);
}

std::expected<RgbaImage, std::string> decode(std::span<const std::byte> bytes) {
  if (isJpeg(bytes)) return decodeJpeg(bytes);
  if (isPng(bytes)) return decodePng(bytes);
  return std::unexpected(std::string("neither JPEG nor PNG"));
}

} // namespace codec

std::expected<RgbaImage, std::string> readImageFile(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return std::unexpected("cannot open " + file.string());
  std::vector<char> raw((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto img = codec::decode(std::as_bytes(std::span(raw)));
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
  png_image image;
  std::memset(&image, 0, sizeof image);
  image.version = PNG_IMAGE_VERSION;
  image.width = static_cast<png_uint_32>(width);
  image.height = static_cast<png_uint_32>(height);
  image.format = PNG_FORMAT_RGB;
  // Written next to the target and renamed, so a reader never sees half a PNG.
  const std::filesystem::path tmp = file.string() + ".tmp";
  if (!png_image_write_to_file(&image, tmp.c_str(), 0, rgb.data(), 0, nullptr)) {
    if (error) *error = tmp.string() + ": " + image.message;
    png_image_free(&image);
    return false;
  }
  std::error_code ec;
  std::filesystem::rename(tmp, file, ec);
  if (ec) {
    if (error) *error = file.string() + ": " + ec.message();
    std::filesystem::remove(tmp, ec);
    return false;
  }
  return true;
}

std::vector<std::byte> encodePngRgba(int width, int height, const std::vector<std::uint8_t>& rgba) {
  png_image image;
  std::memset(&image, 0, sizeof image);
  image.version = PNG_IMAGE_VERSION;
  image.width = static_cast<png_uint_32>(width);
  image.height = static_cast<png_uint_32>(height);
  image.format = PNG_FORMAT_RGBA;
  png_alloc_size_t size = 0;
  if (!png_image_write_to_memory(&image, nullptr, &size, 0, rgba.data(), 0, nullptr)) return {};
  std::vector<std::byte> out(size);
  if (!png_image_write_to_memory(&image, out.data(), &size, 0, rgba.data(), 0, nullptr)) return {};
  out.resize(size);
  return out;
}

} // namespace tellus::planet
