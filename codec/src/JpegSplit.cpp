// The DCT-domain split of a JPEG into tiles (see JpegSplit.hpp). libjpeg reports errors by longjmp:
// splitRaw keeps no object with a destructor alive across its libjpeg calls; what it produces is
// written into malloc()ed buffers that the caller owns (and frees, also after an error).

#include <tellus/codec/Jpeg.hpp>
#include <tellus/codec/JpegSplit.hpp>

#include <csetjmp>
#include <cstdio> // jpeglib.h needs FILE
#include <cstdlib>
#include <cstring>
#include <jpeglib.h>
// after jpeglib.h: the message codes
#include <jerror.h>

namespace tellus::codec {

namespace {

struct SplitErrorMgr {
  jpeg_error_mgr mgr; // first: libjpeg hands out a pointer to it
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX];
  bool warned;
};

extern "C" void splitErrorExit(j_common_ptr c) {
  auto* e = reinterpret_cast<SplitErrorMgr*>(c->err);
  (*c->err->format_message)(c, e->message);
  std::longjmp(e->jump, 1);
}

// Any warning (corrupt data, a premature end padded with zeros) makes the JPEG invalid: a metatile
// is the upstream's answer for up to 16 tiles and none of them may be cached from a damaged one.
extern "C" void splitWarning(j_common_ptr c, int level) {
  if (level >= 0) return; // trace messages
  auto* e = reinterpret_cast<SplitErrorMgr*>(c->err);
  if (!e->warned) (*c->err->format_message)(c, e->message);
  e->warned = true;
}

/** A growing malloc()ed output buffer whose pointer is valid at every moment (libjpeg's
 * jpeg_mem_dest frees a buffer it grew and leaves the caller's pointer dangling on an error). */
struct TileDest {
  jpeg_destination_mgr pub; // first
  unsigned char* data;
  std::size_t capacity;
  std::size_t size; // after term_destination
};

extern "C" void tileDestInit(j_compress_ptr c) {
  auto* d = reinterpret_cast<TileDest*>(c->dest);
  d->pub.next_output_byte = d->data;
  d->pub.free_in_buffer = d->capacity;
}

extern "C" boolean tileDestEmpty(j_compress_ptr c) {
  auto* d = reinterpret_cast<TileDest*>(c->dest);
  const std::size_t grown = d->capacity * 2;
  auto* bigger = static_cast<unsigned char*>(std::realloc(d->data, grown));
  if (!bigger) { // libjpeg's ERREXIT1, without its C casts
    c->err->msg_code = JERR_OUT_OF_MEMORY;
    c->err->msg_parm.i[0] = 10;
    (*c->err->error_exit)(reinterpret_cast<j_common_ptr>(c));
  }
  d->data = bigger;
  d->pub.next_output_byte = d->data + d->capacity; // the whole old buffer was full
  d->pub.free_in_buffer = grown - d->capacity;
  d->capacity = grown;
  return TRUE;
}

extern "C" void tileDestTerm(j_compress_ptr c) {
  auto* d = reinterpret_cast<TileDest*>(c->dest);
  d->size = d->capacity - d->pub.free_in_buffer;
}

enum class Result { Ok, Invalid, NotAligned };

/** Writes the tile at (tr, tc) of `src`'s coefficients into `d`: the source's quantisation
 * tables and sampling, its blocks copied into virtual arrays of the tile's size. Called inside
 * splitRaw's libjpeg error scope (no object with a destructor lives here). */
void writeTile(jpeg_decompress_struct& src,
               jvirt_barray_ptr* srcArrays,
               jpeg_compress_struct& dst,
               TileDest& dest,
               int tr,
               int tc,
               int tileWidth,
               int tileHeight,
               bool optimize) {
  TileDest* d = &dest;
  // max_*_samp_factor are set by jpeg_read_header; the iMCU is 8 x 8 blocks of the largest factor.
  const int mcuW = src.max_h_samp_factor * DCTSIZE;
  const int mcuH = src.max_v_samp_factor * DCTSIZE;
  d->pub.init_destination = tileDestInit;
  d->pub.empty_output_buffer = tileDestEmpty;
  d->pub.term_destination = tileDestTerm;
  dst.dest = &d->pub;
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

/** Reads the coefficients of `data` once, then writes each of the cols x rows tiles into
 * dests[i] (the caller allocated their first buffers). */
Result splitRaw(const unsigned char* data,
                unsigned long size,
                int cols,
                int rows,
                int tileWidth,
                int tileHeight,
                bool optimize,
                TileDest* dests,
                char* message) {
  jpeg_decompress_struct src;
  jpeg_compress_struct dst;
  std::memset(&src, 0, sizeof src); // mem == nullptr: jpeg_destroy_* is a no-op until created
  std::memset(&dst, 0, sizeof dst);
  SplitErrorMgr err;
  src.err = jpeg_std_error(&err.mgr);
  dst.err = &err.mgr;
  err.mgr.error_exit = splitErrorExit;
  err.mgr.emit_message = splitWarning;
  err.message[0] = '\0';
  err.warned = false;
  if (setjmp(err.jump)) {
    jpeg_destroy_compress(&dst);
    jpeg_destroy_decompress(&src);
    std::memcpy(message, err.message, sizeof err.message);
    return Result::Invalid;
  }
  jpeg_create_decompress(&src);
  jpeg_create_compress(&dst);
  jpeg_mem_src(&src, data, size);
  jpeg_read_header(&src, TRUE);
  if (static_cast<long>(src.image_width) != static_cast<long>(cols) * tileWidth ||
      static_cast<long>(src.image_height) != static_cast<long>(rows) * tileHeight) {
    std::snprintf(message,
                  JMSG_LENGTH_MAX,
                  "JPEG is %ux%u, expected %ldx%ld",
                  src.image_width,
                  src.image_height,
                  static_cast<long>(cols) * tileWidth,
                  static_cast<long>(rows) * tileHeight);
    jpeg_destroy_compress(&dst);
    jpeg_destroy_decompress(&src);
    return Result::Invalid;
  }
  const bool usable = src.data_precision == 8 &&
                      ((src.num_components == 1 && src.jpeg_color_space == JCS_GRAYSCALE) ||
                       (src.num_components == 3 && src.jpeg_color_space == JCS_YCbCr));
  // max_*_samp_factor are set by jpeg_read_header; the iMCU is 8 x 8 blocks of the largest factor.
  const int mcuW = src.max_h_samp_factor * DCTSIZE;
  const int mcuH = src.max_v_samp_factor * DCTSIZE;
  if (!usable || !jpegTilesAligned(tileWidth, tileHeight, mcuW, mcuH)) {
    jpeg_destroy_compress(&dst);
    jpeg_destroy_decompress(&src);
    return Result::NotAligned;
  }
  jvirt_barray_ptr* srcArrays = jpeg_read_coefficients(&src); // every block entropy-decoded
  if (err.warned) {
    std::memcpy(message, err.message, sizeof err.message);
    jpeg_destroy_compress(&dst);
    jpeg_destroy_decompress(&src);
    return Result::Invalid;
  }
  for (int tr = 0; tr < rows; ++tr) {
    for (int tc = 0; tc < cols; ++tc)
      writeTile(
          src, srcArrays, dst, dests[tr * cols + tc], tr, tc, tileWidth, tileHeight, optimize);
  }
  jpeg_finish_decompress(&src);
  const bool warned = err.warned;
  if (warned) std::memcpy(message, err.message, sizeof err.message);
  jpeg_destroy_compress(&dst);
  jpeg_destroy_decompress(&src);
  return warned ? Result::Invalid : Result::Ok;
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
  std::vector<TileDest> dests(count);
  for (auto& d : dests) {
    std::memset(&d, 0, sizeof d);
    d.data = static_cast<unsigned char*>(std::malloc(guess));
    d.capacity = d.data ? guess : 0;
  }
  auto freeAll = [&] {
    for (auto& d : dests)
      std::free(d.data);
  };
  for (const auto& d : dests) {
    if (!d.data) {
      freeAll();
      return std::unexpected(JpegSplitError{JpegSplitErrc::Invalid, "out of memory"});
    }
  }
  char message[JMSG_LENGTH_MAX] = {};
  const Result r = splitRaw(reinterpret_cast<const unsigned char*>(jpeg.data()),
                            static_cast<unsigned long>(jpeg.size()),
                            cols,
                            rows,
                            tileWidth,
                            tileHeight,
                            optimizeHuffman,
                            dests.data(),
                            message);
  if (r != Result::Ok) {
    freeAll();
    if (r == Result::NotAligned)
      return std::unexpected(
          JpegSplitError{JpegSplitErrc::NotAligned, "tile edges are not on iMCU boundaries"});
    const std::string text(message);
    return std::unexpected(
        JpegSplitError{JpegSplitErrc::Invalid,
                       text.starts_with("JPEG is ") ? text : "JPEG does not decode: " + text});
  }
  std::vector<std::vector<std::byte>> tiles;
  tiles.reserve(count);
  for (const auto& d : dests) {
    const auto* b = reinterpret_cast<const std::byte*>(d.data);
    tiles.emplace_back(b, b + d.size);
  }
  freeAll();
  return tiles;
}

} // namespace tellus::codec
