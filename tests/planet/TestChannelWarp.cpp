// A projector channel's warp mesh and blend mask (issue 28): the identity warp changes nothing, a
// mesh shifted by whole pixels shifts the image, the blend mask scales the colour, and malformed
// meshes are refused.
#include <tellus/planet/ChannelWarp.hpp>

#include <gtest/gtest.h>

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
