// A small baseline TIFF reader for one-band value rasters (RawSamples.hpp says what it reads).
// Every offset is checked against the buffer before it is read; sizes are capped at kMaxSide.
#include "RawSamples.hpp"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <zlib.h>

namespace tellus::values::detail {

namespace {

using Error = std::unexpected<std::string>;

class Reader {
public:
  Reader(std::span<const std::byte> bytes, bool little) : bytes_(bytes), little_(little) {}

  bool has(std::uint64_t offset, std::uint64_t count) const noexcept {
    return offset <= bytes_.size() && count <= bytes_.size() - offset;
  }
  std::uint16_t u16(std::size_t at) const noexcept {
    const auto a = static_cast<unsigned>(bytes_[at]), b = static_cast<unsigned>(bytes_[at + 1]);
    return static_cast<std::uint16_t>(little_ ? a | (b << 8) : (a << 8) | b);
  }
  std::uint32_t u32(std::size_t at) const noexcept {
    const std::uint32_t lo = u16(at), hi = u16(at + 2);
    return little_ ? lo | (hi << 16) : (lo << 16) | hi;
  }
  std::span<const std::byte> bytes() const noexcept { return bytes_; }
  bool little() const noexcept { return little_; }

private:
  std::span<const std::byte> bytes_;
  bool little_;
};

struct Ifd {
  std::uint32_t width = 0, height = 0;
  std::uint32_t bits = 0, sampleFormat = 1, compression = 1, predictor = 1, samplesPerPixel = 1;
  std::uint32_t rowsPerStrip = std::numeric_limits<std::uint32_t>::max();
  std::uint32_t tileWidth = 0, tileHeight = 0;
  std::vector<std::uint32_t> offsets, counts;
  bool tiled = false;
};

/** The values of the IFD entry at `entry` (SHORT or LONG, at most 2^24 of them). */
std::expected<std::vector<std::uint32_t>, std::string> values(const Reader& r, std::size_t entry) {
  const std::uint16_t tag = r.u16(entry), type = r.u16(entry + 2);
  const std::uint32_t count = r.u32(entry + 4);
  const std::uint32_t size = type == 3 ? 2 : type == 4 ? 4 : 0;
  if (size == 0)
    return Error("the TIFF's tag " + std::to_string(tag) + " has type " + std::to_string(type) +
                 ", not SHORT or LONG");
  if (count > (1u << 24))
    return Error("the TIFF's tag " + std::to_string(tag) + " has too many values");
  const std::uint64_t total = std::uint64_t{count} * size;
  const std::uint64_t at = total <= 4 ? entry + 8 : r.u32(entry + 8);
  if (!r.has(at, total))
    return Error("the TIFF is truncated (tag " + std::to_string(tag) + " lies past the end)");
  std::vector<std::uint32_t> out(count);
  for (std::uint32_t i = 0; i < count; ++i) {
    const auto p = static_cast<std::size_t>(at + std::uint64_t{i} * size);
    out[i] = size == 2 ? r.u16(p) : r.u32(p);
  }
  return out;
}

std::expected<void, std::string> readEntry(const Reader& r, std::size_t entry, Ifd& ifd) {
  const std::uint16_t tag = r.u16(entry);
  static constexpr std::uint16_t kKnown[] = {
      256, 257, 258, 259, 273, 277, 278, 279, 317, 322, 323, 324, 325, 339};
  if (std::find(std::begin(kKnown), std::end(kKnown), tag) == std::end(kKnown)) return {};
  auto v = values(r, entry);
  if (!v) return Error(v.error());
  if (v->empty()) return Error("the TIFF's tag " + std::to_string(tag) + " has no value");
  const std::uint32_t first = v->front();
  if (tag == 258 && std::any_of(v->begin(), v->end(), [&](auto b) { return b != first; }))
    return Error("the TIFF's bands differ in bits per sample");
  switch (tag) {
  case 256:
    ifd.width = first;
    break;
  case 257:
    ifd.height = first;
    break;
  case 258:
    ifd.bits = first;
    break;
  case 259:
    ifd.compression = first;
    break;
  case 277:
    ifd.samplesPerPixel = first;
    break;
  case 278:
    ifd.rowsPerStrip = first;
    break;
  case 317:
    ifd.predictor = first;
    break;
  case 322:
    ifd.tileWidth = first;
    break;
  case 323:
    ifd.tileHeight = first;
    break;
  case 339:
    ifd.sampleFormat = first;
    break;
  case 273:
  case 324:
    ifd.offsets = std::move(*v), ifd.tiled = tag == 324;
    break;
  case 279:
  case 325:
    ifd.counts = std::move(*v);
    break;
  default:
    break;
  }
  return {};
}

std::expected<Ifd, std::string> readIfd(const Reader& r) {
  const std::uint32_t at = r.u32(4);
  if (!r.has(at, 2)) return Error("the TIFF is truncated (its directory lies past the end)");
  const std::uint16_t n = r.u16(at);
  // The entries and the next directory's 4-byte offset (read by nobody here, but part of it).
  if (!r.has(std::uint64_t{at} + 2, std::uint64_t{n} * 12 + 4))
    return Error("the TIFF is truncated (its directory has " + std::to_string(n) + " entries)");
  Ifd ifd;
  for (std::uint16_t i = 0; i < n; ++i)
    if (auto ok = readEntry(r, std::size_t{at} + 2 + std::size_t{i} * 12, ifd); !ok)
      return Error(ok.error());
  return ifd;
}

std::expected<Encoding, std::string> sampleType(const Ifd& ifd) {
  if (ifd.samplesPerPixel != 1)
    return Error("the TIFF has " + std::to_string(ifd.samplesPerPixel) +
                 " bands; only one-band TIFFs are supported");
  if (ifd.bits == 16 && ifd.sampleFormat == 2) return Encoding::Int16;
  if (ifd.bits == 16 && ifd.sampleFormat == 1) return Encoding::UInt16;
  if (ifd.bits == 32 && ifd.sampleFormat == 3) return Encoding::Float32;
  return Error("the TIFF's samples (" + std::to_string(ifd.bits) + " bits, SampleFormat " +
               std::to_string(ifd.sampleFormat) +
               ") are not supported; only Int16, UInt16 and Float32 are");
}

std::expected<void, std::string> checkLayout(const Ifd& ifd) {
  if (ifd.width == 0 || ifd.height == 0) return Error("the TIFF has no width or height");
  if (ifd.width > kMaxSide || ifd.height > kMaxSide)
    return Error("the TIFF is " + std::to_string(ifd.width) + " x " + std::to_string(ifd.height) +
                 ", larger than " + std::to_string(kMaxSide) + " pixels");
  if (ifd.compression != 1 && ifd.compression != 8 && ifd.compression != 32946)
    return Error("the TIFF's compression " + std::to_string(ifd.compression) +
                 (ifd.compression == 5   ? " (LZW)"
                  : ifd.compression == 7 ? " (JPEG)"
                                         : "") +
                 " is not supported; only none and Deflate are");
  if (ifd.predictor != 1 && ifd.predictor != 2)
    return Error("the TIFF's predictor " + std::to_string(ifd.predictor) +
                 " is not supported; only none and horizontal (2) are");
  if (ifd.tiled && (ifd.tileWidth == 0 || ifd.tileHeight == 0 || ifd.tileWidth > kMaxSide ||
                    ifd.tileHeight > kMaxSide))
    return Error("the TIFF's tiles have no size or are larger than " + std::to_string(kMaxSide));
  if (ifd.offsets.empty() || ifd.counts.size() != ifd.offsets.size())
    return Error("the TIFF has no strip or tile offsets, or not one byte count for each");
  return {};
}

struct Block {
  std::uint32_t x0, y0, w, h; // in pixels; w x h samples stored (tiles may pass the edges)
};

/** The block's bytes, decompressed when needed, exactly w * h * bytesPerSample of them. */
std::expected<std::span<const std::byte>, std::string> blockBytes(const Reader& r,
                                                                  const Ifd& ifd,
                                                                  std::size_t i,
                                                                  const Block& b,
                                                                  std::vector<std::byte>& scratch) {
  const std::uint64_t want = std::uint64_t{b.w} * b.h * (ifd.bits / 8);
  if (!r.has(ifd.offsets[i], ifd.counts[i]))
    return Error("the TIFF is truncated (block " + std::to_string(i) + " lies past the end)");
  const auto stored = r.bytes().subspan(ifd.offsets[i], ifd.counts[i]);
  if (ifd.compression == 1) {
    if (stored.size() < want)
      return Error("the TIFF is truncated (block " + std::to_string(i) + " has " +
                   std::to_string(stored.size()) + " bytes, not " + std::to_string(want) + ")");
    return stored.first(static_cast<std::size_t>(want));
  }
  // Deflate expands at most ~1032:1: a block claiming more is refused before any allocation.
  if (want > std::uint64_t{stored.size()} * 1032 + 64)
    return Error("the TIFF's Deflate block " + std::to_string(i) + " is too short for " +
                 std::to_string(want) + " bytes");
  scratch.resize(static_cast<std::size_t>(want));
  uLongf got = static_cast<uLongf>(want);
  const int rc = uncompress(reinterpret_cast<Bytef*>(scratch.data()),
                            &got,
                            reinterpret_cast<const Bytef*>(stored.data()),
                            static_cast<uLong>(stored.size()));
  if (rc != Z_OK || got != want)
    return Error("the TIFF's Deflate block " + std::to_string(i) + " is corrupt or not " +
                 std::to_string(want) + " bytes");
  return std::span<const std::byte>(scratch);
}

float sampleAt(const Reader& r,
               std::span<const std::byte> data,
               std::size_t k,
               Encoding type,
               std::uint32_t& previous,
               bool predictor,
               bool rowStart) {
  const Reader d(data, r.little());
  if (type == Encoding::Float32) return std::bit_cast<float>(d.u32(k * 4));
  std::uint32_t raw = d.u16(k * 2);
  if (predictor && !rowStart) raw = (raw + previous) & 0xFFFFu;
  previous = raw;
  if (type == Encoding::UInt16) return static_cast<float>(raw);
  return static_cast<float>(std::bit_cast<std::int16_t>(static_cast<std::uint16_t>(raw)));
}

void copyBlock(const Reader& r,
               const Ifd& ifd,
               std::span<const std::byte> data,
               const Block& b,
               RawSamples& out) {
  const bool predictor = ifd.predictor == 2 && out.encoding != Encoding::Float32;
  for (std::uint32_t y = 0; y < b.h; ++y) {
    std::uint32_t previous = 0;
    for (std::uint32_t x = 0; x < b.w; ++x) {
      const float v =
          sampleAt(r, data, std::size_t{y} * b.w + x, out.encoding, previous, predictor, x == 0);
      const std::uint32_t px = b.x0 + x, py = b.y0 + y;
      if (px < ifd.width && py < ifd.height) out.samples[std::size_t{py} * ifd.width + px] = v;
    }
  }
}

std::vector<Block> blocks(const Ifd& ifd) {
  std::vector<Block> out;
  if (ifd.tiled) {
    for (std::uint32_t y = 0; y < ifd.height; y += ifd.tileHeight)
      for (std::uint32_t x = 0; x < ifd.width; x += ifd.tileWidth)
        out.push_back({x, y, ifd.tileWidth, ifd.tileHeight});
    return out;
  }
  const std::uint32_t rows = std::clamp<std::uint32_t>(ifd.rowsPerStrip, 1, ifd.height);
  for (std::uint32_t y = 0; y < ifd.height; y += rows)
    out.push_back({0, y, ifd.width, std::min(rows, ifd.height - y)});
  return out;
}

} // namespace

std::expected<RawSamples, std::string> readTiff(std::span<const std::byte> bytes) {
  if (bytes.size() < 8) return Error("the TIFF is truncated (no header)");
  const auto b0 = static_cast<char>(bytes[0]), b1 = static_cast<char>(bytes[1]);
  if (!((b0 == 'I' && b1 == 'I') || (b0 == 'M' && b1 == 'M'))) return Error("not a TIFF");
  const Reader r(bytes, b0 == 'I');
  if (r.u16(2) == 43) return Error("the TIFF is a BigTIFF, which is not supported");
  if (r.u16(2) != 42) return Error("not a TIFF (no 42 after the byte order)");
  auto ifd = readIfd(r);
  if (!ifd) return Error(ifd.error());
  auto type = sampleType(*ifd);
  if (!type) return Error(type.error());
  if (auto ok = checkLayout(*ifd); !ok) return Error(ok.error());
  const std::vector<Block> parts = blocks(*ifd);
  if (ifd->offsets.size() < parts.size())
    return Error("the TIFF has " + std::to_string(ifd->offsets.size()) + " blocks, not " +
                 std::to_string(parts.size()));
  RawSamples out{static_cast<int>(ifd->width), static_cast<int>(ifd->height), *type, {}};
  out.samples.assign(std::size_t{ifd->width} * ifd->height, 0.0f);
  std::vector<std::byte> scratch;
  for (std::size_t i = 0; i < parts.size(); ++i) {
    auto data = blockBytes(r, *ifd, i, parts[i], scratch);
    if (!data) return Error(data.error());
    copyBlock(r, *ifd, *data, parts[i], out);
  }
  return out;
}

} // namespace tellus::values::detail
