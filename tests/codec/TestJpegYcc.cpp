// The composer's JPEG planes (tellus/codec/JpegYcc.hpp): region decodes against whole decodes,
// the segments of tiles with restart markers decoded on their own, damaged streams, and the JPEGs
// left to the RGB path. On tiles cut from the bundled Blue Marble and encoded as the seeder encodes
// them (quality 90, 4:2:0, restart markers), and as an upstream may (no markers). The maps made on
// these planes are the composer's and tested in tests/proxy/TestComposeYcc.cpp.

#include "../support/BlueMarbleTiles.hpp"

#include <tellus/codec/Jpeg.hpp>
#include <tellus/codec/JpegSplit.hpp>
#include <tellus/codec/JpegYcc.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <tuple>

using namespace tellus;

namespace {

constexpr int kTile = test::kBlueMarbleTile;

struct Planes {
  std::vector<std::uint8_t> y, cb, cr;
  explicit Planes(std::uint8_t fill = 0)
      : y(kTile * kTile, fill), cb(kTile * kTile / 4, fill), cr(kTile * kTile / 4, fill) {}
};

codec::YccDecode
decode(const std::vector<std::byte>& jpeg, const std::array<std::int32_t, 4>* region, Planes& p) {
  std::string message;
  return codec::decodeJpegYcc(
      jpeg, kTile, kTile, region, p.y.data(), p.cb.data(), p.cr.data(), message);
}

/** A tile with the luma sampled h x v (the chroma 1 x 1), quality 75: 1, 1 is 4:4:4, 2, 1 4:2:2,
 * 2, 2 4:2:0. */
std::vector<std::byte> sampled(const std::vector<std::uint8_t>& rgb, int h, int v) {
  return *codec::encodeJpeg(
      kTile, kTile, 3, rgb.data(), {.quality = 75, .lumaSamplingH = h, .lumaSamplingV = v});
}

} // namespace

TEST(JpegYcc, RegionDecodesMatchTheWholeDecode) {
  test::forBothTileKinds([](test::BlueMarbleJpegTiles& tiles) {
    const auto& jpeg = tiles.at(2, 12, 21); // Europe, level 2
    Planes whole;
    ASSERT_EQ(decode(jpeg, nullptr, whole), codec::YccDecode::Ok);
    const std::array<std::int32_t, 4> regions[] = {
        {0, 0, 512, 512},
        {0, 0, 1, 1},
        {511, 511, 512, 512},
        {17, 33, 18, 34},
        {200, 0, 512, 512},
        {0, 300, 512, 512},
        {100, 100, 300, 300},
        {0, 0, 100, 512},
        {15, 15, 17, 17},
        {496, 0, 512, 16},
        {63, 63, 65, 65},     // across segment corners
        {448, 496, 512, 512}, // the last segment
        {0, 496, 512, 512},   // the last row, all of it
        {130, 7, 131, 500},   // one column
        {-5, -5, 600, 3},     // clamped to the tile
    };
    for (const auto& r : regions) {
      Planes part(0x55);
      ASSERT_EQ(decode(jpeg, &r, part), codec::YccDecode::Ok);
      int bad = 0;
      for (int y = std::max(r[1], 0); y < std::min(r[3], kTile); ++y)
        for (int x = std::max(r[0], 0); x < std::min(r[2], kTile); ++x) {
          const auto k = static_cast<std::size_t>(y * kTile + x);
          const auto kc = static_cast<std::size_t>((y / 2) * (kTile / 2) + x / 2);
          bad += part.y[k] != whole.y[k];
          bad += part.cb[kc] != whole.cb[kc];
          bad += part.cr[kc] != whole.cr[kc];
        }
      EXPECT_EQ(bad, 0) << r[0] << "," << r[1] << " - " << r[2] << "," << r[3];
      // Below the region's last block row nothing is decoded.
      const int below = (r[3] + 15) / 16 * 16;
      if (below < kTile) {
        EXPECT_EQ(part.y[static_cast<std::size_t>(below * kTile)], 0x55);
      }
      // Tiles with restart markers: decoded from the segments around the region unless it needs
      // every segment from the top; without markers, never.
      const bool fromTop = r[1] < 16 && r[0] < 64 && r[2] > kTile - 64;
      EXPECT_EQ(codec::decodesFromSegments(jpeg, kTile, kTile, r), tiles.restart && !fromTop)
          << r[0] << "," << r[1] << " - " << r[2] << "," << r[3];
    }
    // The planes are the RGB decode's colours (JFIF) at the chroma's resolution.
    std::vector<std::uint8_t> rgb;
    ASSERT_TRUE(codec::decodeJpegInto(jpeg, kTile, kTile, rgb));
    double err = 0;
    for (std::size_t k = 0; k < whole.y.size(); ++k) {
      const auto y = codec::rgbToYcc(rgb[k * 3], rgb[k * 3 + 1], rgb[k * 3 + 2])[0];
      err += std::abs(int{y} - int{whole.y[k]});
    }
    EXPECT_LT(err / static_cast<double>(whole.y.size()), 1.0);
  });
}

TEST(JpegYcc, SegmentDecodesOfRandomRegionsMatchTheWholeDecode) {
  // Random regions of tiles with restart markers: exactly the whole decode's samples (the same
  // blocks), with the 64 x 16 segments' edges anywhere in the region.
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> at(0, kTile - 1);
  const std::tuple<int, int, int> keys[] = {{2, 12, 21}, {1, 6, 12}, {0, 2, 3}, {2, 0, 5}};
  for (const auto& [level, row, col] : keys) {
    const auto& jpeg = test::BlueMarbleJpegTiles::withMarkers().at(level, row, col);
    Planes whole;
    ASSERT_EQ(decode(jpeg, nullptr, whole), codec::YccDecode::Ok);
    for (int k = 0; k < 40; ++k) {
      int x0 = at(rng), x1 = at(rng), y0 = at(rng), y1 = at(rng);
      if (x0 > x1) std::swap(x0, x1);
      if (y0 > y1) std::swap(y0, y1);
      const std::array<std::int32_t, 4> r{x0, y0, x1 + 1, y1 + 1};
      Planes part(0x55);
      ASSERT_EQ(decode(jpeg, &r, part), codec::YccDecode::Ok);
      int bad = 0;
      for (int y = r[1]; y < r[3]; ++y)
        for (int x = r[0]; x < r[2]; ++x) {
          const auto i = static_cast<std::size_t>(y * kTile + x);
          const auto ic = static_cast<std::size_t>((y / 2) * (kTile / 2) + x / 2);
          bad += part.y[i] != whole.y[i];
          bad += part.cb[ic] != whole.cb[ic];
          bad += part.cr[ic] != whole.cr[ic];
        }
      EXPECT_EQ(bad, 0) << r[0] << "," << r[1] << " - " << r[2] << "," << r[3];
    }
  }
}

TEST(JpegYcc, TilesCutFromAMetatileAreDecodedFromSegments) {
  // The seeder's metatile split writes its tiles with restart markers too.
  const auto left = test::blueMarbleTileRgb(2, 12, 20);
  const auto right = test::blueMarbleTileRgb(2, 12, 21);
  std::vector<std::uint8_t> meta(static_cast<std::size_t>(2 * kTile * kTile * 3));
  for (std::size_t y = 0; y < kTile; ++y) {
    const std::size_t row = kTile * 3;
    std::memcpy(&meta[y * 2 * row], &left[y * row], row);
    std::memcpy(&meta[y * 2 * row + row], &right[y * row], row);
  }
  const auto jpeg = *codec::encodeJpeg(2 * kTile, kTile, 3, meta.data());
  const auto cut = codec::splitJpegDct(jpeg, 2, 1, kTile, kTile, false);
  ASSERT_TRUE(cut.has_value());
  ASSERT_EQ(cut->size(), 2u);
  const std::array<std::int32_t, 4> r{300, 200, 420, 260};
  for (const auto& tile : *cut) {
    EXPECT_TRUE(codec::decodesFromSegments(tile, kTile, kTile, r));
    Planes whole, part(0x55);
    ASSERT_EQ(decode(tile, nullptr, whole), codec::YccDecode::Ok);
    ASSERT_EQ(decode(tile, &r, part), codec::YccDecode::Ok);
    int bad = 0;
    for (int y = r[1]; y < r[3]; ++y)
      for (int x = r[0]; x < r[2]; ++x)
        bad += part.y[static_cast<std::size_t>(y * kTile + x)] !=
               whole.y[static_cast<std::size_t>(y * kTile + x)];
    EXPECT_EQ(bad, 0);
  }
}

TEST(JpegYcc, DamagedTilesWithRestartMarkersAreDecodedAsAWhole) {
  // A stream whose markers are not all there (truncated) or not in order is decoded as a whole
  // (the damaged part grey, as on the RGB path), never spliced from the wrong segments.
  const auto& jpeg = test::BlueMarbleJpegTiles::withMarkers().at(2, 12, 21);
  const std::array<std::int32_t, 4> lower{100, 400, 300, 500};
  ASSERT_TRUE(codec::decodesFromSegments(jpeg, kTile, kTile, lower));
  const std::vector<std::byte> truncated(
      jpeg.begin(), jpeg.begin() + static_cast<std::ptrdiff_t>(jpeg.size() / 2));
  EXPECT_FALSE(codec::decodesFromSegments(truncated, kTile, kTile, lower));
  Planes p;
  EXPECT_EQ(decode(truncated, &lower, p), codec::YccDecode::Ok);
  // Two restart markers swapped: out of order.
  std::vector<std::byte> swapped = jpeg;
  std::vector<std::size_t> markers;
  for (std::size_t i = 0; i + 1 < swapped.size(); ++i)
    if (swapped[i] == std::byte{0xFF} && (std::to_integer<int>(swapped[i + 1]) & 0xF8) == 0xD0)
      markers.push_back(i + 1);
  ASSERT_GE(markers.size(), 100u); // 8 x 32 segments of a 512-pixel tile
  std::swap(swapped[markers[10]], swapped[markers[11]]);
  EXPECT_FALSE(codec::decodesFromSegments(swapped, kTile, kTile, lower));
  EXPECT_EQ(decode(swapped, &lower, p), codec::YccDecode::Ok);
  // Not the tile's size.
  EXPECT_FALSE(codec::decodesFromSegments(jpeg, 256, 256, lower));
}

TEST(JpegYcc, OtherSamplingsAndShapesAreLeftToTheRgbPath) {
  const auto rgb = test::blueMarbleTileRgb(1, 5, 10);
  Planes p;
  EXPECT_EQ(decode(sampled(rgb, 1, 1), nullptr, p),
            codec::YccDecode::NotYcc420); // 4:4:4
  EXPECT_EQ(decode(sampled(rgb, 2, 1), nullptr, p),
            codec::YccDecode::NotYcc420); // 4:2:2
  EXPECT_EQ(decode(sampled(rgb, 2, 2), nullptr, p), codec::YccDecode::Ok);
  std::vector<std::uint8_t> grey(static_cast<std::size_t>(kTile * kTile), 128);
  EXPECT_EQ(decode(*codec::encodeJpeg(kTile, kTile, 1, grey.data()), nullptr, p),
            codec::YccDecode::NotYcc420);
  const auto& jpeg = test::BlueMarbleJpegTiles::withMarkers().at(1, 5, 10);
  std::string message;
  EXPECT_EQ(
      codec::decodeJpegYcc(jpeg, 256, 256, nullptr, p.y.data(), p.cb.data(), p.cr.data(), message),
      codec::YccDecode::NotYcc420); // not the tile size
  const std::vector<std::byte> garbage(jpeg.begin(), jpeg.begin() + 40);
  EXPECT_EQ(decode(garbage, nullptr, p), codec::YccDecode::Failed);
  // A truncated stream decodes (with grey blocks), as on the RGB path.
  const std::vector<std::byte> truncated(
      jpeg.begin(), jpeg.begin() + static_cast<std::ptrdiff_t>(jpeg.size() / 2));
  EXPECT_EQ(decode(truncated, nullptr, p), codec::YccDecode::Ok);
}
