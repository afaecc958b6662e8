// Issue 29: the global texture from an overview layer (RendererOptions::overviewLayer). A whole-
// globe view whose level-zero texels are far below a pixel draws the overview and fetches no tile
// of the base layer; a close view fetches the base layer's tiles it draws and no level-zero one.

#include "GlTestSupport.hpp"

#include <tellus/planet_gl/Renderer.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <vector>

using namespace tellus;
using namespace tellus::planet;
using namespace tellus::planet::gltest;

namespace {

const GridSpec kBase{Sector{}, 36.0, 512, 512, 8};
const GridSpec kOverview{Sector{}, 90.0, 256, 256, 1}; // 1024 x 512: 5 times level zero's texel

/** Every overview tile one colour. */
FakeTileSource::Answer solid(std::uint8_t r, std::uint8_t g, std::uint8_t b) {
  std::vector<std::uint8_t> px(256 * 256 * 4);
  for (std::size_t i = 0; i < px.size(); i += 4) {
    px[i] = r;
    px[i + 1] = g;
    px[i + 2] = b;
    px[i + 3] = 255;
  }
  const auto png = encodePngRgba(256, 256, px);
  return [png](const TileAddress&) {
    return FakeTileSource::result(TileStatus::Ok, png, "image/png");
  };
}

} // namespace

TEST(OverviewGl, AWholeGlobeViewDrawsTheOverviewAndFetchesNoBaseTile) {
  const Geodesy geodesy;
  FakeTileSource src;
  src.addLayer({"base", kBase, "image/png", rampTiles(kBase)});
  src.addLayer({"overview", kOverview, "image/png", solid(200, 60, 40)});
  auto o = options("base", 320, 180);
  o.globalImage.clear();
  o.overviewLayer = "overview";
  OPEN_RENDERER(r, src, geodesy, o);
  const CameraPose globe{0.0, 0.0, 2.0e7, 0.0, 0.0};
  const Rendered out = renderComplete(r, globe);
  ASSERT_TRUE(out.complete);
  std::size_t overviewTiles = 0, baseTiles = 0;
  for (const auto& q : src.requests())
    (q.address.layer == "overview" ? overviewTiles : baseTiles) += 1;
  EXPECT_EQ(overviewTiles, 8u); // its 4 x 2 level-zero tiles: the polar caps span every column
  EXPECT_EQ(baseTiles, 0u);
  const auto* c = &out.pixels[static_cast<std::size_t>((o.height / 2 * o.width + o.width / 2) * 4)];
  EXPECT_NEAR(c[0], 200, 3); // the overview's colour, RGBA
  EXPECT_NEAR(c[1], 60, 3);
  EXPECT_NEAR(c[2], 40, 3);

  // Closer: the base layer's tiles where its LOD asks for them, none of level zero (the roots
  // above them fall back on the overview while theirs load), and the image complete.
  const CameraPose close{10.0, 20.0, 2.0e5, 0.0, 0.0};
  const Rendered near = renderComplete(r, close);
  ASSERT_TRUE(near.complete);
  std::size_t levelZero = 0;
  baseTiles = 0;
  for (const auto& q : src.requests())
    if (q.address.layer == "base") {
      ++baseTiles;
      levelZero += q.address.key.level == 0 ? 1u : 0u;
    }
  EXPECT_GT(baseTiles, 0u);
  EXPECT_EQ(levelZero, 0u);
}

// A close view asks only for the overview's tiles under what it draws (and drew on the way).
TEST(OverviewGl, ACloseViewAsksForTheOverviewTilesUnderItOnly) {
  const Geodesy geodesy;
  FakeTileSource src;
  src.addLayer({"base", kBase, "image/png", rampTiles(kBase)});
  src.addLayer({"overview", kOverview, "image/png", solid(200, 60, 40)});
  auto o = options("base", 320, 180);
  o.overviewLayer = "overview";
  OPEN_RENDERER(r, src, geodesy, o);
  const Rendered out = renderComplete(r, {46.5, 9.0, 5.0e4, 0.0, 0.0});
  ASSERT_TRUE(out.complete);
  std::vector<TileKey> asked;
  for (const auto& q : src.requests())
    if (q.address.layer == "overview") asked.push_back(q.address.key);
  // The roots drawn on the way down ask for the tiles under them; never all of them.
  EXPECT_LT(asked.size(), 8u);
  EXPECT_TRUE(std::find(asked.begin(), asked.end(), TileKey{0, 1, 2}) != asked.end()); // 0-90 N, E
}

TEST(OverviewGl, AnUnknownOverviewLayerIsRefused) {
  if (!haveDisplay()) GTEST_SKIP() << "no DISPLAY: run the gl label under xvfb-run";
  const Geodesy geodesy;
  FakeTileSource src;
  src.addLayer({"base", kBase, "image/png", rampTiles(kBase)});
  auto o = options("base", 64, 64);
  o.overviewLayer = "nope";
  const auto made = Renderer::create(src, geodesy, o);
  ASSERT_FALSE(made.has_value());
  EXPECT_NE(made.error().find("nope"), std::string::npos) << made.error();
}
