// The DCT-domain split of a JPEG into tiles (tellus/codec/JpegSplit.hpp): the tiles hold exactly
// the whole image's blocks, misaligned tiles and damaged or wrong-sized JPEGs give no tile.

#include "CodecTestSupport.hpp"

#include <tellus/codec/Jpeg.hpp>
#include <tellus/codec/JpegSplit.hpp>

#include <gtest/gtest.h>

using namespace tellus;
using test::sz;
using test::testPixels;

namespace {

/** Decodes with box (not "fancy") chroma upsampling: every output pixel then comes from its own
 * 8x8 blocks only, so equal blocks give equal pixels. Channels as stored (1 or 3). */
bool decodeBlocks(const std::vector<std::byte>& bytes,
                  int& w,
                  int& h,
                  int& channels,
                  std::vector<std::uint8_t>& out) {
  auto img = codec::decodeJpeg(bytes, {.channels = 0, .fancyUpsampling = false});
  if (!img) return false;
  w = img->width;
  h = img->height;
  channels = img->channels;
  out = std::move(img->pixels);
  return true;
}

/** Encodes grey or RGB pixels with libjpeg's defaults (4:2:0 for colour) at quality 90. */
std::vector<std::byte> encodeTestJpeg(int w, int h, int channels, const std::uint8_t* px) {
  auto e = codec::encodeJpeg(w, h, channels, px);
  EXPECT_TRUE(e) << (e ? "" : e.error());
  return e ? *e : std::vector<std::byte>{};
}

} // namespace

TEST(JpegSplit, TilesHoldExactlyTheWholeImagesBlocks) {
  for (const int channels : {3, 1}) {
    SCOPED_TRACE(channels);
    const int cols = 3, rows = 2, tw = 256, th = 256;
    const auto px = testPixels(cols * tw, rows * th, channels);
    const auto whole = encodeTestJpeg(cols * tw, rows * th, channels, px.data());
    auto tiles = codec::splitJpegDct(whole, cols, rows, tw, th);
    ASSERT_TRUE(tiles) << tiles.error().message;
    ASSERT_EQ(tiles->size(), 6u);
    int W = 0, H = 0, C = 0;
    std::vector<std::uint8_t> all;
    ASSERT_TRUE(decodeBlocks(whole, W, H, C, all));
    // The composer's decoder (fancy upsampling) too: the tile's interior is the whole's.
    std::vector<std::uint8_t> fancyAll;
    ASSERT_TRUE(codec::decodeJpegInto(whole, W, H, fancyAll, nullptr));
    for (int tr = 0; tr < rows; ++tr) {
      for (int tc = 0; tc < cols; ++tc) {
        const auto& tile = (*tiles)[sz(tr * cols + tc)];
        int w = 0, h = 0, c = 0;
        std::vector<std::uint8_t> got;
        ASSERT_TRUE(decodeBlocks(tile, w, h, c, got));
        ASSERT_EQ(w, tw);
        ASSERT_EQ(h, th);
        ASSERT_EQ(c, C);
        std::size_t differing = 0;
        for (int y = 0; y < th; ++y)
          for (int x = 0; x < tw * c; ++x)
            differing += got[sz(y) * sz(tw) * sz(c) + sz(x)] !=
                         all[(sz(tr * th + y) * sz(W) + sz(tc * tw)) * sz(c) + sz(x)];
        EXPECT_EQ(differing, 0u) << "tile " << tr << "," << tc;
        std::vector<std::uint8_t> fancy;
        ASSERT_TRUE(codec::decodeJpegInto(tile, tw, th, fancy, nullptr));
        differing = 0;
        for (int y = 1; y + 1 < th; ++y)
          for (int x = 3; x < (tw - 1) * 3; ++x)
            differing += fancy[sz(y) * sz(tw) * 3 + sz(x)] !=
                         fancyAll[(sz(tr * th + y) * sz(W) + sz(tc * tw)) * 3 + sz(x)];
        EXPECT_EQ(differing, 0u) << "tile " << tr << "," << tc << " (interior, fancy upsampling)";
      }
    }
  }
}

TEST(JpegSplit, ADamagedOrWrongSizedJpegGivesNoTile) {
  const auto px = testPixels(512, 512, 3);
  const auto whole = encodeTestJpeg(512, 512, 3, px.data());
  // Wrong size: not 2x2 tiles of 256 x 128.
  auto wrong = codec::splitJpegDct(whole, 2, 2, 256, 128);
  ASSERT_FALSE(wrong);
  EXPECT_EQ(wrong.error().code, codec::JpegSplitErrc::Invalid);
  EXPECT_NE(wrong.error().message.find("512x512"), std::string::npos) << wrong.error().message;
  // Truncated: the second half is gone (an end marker appended, as a broken proxy might).
  auto truncated = std::vector<std::byte>(
      whole.begin(), whole.begin() + static_cast<std::ptrdiff_t>(whole.size() / 2));
  truncated.push_back(std::byte{0xFF});
  truncated.push_back(std::byte{0xD9});
  auto t = codec::splitJpegDct(truncated, 2, 2, 256, 256);
  ASSERT_FALSE(t);
  EXPECT_EQ(t.error().code, codec::JpegSplitErrc::Invalid) << t.error().message;
  // Garbage in the entropy-coded data (a marker-like byte pair in the middle).
  auto corrupt = whole;
  for (std::size_t i = corrupt.size() / 2; i < corrupt.size() / 2 + 64; i += 2) {
    corrupt[i] = std::byte{0xFF};
    corrupt[i + 1] = static_cast<std::byte>(0xD0 + i % 7);
  }
  auto c = codec::splitJpegDct(corrupt, 2, 2, 256, 256);
  ASSERT_FALSE(c);
  EXPECT_EQ(c.error().code, codec::JpegSplitErrc::Invalid) << c.error().message;
}

TEST(JpegSplit, MisalignedTilesAreLeftToTheCaller) {
  // 200 px tiles do not fall on 4:2:0's 16-px iMCUs; 4:4:4 and grey have 8-px iMCUs.
  const auto px = testPixels(400, 200, 3);
  const auto whole = encodeTestJpeg(400, 200, 3, px.data());
  auto dct = codec::splitJpegDct(whole, 2, 1, 200, 200);
  ASSERT_FALSE(dct);
  EXPECT_EQ(dct.error().code, codec::JpegSplitErrc::NotAligned);
  const auto s444 =
      *codec::encodeJpeg(400, 200, 3, px.data(), {.lumaSamplingH = 1, .lumaSamplingV = 1});
  EXPECT_TRUE(codec::splitJpegDct(s444, 2, 1, 200, 200)) << "8-px iMCUs: 200 = 25 x 8";
  EXPECT_TRUE(codec::jpegTilesAligned(256, 256, 16, 16));
  EXPECT_FALSE(codec::jpegTilesAligned(200, 256, 16, 16));
  EXPECT_FALSE(codec::jpegTilesAligned(256, 256, 0, 16));
  // Shapes out of range are refused before anything is read.
  EXPECT_FALSE(codec::splitJpegDct(whole, 0, 1, 200, 200));
  EXPECT_FALSE(codec::splitJpegDct(whole, 65, 1, 200, 200));
  EXPECT_FALSE(codec::splitJpegDct({}, 2, 1, 200, 200));
}

TEST(JpegSplitExtremes, OneTileAndTilesOfOneIMcu) {
  const auto px = testPixels(256, 128, 3);
  const auto whole = encodeTestJpeg(256, 128, 3, px.data());
  const auto one = codec::splitJpegDct(whole, 1, 1, 256, 128);
  ASSERT_TRUE(one) << one.error().message;
  ASSERT_EQ(one->size(), 1u);
  int w = 0, h = 0, c = 0;
  std::vector<std::uint8_t> a, b;
  ASSERT_TRUE(decodeBlocks(whole, w, h, c, a));
  ASSERT_TRUE(decodeBlocks((*one)[0], w, h, c, b));
  EXPECT_EQ(a, b);
  // 16 x 8 tiles of 16 x 16 pixels: the smallest 4:2:0 tiles.
  const auto many = codec::splitJpegDct(whole, 16, 8, 16, 16);
  ASSERT_TRUE(many) << many.error().message;
  ASSERT_EQ(many->size(), 128u);
  for (const auto& tile : *many) {
    const auto info = codec::probeJpeg(tile);
    ASSERT_TRUE(info);
    EXPECT_EQ(info->width, 16);
    EXPECT_EQ(info->restartInterval, codec::kTileRestartInterval);
  }
}
