// A polar cap fetched in bands (issue 29, proxy/src/tiles/CapBands.hpp): the bands' boxes and
// sizes at both poles, from level zero's 36-degree rows down to centimetre rows, and the cap made
// of their images.

#include "../../proxy/src/tiles/CapBands.hpp"
#include "../support/SyntheticWms.hpp"

#include <tellus/proxy/ImageCodec.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

using namespace tellus;

namespace {

Sector capRow(bool north, double h) {
  return north ? Sector{-180.0, 90.0 - h, 180.0, 90.0} : Sector{-180.0, -90.0, 180.0, -90.0 + h};
}

std::vector<std::byte> bytesOf(const std::string& s) {
  const auto b = std::as_bytes(std::span(s.data(), s.size()));
  return {b.begin(), b.end()};
}

/** PSNR of two decoded images of the same size. */
double psnr(const DecodedImage& a, const DecodedImage& b) {
  double sum = 0.0;
  for (std::size_t i = 0; i < a.pixels.size(); ++i) {
    const double d = static_cast<double>(a.pixels[i]) - static_cast<double>(b.pixels[i]);
    sum += d * d;
  }
  return sum == 0.0 ? 99.0
                    : 10.0 * std::log10(255.0 * 255.0 * static_cast<double>(a.pixels.size()) / sum);
}

} // namespace

// At both poles and every row height from level zero's 36 degrees to a level-30 row, for tiles of
// 512, 256 and 205 px: the bands cover the row exactly (every longitude, latitudes joined end to
// end from the pole to the rim, the rim and the pole exact), their rows sum to the image's, the
// rim band is the cap's full width, and no band's equatorward parallel has wider texels than the
// rim (in metres: width / sin(co-latitude) never below the rim's); the texels asked for are at
// most 0.6 of one GetMap of the whole row.
TEST(CapBandsExtremes, BandsTileTheRowAndKeepTheRimsTexelWidth) {
  const double toRad = std::numbers::pi / 180.0;
  for (const bool north : {true, false})
    for (const int tile : {512, 256, 205})
      for (int level = 0; level <= 30; level += 5) {
        const double h = std::ldexp(36.0, -level);
        const int width = 8 * tile;
        SCOPED_TRACE(std::to_string(tile) + " px, level " + std::to_string(level) +
                     (north ? " north" : " south"));
        const Sector row = capRow(north, h);
        const auto bands = capBands(row, width, tile);
        ASSERT_EQ(bands.size(), static_cast<std::size_t>(kCapBands));
        int rows = 0;
        double texels = 0.0;
        for (std::size_t i = 0; i < bands.size(); ++i) {
          const CapBand& b = bands[i];
          EXPECT_EQ(b.box.west, -180.0);
          EXPECT_EQ(b.box.east, 180.0);
          EXPECT_EQ(b.row0, rows);
          EXPECT_GE(b.height, kMinCapBandRows);
          EXPECT_LT(b.box.south, b.box.north);
          if (i > 0) {
            EXPECT_EQ(b.box.north, bands[i - 1].box.south); // joined, no gap
          }
          // The band's degrees a row are the whole row's, to the precision of a latitude near 90
          // degrees (an ulp is 1.4e-14 degrees there: 1.6 nm).
          EXPECT_NEAR(b.box.north - b.box.south, h * b.height / tile, 1e-13);
          const double colat = 90.0 - std::fabs(north ? b.box.south : b.box.north);
          EXPECT_GE(b.width / std::sin(colat * toRad), width / std::sin(h * toRad) * (1 - 1e-12));
          EXPECT_LE(b.width, width);
          rows += b.height;
          texels += static_cast<double>(b.width) * b.height;
        }
        EXPECT_EQ(rows, tile);
        EXPECT_EQ(bands.front().box.north, row.north);
        EXPECT_EQ(bands.back().box.south, row.south);
        EXPECT_EQ((north ? bands.back() : bands.front()).width, width); // the rim's band
        EXPECT_LE(texels, 0.6 * width * tile);
      }
}

// Rows that are no cap, or too short to cut, are one band: the whole row as asked.
TEST(CapBandsExtremes, WhatIsNoCapIsOneBand) {
  const auto one = [](const Sector& s, int w, int h) {
    const auto b = capBands(s, w, h);
    return b.size() == 1 && b[0] == CapBand{s, w, h, 0};
  };
  EXPECT_TRUE(one(Sector{-180.0, 54.0, 180.0, 72.0}, 2048, 256));     // touches no pole
  EXPECT_TRUE(one(Sector{-180.0, -90.0, 180.0, 90.0}, 2048, 1024));   // both poles
  EXPECT_TRUE(one(Sector{-180.0, -90.0, 180.0, 90.0 - 180.0}, 8, 8)); // empty
  EXPECT_TRUE(one(Sector{-180.0, -90.0, 180.0, 10.0}, 2048, 256));    // past the equator
  EXPECT_TRUE(one(capRow(true, 36.0), 256, 2 * kMinCapBandRows - 1)); // too few rows
  EXPECT_EQ(capBands(capRow(true, 36.0), 256, 2 * kMinCapBandRows).size(), 2u);
}

// The cap from its bands' images against one GetMap of the whole row, on the smooth synthetic
// picture, at both poles, level zero and deep: within JPEG's noise (PSNR >= 38 dB).
TEST(CapBands, TheCapOfItsBandsIsTheWholeRowsPicture) {
  for (const bool north : {true, false})
    for (const double h : {36.0, 36.0 / 1024.0}) {
      SCOPED_TRACE(std::to_string(h) + (north ? " north" : " south"));
      const Sector row = capRow(north, h);
      const auto bands = capBands(row, 2048, 256);
      std::vector<std::vector<std::byte>> images;
      for (const CapBand& b : bands)
        images.push_back(bytesOf(test::syntheticJpeg(
            b.box.west, b.box.south, b.box.east, b.box.north, b.width, b.height)));
      const auto cap = composeBands(bands, images, 2048, 256, "image/jpeg");
      ASSERT_TRUE(cap) << cap.error();
      const auto got = decodeImagery(*cap, "image/jpeg", 2048, 256);
      ASSERT_TRUE(got) << got.error();
      const auto whole =
          bytesOf(test::syntheticJpeg(row.west, row.south, row.east, row.north, 2048, 256));
      const auto want = decodeImagery(whole, "image/jpeg", 2048, 256);
      ASSERT_TRUE(want);
      const double p = psnr(*got, *want);
      std::printf("cap of %zu bands against the whole row: PSNR %.1f dB\n", bands.size(), p);
      EXPECT_GE(p, 38.0);
    }
}

// The stretch wraps around the antimeridian (the row is a whole parallel): the cap's first and
// last columns blend the band's last and first texels; a transparent texel does not darken its
// neighbour (premultiplied); a band of the wrong size or no image refuses the cap.
TEST(CapBands, TheStretchWrapsAndKeepsAlpha) {
  const std::vector<CapBand> bands = {{Sector{-180.0, 89.0, 180.0, 90.0}, 2, 1, 0},
                                      {Sector{-180.0, 88.0, 180.0, 89.0}, 2, 1, 1}};
  // Band 0: white then black, opaque; band 1: red, then transparent.
  const std::uint8_t b0[] = {255, 255, 255, 0, 0, 0};
  const std::uint8_t b1[] = {255, 0, 0, 255, 0, 0, 0, 0};
  const std::vector<std::vector<std::byte>> images = {*encodeImage("image/png", 2, 1, 3, b0),
                                                      *encodeImage("image/png", 2, 1, 4, b1)};
  const auto cap = composeBands(bands, images, 4, 2, "image/png");
  ASSERT_TRUE(cap) << cap.error();
  const auto img = decodeImagery(*cap, "image/png", 4, 2);
  ASSERT_TRUE(img) << img.error();
  ASSERT_EQ(img->channels, 4);
  const auto px = [&](int x, int y, int c) {
    return static_cast<int>(img->pixels[static_cast<std::size_t>((y * 4 + x) * 4 + c)]);
  };
  // Two texels stretched to four columns: column 0's centre is a quarter texel west of texel 0's,
  // so it takes a quarter of texel 1, across the antimeridian; column 3 a quarter of texel 0.
  EXPECT_EQ(px(0, 0, 0), 191);
  EXPECT_EQ(px(1, 0, 0), 191);
  EXPECT_EQ(px(2, 0, 0), 64);
  EXPECT_EQ(px(3, 0, 0), 64);
  EXPECT_EQ(px(0, 0, 3), 255); // an opaque band stays opaque in an RGBA cap
  // Red beside transparent: the colour stays red, only the alpha blends.
  for (int x = 0; x < 4; ++x)
    if (px(x, 1, 3) > 0) {
      EXPECT_EQ(px(x, 1, 0), 255) << x;
    }
  EXPECT_EQ(px(0, 1, 3), 191);
  EXPECT_EQ(px(1, 1, 3), 191);
  EXPECT_EQ(px(2, 1, 3), 64);
  EXPECT_EQ(px(3, 1, 3), 64);
  const std::uint8_t three[9] = {};
  const std::vector<std::vector<std::byte>> wrong = {images[0],
                                                     *encodeImage("image/png", 3, 1, 3, three)};
  EXPECT_FALSE(composeBands(bands, wrong, 4, 2, "image/png"));
  const std::vector<std::vector<std::byte>> junk = {images[0], bytesOf("no image")};
  EXPECT_FALSE(composeBands(bands, junk, 4, 2, "image/png"));
  EXPECT_FALSE(composeBands(bands, std::span(images).first(1), 4, 2, "image/png"));
}
