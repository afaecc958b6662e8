// Hostile and damaged value tiles: every one refused with a clear message, none read out of
// bounds (ASan runs this executable too).
#include "TiffBuilder.hpp"

#include <tellus/values/ValueFormat.hpp>

#include <gtest/gtest.h>

namespace tellus::values {
namespace {

using test::TiffBuilder;
using test::TiffSpec;

ValueFormat tiff() {
  ValueFormat f;
  f.container = Container::Tiff;
  return f;
}

std::string errorOf(const std::vector<std::byte>& bytes) {
  auto r = decode(bytes, tiff());
  return r ? std::string("decoded") : r.error();
}

/** Sets the 4-byte value of the IFD entry with this tag (little-endian file). */
void patchTag(std::vector<std::byte>& t, std::uint32_t ifd, std::uint16_t tag, std::uint32_t v) {
  const auto u16 = [&](std::size_t at) {
    return std::to_integer<unsigned>(t[at]) | std::to_integer<unsigned>(t[at + 1]) << 8;
  };
  const unsigned n = u16(ifd);
  for (unsigned i = 0; i < n; ++i) {
    const std::size_t e = ifd + 2 + i * 12;
    if (u16(e) != tag) continue;
    for (int k = 0; k < 4; ++k)
      t[e + 8 + std::size_t(k)] = std::byte(v >> (8 * k) & 0xFF);
    return;
  }
  FAIL() << "no tag " << tag;
}

TEST(ValueDecodeExtremes, BilOfTheWrongSizeOrShape) {
  ValueFormat f;
  auto r = decode(std::vector<std::byte>(7), f, 2, 2);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error(), "the BIL tile has 7 bytes, not 8");
  EXPECT_FALSE(decode(std::vector<std::byte>(8), f, 0, 2));
  EXPECT_FALSE(decode(std::vector<std::byte>(8), f, -2, -1));
  EXPECT_FALSE(decode(std::vector<std::byte>(8), f, 1 << 20, 1));
  f.encoding = Encoding::Float32;
  EXPECT_FALSE(decode(std::vector<std::byte>(8), f, 2, 2)); // needs 16
}

TEST(ValueDecodeExtremes, EveryTruncationOfATiffIsRefused) {
  for (const int compression : {1, 8}) {
    TiffSpec s{
        .width = 20, .height = 18, .compression = compression, .tileWidth = 16, .tileHeight = 16};
    const auto whole = TiffBuilder(s).build(std::vector<std::uint32_t>(360, 3));
    ASSERT_TRUE(decode(whole, tiff()));
    for (std::size_t n = 0; n < whole.size(); ++n) {
      // A copy of exactly n bytes, so that ASan sees any read past it.
      std::vector<std::byte> cut(whole.begin(), whole.begin() + std::ptrdiff_t(n));
      EXPECT_FALSE(decode(cut, tiff())) << n << " of " << whole.size();
    }
  }
}

TEST(ValueDecodeExtremes, HugeDimensionsAreRefusedBeforeAllocating) {
  TiffBuilder b(TiffSpec{});
  auto t = b.build(std::vector<std::uint32_t>(12, 1));
  patchTag(t, b.ifdOffset(), 256, 0x7FFFFFFF);
  EXPECT_NE(errorOf(t).find("larger than 8192"), std::string::npos) << errorOf(t);
  patchTag(t, b.ifdOffset(), 256, 0);
  EXPECT_EQ(errorOf(t), "the TIFF has no width or height");
}

TEST(ValueDecodeExtremes, OffsetsPastTheEndAreRefused) {
  TiffBuilder b(TiffSpec{.rowsPerStrip = 3});
  auto t = b.build(std::vector<std::uint32_t>(12, 1));
  patchTag(t, b.ifdOffset(), 273, 0xFFFFFFF0); // the one strip's offset
  EXPECT_NE(errorOf(t).find("past the end"), std::string::npos) << errorOf(t);
  auto u = b.build(std::vector<std::uint32_t>(12, 1));
  patchTag(u, b.ifdOffset(), 279, 0x7FFFFFFF); // its byte count
  EXPECT_NE(errorOf(u).find("past the end"), std::string::npos) << errorOf(u);
  auto v = b.build(std::vector<std::uint32_t>(12, 1));
  v[4] = std::byte{0xF0}, v[5] = v[6] = v[7] = std::byte{0xFF}; // the IFD's offset
  EXPECT_NE(errorOf(v).find("truncated"), std::string::npos) << errorOf(v);
}

TEST(ValueDecodeExtremes, ADeflateBombIsRefused) {
  // A 16 x 16 tiled TIFF claiming 8192 x 8192 tiles whose Deflate data is a few bytes.
  TiffBuilder b(
      TiffSpec{.width = 16, .height = 16, .compression = 8, .tileWidth = 16, .tileHeight = 16});
  auto t = b.build(std::vector<std::uint32_t>(256, 0));
  patchTag(t, b.ifdOffset(), 322, 8192);
  patchTag(t, b.ifdOffset(), 323, 8192);
  EXPECT_NE(errorOf(t).find("too short"), std::string::npos) << errorOf(t);
}

TEST(ValueDecodeExtremes, UnsupportedFeaturesAreNamed) {
  EXPECT_NE(errorOf(TiffBuilder(TiffSpec{.compression = 5}).build(std::vector<std::uint32_t>(12)))
                .find("compression 5 (LZW) is not supported"),
            std::string::npos);
  EXPECT_NE(
      errorOf(TiffBuilder(TiffSpec{.samplesPerPixel = 3}).build(std::vector<std::uint32_t>(12)))
          .find("3 bands"),
      std::string::npos);
  EXPECT_NE(errorOf(TiffBuilder(TiffSpec{.bits = 32, .sampleFormat = 2})
                        .build(std::vector<std::uint32_t>(12)))
                .find("not supported"),
            std::string::npos);
  EXPECT_NE(errorOf(TiffBuilder(TiffSpec{.predictor = 3}).build(std::vector<std::uint32_t>(12)))
                .find("predictor 3"),
            std::string::npos);
  auto big = TiffBuilder(TiffSpec{}).build(std::vector<std::uint32_t>(12));
  big[2] = std::byte{43};
  EXPECT_EQ(errorOf(big), "the TIFF is a BigTIFF, which is not supported");
  EXPECT_EQ(errorOf(std::vector<std::byte>(16, std::byte{'x'})), "not a TIFF");
  EXPECT_EQ(errorOf({}), "the TIFF is truncated (no header)");
}

TEST(ValueDecodeExtremes, CorruptDeflateIsRefused) {
  auto t = TiffBuilder(TiffSpec{.compression = 8, .rowsPerStrip = 3})
               .build(std::vector<std::uint32_t>(12, 9));
  for (std::size_t i = 8; i < 20; ++i)
    t[i] = std::byte{0x55};
  EXPECT_NE(errorOf(t).find("Deflate"), std::string::npos) << errorOf(t);
}

TEST(ValueDecodeExtremes, PngsThatAreNotValueRasters) {
  ValueFormat f;
  f.container = Container::Png;
  EXPECT_FALSE(decode(std::vector<std::byte>(30, std::byte{1}), f));
  EXPECT_FALSE(decode({}, f));
  f.encoding = Encoding::Float32;
  EXPECT_FALSE(decode({}, f));
}

} // namespace
} // namespace tellus::values
