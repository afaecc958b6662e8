// PNG decode, validation and encode (tellus/codec/Png.hpp): the layouts asked for, alpha and
// palettes, the exact samples of 8- and 16-bit grey PNGs (elevation tiles), and sizes at the ends.

#include "CodecTestSupport.hpp"

#include <tellus/codec/Png.hpp>

#include <gtest/gtest.h>

using namespace tellus;
using test::sz;
using test::testPixels;

TEST(Png, GreyRgbAndRgbaRoundTripExactly) {
  for (const int channels : {1, 3, 4}) {
    SCOPED_TRACE(channels);
    const auto px = testPixels(37, 23, channels);
    const auto png = codec::encodePng(37, 23, channels, px.data());
    ASSERT_TRUE(png) << png.error();
    EXPECT_EQ(codec::sniff(*png), codec::Format::Png);
    // As a tile: RGB, or RGBA when there is alpha.
    std::vector<std::uint8_t> into;
    const auto ch = codec::decodePngInto(*png, 37, 23, into);
    ASSERT_TRUE(ch) << ch.error();
    EXPECT_EQ(*ch, channels == 4 ? 4 : 3);
    // As a texture: always RGBA.
    const auto rgba = codec::decodePng(*png);
    ASSERT_TRUE(rgba) << rgba.error();
    EXPECT_EQ(rgba->channels, 4);
    for (std::size_t i = 0; i < sz(37 * 23); ++i) {
      for (std::size_t c = 0; c < 3; ++c) {
        const auto want = px[i * sz(channels) + (channels == 1 ? 0 : c)];
        ASSERT_EQ(into[i * sz(*ch) + c], want) << i;
        ASSERT_EQ(rgba->pixels[i * 4 + c], want) << i;
      }
      ASSERT_EQ(rgba->pixels[i * 4 + 3], channels == 4 ? px[i * 4 + 3] : 255);
    }
    EXPECT_TRUE(codec::checkPng(*png, 37, 23, into));
  }
}

TEST(Png, APaletteKeepsItsColoursAndTransparency) {
  const std::vector<std::array<std::uint8_t, 4>> palette{
      {0, 0, 0, 0}, {255, 0, 0, 255}, {0, 128, 255, 128}};
  std::vector<std::uint8_t> indices(sz(16 * 8));
  for (std::size_t i = 0; i < indices.size(); ++i)
    indices[i] = static_cast<std::uint8_t>(i % 3);
  const auto png = codec::encodePngPalette(16, 8, palette, indices.data());
  ASSERT_TRUE(png) << png.error();
  std::vector<std::uint8_t> px;
  ASSERT_EQ(codec::decodePngInto(*png, 16, 8, px), 4) << "tRNS gives alpha";
  for (std::size_t i = 0; i < indices.size(); ++i)
    for (std::size_t c = 0; c < 4; ++c)
      ASSERT_EQ(px[i * 4 + c], palette[indices[i]][c]) << i;
  // Opaque palettes have no tRNS: RGB.
  const std::vector<std::array<std::uint8_t, 4>> opaque{{1, 2, 3, 255}, {4, 5, 6, 255}};
  std::vector<std::uint8_t> zeros(sz(16 * 8), 1);
  EXPECT_EQ(codec::decodePngInto(*codec::encodePngPalette(16, 8, opaque, zeros.data()), 16, 8, px),
            3);
  EXPECT_FALSE(codec::encodePngPalette(16, 8, {}, zeros.data()));
  EXPECT_FALSE(
      codec::encodePngPalette(16, 8, std::vector<std::array<std::uint8_t, 4>>(257), zeros.data()));
}

TEST(Png, TilesCheckTheirSize) {
  const auto px = testPixels(20, 10, 3);
  const auto png = *codec::encodePng(20, 10, 3, px.data());
  std::vector<std::uint8_t> out;
  EXPECT_EQ(codec::decodePngInto(png, 10, 10, out).error(), "the PNG is not 10x10");
  EXPECT_EQ(codec::checkPng(png, 10, 20, out).error(), "PNG is 20x10, expected 10x20");
  EXPECT_FALSE(codec::encodePng(20, 10, 2, px.data()));
  EXPECT_FALSE(codec::encodePng(0, 10, 3, px.data()));
  EXPECT_FALSE(codec::encodePng(20, 10, 3, nullptr));
}

TEST(Png, GreySamplesAreReadExactlyAsStored) {
  // 16-bit: big-endian in the file; every value from 0 to 65535 at the ends and between.
  std::vector<std::uint16_t> samples(sz(7 * 5));
  for (std::size_t i = 0; i < samples.size(); ++i)
    samples[i] = static_cast<std::uint16_t>(i * 1927 + 1);
  samples[0] = 0;
  samples[1] = 65535;
  samples[2] = 32768;
  samples[3] = 0x0102; // byte order
  const auto png16 = test::handWrittenPng(7, 5, 16, 0, samples);
  const auto g16 = codec::decodePngGrey(png16, 7, 5);
  ASSERT_TRUE(g16) << g16.error();
  EXPECT_EQ(g16->bitDepth, 16);
  EXPECT_EQ(g16->samples, samples);
  // 8-bit grey, by the module's own encoder.
  const auto px = testPixels(7, 5, 1);
  const auto g8 = codec::decodePngGrey(*codec::encodePng(7, 5, 1, px.data()), 7, 5);
  ASSERT_TRUE(g8) << g8.error();
  EXPECT_EQ(g8->bitDepth, 8);
  ASSERT_EQ(g8->samples.size(), px.size());
  for (std::size_t i = 0; i < px.size(); ++i)
    EXPECT_EQ(g8->samples[i], px[i]);
}

TEST(Png, GreySamplesRefuseOtherPngsWithTheirMessages) {
  const std::vector<std::uint16_t> grey(sz(4 * 3), 9);
  const auto png16 = test::handWrittenPng(4, 3, 16, 0, grey);
  EXPECT_EQ(codec::decodePngGrey(png16, 5, 3).error(), "the PNG is 4 x 3, not 5 x 3");
  const std::vector<std::uint16_t> rgb(sz(4 * 3 * 3), 9);
  EXPECT_EQ(codec::decodePngGrey(test::handWrittenPng(4, 3, 16, 2, rgb), 4, 3).error(),
            "the PNG is not 8- or 16-bit greyscale");
  EXPECT_EQ(codec::decodePngGrey(codec::Bytes(40, std::byte{1}), 4, 3).error(), "not a PNG");
  ASSERT_GT(png16.size(), 20U);
  // Copied short, not resized: GCC 12 at -O1 in a unity batch read resize(size() - 20) as a
  // possible 2^64-byte memset (-Wstringop-overflow) and CI's ASan tree failed to build.
  const codec::Bytes cut(png16.begin(), png16.end() - 20);
  EXPECT_EQ(codec::decodePngGrey(cut, 4, 3).error(), "the PNG is corrupt");
  // The pictures' readers take a 16-bit grey PNG too (reduced to 8 bits).
  const auto img = codec::decodePng(png16);
  ASSERT_TRUE(img) << img.error();
  EXPECT_EQ(img->channels, 4);
}

TEST(Png, BytesThatAreNoPngAreErrors) {
  std::vector<std::uint8_t> px;
  for (const codec::Bytes& bytes : {codec::Bytes{}, codec::Bytes(100, std::byte{0x42})}) {
    EXPECT_FALSE(codec::decodePng(bytes));
    EXPECT_FALSE(codec::decodePngInto(bytes, 8, 8, px));
    EXPECT_FALSE(codec::checkPng(bytes, 8, 8, px));
  }
  const auto e = codec::decodePng(codec::Bytes(100, std::byte{0x42}));
  EXPECT_TRUE(e.error().starts_with("the PNG does not decode: ")) << e.error();
}

TEST(PngExtremes, OnePixelAndTheWidestAndTallestAccepted) {
  for (const auto& [w, h] :
       {std::pair{1, 1}, std::pair{codec::kMaxSide, 1}, std::pair{1, codec::kMaxSide}}) {
    SCOPED_TRACE(::testing::Message() << w << "x" << h);
    const auto px = testPixels(w, h, 4);
    const auto png = codec::encodePng(w, h, 4, px.data());
    ASSERT_TRUE(png) << png.error();
    const auto img = codec::decodePng(*png);
    ASSERT_TRUE(img) << img.error();
    EXPECT_EQ(img->width, w);
    EXPECT_EQ(img->height, h);
    EXPECT_EQ(img->pixels, px);
    std::vector<std::uint16_t> grey(sz(w) * sz(h));
    for (std::size_t i = 0; i < grey.size(); ++i)
      grey[i] = static_cast<std::uint16_t>(i * 7);
    const auto g = codec::decodePngGrey(test::handWrittenPng(w, h, 16, 0, grey), w, h);
    ASSERT_TRUE(g) << g.error();
    EXPECT_EQ(g->samples, grey);
  }
  // One pixel more than a texture or an image file may have.
  const auto px = testPixels(codec::kMaxSide + 1, 1, 1);
  const auto wide = codec::encodePng(codec::kMaxSide + 1, 1, 1, px.data());
  ASSERT_TRUE(wide) << wide.error();
  const auto refused = codec::decodePng(*wide);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error(), "the PNG is 65537x1: too large or empty");
  std::vector<std::uint8_t> out; // a tile of that size is the caller's to allow
  EXPECT_EQ(codec::decodePngInto(*wide, codec::kMaxSide + 1, 1, out), 3);
}
