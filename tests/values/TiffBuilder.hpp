#pragma once
// Test helper: writes small one-band TIFFs (either byte order, strips or tiles, raw or Deflate,
// with or without the horizontal predictor) so that the values module's reader is checked against
// files whose every byte the test knows. Not a general TIFF writer.

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>
#include <zlib.h>

namespace tellus::values::test {

struct TiffSpec {
  bool little = true;
  int width = 4, height = 3;
  int bits = 16;        // 16 or 32
  int sampleFormat = 2; // 1 uint, 2 int, 3 float
  int compression = 1;  // 1 none, 8 Deflate
  int predictor = 1;    // 1 none, 2 horizontal
  int rowsPerStrip = 2; // strips (when tileWidth == 0)
  int tileWidth = 0, tileHeight = 0;
  int samplesPerPixel = 1;
};

class TiffBuilder {
public:
  explicit TiffBuilder(TiffSpec spec) : s_(spec) {}

  /** samples: width * height raw sample bit patterns (uint16 or the float's uint32 bits). */
  std::vector<std::byte> build(const std::vector<std::uint32_t>& samples) {
    out_.assign(8, std::byte{0});
    out_[0] = out_[1] = std::byte(s_.little ? 'I' : 'M');
    put16(2, 42);
    std::vector<std::uint32_t> offsets, counts;
    const bool tiled = s_.tileWidth > 0;
    const int bw = tiled ? s_.tileWidth : s_.width;
    const int bh = tiled ? s_.tileHeight : s_.rowsPerStrip;
    for (int y0 = 0; y0 < s_.height; y0 += bh)
      for (int x0 = 0; x0 < s_.width; x0 += bw) {
        const int rows = tiled ? bh : std::min(bh, s_.height - y0);
        std::vector<std::byte> block = blockBytes(samples, x0, y0, bw, rows);
        offsets.push_back(static_cast<std::uint32_t>(out_.size()));
        counts.push_back(static_cast<std::uint32_t>(block.size()));
        out_.insert(out_.end(), block.begin(), block.end());
      }
    const std::uint32_t offArray = appendArray(offsets), cntArray = appendArray(counts);
    const auto ifd = static_cast<std::uint32_t>(out_.size());
    put32(4, ifd);
    std::vector<std::array<std::uint32_t, 4>> e = {{256, 4, 1, std::uint32_t(s_.width)},
                                                   {257, 4, 1, std::uint32_t(s_.height)},
                                                   {258, 3, 1, std::uint32_t(s_.bits)},
                                                   {259, 3, 1, std::uint32_t(s_.compression)},
                                                   {262, 3, 1, 1},
                                                   {277, 3, 1, std::uint32_t(s_.samplesPerPixel)},
                                                   {317, 3, 1, std::uint32_t(s_.predictor)},
                                                   {339, 3, 1, std::uint32_t(s_.sampleFormat)}};
    const auto n = static_cast<std::uint32_t>(offsets.size());
    if (tiled) {
      e.push_back({322, 4, 1, std::uint32_t(s_.tileWidth)});
      e.push_back({323, 4, 1, std::uint32_t(s_.tileHeight)});
      e.push_back({324, 4, n, n == 1 ? offsets[0] : offArray});
      e.push_back({325, 4, n, n == 1 ? counts[0] : cntArray});
    } else {
      e.push_back({273, 4, n, n == 1 ? offsets[0] : offArray});
      e.push_back({278, 4, 1, std::uint32_t(s_.rowsPerStrip)});
      e.push_back({279, 4, n, n == 1 ? counts[0] : cntArray});
    }
    std::sort(e.begin(), e.end());
    append16(static_cast<std::uint16_t>(e.size()));
    for (const auto& entry : e) {
      append16(static_cast<std::uint16_t>(entry[0]));
      append16(static_cast<std::uint16_t>(entry[1]));
      append32(entry[2]);
      if (entry[1] == 3 && entry[2] == 1) {
        append16(static_cast<std::uint16_t>(entry[3]));
        append16(0);
      } else {
        append32(entry[3]);
      }
    }
    append32(0);
    return out_;
  }

  /** Where the IFD starts (after build). */
  std::uint32_t ifdOffset() const {
    const auto b = [&](int i) { return std::to_integer<std::uint32_t>(out_[std::size_t(i)]); };
    return s_.little ? b(4) | b(5) << 8 | b(6) << 16 | b(7) << 24
                     : b(7) | b(6) << 8 | b(5) << 16 | b(4) << 24;
  }

private:
  std::vector<std::byte>
  blockBytes(const std::vector<std::uint32_t>& samples, int x0, int y0, int bw, int bh) {
    std::vector<std::byte> raw;
    const int size = s_.bits / 8;
    for (int y = 0; y < bh; ++y) {
      std::uint32_t previous = 0;
      for (int x = 0; x < bw; ++x) {
        const int px = x0 + x, py = y0 + y;
        std::uint32_t v = px < s_.width && py < s_.height
                              ? samples[std::size_t(py) * std::size_t(s_.width) + std::size_t(px)]
                              : 0;
        const std::uint32_t original = v;
        if (s_.predictor == 2 && x > 0) v = (v - previous) & 0xFFFF;
        previous = original;
        for (int k = 0; k < size; ++k) {
          const int shift = s_.little ? 8 * k : 8 * (size - 1 - k);
          raw.push_back(std::byte((v >> shift) & 0xFF));
        }
      }
    }
    if (s_.compression != 8) return raw;
    uLongf n = compressBound(static_cast<uLong>(raw.size()));
    std::vector<std::byte> packed(n);
    compress(reinterpret_cast<Bytef*>(packed.data()),
             &n,
             reinterpret_cast<const Bytef*>(raw.data()),
             static_cast<uLong>(raw.size()));
    packed.resize(n);
    return packed;
  }
  std::uint32_t appendArray(const std::vector<std::uint32_t>& v) {
    const auto at = static_cast<std::uint32_t>(out_.size());
    for (auto x : v)
      append32(x);
    return at;
  }
  void put16(std::size_t at, std::uint16_t v) {
    out_[at] = std::byte(s_.little ? v & 0xFF : v >> 8);
    out_[at + 1] = std::byte(s_.little ? v >> 8 : v & 0xFF);
  }
  void put32(std::size_t at, std::uint32_t v) {
    put16(at + (s_.little ? 0 : 2), static_cast<std::uint16_t>(v & 0xFFFF));
    put16(at + (s_.little ? 2 : 0), static_cast<std::uint16_t>(v >> 16));
  }
  void append16(std::uint16_t v) {
    out_.resize(out_.size() + 2);
    put16(out_.size() - 2, v);
  }
  void append32(std::uint32_t v) {
    out_.resize(out_.size() + 4);
    put32(out_.size() - 4, v);
  }

  TiffSpec s_;
  std::vector<std::byte> out_;
};

} // namespace tellus::values::test
