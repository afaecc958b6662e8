// JPEG decode, validation and encode through libjpeg-turbo, each library call inside the one
// error wrapper (JpegSession.hpp): the functions given to run() keep no object with a destructor.

#include "JpegSession.hpp"

#include <tellus/codec/Jpeg.hpp>

#include <algorithm>
#include <cstring>

namespace tellus::codec {

using detail::JpegCompress;
using detail::JpegDecompress;
using detail::JpegErrors;
using detail::JpegVectorDestination;

namespace {

/** Reads the header of `bytes` into `d` (created here). */
bool readHeader(JpegErrors& err, JpegDecompress& d, std::span<const std::byte> bytes) {
  return err.run([&] {
    d.create();
    d.source(bytes.data(), bytes.size());
    jpeg_read_header(d.get(), TRUE);
  });
}

/** Decodes the rows of a started decompressor into `dst` (`stride` bytes a row, as libjpeg
 * writes them), or, with `row` (width * 3 bytes), RGB through it into RGBA. Runs inside a run. */
void readAllRows(jpeg_decompress_struct& c,
                 unsigned char* dst,
                 std::size_t stride,
                 unsigned char* row) {
  const std::size_t w = c.output_width;
  while (c.output_scanline < c.output_height) {
    unsigned char* out = dst + static_cast<std::size_t>(c.output_scanline) * stride;
    JSAMPROW r = row ? row : out;
    jpeg_read_scanlines(&c, &r, 1);
    if (!row) continue;
    for (std::size_t x = 0; x < w; ++x) {
      out[4 * x + 0] = row[3 * x + 0];
      out[4 * x + 1] = row[3 * x + 1];
      out[4 * x + 2] = row[3 * x + 2];
      out[4 * x + 3] = 255;
    }
  }
}

/** The rows of a started RGB decompressor around `region` (all without one) into `dst`, a
 * width x height x 3 image; stops after the region's last row. Runs inside a run. */
void readRegion(
    jpeg_decompress_struct& c, int width, int height, const Region* region, unsigned char* dst) {
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
    if (cropWidth < static_cast<JDIMENSION>(width)) jpeg_crop_scanline(&c, &x0, &cropWidth);
    if (top > 0) jpeg_skip_scanlines(&c, static_cast<JDIMENSION>(top));
  }
  const auto stride = static_cast<std::size_t>(width) * 3;
  while (c.output_scanline < y1) {
    JSAMPROW row = dst + c.output_scanline * stride + static_cast<std::size_t>(x0) * 3;
    jpeg_read_scanlines(&c, &row, 1);
  }
  if (c.output_scanline < c.output_height) {
    jpeg_abort_decompress(&c);
  } else {
    jpeg_finish_decompress(&c);
  }
}

enum class Status { Ok, Shape, Failed, Warned };

struct TileDecode {
  Status status = Status::Ok;
  int width = 0, height = 0; ///< the JPEG's, once its header is read
  std::string message;
};

/** A tile that must be width x height, grey or colour, as RGB into `dst` (room for width *
 * height * 3 bytes). */
TileDecode decodeTile(std::span<const std::byte> bytes,
                      int width,
                      int height,
                      const Region* region,
                      unsigned char* dst) {
  JpegErrors err;
  JpegDecompress d(err);
  if (!readHeader(err, d, bytes)) return {Status::Failed, 0, 0, err.message()};
  TileDecode out;
  out.width = static_cast<int>(d->image_width);
  out.height = static_cast<int>(d->image_height);
  if (out.width != width || out.height != height ||
      (d->num_components != 1 && d->num_components != 3)) {
    out.status = Status::Shape;
    return out;
  }
  d->out_color_space = JCS_RGB;
  if (!err.run([&] {
        jpeg_start_decompress(d.get());
        readRegion(*d.get(), width, height, region, dst);
      })) {
    out.status = Status::Failed;
  } else if (err.warned()) {
    out.status = Status::Warned;
  }
  if (out.status != Status::Ok) out.message = err.message();
  return out;
}

std::string sizeText(int width, int height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

} // namespace

std::expected<JpegInfo, std::string> probeJpeg(std::span<const std::byte> bytes) {
  JpegErrors err;
  JpegDecompress d(err);
  if (!readHeader(err, d, bytes))
    return std::unexpected("the JPEG does not decode: " + err.message());
  JpegInfo info;
  info.width = static_cast<int>(d->image_width);
  info.height = static_cast<int>(d->image_height);
  info.components = d->num_components;
  // max_*_samp_factor are set by jpeg_read_header; the iMCU is 8 x 8 blocks of the largest.
  info.mcuWidth = d->max_h_samp_factor * DCTSIZE;
  info.mcuHeight = d->max_v_samp_factor * DCTSIZE;
  info.progressive = d->progressive_mode != FALSE;
  info.restartInterval = static_cast<int>(d->restart_interval);
  return info;
}

std::expected<Image, std::string> decodeJpeg(std::span<const std::byte> bytes,
                                             const JpegDecodeOptions& options) {
  const int channels = options.channels;
  if (channels != 0 && channels != 1 && channels != 3 && channels != 4)
    return std::unexpected("cannot decode a JPEG into " + std::to_string(channels) + " channels");
  JpegErrors err;
  JpegDecompress d(err);
  if (!readHeader(err, d, bytes))
    return std::unexpected("the JPEG does not decode: " + err.message());
  Image img;
  img.width = static_cast<int>(d->image_width);
  img.height = static_cast<int>(d->image_height);
  if (img.width <= 0 || img.height <= 0 || img.width > kMaxSide || img.height > kMaxSide)
    return std::unexpected("the JPEG is " + sizeText(img.width, img.height) +
                           ": too large or empty");
  const bool grey = channels == 1 || (channels == 0 && d->num_components == 1);
  d->out_color_space = grey ? JCS_GRAYSCALE : JCS_RGB;
  d->do_fancy_upsampling = options.fancyUpsampling ? TRUE : FALSE;
  img.channels = grey ? 1 : channels == 4 ? 4 : 3;
  const auto w = static_cast<std::size_t>(img.width);
  img.pixels.resize(w * static_cast<std::size_t>(img.height) *
                    static_cast<std::size_t>(img.channels));
  std::vector<unsigned char> row(img.channels == 4 ? w * 3 : 0);
  if (!err.run([&] {
        jpeg_start_decompress(d.get());
        readAllRows(*d.get(),
                    img.pixels.data(),
                    w * static_cast<std::size_t>(img.channels),
                    row.empty() ? nullptr : row.data());
        jpeg_finish_decompress(d.get());
      }))
    return std::unexpected("the JPEG does not decode: " + err.message());
  return img;
}

std::expected<int, std::string> decodeJpegInto(std::span<const std::byte> bytes,
                                               int width,
                                               int height,
                                               std::vector<std::uint8_t>& pixels,
                                               const Region* region) {
  if (width <= 0 || height <= 0) return std::unexpected("bad image shape");
  pixels.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 3);
  const TileDecode r = decodeTile(bytes, width, height, region, pixels.data());
  switch (r.status) {
  case Status::Ok:
  case Status::Warned:
    return 3;
  case Status::Shape:
    return std::unexpected("the JPEG is not " + sizeText(width, height) + " grey or RGB");
  case Status::Failed:
    break;
  }
  return std::unexpected("the JPEG does not decode: " + r.message);
}

std::expected<void, std::string> checkJpeg(std::span<const std::byte> bytes,
                                           int width,
                                           int height,
                                           std::vector<std::uint8_t>& scratch) {
  if (width <= 0 || height <= 0) return std::unexpected("bad image shape");
  scratch.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 3);
  const TileDecode r = decodeTile(bytes, width, height, nullptr, scratch.data());
  switch (r.status) {
  case Status::Ok:
    return {};
  case Status::Shape:
    if (r.width != width || r.height != height)
      return std::unexpected("JPEG is " + sizeText(r.width, r.height) + ", expected " +
                             sizeText(width, height));
    return std::unexpected("JPEG has an unusable channel count");
  case Status::Failed:
  case Status::Warned:
    break;
  }
  return std::unexpected("JPEG does not decode: " + r.message);
}

std::expected<Bytes, std::string> encodeJpeg(int width,
                                             int height,
                                             int channels,
                                             const std::uint8_t* pixels,
                                             const JpegEncodeOptions& options) {
  if (width <= 0 || height <= 0 || (channels != 1 && channels != 3) || !pixels)
    return std::unexpected("bad image shape for JPEG");
  const auto stride = static_cast<std::size_t>(width) * static_cast<std::size_t>(channels);
  // A first guess of the size (grown by doubling): a quality 90 tile of imagery is about 1.5
  // bits per pixel.
  Bytes out(std::max<std::size_t>(4096, stride * static_cast<std::size_t>(height) / 8));
  JpegErrors err;
  JpegCompress c(err);
  JpegVectorDestination dest(out);
  if (!err.run([&] {
        c.create();
        dest.attach(c.get());
        c->image_width = static_cast<JDIMENSION>(width);
        c->image_height = static_cast<JDIMENSION>(height);
        c->input_components = channels;
        c->in_color_space = channels == 1 ? JCS_GRAYSCALE : JCS_RGB;
        jpeg_set_defaults(c.get());
        jpeg_set_quality(c.get(), std::clamp(options.quality, 1, 100), TRUE);
        c->restart_interval = static_cast<unsigned int>(std::max(options.restartInterval, 0));
        if (channels == 3 && options.lumaSamplingH > 0 && options.lumaSamplingV > 0) {
          c->comp_info[0].h_samp_factor = options.lumaSamplingH;
          c->comp_info[0].v_samp_factor = options.lumaSamplingV;
        }
        jpeg_start_compress(c.get(), TRUE);
        while (c->next_scanline < c->image_height) {
          JSAMPROW row = const_cast<std::uint8_t*>(pixels) + c->next_scanline * stride;
          jpeg_write_scanlines(c.get(), &row, 1);
        }
        jpeg_finish_compress(c.get());
      }))
    return std::unexpected("cannot encode JPEG: " + err.message());
  return out;
}

} // namespace tellus::codec
