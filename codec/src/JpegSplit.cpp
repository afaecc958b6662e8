// The DCT-domain split of a JPEG into tiles (see JpegSplit.hpp). Every libjpeg call runs inside
// the one error wrapper (JpegSession.hpp): the functions given to run() keep no object with a
// non-trivial destructor; the tiles are written into vectors that the caller owns.

#include "JpegSession.hpp"

#include <tellus/codec/Jpeg.hpp>
#include <tellus/codec/JpegSplit.hpp>

#include <cstring>

namespace tellus::codec {

using detail::JpegCompress;
using detail::JpegDecompress;
using detail::JpegErrors;
using detail::JpegVectorDestination;

namespace {

enum class Result { Ok, Invalid, NotAligned };

/** Writes the tile at (tr, tc) of `src`'s coefficients into `out`: the source's quantisation
 * tables and sampling, its blocks copied into virtual arrays of the tile's size. Called inside
 * splitRaw's run (the destination here is trivially destructible). */
void writeTile(jpeg_decompress_struct& src,
               jvirt_barray_ptr* srcArrays,
               jpeg_compress_struct& dst,
               Bytes& out,
               int tr,
               int tc,
               int tileWidth,
               int tileHeight,
               bool optimize) {
  JpegVectorDestination dest(out);
  // max_*_samp_factor are set by jpeg_read_header; the iMCU is 8 x 8 blocks of the largest factor.
  const int mcuW = src.max_h_samp_factor * DCTSIZE;
  const int mcuH = src.max_v_samp_factor * DCTSIZE;
  dest.attach(&dst);
  jpeg_copy_critical_parameters(&src, &dst); // quantisation tables, sampling, colour space
  dst.image_width = static_cast<JDIMENSION>(tileWidth);
  dst.image_height = static_cast<JDIMENSION>(tileHeight);
  dst.arith_code = FALSE;
  dst.optimize_coding = optimize ? TRUE : FALSE;
  dst.restart_interval = kTileRestartInterval; // the composer's region decodes use them
  jvirt_barray_ptr dstArrays[MAX_COMPONENTS];
  JDIMENSION blocksW[MAX_COMPONENTS];
  JDIMENSION blocksH[MAX_COMPONENTS];
  for (int ci = 0; ci < src.num_components; ++ci) {
    const jpeg_component_info& comp = src.comp_info[ci];
    // Whole iMCUs: exact block counts, already multiples of the component's factors.
    blocksW[ci] = static_cast<JDIMENSION>(tileWidth / mcuW * comp.h_samp_factor);
    blocksH[ci] = static_cast<JDIMENSION>(tileHeight / mcuH * comp.v_samp_factor);
    dstArrays[ci] = (*dst.mem->request_virt_barray)(reinterpret_cast<j_common_ptr>(&dst),
                                                    JPOOL_IMAGE,
                                                    FALSE,
                                                    blocksW[ci],
                                                    blocksH[ci],
                                                    // the encoder reads an iMCU row at once
                                                    static_cast<JDIMENSION>(comp.v_samp_factor));
  }
  jpeg_write_coefficients(&dst, dstArrays); // realizes the arrays; data goes out at finish
  for (int ci = 0; ci < src.num_components; ++ci) {
    const JDIMENSION x0 = static_cast<JDIMENSION>(tc) * blocksW[ci];
    const JDIMENSION y0 = static_cast<JDIMENSION>(tr) * blocksH[ci];
    for (JDIMENSION by = 0; by < blocksH[ci]; ++by) {
      JBLOCKARRAY from = (*src.mem->access_virt_barray)(
          reinterpret_cast<j_common_ptr>(&src), srcArrays[ci], y0 + by, 1, FALSE);
      JBLOCKARRAY to = (*dst.mem->access_virt_barray)(
          reinterpret_cast<j_common_ptr>(&dst), dstArrays[ci], by, 1, TRUE);
      std::memcpy(to[0], from[0] + x0, blocksW[ci] * sizeof(JBLOCK));
    }
  }
  jpeg_finish_compress(&dst); // also releases the tile's arrays (JPOOL_IMAGE)
}

/** Reads the coefficients of `jpeg` once, then writes each of the cols x rows tiles into tiles[i]
 * (sized by the caller to a first guess). */
Result splitRaw(std::span<const std::byte> jpeg,
                int cols,
                int rows,
                int tileWidth,
                int tileHeight,
                bool optimize,
                std::vector<Bytes>& tiles,
                std::string& message) {
  JpegErrors err;
  JpegDecompress src(err);
  JpegCompress dst(err); // destroyed first
  if (!err.run([&] {
        src.create();
        dst.create();
        src.source(jpeg.data(), jpeg.size());
        jpeg_read_header(src.get(), TRUE);
      })) {
    message = err.message();
    return Result::Invalid;
  }
  if (static_cast<long>(src->image_width) != static_cast<long>(cols) * tileWidth ||
      static_cast<long>(src->image_height) != static_cast<long>(rows) * tileHeight) {
    message = "JPEG is " + std::to_string(src->image_width) + "x" +
              std::to_string(src->image_height) + ", expected " +
              std::to_string(static_cast<long>(cols) * tileWidth) + "x" +
              std::to_string(static_cast<long>(rows) * tileHeight);
    return Result::Invalid;
  }
  const bool usable = src->data_precision == 8 &&
                      ((src->num_components == 1 && src->jpeg_color_space == JCS_GRAYSCALE) ||
                       (src->num_components == 3 && src->jpeg_color_space == JCS_YCbCr));
  // max_*_samp_factor are set by jpeg_read_header; the iMCU is 8 x 8 blocks of the largest factor.
  const int mcuW = src->max_h_samp_factor * DCTSIZE;
  const int mcuH = src->max_v_samp_factor * DCTSIZE;
  if (!usable || !jpegTilesAligned(tileWidth, tileHeight, mcuW, mcuH)) return Result::NotAligned;
  jvirt_barray_ptr* srcArrays = nullptr;
  // Every block entropy-decoded; then each tile's blocks written.
  const bool ok = err.run([&] { srcArrays = jpeg_read_coefficients(src.get()); }) &&
                  !err.warned() && err.run([&] {
                    for (int tr = 0; tr < rows; ++tr) {
                      for (int tc = 0; tc < cols; ++tc)
                        writeTile(*src.get(),
                                  srcArrays,
                                  *dst.get(),
                                  tiles[static_cast<std::size_t>(tr * cols + tc)],
                                  tr,
                                  tc,
                                  tileWidth,
                                  tileHeight,
                                  optimize);
                    }
                    jpeg_finish_decompress(src.get());
                  });
  if (!ok || err.warned()) {
    message = err.message();
    return Result::Invalid;
  }
  return Result::Ok;
}

} // namespace

std::expected<std::vector<std::vector<std::byte>>, JpegSplitError>
splitJpegDct(std::span<const std::byte> jpeg,
             int cols,
             int rows,
             int tileWidth,
             int tileHeight,
             bool optimizeHuffman) {
  if (cols <= 0 || rows <= 0 || tileWidth <= 0 || tileHeight <= 0 || cols > 64 || rows > 64 ||
      tileWidth > 16384 || tileHeight > 16384)
    return std::unexpected(JpegSplitError{JpegSplitErrc::Invalid, "bad metatile shape"});
  if (jpeg.empty()) return std::unexpected(JpegSplitError{JpegSplitErrc::Invalid, "empty JPEG"});
  const std::size_t count = static_cast<std::size_t>(cols) * static_cast<std::size_t>(rows);
  // A first guess per tile: its share of the input, with room; grown by doubling when needed.
  const std::size_t guess = jpeg.size() / count + jpeg.size() / (4 * count) + 4096;
  std::vector<Bytes> tiles(count, Bytes(guess));
  std::string message;
  const Result r =
      splitRaw(jpeg, cols, rows, tileWidth, tileHeight, optimizeHuffman, tiles, message);
  if (r == Result::NotAligned)
    return std::unexpected(
        JpegSplitError{JpegSplitErrc::NotAligned, "tile edges are not on iMCU boundaries"});
  if (r != Result::Ok)
    return std::unexpected(JpegSplitError{
        JpegSplitErrc::Invalid,
        message.starts_with("JPEG is ") ? message : "JPEG does not decode: " + message});
  return tiles;
}

} // namespace tellus::codec
