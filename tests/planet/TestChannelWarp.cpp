// A projector channel's warp mesh and blend mask (issue 28): the identity warp changes nothing, a
// mesh shifted by whole pixels shifts the image, the blend mask scales the colour, and malformed
// meshes are refused.
#include <tellus/planet/ChannelWarp.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>

using namespace tellus::planet;

namespace {

std::size_t index(int x, int y, int width) {
  return static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
         static_cast<std::size_t>(x);
}

ChannelImage pattern(int w, int h) {
  ChannelImage im{w, h, std::vector<std::uint8_t>(index(0, h, w) * 4)};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int k = 0; k < 4; ++k)
        im.rgba[index(x, y, w) * 4 + static_cast<std::size_t>(k)] =
            static_cast<std::uint8_t>(k == 3 ? 255 : (x * 37 + y * 11 + k * 71) % 256);
  return im;
}

std::uint8_t at(const ChannelImage& im, int x, int y, int k) {
  return im.rgba[index(x, y, im.width) * 4 + static_cast<std::size_t>(k)];
}

} // namespace

TEST(ChannelWarp, IdentityWarpIsNoWarp) {
  const ChannelImage im = pattern(64, 40);
  const ChannelImage none = warpAndBlend(im, 64, 40, nullptr, nullptr);
  EXPECT_EQ(none.rgba, im.rgba);
  for (const int n : {2, 3, 17}) {
    const WarpMesh identity = WarpMesh::identity(n, n + 1);
    EXPECT_EQ(warpAndBlend(im, 64, 40, &identity, nullptr).rgba, im.rgba) << n;
  }
}

TEST(ChannelWarp, WithoutAWarpARenderOfAnotherSizeIsScaled) {
  // Rendered at twice the projector's size, each pixel of the pattern as a 2 x 2 block: each
  // projector pixel's centre falls between its block's four pixels, which are its colour.
  const ChannelImage small = pattern(64, 40);
  ChannelImage big{128, 80, std::vector<std::uint8_t>(index(0, 80, 128) * 4)};
  for (int y = 0; y < 80; ++y)
    for (int x = 0; x < 128; ++x)
      for (int k = 0; k < 4; ++k)
        big.rgba[index(x, y, 128) * 4 + static_cast<std::size_t>(k)] = at(small, x / 2, y / 2, k);
  EXPECT_EQ(warpAndBlend(big, 64, 40, nullptr, nullptr).rgba, small.rgba);
  // And up: the projector at twice the rendered size samples between the rendered pixels.
  const ChannelImage up = warpAndBlend(small, 128, 80, nullptr, nullptr);
  ASSERT_EQ(up.rgba.size(), index(0, 80, 128) * 4);
  for (int y = 0; y < 40; y += 7)
    for (int x = 0; x < 64; x += 5) // (2x + 1 + 0.5) / 2 - 0.5 = x + 0.25 of the rendered image
      EXPECT_NEAR(at(up, 2 * x + 1, 2 * y + 1, 0),
                  0.75 * 0.75 * at(small, x, y, 0) +
                      0.25 * 0.75 * at(small, std::min(x + 1, 63), y, 0) +
                      0.75 * 0.25 * at(small, x, std::min(y + 1, 39), 0) +
                      0.25 * 0.25 * at(small, std::min(x + 1, 63), std::min(y + 1, 39), 0),
                  0.51)
          << x << "," << y;
}

TEST(ChannelWarp, ARenderMoreThanTwiceTheProjectorsIsFilteredNotSkipped) {
  EXPECT_EQ(warpSubsamples(64, 40, 64, 40), 1);
  EXPECT_EQ(warpSubsamples(128, 80, 64, 40), 1); // 2x: one bilinear sample reads them all
  EXPECT_EQ(warpSubsamples(129, 80, 64, 40), 2);
  EXPECT_EQ(warpSubsamples(256, 160, 64, 40), 2);
  EXPECT_EQ(warpSubsamples(64, 161, 64, 40), 3); // the larger ratio of the two axes
  EXPECT_EQ(warpSubsamples(16384, 16384, 64, 40), 8);
  // Rendered at 4x: one white pixel in each 4 x 4 block, the rest black. A bilinear sample at a
  // projector pixel's centre falls between four black pixels (the dots vanish); the filtered
  // image is their mean over the footprint, 255 / 16, everywhere; with a warp (the identity mesh)
  // as without one.
  const int w = 32, h = 20;
  ChannelImage dots{4 * w, 4 * h, std::vector<std::uint8_t>(index(0, 4 * h, 4 * w) * 4, 0)};
  for (int y = 0; y < 4 * h; ++y)
    for (int x = 0; x < 4 * w; ++x) {
      const std::uint8_t v = x % 4 == 0 && y % 4 == 0 ? 255 : 0;
      for (int k = 0; k < 3; ++k)
        dots.rgba[index(x, y, 4 * w) * 4 + static_cast<std::size_t>(k)] = v;
      dots.rgba[index(x, y, 4 * w) * 4 + 3] = 255;
    }
  const WarpMesh identity = WarpMesh::identity(3, 3);
  for (const WarpMesh* warp : {static_cast<const WarpMesh*>(nullptr), &identity}) {
    const ChannelImage out = warpAndBlend(dots, w, h, warp, nullptr);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        ASSERT_EQ(at(out, x, y, 0), 16) << x << "," << y; // lround(255 / 16)
        ASSERT_EQ(at(out, x, y, 3), 255);
      }
  }
}

TEST(ChannelWarp, ShiftedMeshShiftsTheImage) {
  const ChannelImage im = pattern(64, 40);
  WarpMesh shift = WarpMesh::identity(5, 5);
  for (auto& uv : shift.uv) {
    uv.x += 3.0 / 64.0; // three pixels right, one up in the rendered image
    uv.y -= 1.0 / 40.0;
  }
  const ChannelImage out = warpAndBlend(im, 64, 40, &shift, nullptr);
  for (int y = 1; y < 40; ++y)
    for (int x = 0; x < 61; ++x)
      for (int k = 0; k < 3; ++k)
        ASSERT_EQ(at(out, x, y, k), at(im, x + 3, y - 1, k)) << x << "," << y;
  EXPECT_NE(out.rgba, im.rgba);
}

TEST(ChannelWarp, BlendMaskScalesTheColour) {
  const ChannelImage im = pattern(8, 4);
  std::vector<float> mask(32, 1.0f);
  mask[0] = 0.0f;
  mask[9] = 0.5f;
  const ChannelImage out = warpAndBlend(im, 8, 4, nullptr, &mask);
  EXPECT_EQ(at(out, 0, 0, 0), 0);
  EXPECT_EQ(at(out, 0, 0, 3), 255); // alpha stays
  EXPECT_EQ(at(out, 1, 1, 1), static_cast<int>(std::lround(at(im, 1, 1, 1) * 0.5)));
  EXPECT_EQ(at(out, 2, 2, 2), at(im, 2, 2, 2));
}

TEST(ChannelWarp, RefusesMalformedMeshes) {
  auto error = [](const std::string& json) {
    const auto m = parseWarpMesh(json, "w.json");
    return m ? std::string("parsed") : m.error();
  };
  EXPECT_EQ(error("[]"), "w.json: not a JSON object");
  EXPECT_EQ(error(R"({"columns": 1, "rows": 2, "uv": []})"),
            "w.json: columns: an integer in [2, 4096] is required");
  EXPECT_EQ(error(R"({"columns": 2, "rows": 2, "uv": [[0, 0]]})"),
            "w.json: uv: 4 [u, v] pairs (rows x columns) required");
  EXPECT_EQ(error(R"({"columns": 2, "rows": 2, "uv": [[0, 0], [1, 0], [0, 1], [1]]})"),
            "w.json: uv[3]: not a pair of finite numbers");
  EXPECT_EQ(error(R"({"columns": 2, "rows": 2, "uv": [], "mode": 1})"),
            "w.json: unknown key \"mode\"");
  const auto ok =
      parseWarpMesh(R"({"columns": 2, "rows": 2, "uv": [[0, 0], [1, 0], [0, 1], [1, 1]]})");
  ASSERT_TRUE(ok.has_value());
  EXPECT_EQ(ok->uv, WarpMesh::identity().uv);
  EXPECT_FALSE(readWarpMesh("/nonexistent/w.json").has_value());
  EXPECT_FALSE(readBlendMask("/nonexistent/m.png", 2, 2).has_value());
}
