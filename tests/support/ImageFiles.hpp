#pragma once
// Image files for the proxy tests: whole files as bytes, and images written with OpenImageIO (the
// tests link it; the proxy loads it only through the imaging module).

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <cstddef>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

namespace tellus::test {

inline std::vector<std::byte> readAll(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::vector<char> c((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::vector<std::byte> b(c.size());
  if (!c.empty()) std::memcpy(b.data(), c.data(), c.size());
  return b;
}

inline void writeAll(const std::filesystem::path& p, const std::vector<std::byte>& b) {
  std::ofstream out(p, std::ios::binary);
  out.write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
}

/** Writes an image with OpenImageIO, samples in a fixed pattern (byte i is (7 i) % 251). */
inline void
writeWithOiio(const std::filesystem::path& file, int w, int h, int channels, OIIO::TypeDesc type) {
  OIIO::attribute("threads", 1);
  OIIO::ImageSpec spec(w, h, channels, type);
  std::vector<std::byte> px(spec.image_bytes());
  for (std::size_t i = 0; i < px.size(); ++i)
    px[i] = static_cast<std::byte>((i * 7) % 251);
  auto out = OIIO::ImageOutput::create(file.string());
  ASSERT_TRUE(out) << OIIO::geterror();
  out->threads(1);
  ASSERT_TRUE(out->open(file.string(), spec) && out->write_image(type, px.data()) && out->close())
      << out->geterror();
}

} // namespace tellus::test
