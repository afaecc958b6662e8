#include <tellus/proxy/RasterHeader.hpp>

#include <algorithm>
#include <array>
#include <cerrno>
#include <climits>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <initializer_list>
#include <system_error>
#include <vector>

namespace tellus {

const char* toString(SampleType type) noexcept {
  switch (type) {
  case SampleType::UInt8:
    return "uint8";
  case SampleType::Int8:
    return "int8";
  case SampleType::UInt16:
    return "uint16";
  case SampleType::Int16:
    return "int16";
  case SampleType::UInt32:
    return "uint32";
  case SampleType::Int32:
    return "int32";
  case SampleType::Float16:
    return "float16";
  case SampleType::Float32:
    return "float32";
  case SampleType::Float64:
    return "float64";
  case SampleType::Other:
    return "other";
  }
  return "other";
}

namespace {

using Result = std::expected<std::optional<RasterHeader>, std::string>;

/** Random access to the bytes of a file or a buffer. */
class Source {
public:
  Source() = default;
  Source(const Source&) = delete;
  Source& operator=(const Source&) = delete;
  virtual ~Source() = default;
  /** Exactly out.size() bytes at `offset`, or false when the source ends first. */
  virtual bool read(std::uint64_t offset, std::span<std::uint8_t> out) = 0;
};

class MemorySource final : public Source {
public:
  explicit MemorySource(std::span<const std::byte> bytes) noexcept : bytes_(bytes) {}
  bool read(std::uint64_t offset, std::span<std::uint8_t> out) override {
    if (offset > bytes_.size() || bytes_.size() - offset < out.size()) return false;
    if (!out.empty()) std::memcpy(out.data(), bytes_.data() + offset, out.size());
    return true;
  }

private:
  std::span<const std::byte> bytes_;
};

class FileSource final : public Source {
public:
  explicit FileSource(std::ifstream& in) noexcept : in_(in) {}
  bool read(std::uint64_t offset, std::span<std::uint8_t> out) override {
    if (offset > static_cast<std::uint64_t>(LLONG_MAX)) return false;
    in_.clear();
    if (!in_.seekg(static_cast<std::streamoff>(offset))) return false;
    in_.read(reinterpret_cast<char*>(out.data()), static_cast<std::streamsize>(out.size()));
    return in_.gcount() == static_cast<std::streamsize>(out.size());
  }

private:
  std::ifstream& in_;
};

std::uint32_t be16(const std::uint8_t* p) noexcept {
  return static_cast<std::uint32_t>(p[0]) << 8 | p[1];
}
std::uint32_t be32(const std::uint8_t* p) noexcept {
  return be16(p) << 16 | be16(p + 2);
}

std::unexpected<std::string> malformed(const char* format, const std::string& what) {
  return std::unexpected(std::string("malformed ") + format + " header: " + what);
}
std::unexpected<std::string> truncated(const char* format, const std::string& where) {
  return std::unexpected(std::string("truncated ") + format + " header (" + where + ")");
}

// ---- JPEG: markers up to the first SOFn (ITU T.81 B.1) ----

Result jpeg(Source& src) {
  std::uint64_t pos = 2; // after SOI
  for (;;) {
    // A marker is 0xFF (fill bytes may repeat it) and a code; libjpeg skips stray bytes before it.
    std::array<std::uint8_t, 1> b{};
    do {
      if (!src.read(pos++, b)) return truncated("JPEG", "no frame header before the end");
    } while (b[0] != 0xFF);
    do {
      if (!src.read(pos++, b)) return truncated("JPEG", "no frame header before the end");
    } while (b[0] == 0xFF);
    const std::uint8_t marker = b[0];
    if (marker == 0x00 || marker == 0x01 || (marker >= 0xD0 && marker <= 0xD8)) continue;
    if (marker == 0xD9 || marker == 0xDA)
      return malformed("JPEG", "image data before a frame header (SOFn)");
    std::array<std::uint8_t, 2> len{};
    if (!src.read(pos, len)) return truncated("JPEG", "segment length");
    const std::uint32_t length = be16(len.data());
    if (length < 2) return malformed("JPEG", "segment length " + std::to_string(length));
    const bool sof =
        marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
    if (!sof) {
      pos += length;
      continue;
    }
    std::array<std::uint8_t, 6> f{};
    if (length < 8)
      return malformed("JPEG", "frame header of " + std::to_string(length) + " bytes");
    if (!src.read(pos + 2, f)) return truncated("JPEG", "frame header");
    const unsigned precision = f[0];
    const auto height = static_cast<int>(be16(&f[1]));
    const auto width = static_cast<int>(be16(&f[3]));
    const unsigned components = f[5];
    if (width == 0) return malformed("JPEG", "width 0");
    if (components == 0) return malformed("JPEG", "no components");
    // Baseline, extended and progressive Huffman or arithmetic, 8-bit, grey or three components
    // (YCbCr or RGB, both decoded to RGB). Lossless, hierarchical, 12-bit, CMYK, and a height
    // given later (DNL) are left to the imaging module.
    const bool plain =
        marker == 0xC0 || marker == 0xC1 || marker == 0xC2 || marker == 0xC9 || marker == 0xCA;
    if (!plain || precision != 8 || (components != 1 && components != 3) || height == 0)
      return std::optional<RasterHeader>{};
    return RasterHeader{"JPEG", width, height, static_cast<int>(components), SampleType::UInt8};
  }
}

// ---- PNG: IHDR, then the chunks before IDAT (for tRNS) ----

Result png(Source& src) {
  std::array<std::uint8_t, 8 + 13 + 4> ihdr{};
  std::array<std::uint8_t, 8> chunk{};
  if (!src.read(8, chunk)) return truncated("PNG", "IHDR");
  if (std::memcmp(&chunk[4], "IHDR", 4) != 0 || be32(chunk.data()) != 13)
    return malformed("PNG", "the first chunk is not a 13-byte IHDR");
  if (!src.read(8, ihdr)) return truncated("PNG", "IHDR");
  const std::uint32_t w = be32(&ihdr[8]);
  const std::uint32_t h = be32(&ihdr[12]);
  const unsigned depth = ihdr[16];
  const unsigned colour = ihdr[17];
  if (w == 0 || h == 0 || w > INT_MAX || h > INT_MAX)
    return malformed("PNG", "size " + std::to_string(w) + "x" + std::to_string(h));
  const bool depthOk = colour == 0
                           ? (depth == 1 || depth == 2 || depth == 4 || depth == 8 || depth == 16)
                       : colour == 3 ? (depth == 1 || depth == 2 || depth == 4 || depth == 8)
                       : (colour == 2 || colour == 4 || colour == 6) ? (depth == 8 || depth == 16)
                                                                     : false;
  if (!depthOk) {
    return malformed("PNG",
                     "bit depth " + std::to_string(depth) + " with colour type " +
                         std::to_string(colour));
  }
  // A tRNS chunk becomes an alpha channel in the decoder; it must come before the image data.
  std::uint64_t pos = 8 + ihdr.size();
  for (;;) {
    if (!src.read(pos, chunk)) return truncated("PNG", "no image data");
    const std::uint32_t length = be32(chunk.data());
    if (length > 0x7FFFFFFFu) return malformed("PNG", "chunk length " + std::to_string(length));
    if (std::memcmp(&chunk[4], "IDAT", 4) == 0) break;
    if (std::memcmp(&chunk[4], "IEND", 4) == 0) return malformed("PNG", "no image data");
    if (std::memcmp(&chunk[4], "tRNS", 4) == 0) return std::optional<RasterHeader>{};
    pos += 8 + static_cast<std::uint64_t>(length) + 4;
  }
  if (colour == 3 || depth < 8) return std::optional<RasterHeader>{}; // expanded by the decoder
  const int channels = colour == 0 ? 1 : colour == 4 ? 2 : colour == 2 ? 3 : 4;
  return RasterHeader{"PNG",
                      static_cast<int>(w),
                      static_cast<int>(h),
                      channels,
                      depth == 16 ? SampleType::UInt16 : SampleType::UInt8};
}

// ---- TIFF: the first IFD of a classic TIFF (TIFF 6.0, section 2) ----

class Tiff {
public:
  Tiff(Source& src, bool littleEndian) noexcept : src_(src), little_(littleEndian) {}

  std::uint32_t u16(const std::uint8_t* p) const noexcept {
    return little_ ? static_cast<std::uint32_t>(p[1]) << 8 | p[0] : be16(p);
  }
  std::uint32_t u32(const std::uint8_t* p) const noexcept {
    return little_ ? u16(p + 2) << 16 | u16(p) : be32(p);
  }

  /** The unsigned values of an IFD entry (BYTE, SHORT or LONG), at most `maxCount` of them. */
  std::expected<std::vector<std::uint32_t>, std::string> values(const std::uint8_t* entry,
                                                                std::uint32_t maxCount) {
    const std::uint32_t tag = u16(entry);
    const std::uint32_t type = u16(entry + 2);
    const std::uint32_t count = u32(entry + 4);
    const std::size_t size = type == 1 ? 1 : type == 3 ? 2 : type == 4 ? 4 : 0;
    if (size == 0) {
      return malformed("TIFF", "tag " + std::to_string(tag) + " has type " + std::to_string(type));
    }
    if (count == 0 || count > maxCount) {
      return malformed("TIFF",
                       "tag " + std::to_string(tag) + " has " + std::to_string(count) + " values");
    }
    std::vector<std::uint8_t> raw(size * count);
    if (raw.size() <= 4) {
      std::memcpy(raw.data(), entry + 8, raw.size());
    } else if (!src_.read(u32(entry + 8), raw)) {
      return truncated("TIFF", "values of tag " + std::to_string(tag));
    }
    std::vector<std::uint32_t> out(count);
    for (std::size_t i = 0; i < count; ++i) {
      const std::uint8_t* p = &raw[i * size];
      out[i] = size == 1 ? p[0] : size == 2 ? u16(p) : u32(p);
    }
    return out;
  }

  Result header() {
    auto tags = readTags();
    if (!tags) return std::unexpected(tags.error());
    const Tags& t = *tags;
    if (!t.width || !t.height) return malformed("TIFF", "no ImageWidth or ImageLength");
    if (*t.width == 0 || *t.height == 0 || *t.width > INT_MAX || *t.height > INT_MAX) {
      return malformed("TIFF",
                       "size " + std::to_string(*t.width) + "x" + std::to_string(*t.height));
    }
    if (t.samples == 0 || t.samples > kMaxSamples)
      return malformed("TIFF", std::to_string(t.samples) + " samples per pixel");
    auto allSame = [](const std::vector<std::uint32_t>& v) {
      for (auto x : v)
        if (x != v.front()) return false;
      return true;
    };
    // Grey or RGB (with any extra samples, which decoders keep as channels). Palette, CMYK,
    // YCbCr, Lab, bilevel, mixed or odd sample sizes: the imaging module knows what they become.
    if (!t.photometric || *t.photometric > 2 || (*t.photometric == 2 && t.samples < 3) ||
        !allSame(t.bits) || !allSame(t.sampleFormat))
      return std::optional<RasterHeader>{};
    const auto type = sampleType(t.bits.front(), t.sampleFormat.front());
    if (!type) return std::optional<RasterHeader>{};
    return RasterHeader{"TIFF",
                        static_cast<int>(*t.width),
                        static_cast<int>(*t.height),
                        static_cast<int>(t.samples),
                        *type};
  }

private:
  static constexpr std::uint32_t kMaxSamples = 1024;

  /** The first IFD's tags that say what the pixels are. */
  struct Tags {
    std::optional<std::uint32_t> width;
    std::optional<std::uint32_t> height;
    std::optional<std::uint32_t> photometric;
    std::uint32_t samples = 1;                  // TIFF defaults
    std::vector<std::uint32_t> bits{1};         //
    std::vector<std::uint32_t> sampleFormat{1}; //
  };

  std::expected<Tags, std::string> readTags() {
    std::array<std::uint8_t, 4> b{};
    if (!src_.read(4, b)) return truncated("TIFF", "first IFD offset");
    const std::uint32_t ifd = u32(b.data());
    if (ifd < 8) return malformed("TIFF", "first IFD at offset " + std::to_string(ifd));
    std::array<std::uint8_t, 2> n{};
    if (!src_.read(ifd, n)) return truncated("TIFF", "IFD at offset " + std::to_string(ifd));
    const std::uint32_t entries = u16(n.data());
    if (entries == 0) return malformed("TIFF", "empty IFD");
    std::vector<std::uint8_t> dir(static_cast<std::size_t>(entries) * 12);
    if (!src_.read(static_cast<std::uint64_t>(ifd) + 2, dir)) {
      return truncated("TIFF", std::to_string(entries) + " IFD entries");
    }
    Tags t;
    for (std::uint32_t i = 0; i < entries; ++i) {
      const std::uint8_t* e = &dir[static_cast<std::size_t>(i) * 12];
      const std::uint32_t tag = u16(e);
      if (tag != 256 && tag != 257 && tag != 258 && tag != 262 && tag != 277 && tag != 339)
        continue;
      auto v = values(e, tag == 258 || tag == 339 ? kMaxSamples : 1);
      if (!v) return std::unexpected(v.error());
      switch (tag) {
      case 256:
        t.width = v->front();
        break;
      case 257:
        t.height = v->front();
        break;
      case 258:
        t.bits = std::move(*v);
        break;
      case 262:
        t.photometric = v->front();
        break;
      case 277:
        t.samples = v->front();
        break;
      default: // 339
        t.sampleFormat = std::move(*v);
        break;
      }
    }
    return t;
  }

  /** Bits per sample and SampleFormat (1 unsigned, 2 signed, 3 IEEE float) as a SampleType. */
  static std::optional<SampleType> sampleType(std::uint32_t bps, std::uint32_t fmt) {
    if (bps == 8 && fmt == 1) return SampleType::UInt8;
    if (bps == 8 && fmt == 2) return SampleType::Int8;
    if (bps == 16 && fmt == 1) return SampleType::UInt16;
    if (bps == 16 && fmt == 2) return SampleType::Int16;
    if (bps == 16 && fmt == 3) return SampleType::Float16;
    if (bps == 32 && fmt == 1) return SampleType::UInt32;
    if (bps == 32 && fmt == 2) return SampleType::Int32;
    if (bps == 32 && fmt == 3) return SampleType::Float32;
    if (bps == 64 && fmt == 3) return SampleType::Float64;
    return std::nullopt;
  }

  Source& src_;
  bool little_;
};

Result parse(Source& src) {
  std::array<std::uint8_t, 8> magic{};
  std::size_t have = magic.size();
  while (have > 0 && !src.read(0, std::span(magic).first(have)))
    --have;
  const auto starts = [&](std::initializer_list<std::uint8_t> m) {
    return have >= m.size() && std::equal(m.begin(), m.end(), magic.begin());
  };
  if (starts({0xFF, 0xD8})) return jpeg(src);
  if (starts({0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A})) return png(src);
  if (starts({'I', 'I', 42, 0}) || starts({'M', 'M', 0, 42}))
    return Tiff(src, magic[0] == 'I').header();
  return std::optional<RasterHeader>{}; // another format (BigTIFF included), or too short to tell
}

} // namespace

Result parseRasterHeader(std::span<const std::byte> bytes) {
  MemorySource src(bytes);
  return parse(src);
}

Result readRasterHeader(const std::filesystem::path& file) {
  std::error_code ec;
  const auto status = std::filesystem::status(file, ec);
  if (ec) return std::unexpected("cannot open " + file.string() + ": " + ec.message());
  if (!std::filesystem::is_regular_file(status))
    return std::unexpected("cannot open " + file.string() + ": not a regular file");
  std::ifstream in(file, std::ios::binary);
  if (!in) {
    const int err = errno;
    return std::unexpected("cannot open " + file.string() + ": " +
                           std::generic_category().message(err));
  }
  FileSource src(in);
  auto r = parse(src);
  if (!r) return std::unexpected(file.string() + ": " + r.error());
  return r;
}

} // namespace tellus
