// JPEG (libjpeg-turbo) and 8-bit PNG (libpng) linked into the proxy itself: they are small (about
// 1 MiB mapped together), unlike OpenImageIO (about 121 MiB, loaded on demand by ImagingLoader), so
// composing maps from JPEG or PNG tiles never loads OpenImageIO. Everything here is C libraries
// that report errors by longjmp: the functions that call them keep no object with a destructor
// alive across those calls.

#include "codec/Codecs.hpp"

#include <algorithm>
#include <csetjmp>
#include <cstdio> // jpeglib.h needs FILE
#include <cstdlib>
#include <cstring>
#include <jpeglib.h>
#include <png.h>

namespace tellus::codecs {

namespace {

struct JpegError {
  jpeg_error_mgr mgr; // first: libjpeg hands out a pointer to it
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX];
  bool warned; // a warning (corrupt data, premature end) was emitted
};

extern "C" void jpegErrorExit(j_common_ptr c) {
  auto* e = reinterpret_cast<JpegError*>(c->err);
  (*c->err->format_message)(c, e->message);
  std::longjmp(e->jump, 1);
}

// Warnings (a truncated stream among them) are remembered: composing ignores them (maps are made
// of cached tiles, and only validated tiles are cached), validation fails on them.
extern "C" void jpegWarning(j_common_ptr c, int level) {
  if (level >= 0) return; // trace messages
  auto* e = reinterpret_cast<JpegError*>(c->err);
  if (!e->warned) (*c->err->format_message)(c, e->message);
  e->warned = true;
}

enum class Status { Ok, Shape, Failed, Warned };

/** The libjpeg part of decodeJpegInto: `dst` has room for width * height * 3 bytes. */
Status decodeJpegRaw(const unsigned char* bytes,
                     unsigned long size,
                     int width,
                     int height,
                     const std::array<std::int32_t, 4>* region,
                     unsigned char* dst,
                     char* message,
                     int* actualWidth,
                     int* actualHeight) {
  jpeg_decompress_struct cinfo;
  JpegError err;
  cinfo.err = jpeg_std_error(&err.mgr);
  err.mgr.error_exit = jpegErrorExit;
  err.mgr.emit_message = jpegWarning;
  err.message[0] = '\0';
  err.warned = false;
  if (setjmp(err.jump)) {
    jpeg_destroy_decompress(&cinfo);
    std::memcpy(message, err.message, sizeof err.message);
    return Status::Failed;
  }
  jpeg_create_decompress(&cinfo);
  jpeg_mem_src(&cinfo, bytes, size);
  jpeg_read_header(&cinfo, TRUE);
  *actualWidth = static_cast<int>(cinfo.image_width);
  *actualHeight = static_cast<int>(cinfo.image_height);
  if (static_cast<int>(cinfo.image_width) != width ||
      static_cast<int>(cinfo.image_height) != height ||
      (cinfo.num_components != 1 && cinfo.num_components != 3)) {
    jpeg_destroy_decompress(&cinfo);
    return Status::Shape;
  }
  cinfo.out_color_space = JCS_RGB;
  jpeg_start_decompress(&cinfo);
  JDIMENSION x0 = 0, cropWidth = static_cast<JDIMENSION>(width);
  JDIMENSION y1 = static_cast<JDIMENSION>(height);
  if (region) {
    const auto& r = *region;
    const auto left = std::clamp(r[0], 0, width - 1);
    const auto right = std::clamp(r[2], left + 1, width);
    const auto top = std::clamp(r[1], 0, height - 1);
    y1 = static_cast<JDIMENSION>(std::clamp(r[3], top + 1, height));
    x0 = static_cast<JDIMENSION>(left);
    cropWidth = static_cast<JDIMENSION>(right - left);
    // Whole iMCU columns around the crop are decoded, so its pixels are the whole decode's.
    if (cropWidth < static_cast<JDIMENSION>(width)) jpeg_crop_scanline(&cinfo, &x0, &cropWidth);
    if (top > 0) jpeg_skip_scanlines(&cinfo, static_cast<JDIMENSION>(top));
  }
  const auto stride = static_cast<std::size_t>(width) * 3;
  while (cinfo.output_scanline < y1) {
    JSAMPROW row = dst + cinfo.output_scanline * stride + static_cast<std::size_t>(x0) * 3;
    jpeg_read_scanlines(&cinfo, &row, 1);
  }
  if (cinfo.output_scanline < cinfo.output_height) {
    jpeg_abort_decompress(&cinfo);
  } else {
    jpeg_finish_decompress(&cinfo);
  }
  jpeg_destroy_decompress(&cinfo);
  if (err.warned) {
    std::memcpy(message, err.message, sizeof err.message);
    return Status::Warned;
  }
  return Status::Ok;
}

/** The libjpeg part of encodeJpeg: the bytes in a malloc()ed buffer the caller frees. */
bool encodeJpegRaw(int width,
                   int height,
                   int channels,
                   const std::uint8_t* pixels,
                   int restartInterval,
                   int quality,
                   unsigned char** buffer,
                   unsigned long* size,
                   char* message) {
  jpeg_compress_struct cinfo;
  JpegError err;
  cinfo.err = jpeg_std_error(&err.mgr);
  err.mgr.error_exit = jpegErrorExit;
  err.mgr.emit_message = jpegWarning;
  err.message[0] = '\0';
  err.warned = false;
  if (setjmp(err.jump)) {
    jpeg_destroy_compress(&cinfo);
    std::memcpy(message, err.message, sizeof err.message);
    return false;
  }
  jpeg_create_compress(&cinfo);
  jpeg_mem_dest(&cinfo, buffer, size);
  cinfo.image_width = static_cast<JDIMENSION>(width);
  cinfo.image_height = static_cast<JDIMENSION>(height);
  cinfo.input_components = channels;
  cinfo.in_color_space = channels == 1 ? JCS_GRAYSCALE : JCS_RGB;
  jpeg_set_defaults(&cinfo);
  jpeg_set_quality(&cinfo, std::clamp(quality, 1, 100), TRUE);
  cinfo.restart_interval = static_cast<unsigned int>(std::max(restartInterval, 0));
  jpeg_start_compress(&cinfo, TRUE);
  const auto stride = static_cast<std::size_t>(width) * static_cast<std::size_t>(channels);
  while (cinfo.next_scanline < cinfo.image_height) {
    JSAMPROW row = const_cast<std::uint8_t*>(pixels) + cinfo.next_scanline * stride;
    jpeg_write_scanlines(&cinfo, &row, 1);
  }
  jpeg_finish_compress(&cinfo);
  jpeg_destroy_compress(&cinfo);
  return true;
}

} // namespace

std::expected<int, std::string> decodeJpegInto(std::span<const std::byte> bytes,
                                               int width,
                                               int height,
                                               std::vector<std::uint8_t>& pixels,
                                               const std::array<std::int32_t, 4>* region) {
  if (width <= 0 || height <= 0) return std::unexpected("bad image shape");
  pixels.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 3);
  char message[JMSG_LENGTH_MAX] = {};
  int w = 0, h = 0;
  switch (decodeJpegRaw(reinterpret_cast<const unsigned char*>(bytes.data()),
                        static_cast<unsigned long>(bytes.size()),
                        width,
                        height,
                        region,
                        pixels.data(),
                        message,
                        &w,
                        &h)) {
  case Status::Ok:
  case Status::Warned:
    return 3;
  case Status::Shape:
    return std::unexpected("the JPEG is not " + std::to_string(width) + "x" +
                           std::to_string(height) + " grey or RGB");
  case Status::Failed:
    break;
  }
  return std::unexpected(std::string("the JPEG does not decode: ") + message);
}

std::expected<void, std::string> checkJpeg(std::span<const std::byte> bytes,
                                           int width,
                                           int height,
                                           std::vector<std::uint8_t>& scratch) {
  if (width <= 0 || height <= 0) return std::unexpected("bad image shape");
  scratch.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 3);
  char message[JMSG_LENGTH_MAX] = {};
  int w = 0, h = 0;
  switch (decodeJpegRaw(reinterpret_cast<const unsigned char*>(bytes.data()),
                        static_cast<unsigned long>(bytes.size()),
                        width,
                        height,
                        nullptr,
                        scratch.data(),
                        message,
                        &w,
                        &h)) {
  case Status::Ok:
    return {};
  case Status::Shape:
    if (w != width || h != height)
      return std::unexpected("JPEG is " + std::to_string(w) + "x" + std::to_string(h) +
                             ", expected " + std::to_string(width) + "x" + std::to_string(height));
    return std::unexpected("JPEG has an unusable channel count");
  case Status::Failed:
  case Status::Warned:
    break;
  }
  return std::unexpected(std::string("JPEG does not decode: ") + message);
}

std::expected<void, std::string> checkPng(std::span<const std::byte> bytes,
                                          int width,
                                          int height,
                                          std::vector<std::uint8_t>& scratch) {
  png_image image;
  std::memset(&image, 0, sizeof image);
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_memory(&image, bytes.data(), bytes.size()))
    return std::unexpected(std::string("PNG does not decode: ") + image.message);
  if (static_cast<int>(image.width) != width || static_cast<int>(image.height) != height) {
    const auto w = image.width, h = image.height;
    png_image_free(&image);
    return std::unexpected("PNG is " + std::to_string(w) + "x" + std::to_string(h) + ", expected " +
                           std::to_string(width) + "x" + std::to_string(height));
  }
  image.format = PNG_FORMAT_RGBA;
  scratch.resize(PNG_IMAGE_SIZE(image));
  if (!png_image_finish_read(&image, nullptr, scratch.data(), 0, nullptr))
    return std::unexpected(std::string("PNG does not decode: ") + image.message);
  return {};
}

std::expected<std::vector<std::byte>, std::string> encodeJpeg(int width,
                                                              int height,
                                                              int channels,
                                                              const std::uint8_t* pixels,
                                                              int restartInterval,
                                                              int quality) {
  if (width <= 0 || height <= 0 || (channels != 1 && channels != 3) || !pixels)
    return std::unexpected("bad image shape for JPEG");
  unsigned char* buffer = nullptr;
  unsigned long size = 0;
  char message[JMSG_LENGTH_MAX] = {};
  const bool ok = encodeJpegRaw(
      width, height, channels, pixels, restartInterval, quality, &buffer, &size, message);
  std::vector<std::byte> out;
  if (ok) {
    const auto* b = reinterpret_cast<const std::byte*>(buffer);
    out.assign(b, b + size);
  }
  std::free(buffer); // jpeg_mem_dest's buffer (malloc()ed by libjpeg), also after an error
  if (!ok) return std::unexpected(std::string("cannot encode JPEG: ") + message);
  return out;
}

std::expected<int, std::string> decodePngInto(std::span<const std::byte> bytes,
                                              int width,
                                              int height,
                                              std::vector<std::uint8_t>& pixels) {
  png_image image;
  std::memset(&image, 0, sizeof image);
  image.version = PNG_IMAGE_VERSION;
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

std::expected<std::vector<std::byte>, std::string>
encodePng(int width, int height, int channels, const std::uint8_t* pixels) {
  if (width <= 0 || height <= 0 || (channels != 1 && channels != 3 && channels != 4) || !pixels)
    return std::unexpected("bad image shape for PNG");
  png_image image;
  std::memset(&image, 0, sizeof image);
  image.version = PNG_IMAGE_VERSION;
  image.width = static_cast<png_uint_32>(width);
  image.height = static_cast<png_uint_32>(height);
  image.format = channels == 1 ? PNG_FORMAT_GRAY : channels == 3 ? PNG_FORMAT_RGB : PNG_FORMAT_RGBA;
  png_alloc_size_t size = 0;
  // The size first (a NULL buffer), then the bytes.
  if (!png_image_write_to_memory(&image, nullptr, &size, 0, pixels, 0, nullptr))
    return std::unexpected(std::string("cannot encode PNG: ") + image.message);
  std::vector<std::byte> out(size);
  if (!png_image_write_to_memory(&image, out.data(), &size, 0, pixels, 0, nullptr))
    return std::unexpected(std::string("cannot encode PNG: ") + image.message);
  out.resize(size);
  return out;
}

std::expected<std::vector<std::byte>, std::string>
encodePngPalette(int width,
                 int height,
                 const std::vector<std::array<std::uint8_t, 4>>& palette,
                 const std::uint8_t* indices) {
  if (width <= 0 || height <= 0 || palette.empty() || palette.size() > 256 || !indices)
    return std::unexpected("bad image shape for a paletted PNG");
  png_image image;
  std::memset(&image, 0, sizeof image);
  image.version = PNG_IMAGE_VERSION;
  image.width = static_cast<png_uint_32>(width);
  image.height = static_cast<png_uint_32>(height);
  image.format = PNG_FORMAT_RGBA_COLORMAP;
  image.colormap_entries = static_cast<png_uint_32>(palette.size());
  png_alloc_size_t size = 0;
  if (!png_image_write_to_memory(&image, nullptr, &size, 0, indices, 0, palette.data()))
    return std::unexpected(std::string("cannot encode PNG: ") + image.message);
  std::vector<std::byte> out(size);
  if (!png_image_write_to_memory(&image, out.data(), &size, 0, indices, 0, palette.data()))
    return std::unexpected(std::string("cannot encode PNG: ") + image.message);
  out.resize(size);
  return out;
}

} // namespace tellus::codecs
