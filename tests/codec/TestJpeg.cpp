// JPEG decode, validation and encode (tellus/codec/Jpeg.hpp): round trips of grey and colour, the
// layouts asked for, the region decode of the composer, the header probe, the encoder's options,
// and the sizes at the ends of what JPEG allows.

#include "CodecTestSupport.hpp"

#include <tellus/codec/Jpeg.hpp>

#include <gtest/gtest.h>

using namespace tellus;
using test::sz;
using test::testPixels;

namespace {

codec::Bytes encode(int w, int h, int channels, const codec::JpegEncodeOptions& o = {}) {
  const auto px = testPixels(w, h, channels);
  auto e = codec::encodeJpeg(w, h, channels, px.data(), o);
  EXPECT_TRUE(e) << (e ? "" : e.error());
  return e ? *e : codec::Bytes{};
}

} // namespace

TEST(Jpeg, GreyAndRgbRoundTripCloseToTheOriginal) {
  for (const int channels : {1, 3}) {
    SCOPED_TRACE(channels);
    const auto px = testPixels(96, 80, channels);
    const auto jpeg = *codec::encodeJpeg(96, 80, channels, px.data());
    EXPECT_EQ(codec::sniff(jpeg), codec::Format::Jpeg);
    const auto img = codec::decodeJpeg(jpeg, {.channels = 0});
    ASSERT_TRUE(img) << img.error();
    EXPECT_EQ(img->width, 96);
    EXPECT_EQ(img->height, 80);
    EXPECT_EQ(img->channels, channels); // as stored
    EXPECT_LT(test::meanAbsDiff(img->pixels, px), 3.0);
  }
}

TEST(Jpeg, LayoutsAreGreyRgbOrRgbaWithOpaqueAlpha) {
  const auto colour = encode(40, 24, 3);
  const auto rgb = *codec::decodeJpeg(colour);
  ASSERT_EQ(rgb.channels, 3);
  const auto rgba = *codec::decodeJpeg(colour, {.channels = 4});
  ASSERT_EQ(rgba.channels, 4);
  ASSERT_EQ(rgba.pixels.size(), sz(40 * 24 * 4));
  for (std::size_t i = 0; i < sz(40 * 24); ++i) {
    ASSERT_EQ(rgba.pixels[i * 4 + 3], 255);
    for (std::size_t c = 0; c < 3; ++c)
      ASSERT_EQ(rgba.pixels[i * 4 + c], rgb.pixels[i * 3 + c]);
  }
  // Grey expanded to RGB is three equal samples; colour asked as grey is its luma.
  const auto grey = encode(40, 24, 1);
  const auto expanded = *codec::decodeJpeg(grey, {.channels = 3});
  const auto stored = *codec::decodeJpeg(grey, {.channels = 1});
  ASSERT_EQ(expanded.channels, 3);
  for (std::size_t i = 0; i < stored.pixels.size(); ++i) {
    ASSERT_EQ(expanded.pixels[i * 3], stored.pixels[i]);
    ASSERT_EQ(expanded.pixels[i * 3 + 2], stored.pixels[i]);
  }
  const auto luma = *codec::decodeJpeg(colour, {.channels = 1});
  EXPECT_EQ(luma.channels, 1);
  EXPECT_EQ(luma.pixels.size(), sz(40 * 24));
  EXPECT_FALSE(codec::decodeJpeg(colour, {.channels = 2}));
}

TEST(Jpeg, TheBundledBlueMarbleDecodes) {
  const auto bytes = test::readFile(test::blueMarblePath());
  const auto img = codec::decodeJpeg(bytes);
  ASSERT_TRUE(img) << img.error();
  EXPECT_EQ(img->width, 2048);
  EXPECT_EQ(img->height, 1024);
  EXPECT_EQ(img->channels, 3);
  const auto info = codec::probeJpeg(bytes);
  ASSERT_TRUE(info);
  EXPECT_EQ(info->width, 2048);
  EXPECT_EQ(info->components, 3);
}

TEST(Jpeg, EncoderOptionsReachTheStream) {
  const auto plain = encode(64, 64, 3);
  const auto marked = encode(64, 64, 3, {.restartInterval = codec::kTileRestartInterval});
  EXPECT_EQ(codec::probeJpeg(plain)->restartInterval, 0);
  EXPECT_EQ(codec::probeJpeg(marked)->restartInterval, codec::kTileRestartInterval);
  EXPECT_EQ(codec::probeJpeg(plain)->mcuWidth, 16); // 4:2:0 by default
  EXPECT_EQ(codec::probeJpeg(plain)->mcuHeight, 16);
  const auto s444 = encode(64, 64, 3, {.lumaSamplingH = 1, .lumaSamplingV = 1});
  EXPECT_EQ(codec::probeJpeg(s444)->mcuWidth, 8);
  EXPECT_EQ(codec::probeJpeg(s444)->mcuHeight, 8);
  const auto s422 = encode(64, 64, 3, {.lumaSamplingH = 2, .lumaSamplingV = 1});
  EXPECT_EQ(codec::probeJpeg(s422)->mcuWidth, 16);
  EXPECT_EQ(codec::probeJpeg(s422)->mcuHeight, 8);
  EXPECT_EQ(codec::probeJpeg(encode(64, 64, 1))->mcuWidth, 8);
  EXPECT_FALSE(codec::probeJpeg(plain)->progressive);
  // Quality: clamped to 1-100, and more of it is more bytes.
  const auto q100 = encode(64, 64, 3, {.quality = 100});
  EXPECT_EQ(encode(64, 64, 3, {.quality = 1000}), q100);
  EXPECT_EQ(encode(64, 64, 3, {.quality = -5}), encode(64, 64, 3, {.quality = 1}));
  EXPECT_GT(q100.size(), encode(64, 64, 3, {.quality = 30}).size());
}

TEST(Jpeg, EncodeRefusesBadShapes) {
  const auto px = testPixels(8, 8, 4);
  EXPECT_FALSE(codec::encodeJpeg(8, 8, 4, px.data())); // no alpha in JPEG
  EXPECT_FALSE(codec::encodeJpeg(8, 8, 2, px.data()));
  EXPECT_FALSE(codec::encodeJpeg(0, 8, 3, px.data()));
  EXPECT_FALSE(codec::encodeJpeg(8, -1, 3, px.data()));
  EXPECT_FALSE(codec::encodeJpeg(8, 8, 3, nullptr));
}

// Composed maps decode only the part of a JPEG tile they sample: those pixels must be exactly the
// ones a whole decode gives (libjpeg-turbo decodes the blocks around the crop in full), and the
// pixels outside are not written.
TEST(Jpeg, RegionDecodeEqualsTheWholeDecodeInside) {
  std::vector<std::uint8_t> px(512 * 512 * 3);
  for (int y = 0; y < 512; ++y)
    for (int x = 0; x < 512; ++x) {
      auto* p = &px[static_cast<std::size_t>((y * 512 + x) * 3)];
      p[0] = static_cast<std::uint8_t>(x * 7 + y);
      p[1] = static_cast<std::uint8_t>((x ^ y) & 255);
      p[2] = static_cast<std::uint8_t>(y * 3);
    }
  const auto jpeg = *codec::encodeJpeg(512, 512, 3, px.data());
  std::vector<std::uint8_t> whole;
  const auto channels = codec::decodeJpegInto(jpeg, 512, 512, whole);
  ASSERT_TRUE(channels) << channels.error();
  ASSERT_EQ(*channels, 3);
  EXPECT_EQ(whole, codec::decodeJpeg(jpeg)->pixels);
  for (const codec::Region region : {codec::Region{0, 0, 512, 512},
                                     {100, 37, 301, 250},
                                     {511, 511, 512, 512},
                                     {0, 300, 5, 512},
                                     {-5, -9, 9000, 20}}) {
    std::vector<std::uint8_t> part(512 * 512 * 3, 7);
    const auto ch = codec::decodeJpegInto(jpeg, 512, 512, part, &region);
    ASSERT_TRUE(ch) << ch.error();
    const int x0 = std::clamp(region[0], 0, 511), x1 = std::clamp(region[2], x0 + 1, 512);
    const int y0 = std::clamp(region[1], 0, 511), y1 = std::clamp(region[3], y0 + 1, 512);
    int differ = 0;
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x)
        for (int c = 0; c < 3; ++c) {
          const auto k = static_cast<std::size_t>((y * 512 + x) * 3 + c);
          differ += part[k] != whole[k];
        }
    EXPECT_EQ(differ, 0) << region[0] << "," << region[1] << "," << region[2] << "," << region[3];
    if (y1 < 512) {
      EXPECT_EQ(part[static_cast<std::size_t>((511 * 512 + 511) * 3)], 7) << "not decoded";
    }
  }
  // Broken bytes are an error, never a crash (libjpeg's longjmp path).
  std::vector<std::byte> broken(jpeg.begin(), jpeg.begin() + 200);
  broken[2] = std::byte{0};
  std::vector<std::uint8_t> out;
  EXPECT_FALSE(codec::decodeJpegInto(broken, 512, 512, out));
  EXPECT_FALSE(codec::decodeJpegInto(jpeg, 256, 512, out)) << "the size is checked";
}

TEST(Jpeg, TileDecodesCheckTheShapeWithTheirMessages) {
  const auto jpeg = encode(64, 32, 3);
  std::vector<std::uint8_t> px;
  EXPECT_EQ(codec::decodeJpegInto(jpeg, 32, 32, px).error(), "the JPEG is not 32x32 grey or RGB");
  EXPECT_EQ(codec::checkJpeg(jpeg, 32, 32, px).error(), "JPEG is 64x32, expected 32x32");
  EXPECT_EQ(codec::decodeJpegInto(jpeg, 0, 32, px).error(), "bad image shape");
  EXPECT_EQ(codec::checkJpeg(jpeg, 64, -1, px).error(), "bad image shape");
  EXPECT_TRUE(codec::checkJpeg(jpeg, 64, 32, px));
  EXPECT_TRUE(codec::checkJpeg(encode(64, 32, 1), 64, 32, px)) << "grey is a tile too";
}

TEST(Jpeg, ATruncatedStreamDecodesGreyButFailsTheCheck) {
  // libjpeg pads a premature end with grey and warns: composing (cached, validated tiles) takes
  // what is there; validating a fetched tile refuses it.
  const auto jpeg = encode(128, 128, 3);
  const codec::Bytes half(jpeg.begin(),
                          jpeg.begin() + static_cast<std::ptrdiff_t>(jpeg.size() / 2));
  std::vector<std::uint8_t> px;
  EXPECT_TRUE(codec::decodeJpegInto(half, 128, 128, px));
  EXPECT_TRUE(codec::decodeJpeg(half));
  const auto checked = codec::checkJpeg(half, 128, 128, px);
  ASSERT_FALSE(checked);
  EXPECT_TRUE(checked.error().starts_with("JPEG does not decode: ")) << checked.error();
  EXPECT_TRUE(codec::probeJpeg(half)) << "the header is all there";
}

TEST(Jpeg, BytesThatAreNoJpegAreErrors) {
  std::vector<std::uint8_t> px;
  for (const codec::Bytes& bytes :
       {codec::Bytes{}, codec::Bytes(3, std::byte{0xFF}), codec::Bytes(100, std::byte{0x42})}) {
    EXPECT_FALSE(codec::probeJpeg(bytes));
    EXPECT_FALSE(codec::decodeJpeg(bytes));
    EXPECT_FALSE(codec::decodeJpegInto(bytes, 8, 8, px));
    EXPECT_FALSE(codec::checkJpeg(bytes, 8, 8, px));
    EXPECT_EQ(codec::sniff(bytes), codec::Format::Unknown);
  }
  const auto e = codec::decodeJpeg(codec::Bytes(100, std::byte{0x42}));
  EXPECT_TRUE(e.error().starts_with("the JPEG does not decode: ")) << e.error();
}

TEST(JpegExtremes, OnePixelGreyAndColour) {
  for (const int channels : {1, 3}) {
    const std::vector<std::uint8_t> px(sz(channels), 200);
    const auto jpeg = codec::encodeJpeg(1, 1, channels, px.data());
    ASSERT_TRUE(jpeg);
    const auto img = codec::decodeJpeg(*jpeg, {.channels = 0});
    ASSERT_TRUE(img) << img.error();
    EXPECT_EQ(img->width, 1);
    EXPECT_EQ(img->height, 1);
    EXPECT_NEAR(img->pixels[0], 200, 2);
    std::vector<std::uint8_t> into;
    const codec::Region r{0, 0, 1, 1};
    EXPECT_TRUE(codec::decodeJpegInto(*jpeg, 1, 1, into, &r));
    EXPECT_TRUE(codec::checkJpeg(*jpeg, 1, 1, into));
  }
}

TEST(JpegExtremes, TheWidestAndTallestJpegAndOneBeyond) {
  // JPEG stores sizes in 16 bits and libjpeg stops at 65,500 pixels a side.
  for (const auto& [w, h] : {std::pair{65500, 1}, std::pair{1, 65500}, std::pair{65500, 3}}) {
    SCOPED_TRACE(::testing::Message() << w << "x" << h);
    const auto px = testPixels(w, h, 3);
    const auto jpeg = codec::encodeJpeg(w, h, 3, px.data(), {.restartInterval = 4});
    ASSERT_TRUE(jpeg) << jpeg.error();
    const auto img = codec::decodeJpeg(*jpeg);
    ASSERT_TRUE(img) << img.error();
    EXPECT_EQ(img->width, w);
    EXPECT_EQ(img->height, h);
    EXPECT_LT(test::meanAbsDiff(img->pixels, px), 6.0);
    // The last pixel alone, by region.
    std::vector<std::uint8_t> part;
    const codec::Region r{w - 1, h - 1, w, h};
    ASSERT_TRUE(codec::decodeJpegInto(*jpeg, w, h, part, &r));
    const auto last = sz(w) * sz(h) * 3 - 3;
    EXPECT_EQ(part[last], img->pixels[last]);
  }
  const auto px = testPixels(65501, 1, 3);
  const auto beyond = codec::encodeJpeg(65501, 1, 3, px.data());
  ASSERT_FALSE(beyond);
  EXPECT_TRUE(beyond.error().starts_with("cannot encode JPEG: ")) << beyond.error();
}

TEST(JpegExtremes, OddSizesKeepTheirEdges) {
  for (const auto& [w, h] :
       {std::pair{17, 9}, std::pair{33, 1}, std::pair{1, 31}, std::pair{255, 257}}) {
    SCOPED_TRACE(::testing::Message() << w << "x" << h);
    const auto px = testPixels(w, h, 3);
    const auto jpeg = *codec::encodeJpeg(w, h, 3, px.data(), {.quality = 100});
    std::vector<std::uint8_t> out;
    ASSERT_TRUE(codec::decodeJpegInto(jpeg, w, h, out));
    EXPECT_LT(test::meanAbsDiff(out, px), 3.0);
  }
}
