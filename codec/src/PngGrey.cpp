// The exact samples of 8- and 16-bit grey PNGs (elevation tiles): libpng's low-level reader, as
// the simplified API would convert 16-bit samples. libpng reports errors by longjmp to the
// png_jmpbuf set in readHeader / readRows: those two functions and the callbacks hold no object
// with a destructor (a std::string or vector there could be left half-built: -Wclobbered), and
// everything that has one lives in decodePngGrey, outside the jumps.

#include <tellus/codec/Png.hpp>

#include <csetjmp>
#include <cstring>
#include <png.h>

namespace tellus::codec {

namespace {

struct Reader {
  std::span<const std::byte> bytes;
  std::size_t at = 0;
};

extern "C" void tellusPngReadBytes(png_structp png, png_bytep out, png_size_t count) {
  auto* r = static_cast<Reader*>(png_get_io_ptr(png));
  if (r->at + count > r->bytes.size()) png_error(png, "truncated PNG");
  std::memcpy(out, r->bytes.data() + r->at, count);
  r->at += count;
}

extern "C" void tellusPngQuietWarning(png_structp, png_const_charp) {}

struct PngRead {
  png_structp png = nullptr;
  png_infop info = nullptr;
  Reader reader;
  png_uint_32 width = 0;
  png_uint_32 height = 0;
  int depth = 0;
  int colour = 0;
};

bool readHeader(PngRead* r) {
  if (setjmp(png_jmpbuf(r->png)) != 0) return false;
  png_set_read_fn(r->png, &r->reader, tellusPngReadBytes);
  png_read_info(r->png, r->info);
  r->width = png_get_image_width(r->png, r->info);
  r->height = png_get_image_height(r->png, r->info);
  r->depth = png_get_bit_depth(r->png, r->info);
  r->colour = png_get_color_type(r->png, r->info);
  return true;
}

bool readRows(PngRead* r, png_byte* out, std::size_t rowBytes) {
  if (setjmp(png_jmpbuf(r->png)) != 0) return false;
  for (png_uint_32 y = 0; y < r->height; ++y)
    png_read_row(r->png, out + y * rowBytes, nullptr);
  return true;
}

} // namespace

std::expected<GreySamples, std::string>
decodePngGrey(std::span<const std::byte> bytes, int width, int height) {
  if (bytes.size() < 8 || png_sig_cmp(reinterpret_cast<png_const_bytep>(bytes.data()), 0, 8) != 0)
    return std::unexpected(std::string("not a PNG"));
  PngRead r;
  r.reader = {bytes, 0};
  r.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, tellusPngQuietWarning);
  if (r.png == nullptr) return std::unexpected(std::string("libpng: out of memory"));
  r.info = png_create_info_struct(r.png);
  std::string error;
  std::vector<png_byte> pixels;
  GreySamples out;
  if (r.info == nullptr || !readHeader(&r)) {
    error = "the PNG is corrupt";
  } else if (static_cast<int>(r.width) != width || static_cast<int>(r.height) != height) {
    error = "the PNG is " + std::to_string(r.width) + " x " + std::to_string(r.height) + ", not " +
            std::to_string(width) + " x " + std::to_string(height);
  } else if (r.colour != PNG_COLOR_TYPE_GRAY || (r.depth != 16 && r.depth != 8)) {
    error = "the PNG is not 8- or 16-bit greyscale";
  } else {
    const std::size_t bytesPerSample = r.depth == 16 ? 2 : 1;
    const std::size_t rowBytes = static_cast<std::size_t>(width) * bytesPerSample;
    pixels.resize(rowBytes * static_cast<std::size_t>(height));
    if (!readRows(&r, pixels.data(), rowBytes)) {
      error = "the PNG is corrupt";
    } else {
      out.width = width;
      out.height = height;
      out.bitDepth = r.depth;
      out.samples.reserve(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
      for (std::size_t i = 0; i < pixels.size(); i += bytesPerSample) // 16-bit: big-endian
        out.samples.push_back(bytesPerSample == 2
                                  ? static_cast<std::uint16_t>((pixels[i] << 8) | pixels[i + 1])
                                  : pixels[i]);
    }
  }
  png_destroy_read_struct(&r.png, &r.info, nullptr);
  if (!error.empty()) return std::unexpected(error);
  return out;
}

} // namespace tellus::codec
