#pragma once
// Pixels and files for the codec tests: textured test images, the bundled data, and a PNG writer
// of our own (stored deflate blocks) for grey PNGs that the module itself never writes.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace tellus::test {

constexpr std::size_t sz(int v) {
  return static_cast<std::size_t>(v);
}

/** Smooth but not flat colours with some texture: what a JPEG encoder meets in imagery. */
inline std::vector<std::uint8_t> testPixels(int w, int h, int channels) {
  std::vector<std::uint8_t> px(sz(w) * sz(h) * sz(channels));
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      for (int c = 0; c < channels; ++c) {
        const double v = 128 + 60 * std::sin(x * 0.031 * (c + 1) + y * 0.017) +
                         40 * std::cos(y * 0.043 * (c + 2) - x * 0.011) + ((x * 7 + y * 13) % 17);
        px[(sz(y) * sz(w) + sz(x)) * sz(channels) + sz(c)] =
            static_cast<std::uint8_t>(std::clamp(v, 0.0, 255.0));
      }
    }
  }
  return px;
}

inline std::vector<std::byte> readFile(const std::filesystem::path& p) {
  std::ifstream f(p, std::ios::binary);
  const std::vector<char> c{std::istreambuf_iterator<char>(f), {}};
  std::vector<std::byte> out(c.size());
  std::memcpy(out.data(), c.data(), c.size());
  return out;
}

/** The bundled 2048 x 1024 Blue Marble JPEG. */
inline std::filesystem::path blueMarblePath() {
  return std::filesystem::path(TELLUS_TEST_DATA_DIR) / "bmng_2048x1024.jpg";
}

/** Mean absolute difference of two sample vectors of the same size. */
inline double meanAbsDiff(const std::vector<std::uint8_t>& a, const std::vector<std::uint8_t>& b) {
  if (a.size() != b.size() || a.empty()) return 1e9;
  double sum = 0;
  for (std::size_t i = 0; i < a.size(); ++i)
    sum += std::abs(static_cast<int>(a[i]) - static_cast<int>(b[i]));
  return sum / static_cast<double>(a.size());
}

namespace detail {
inline std::uint32_t crc32(const std::uint8_t* p, std::size_t n, std::uint32_t crc = 0) {
  crc = ~crc;
  for (std::size_t i = 0; i < n; ++i) {
    crc ^= p[i];
    for (int k = 0; k < 8; ++k)
      crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}
inline void put32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  for (int s = 24; s >= 0; s -= 8)
    out.push_back(static_cast<std::uint8_t>(v >> s));
}
inline void
chunk(std::vector<std::uint8_t>& out, const char* type, const std::vector<std::uint8_t>& data) {
  put32(out, static_cast<std::uint32_t>(data.size()));
  const std::size_t start = out.size();
  out.insert(out.end(), type, type + 4);
  out.insert(out.end(), data.begin(), data.end());
  put32(out, crc32(&out[start], out.size() - start));
}
} // namespace detail

/**
 * A non-interlaced PNG of `bitDepth` (8 or 16) samples of colour type `colourType` (0 grey, 2
 * RGB), `samples` row-major (channels per pixel by the colour type), written here without libpng:
 * filter 0 on every row, the zlib stream in stored blocks.
 */
inline std::vector<std::byte> handWrittenPng(int width,
                                             int height,
                                             int bitDepth,
                                             int colourType,
                                             const std::vector<std::uint16_t>& samples) {
  using namespace detail;
  const int channels = colourType == 2 ? 3 : 1;
  const int bytesPerSample = bitDepth / 8;
  std::vector<std::uint8_t> raw;
  for (int y = 0; y < height; ++y) {
    raw.push_back(0); // filter: none
    for (int i = 0; i < width * channels; ++i) {
      const std::uint16_t v = samples[sz(y) * sz(width) * sz(channels) + sz(i)];
      if (bytesPerSample == 2) raw.push_back(static_cast<std::uint8_t>(v >> 8));
      raw.push_back(static_cast<std::uint8_t>(v));
    }
  }
  std::vector<std::uint8_t> z{0x78, 0x01};
  std::uint32_t a = 1, b = 0;
  for (const std::uint8_t v : raw) {
    a = (a + v) % 65521;
    b = (b + a) % 65521;
  }
  for (std::size_t at = 0; at < raw.size() || at == 0;) {
    const std::size_t n = std::min<std::size_t>(65535, raw.size() - at);
    const bool last = at + n == raw.size();
    z.push_back(last ? 1 : 0);
    z.push_back(static_cast<std::uint8_t>(n));
    z.push_back(static_cast<std::uint8_t>(n >> 8));
    z.push_back(static_cast<std::uint8_t>(~n));
    z.push_back(static_cast<std::uint8_t>(~n >> 8));
    z.insert(z.end(),
             raw.begin() + static_cast<std::ptrdiff_t>(at),
             raw.begin() + static_cast<std::ptrdiff_t>(at + n));
    at += n;
    if (last) break;
  }
  put32(z, (b << 16) | a);
  std::vector<std::uint8_t> png{0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A};
  std::vector<std::uint8_t> ihdr;
  put32(ihdr, static_cast<std::uint32_t>(width));
  put32(ihdr, static_cast<std::uint32_t>(height));
  ihdr.insert(
      ihdr.end(),
      {static_cast<std::uint8_t>(bitDepth), static_cast<std::uint8_t>(colourType), 0, 0, 0});
  chunk(png, "IHDR", ihdr);
  chunk(png, "IDAT", z);
  chunk(png, "IEND", {});
  std::vector<std::byte> out(png.size());
  std::memcpy(out.data(), png.data(), png.size());
  return out;
}

} // namespace tellus::test
