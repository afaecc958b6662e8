#include "HeightDecode.hpp"

#include <tellus/planet/HeightStreamer.hpp>
#include <tellus/planet_gl/Renderer.hpp>

#include <csetjmp>
#include <cstring>
#include <png.h>
#include <vector>

namespace tellus::planet {

namespace {

struct Reader {
  std::span<const std::byte> bytes;
  std::size_t at = 0;
};

extern "C" void readBytes(png_structp png, png_bytep out, png_size_t count) {
  auto* r = static_cast<Reader*>(png_get_io_ptr(png));
  if (r->at + count > r->bytes.size()) png_error(png, "truncated PNG");
  std::memcpy(out, r->bytes.data() + r->at, count);
  r->at += count;
}

extern "C" void quietWarning(png_structp, png_const_charp) {}

/** A 16-bit (height + 32768) or 8-bit greyscale PNG's samples, row 0 at the top, as raw numbers. */
std::expected<std::vector<double>, std::string>
readGreyPng(std::span<const std::byte> bytes, int width, int height) {
  if (bytes.size() < 8 || png_sig_cmp(reinterpret_cast<png_const_bytep>(bytes.data()), 0, 8) != 0)
    return std::unexpected(std::string("not a PNG"));
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, quietWarning);
  if (png == nullptr) return std::unexpected(std::string("libpng: out of memory"));
  png_infop info = png_create_info_struct(png);
  Reader reader{bytes, 0};
  std::vector<double> out;
  std::vector<png_byte> row;
  std::string error;
  if (setjmp(png_jmpbuf(png)) != 0) {
    png_destroy_read_struct(&png, &info, nullptr);
    return std::unexpected(std::string("the elevation PNG is corrupt"));
  }
  png_set_read_fn(png, &reader, readBytes);
  png_read_info(png, info);
  const auto w = static_cast<int>(png_get_image_width(png, info));
  const auto h = static_cast<int>(png_get_image_height(png, info));
  const int depth = png_get_bit_depth(png, info);
  const int colour = png_get_color_type(png, info);
  if (w != width || h != height) {
    error = "the elevation PNG is " + std::to_string(w) + " x " + std::to_string(h) + ", not " +
            std::to_string(width) + " x " + std::to_string(height);
  } else if (colour != PNG_COLOR_TYPE_GRAY || (depth != 16 && depth != 8)) {
    error = "the elevation PNG is not 8- or 16-bit greyscale";
  } else {
    const std::size_t bytesPerSample = depth == 16 ? 2 : 1;
    row.resize(static_cast<std::size_t>(w) * bytesPerSample);
    out.reserve(static_cast<std::size_t>(w) * static_cast<std::size_t>(h));
    for (int y = 0; y < h; ++y) {
      png_read_row(png, row.data(), nullptr);
      for (int x = 0; x < w; ++x) {
        const auto i = static_cast<std::size_t>(x) * bytesPerSample;
        // PNG stores 16-bit samples big-endian.
        // PNG stores 16-bit samples big-endian; tellus stores heights in 16-bit PNGs as
        // height + 32768 (the proxy's encodeHeights/decodeHeights), so that is undone here.
        out.push_back(depth == 16 ? static_cast<double>((row[i] << 8) | row[i + 1]) - 32768.0
                                  : static_cast<double>(row[i]));
      }
    }
  }
  png_destroy_read_struct(&png, &info, nullptr);
  if (!error.empty()) return std::unexpected(error);
  return out;
}

} // namespace

std::expected<HeightTile, std::string> decodeHeights(const TileKey& key,
                                                     int width,
                                                     int height,
                                                     std::span<const std::byte> bytes,
                                                     std::string_view contentType,
                                                     const HeightEncoding& encoding) {
  if (contentType.starts_with("image/png")) {
    auto raw = readGreyPng(bytes, width, height);
    if (!raw) return std::unexpected(raw.error());
    return heightTileFromSamples(key, width, height, *raw, encoding);
  }
  return decodeHeightsBil16Only(key, width, height, bytes, contentType, encoding);
}

std::expected<HeightTile, std::string> decodeHeightTile(const TileKey& key,
                                                        int width,
                                                        int height,
                                                        std::span<const std::byte> bytes,
                                                        std::string_view contentType,
                                                        const HeightEncoding& encoding) {
  return decodeHeights(key, width, height, bytes, contentType, encoding);
}

} // namespace tellus::planet
