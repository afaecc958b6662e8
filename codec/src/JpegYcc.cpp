// The planar (4:2:0 YCbCr) JPEG paths of the composer. Every libjpeg call runs inside the one
// error wrapper (JpegSession.hpp): the functions given to run() keep no object with a non-trivial
// destructor (the storage they use belongs to their callers).
//
// Decoding a region: libjpeg-turbo's jpeg_crop_scanline and jpeg_skip_scanlines (which decode only
// the iMCU columns around a region and only entropy-decode the rows above it) are refused in raw
// data mode, and decoding whole tiles instead costs more than the colour conversion saved (tiles
// at the edge of a map are sampled in part). So a region is decoded in scanline mode set up to need
// no context rows (no fancy up-sampling, YCbCr out): crop and skip there, then the decompressor is
// switched to raw data output (raw_data_out and the state jpeg_start_decompress would have left in
// raw mode), and jpeg_read_raw_data hands out the coefficient controller's blocks of the cropped
// columns. That relies on how libjpeg-turbo 2.1 (Debian 12) is built inside: the coefficient
// controller is the same in both modes and reads its columns from first_iMCU_col/last_iMCU_col,
// which jpeg_crop_scanline sets. TestJpegYcc checks region decodes against whole decodes, so a
// libjpeg-turbo that behaves otherwise fails the tests rather than making wrong maps.

#include "JpegSession.hpp"

#include <tellus/codec/JpegYcc.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <optional>

namespace tellus::codec {

using detail::JpegCompress;
using detail::JpegDecompress;
using detail::JpegErrors;
using detail::JpegVectorDestination;

namespace {

// jpegint.h's value (not in jpeglib.h): the state jpeg_start_decompress leaves in raw data mode.
constexpr int kStateRawOk = 206;

bool is420(const jpeg_decompress_struct& c) noexcept {
  return c.num_components == 3 && c.jpeg_color_space == JCS_YCbCr && !c.progressive_mode &&
         c.comp_info[0].h_samp_factor == 2 && c.comp_info[0].v_samp_factor == 2 &&
         c.comp_info[1].h_samp_factor == 1 && c.comp_info[1].v_samp_factor == 1 &&
         c.comp_info[2].h_samp_factor == 1 && c.comp_info[2].v_samp_factor == 1;
}

/** The rows and columns of a region decode: whole 16 x 16 blocks from (x0, top), `width`
 * columns, down to row y1 (the whole tile without a region). */
struct Crop {
  JDIMENSION x0 = 0, width = 0, top = 0, y1 = 0;
};

Crop cropOf(int width, int height, const std::array<std::int32_t, 4>* region) {
  Crop c{0, static_cast<JDIMENSION>(width), 0, static_cast<JDIMENSION>(height)};
  if (!region) return c;
  const auto& r = *region;
  const auto left = std::clamp(r[0], 0, width - 1) / 16 * 16;
  const auto right = std::clamp(r[2], left + 1, width);
  c.top = static_cast<JDIMENSION>(std::clamp(r[1], 0, height - 1) / 16 * 16);
  c.y1 = static_cast<JDIMENSION>(std::clamp(r[3], static_cast<int>(c.top) + 1, height));
  c.x0 = static_cast<JDIMENSION>(left);
  c.width = static_cast<JDIMENSION>(right - left);
  return c;
}

/** The raw-data rows of a started decompressor (cropped and skipped to `c`) into the planes, down
 * to c.y1; runs inside decodeRaw's run. */
void readRawRows(jpeg_decompress_struct& d,
                 const Crop& c,
                 std::uint8_t* y,
                 std::uint8_t* cb,
                 std::uint8_t* cr,
                 std::size_t strideY,
                 std::size_t strideC) {
  JSAMPROW rowsY[16], rowsCb[8], rowsCr[8];
  JSAMPARRAY planes[3] = {rowsY, rowsCb, rowsCr};
  while (d.output_scanline < c.y1) {
    const std::size_t s = d.output_scanline;
    for (std::size_t i = 0; i < 16; ++i)
      rowsY[i] = y + (s + i) * strideY + c.x0;
    for (std::size_t i = 0; i < 8; ++i) {
      rowsCb[i] = cb + (s / 2 + i) * strideC + c.x0 / 2;
      rowsCr[i] = cr + (s / 2 + i) * strideC + c.x0 / 2;
    }
    if (jpeg_read_raw_data(&d, planes, 16) != 16) break;
  }
  if (d.output_scanline < d.output_height) {
    jpeg_abort_decompress(&d);
  } else {
    jpeg_finish_decompress(&d);
  }
}

/** `strideY` and `strideC`: the samples from one row of the luma or a chroma plane to the next. */
YccDecode decodeRaw(const unsigned char* bytes,
                    std::size_t size,
                    int width,
                    int height,
                    const std::array<std::int32_t, 4>* region,
                    std::uint8_t* y,
                    std::uint8_t* cb,
                    std::uint8_t* cr,
                    std::size_t strideY,
                    std::size_t strideC,
                    std::string& message) {
  JpegErrors err;
  JpegDecompress d(err);
  bool multipleScans = false;
  if (!err.run([&] {
        d.create();
        d.source(bytes, size);
        jpeg_read_header(d.get(), TRUE);
        multipleScans = jpeg_has_multiple_scans(d.get()) != FALSE;
      })) {
    message = err.message();
    return YccDecode::Failed;
  }
  if (static_cast<int>(d->image_width) != width || static_cast<int>(d->image_height) != height ||
      !is420(*d.get()) || multipleScans)
    return YccDecode::NotYcc420;
  d->out_color_space = JCS_YCbCr;
  d->do_fancy_upsampling = FALSE; // no context rows: skipping whole iMCU rows is simple
  d->do_block_smoothing = FALSE;
  Crop c = cropOf(width, height, region);
  if (!err.run([&] {
        jpeg_start_decompress(d.get());
        if (c.width < static_cast<JDIMENSION>(width)) jpeg_crop_scanline(d.get(), &c.x0, &c.width);
        if (c.top > 0) jpeg_skip_scanlines(d.get(), c.top);
      })) {
    message = err.message();
    return YccDecode::Failed;
  }
  if (d->output_scanline != c.top || c.x0 % 16 != 0) // not what this code expects of libjpeg
    return YccDecode::NotYcc420;
  d->raw_data_out = TRUE;
  d->global_state = kStateRawOk;
  if (!err.run([&] { readRawRows(*d.get(), c, y, cb, cr, strideY, strideC); })) {
    message = err.message();
    return YccDecode::Failed;
  }
  return YccDecode::Ok;
}

std::uint32_t be16(const unsigned char* p) noexcept {
  return static_cast<std::uint32_t>(p[0]) << 8 | p[1];
}

/** What spliceRegion made: a JPEG of the segments around the region, and where its samples go. */
struct Spliced {
  std::vector<unsigned char> bytes;
  int width = 0, height = 0; ///< of the spliced image
  int x = 0, y = 0;          ///< its top-left texel in the tile
};

/** Where a baseline JPEG's frame header (SOF0/1) and its first scan's data are, and its restart
 * interval (0: none). */
struct StreamLayout {
  std::size_t sof = 0, data = 0;
  std::uint32_t interval = 0;
};

/** The segments up to the (first) scan; nullopt for a stream this path does not take
 * (progressive, lossless, arithmetic, not one interleaved scan, damaged). */
std::optional<StreamLayout> readLayout(const unsigned char* p, std::size_t n) {
  if (n < 4 || p[0] != 0xFF || p[1] != 0xD8) return std::nullopt;
  StreamLayout l;
  std::size_t at = 2;
  while (at + 4 <= n) {
    if (p[at] != 0xFF) return std::nullopt;
    const unsigned char m = p[at + 1];
    if (m == 0xFF) { // fill byte
      ++at;
      continue;
    }
    const std::size_t len = be16(p + at + 2);
    if (len < 2 || at + 2 + len > n) return std::nullopt;
    if (m == 0xC0 || m == 0xC1) {
      if (len < 8) return std::nullopt;
      l.sof = at;
    } else if ((m >= 0xC2 && m <= 0xCF && m != 0xC4 && m != 0xC8 && m != 0xCC)) {
      return std::nullopt; // progressive, lossless, arithmetic: not this path
    } else if (m == 0xDD) {
      if (len != 4) return std::nullopt;
      l.interval = be16(p + at + 4);
    } else if (m == 0xDA) {
      if (len < 3 || p[at + 4] != 3) return std::nullopt; // not one interleaved scan
      l.data = at + 2 + len;
      break;
    }
    at += 2 + len;
  }
  return l;
}

/** The starts of the first `needed` segments of the scan at `data` (in `starts`, the markers
 * found on the way checked for their order) and the end of the last; 0 when they are not all
 * there. */
std::size_t segmentStarts(const unsigned char* p,
                          std::size_t n,
                          std::size_t data,
                          std::size_t needed,
                          std::vector<std::uint32_t>& starts) {
  starts.clear();
  starts.push_back(static_cast<std::uint32_t>(data));
  std::size_t endOfLast = 0;
  for (std::size_t i = data; i + 1 < n;) {
    const void* ff = std::memchr(p + i, 0xFF, n - 1 - i);
    if (!ff) return 0;
    i = static_cast<std::size_t>(static_cast<const unsigned char*>(ff) - p);
    const unsigned char m = p[i + 1];
    if (m == 0x00) {
      i += 2;
      continue;
    }
    if (m >= 0xD0 && m <= 0xD7) {
      if (static_cast<std::size_t>(m) != 0xD0 + (starts.size() - 1) % 8)
        return 0; // markers out of order
      if (starts.size() == needed) {
        endOfLast = i;
        break;
      }
      starts.push_back(static_cast<std::uint32_t>(i + 2));
      i += 2;
      continue;
    }
    if (m == 0xD9 && starts.size() == needed) endOfLast = i;
    break; // EOI (or anything else) ends the search
  }
  return starts.size() == needed ? endOfLast : 0;
}

/**
 * The fast path for a tile with restart markers: a baseline JPEG whose restart interval divides its
 * rows of 16 x 16 MCUs is a grid of independent segments (the DC predictions start again at each
 * marker), so the segments around a region, copied into a JPEG of their own (the same tables, the
 * size in the SOF changed, the markers renumbered), decode to exactly the tile's blocks there,
 * without entropy-decoding the rows above the region and the columns beside it (which a decoder of
 * the whole stream must). False (and the caller decodes the tile as it is) for any other stream:
 * no restart interval, one that does not divide the rows, several scans, markers it does not
 * expect, a region that needs every segment anyway.
 */
bool spliceRegion(const unsigned char* p,
                  std::size_t n,
                  int width,
                  int height,
                  const std::array<std::int32_t, 4>& region,
                  Spliced& out) {
  const auto layout = readLayout(p, n);
  if (!layout) return false;
  const auto [sof, data, interval] = *layout;
  // Three components at 4:2:0 (16 x 16 MCUs): the segments' geometry below.
  if (!sof || !data || interval == 0 || be16(p + sof + 2) < 17 || p[sof + 9] != 3 ||
      p[sof + 11] != 0x22 || p[sof + 14] != 0x11 || p[sof + 17] != 0x11)
    return false;
  if (static_cast<int>(be16(p + sof + 5)) != height || static_cast<int>(be16(p + sof + 7)) != width)
    return false;
  const std::uint32_t mcuCols = static_cast<std::uint32_t>(width) / 16;
  const std::uint32_t mcuRows = static_cast<std::uint32_t>(height) / 16;
  if (mcuCols % interval != 0) return false;
  const std::uint32_t segCols = mcuCols / interval;
  const auto segPx = static_cast<int>(interval) * 16;
  const int left = std::clamp(region[0], 0, width - 1);
  const int top = std::clamp(region[1], 0, height - 1);
  const auto x0 = static_cast<std::uint32_t>(left / segPx);
  const auto x1 =
      static_cast<std::uint32_t>((std::clamp(region[2], left + 1, width) + segPx - 1) / segPx);
  const auto y0 = static_cast<std::uint32_t>(top / 16);
  const auto y1 = static_cast<std::uint32_t>((std::clamp(region[3], top + 1, height) + 15) / 16);
  if (x0 >= x1 || y0 >= y1 || x1 > segCols || y1 > mcuRows) return false;
  if (x0 == 0 && x1 == segCols && y0 == 0) return false; // whole rows from the top: no gain
  // The segments' starts, up to the last row the region needs.
  const std::size_t needed = static_cast<std::size_t>(y1) * segCols;
  thread_local std::vector<std::uint32_t> starts;
  const std::size_t endOfLast = segmentStarts(p, n, data, needed, starts);
  if (endOfLast == 0) return false;
  const auto segEnd = [&](std::size_t s) -> std::size_t {
    return s + 1 < needed ? starts[s + 1] - 2 : endOfLast;
  };
  // The tables as they are, the size in the SOF changed, the segments with their markers
  // renumbered.
  out.bytes.clear();
  out.bytes.insert(out.bytes.end(), p, p + data);
  out.width = static_cast<int>((x1 - x0) * interval * 16);
  out.height = static_cast<int>((y1 - y0) * 16);
  out.x = static_cast<int>(x0 * interval * 16);
  out.y = static_cast<int>(y0 * 16);
  out.bytes[sof + 5] = static_cast<unsigned char>(out.height >> 8);
  out.bytes[sof + 6] = static_cast<unsigned char>(out.height);
  out.bytes[sof + 7] = static_cast<unsigned char>(out.width >> 8);
  out.bytes[sof + 8] = static_cast<unsigned char>(out.width);
  std::uint32_t k = 0;
  for (std::uint32_t r = y0; r < y1; ++r) {
    for (std::uint32_t c = x0; c < x1; ++c) {
      if (k > 0) {
        out.bytes.push_back(0xFF);
        out.bytes.push_back(static_cast<unsigned char>(0xD0 + (k - 1) % 8));
      }
      const std::size_t s = static_cast<std::size_t>(r) * segCols + c;
      out.bytes.insert(out.bytes.end(), p + starts[s], p + segEnd(s));
      ++k;
    }
  }
  out.bytes.push_back(0xFF);
  out.bytes.push_back(0xD9);
  return true;
}

/** Writes the planes' rows into a started raw-data compressor; `scratch` holds 16 luma and 2 x 8
 * chroma rows of the padded widths (used when the planes' widths are not whole blocks). Runs
 * inside encodeRaw's run. */
void writePlanes(jpeg_compress_struct& cinfo,
                 int width,
                 int height,
                 const std::uint8_t* y,
                 const std::uint8_t* cb,
                 const std::uint8_t* cr,
                 std::uint8_t* scratch) {
  const auto w = static_cast<std::size_t>(width);
  const auto h = static_cast<std::size_t>(height);
  const std::size_t cw = (w + 1) / 2, ch = (h + 1) / 2;
  // What libjpeg reads per row: whole 8-sample blocks of each component.
  const std::size_t padY = (w + 7) / 8 * 8, padC = (w + 15) / 16 * 8;
  std::uint8_t* scratchY = scratch;
  std::uint8_t* scratchC = scratch + 16 * padY;
  JSAMPROW rowsY[16], rowsCb[8], rowsCr[8];
  JSAMPARRAY planes[3] = {rowsY, rowsCb, rowsCr};
  const auto row = [](const std::uint8_t* plane,
                      std::size_t rowIndex,
                      std::size_t rows,
                      std::size_t samples,
                      std::size_t padded,
                      std::uint8_t* spare) -> JSAMPROW {
    const std::uint8_t* src = plane + std::min(rowIndex, rows - 1) * samples;
    if (padded == samples) return const_cast<JSAMPROW>(src);
    std::memcpy(spare, src, samples);
    std::memset(spare + samples, src[samples - 1], padded - samples);
    return spare;
  };
  while (cinfo.next_scanline < cinfo.image_height) {
    const std::size_t s = cinfo.next_scanline;
    for (std::size_t i = 0; i < 16; ++i)
      rowsY[i] = row(y, s + i, h, w, padY, scratchY + i * padY);
    for (std::size_t i = 0; i < 8; ++i) {
      rowsCb[i] = row(cb, s / 2 + i, ch, cw, padC, scratchC + i * padC);
      rowsCr[i] = row(cr, s / 2 + i, ch, cw, padC, scratchC + (8 + i) * padC);
    }
    jpeg_write_raw_data(&cinfo, planes, 16);
  }
}

/** The libjpeg part of encodeJpegYcc, into `out` (sized to a first guess). */
bool encodeRaw(int width,
               int height,
               const std::uint8_t* y,
               const std::uint8_t* cb,
               const std::uint8_t* cr,
               int quality,
               std::uint8_t* scratch,
               std::vector<std::byte>& out,
               std::string& message) {
  JpegErrors err;
  JpegCompress c(err);
  JpegVectorDestination dest(out);
  if (err.run([&] {
        c.create();
        dest.attach(c.get());
        c->image_width = static_cast<JDIMENSION>(width);
        c->image_height = static_cast<JDIMENSION>(height);
        c->input_components = 3;
        c->in_color_space = JCS_YCbCr;
        jpeg_set_defaults(c.get()); // 4:2:0 for YCbCr, as for RGB
        jpeg_set_quality(c.get(), std::clamp(quality, 1, 100), TRUE);
        c->raw_data_in = TRUE;
        jpeg_start_compress(c.get(), TRUE);
        writePlanes(*c.get(), width, height, y, cb, cr, scratch);
        jpeg_finish_compress(c.get());
      }))
    return true;
  message = err.message();
  return false;
}

std::uint8_t clampRound(double v) noexcept {
  return static_cast<std::uint8_t>(std::clamp(std::lround(v), 0L, 255L));
}

} // namespace

YccDecode decodeJpegYcc(std::span<const std::byte> bytes,
                        int width,
                        int height,
                        const std::array<std::int32_t, 4>* region,
                        std::uint8_t* y,
                        std::uint8_t* cb,
                        std::uint8_t* cr,
                        std::string& message) {
  if (width <= 0 || height <= 0 || width % 16 != 0 || height % 16 != 0) return YccDecode::NotYcc420;
  std::string text;
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
  const auto w = static_cast<std::size_t>(width);
  thread_local Spliced spliced;
  if (region && spliceRegion(data, bytes.size(), width, height, *region, spliced)) {
    // The region in the spliced image's texels, its samples written where the tile's go.
    const std::array<std::int32_t, 4> inside{(*region)[0] - spliced.x,
                                             (*region)[1] - spliced.y,
                                             (*region)[2] - spliced.x,
                                             (*region)[3] - spliced.y};
    const auto sx = static_cast<std::size_t>(spliced.x);
    const auto sy = static_cast<std::size_t>(spliced.y);
    const YccDecode status = decodeRaw(spliced.bytes.data(),
                                       spliced.bytes.size(),
                                       spliced.width,
                                       spliced.height,
                                       &inside,
                                       y + sy * w + sx,
                                       cb + sy / 2 * (w / 2) + sx / 2,
                                       cr + sy / 2 * (w / 2) + sx / 2,
                                       w,
                                       w / 2,
                                       text);
    if (status != YccDecode::Failed) {
      if (spliced.bytes.capacity() > (1u << 20)) spliced.bytes = {};
      return status;
    }
    // A stream this path misread: the whole stream's decoder says what is wrong with it.
  }
  const YccDecode status =
      decodeRaw(data, bytes.size(), width, height, region, y, cb, cr, w, w / 2, text);
  if (status == YccDecode::Failed) message = "the JPEG does not decode: " + text;
  return status;
}

bool decodesFromSegments(std::span<const std::byte> bytes,
                         int width,
                         int height,
                         const std::array<std::int32_t, 4>& region) {
  if (width <= 0 || height <= 0 || width % 16 != 0 || height % 16 != 0) return false;
  Spliced spliced;
  return spliceRegion(reinterpret_cast<const unsigned char*>(bytes.data()),
                      bytes.size(),
                      width,
                      height,
                      region,
                      spliced);
}

std::expected<std::vector<std::byte>, std::string> encodeJpegYcc(int width,
                                                                 int height,
                                                                 const std::uint8_t* y,
                                                                 const std::uint8_t* cb,
                                                                 const std::uint8_t* cr,
                                                                 int quality) {
  if (width <= 0 || height <= 0 || !y || !cb || !cr)
    return std::unexpected("bad image shape for JPEG");
  const auto w = static_cast<std::size_t>(width);
  const std::size_t padY = (w + 7) / 8 * 8, padC = (w + 15) / 16 * 8;
  std::vector<std::uint8_t> scratch(16 * padY + 16 * padC);
  // A first guess of the size (a quality 90 map of imagery is about 1 bit per pixel); grown by
  // doubling.
  std::vector<std::byte> out(std::max<std::size_t>(4096, w * static_cast<std::size_t>(height) / 6));
  std::string message;
  if (!encodeRaw(width, height, y, cb, cr, quality, scratch.data(), out, message))
    return std::unexpected("cannot encode JPEG: " + message);
  return out;
}

std::array<std::uint8_t, 3> rgbToYcc(std::uint8_t r, std::uint8_t g, std::uint8_t b) noexcept {
  return {clampRound(0.299 * r + 0.587 * g + 0.114 * b),
          clampRound(128.0 - 0.168735892 * r - 0.331264108 * g + 0.5 * b),
          clampRound(128.0 + 0.5 * r - 0.418687589 * g - 0.081312411 * b)};
}

} // namespace tellus::codec
