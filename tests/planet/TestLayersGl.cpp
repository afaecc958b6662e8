// Layers over the base imagery (issue #7, label gl): blending by pixels in one pass and in several,
// opacity and visibility, a layer's maximum level, time changes that swap a layer all at once, and
// regional datasets inside one layer (the smallest covering dataset wins).

#include "../support/FakeTileSource.hpp"
#include "GlTestSupport.hpp"

#include <tellus/cache/TileGrid.hpp>
#include <tellus/planet/Camera.hpp>
#include <tellus/planet/RegionalSource.hpp>
#include <tellus/planet_gl/Renderer.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <deque>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

using namespace tellus;
using namespace tellus::planet;
using tellus::planet::gltest::haveDisplay;

namespace {

using Rgba = std::array<std::uint8_t, 4>;

std::vector<std::byte> solidPng(int w, int h, Rgba c) {
  std::vector<std::uint8_t> px(static_cast<std::size_t>(w * h * 4));
  for (std::size_t i = 0; i < px.size(); i += 4)
    std::copy(c.begin(), c.end(), px.begin() + static_cast<std::ptrdiff_t>(i));
  return encodePngRgba(w, h, px);
}

/** Layers of one colour each (a colour per layer and time) through the tests' fake tile source.
 * Requests of times listed in `held` wait until source.release(); the others are answered at once.
 * A (layer, time) without a colour is absent. */
struct ColourWorld {
  ColourWorld() {
    source.holdIf([this](const TileAddress& a) { return held.contains(a.time); });
  }
  void add(const std::string& layer, GridSpec grid) {
    source.addLayer(
        {layer, grid, "image/png", [this, grid](const TileAddress& a) {
           const auto c = colours.find({a.layer, a.time});
           if (c == colours.end()) return test::FakeTileSource::result(TileStatus::Absent);
           return test::FakeTileSource::result(
               TileStatus::Ok, solidPng(grid.tileWidth, grid.tileHeight, c->second), "image/png");
         }});
  }
  std::map<std::pair<std::string, std::string>, Rgba> colours; ///< (layer, time) -> colour
  std::set<std::string> held;
  test::FakeTileSource source; ///< last: gone before what its answers read
};

constexpr GridSpec kGrid{Sector{}, 36.0, 32, 32, 6};
constexpr Rgba kBase{200, 40, 40, 255};
constexpr Rgba kBlue{20, 60, 220, 255};
constexpr Rgba kGreenHalf{0, 255, 0, 128}; ///< a texel that is itself half transparent

void fill(ColourWorld& w) {
  w.add("base", kGrid);
  w.add("blue", kGrid);
  w.add("green", kGrid);
  w.add("empty", kGrid); // every tile absent: must show what lies under it
  w.colours[{"base", ""}] = kBase;
  w.colours[{"blue", ""}] = kBlue;
  w.colours[{"green", ""}] = kGreenHalf;
}

RendererOptions opts(std::vector<LayerOptions> overlays, int perPass = 0) {
  RendererOptions o;
  o.layer = "base";
  o.width = 96;
  o.height = 96;
  o.overlays = std::move(overlays);
  o.overlaysPerPass = perPass;
  return o;
}

const CameraPose kView{10.0, 20.0, 8.0e6, 0.0, 0.0}; // the globe fills the middle of the image

Rgba centre(const Renderer& r, const std::vector<std::uint8_t>& px) {
  const auto i = static_cast<std::size_t>(((r.height() / 2) * r.width() + r.width() / 2) * 4);
  return {px[i], px[i + 1], px[i + 2], px[i + 3]};
}

/** Over the middle 20 x 20 pixels (inside the globe): the largest difference from `want`. */
int worstOff(const Renderer& r,
             const std::vector<std::uint8_t>& px,
             const std::array<double, 3>& want) {
  int worst = 0;
  for (int y = r.height() / 2 - 10; y < r.height() / 2 + 10; ++y)
    for (int x = r.width() / 2 - 10; x < r.width() / 2 + 10; ++x)
      for (std::size_t c = 0; c < 3; ++c) {
        const double v = px[static_cast<std::size_t>((y * r.width() + x) * 4) + c];
        worst = std::max(worst, static_cast<int>(std::lround(std::abs(v - want[c]))));
      }
  return worst;
}

std::array<double, 3> over(const std::array<double, 3>& under, Rgba top, double opacity) {
  const double a = top[3] / 255.0 * opacity;
  std::array<double, 3> out{};
  for (std::size_t c = 0; c < 3; ++c)
    out[c] = under[c] * (1.0 - a) + top[c] * a;
  return out;
}

const std::array<double, 3> kBaseRgb{kBase[0], kBase[1], kBase[2]};

TEST(LayersGl, HalfOverlayOverAKnownColourGivesTheMix) {
  ColourWorld w;
  fill(w);
  const Geodesy wgs;
  OPEN_RENDERER(r, w.source, wgs, opts({{"blue", "", 0.5, true, -1}}));
  const auto done = gltest::renderComplete(r, kView);
  ASSERT_TRUE(done.complete);
  const auto want = over(kBaseRgb, kBlue, 0.5); // (110, 50, 130)
  EXPECT_LE(worstOff(r, done.pixels, want), 2)
      << "centre " << int(centre(r, done.pixels)[0]) << "," << int(centre(r, done.pixels)[1]) << ","
      << int(centre(r, done.pixels)[2]);
  EXPECT_EQ(done.stats.passes, 1);
  ASSERT_EQ(done.stats.layers.size(), 2u);
  EXPECT_EQ(done.stats.layers[1].name, "blue");
  EXPECT_GT(done.stats.layers[1].tilesReceived, 0u);
}

// Three overlays (one with its own alpha, one absent everywhere) in one pass and in one pass
// each: the same colours, and the texel's alpha times the layer's opacity.
TEST(LayersGl, OnePassAndSeveralPassesGiveTheSameImage) {
  ColourWorld w;
  fill(w);
  const Geodesy wgs;
  const std::vector<LayerOptions> layers = {
      {"blue", "", 0.5, true, -1}, {"empty", "", 1.0, true, -1}, {"green", "", 0.8, true, -1}};
  std::vector<std::uint8_t> one, several;
  {
    OPEN_RENDERER(r, w.source, wgs, opts(layers));
    const auto done = gltest::renderComplete(r, kView);
    ASSERT_TRUE(done.complete);
    ASSERT_GE(done.stats.overlaysPerPass, 3);
    EXPECT_EQ(done.stats.passes, 1);
    one = done.pixels;
    const auto want = over(over(kBaseRgb, kBlue, 0.5), kGreenHalf, 0.8);
    EXPECT_LE(worstOff(r, one, want), 2);
  }
  {
    OPEN_RENDERER(r, w.source, wgs, opts(layers, 1));
    const auto done = gltest::renderComplete(r, kView);
    ASSERT_TRUE(done.complete);
    EXPECT_EQ(done.stats.overlaysPerPass, 1);
    EXPECT_EQ(done.stats.passes, 2); // "empty" has no texture anywhere: nothing to draw
    several = done.pixels;
  }
  ASSERT_EQ(one.size(), several.size());
  int worst = 0;
  for (std::size_t i = 0; i < one.size(); ++i)
    worst = std::max(worst, std::abs(int(one[i]) - int(several[i])));
  EXPECT_LE(worst, 1) << "one pass and three passes differ";
}

// The same on the dome drawn directly (issue #7): the later passes map the vertices through the
// fisheye again and must land on the first pass's depth exactly (invariant gl_Position, depth
// test GEQUAL), or the overlays would be missing or z-fight.
TEST(LayersGl, DirectDomeOnePassAndSeveralPassesGiveTheSameImage) {
  ColourWorld w;
  fill(w);
  const Geodesy wgs;
  const std::vector<LayerOptions> layers = {
      {"blue", "", 0.5, true, -1}, {"empty", "", 1.0, true, -1}, {"green", "", 0.8, true, -1}};
  std::vector<std::uint8_t> images[2];
  for (const int perPass : {0, 1}) {
    RendererOptions o = opts(layers, perPass);
    o.width = o.height = 192; // the globe 28 px around the centre: the middle 20 x 20 is ground
    o.dome = DomeOptions{180.0, 0.0, 0.64};
    o.dome->method = DomeMethod::Direct;
    OPEN_RENDERER(r, w.source, wgs, o);
    const auto done = gltest::renderComplete(r, kView);
    ASSERT_TRUE(done.complete);
    EXPECT_EQ(done.stats.domeMethod, "direct");
    EXPECT_EQ(done.stats.passes, perPass == 1 ? 2 : 1);
    const auto want = over(over(kBaseRgb, kBlue, 0.5), kGreenHalf, 0.8);
    EXPECT_LE(worstOff(r, done.pixels, want), 2) << perPass;
    images[perPass] = done.pixels;
  }
  int worst = 0;
  for (std::size_t i = 0; i < images[0].size(); ++i)
    worst = std::max(worst, std::abs(int(images[0][i]) - int(images[1][i])));
  EXPECT_LE(worst, 1) << "one pass and two passes differ on the direct dome";
}

TEST(LayersGl, OpacityVisibilityAndMaximumLevelChangeAtRunTime) {
  ColourWorld w;
  fill(w);
  const Geodesy wgs;
  // Close enough that the base goes deeper than level 1.
  const CameraPose low{10.0, 20.0, 3.0e5, 0.0, 0.0};
  OPEN_RENDERER(r, w.source, wgs, opts({{"blue", "", 1.0, true, 1}}));
  auto done = gltest::renderComplete(r, low);
  ASSERT_TRUE(done.complete);
  EXPECT_GT(done.stats.maxLevel, 1);
  EXPECT_LE(w.source.deepestLevel("blue"), 1);           // never asked past its maximum level
  EXPECT_LE(worstOff(r, done.pixels, {20, 60, 220}), 2); // drawn from its level-1 tiles
  r.setLayerOpacity(1, 0.25);
  done = gltest::renderComplete(r, low);
  EXPECT_LE(worstOff(r, done.pixels, over(kBaseRgb, kBlue, 0.25)), 2);
  r.setLayerVisible(1, false);
  done = gltest::renderComplete(r, low);
  EXPECT_LE(worstOff(r, done.pixels, kBaseRgb), 2);
  EXPECT_THROW(r.setLayerOpacity(1, 1.5), std::invalid_argument);
  EXPECT_THROW(r.setLayerOpacity(0, 0.5), std::invalid_argument);
  EXPECT_THROW(r.setLayerVisible(2, true), std::invalid_argument);
}

TEST(LayersGl, OrderAndMaximumLevelChangeAtRunTime) {
  ColourWorld w;
  fill(w);
  const Geodesy wgs;
  const CameraPose low{10.0, 20.0, 3.0e5, 0.0, 0.0};
  OPEN_RENDERER(
      r, w.source, wgs, opts({{"green", "", 1.0, true, -1}, {"blue", "", 1.0, true, -1}}));
  auto done = gltest::renderComplete(r, low);
  ASSERT_TRUE(done.complete);
  EXPECT_LE(worstOff(r, done.pixels, {20, 60, 220}), 2); // opaque blue on top
  r.moveLayer(2, 1);                                     // blue below green now
  done = gltest::renderComplete(r, low);
  EXPECT_EQ(done.stats.layers[2].name, "green");
  EXPECT_LE(worstOff(r, done.pixels, over({20, 60, 220}, kGreenHalf, 1.0)), 2);
  // The deepest level of a layer: swapped in once its coarser textures are there.
  EXPECT_EQ(done.stats.layers[1].levels, kGrid.numLevels);
  r.setLayerMaxLevel(1, 0);
  done = gltest::renderComplete(r, low);
  ASSERT_TRUE(done.complete);
  EXPECT_EQ(done.stats.layers[1].levels, 1);
  EXPECT_EQ(done.stats.layers[1].maxLevel, 0);
  EXPECT_EQ(done.stats.layers[1].swaps, 1u);
  EXPECT_LE(worstOff(r, done.pixels, over({20, 60, 220}, kGreenHalf, 1.0)), 2);
  EXPECT_THROW(r.moveLayer(0, 1), std::invalid_argument);
  EXPECT_THROW(r.setLayerMaxLevel(1, -2), std::invalid_argument);
}

// A time change: the new time's tiles are fetched while the old time is still drawn, and the layer
// swaps all at once (never tile by tile) when they are all there.
TEST(LayersGl, TimeChangeSwapsTheLayerAllAtOnce) {
  ColourWorld w;
  fill(w);
  w.colours[{"blue", "2020-01-01"}] = kBlue;
  w.colours[{"blue", "2020-01-02"}] = Rgba{250, 250, 20, 255};
  w.held = {"2020-01-02"};
  const Geodesy wgs;
  OPEN_RENDERER(r, w.source, wgs, opts({{"blue", "2020-01-01", 1.0, true, -1}}));
  auto done = gltest::renderComplete(r, kView);
  ASSERT_TRUE(done.complete);
  EXPECT_LE(worstOff(r, done.pixels, {20, 60, 220}), 2);
  r.setLayerTime(1, "2020-01-02");
  // Answer the new time's tiles a few at a time: until the last one, every frame shows the old
  // time everywhere.
  int frames = 0;
  for (; frames < 400; ++frames) {
    r.frame(kView);
    const auto px = r.readPixels();
    if (r.stats().layers[1].pendingTime.empty()) break; // swapped
    EXPECT_EQ(r.stats().layers[1].time, "2020-01-01");
    ASSERT_LE(worstOff(r, px, {20, 60, 220}), 2) << "a tile of the new time showed before the swap";
    EXPECT_FALSE(r.complete());
    w.source.release(1);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  EXPECT_GT(frames, 5) << "the new time's tiles came in over several frames";
  EXPECT_EQ(r.stats().layers[1].swaps, 1u);
  EXPECT_EQ(r.stats().layers[1].time, "2020-01-02");
  done = gltest::renderComplete(r, kView);
  EXPECT_LE(worstOff(r, done.pixels, {250, 250, 20}), 2);
  // Going back and forth before a swap: setting the current time again cancels the pending one.
  r.setLayerTime(1, "2020-01-01");
  r.frame(kView);
  EXPECT_EQ(r.stats().layers[1].pendingTime, "2020-01-01");
  r.setLayerTime(1, "2020-01-02");
  r.frame(kView);
  EXPECT_TRUE(r.stats().layers[1].pendingTime.empty());
  EXPECT_EQ(r.stats().layers[1].swaps, 1u);
}

// The base layer changes time the same way (a daily imagery set as the base).
TEST(LayersGl, TheBaseLayerSwapsTimeAllAtOnceToo) {
  ColourWorld w;
  fill(w);
  w.colours[{"base", "d1"}] = kBase;
  w.colours[{"base", "d2"}] = Rgba{30, 200, 30, 255};
  w.held = {"d2"};
  const Geodesy wgs;
  RendererOptions o = opts({});
  o.time = "d1";
  OPEN_RENDERER(r, w.source, wgs, o);
  ASSERT_TRUE(gltest::renderComplete(r, kView).complete);
  r.setLayerTime(0, "d2");
  for (int i = 0; i < 400; ++i) {
    r.frame(kView);
    if (r.stats().layers[0].pendingTime.empty()) break; // swapped
    ASSERT_LE(worstOff(r, r.readPixels(), kBaseRgb), 2) << "a tile of d2 showed before the swap";
    w.source.release(1);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  const auto done = gltest::renderComplete(r, kView);
  ASSERT_TRUE(done.complete);
  EXPECT_LE(worstOff(r, done.pixels, {30, 200, 30}), 2);
  EXPECT_EQ(done.stats.layers[0].swaps, 1u);
}

// Regional datasets in one layer: a global dataset (levels 0-2) and a detailed regional one
// (levels 0-5) over a box; deep over the box the regional colour shows, elsewhere the global one
// (deeper levels there are absent and fall back to the global dataset's level 2).
TEST(LayersGl, TheSmallestCoveringDatasetWins) {
  ColourWorld w;
  w.add("global", GridSpec{Sector{}, 36.0, 32, 32, 3});
  w.add("region", GridSpec{Sector{9.0, 0.0, 27.0, 18.0}, 36.0, 32, 32, 6});
  w.colours[{"global", ""}] = kBase;
  w.colours[{"region", ""}] = kBlue;
  auto regional = RegionalTileSource::create(w.source, {{"imagery", {"global", "region"}}});
  ASSERT_TRUE(regional.has_value()) << regional.error();
  const Geodesy wgs;
  RendererOptions o = opts({});
  o.layer = "imagery";
  OPEN_RENDERER(r, **regional, wgs, o);
  // Inside the box, close: regional tiles.
  auto done = gltest::renderComplete(r, {9.0, 18.0, 4.0e5, 0.0, 0.0});
  ASSERT_TRUE(done.complete);
  EXPECT_GT(done.stats.maxLevel, 2);
  EXPECT_LE(worstOff(r, done.pixels, {20, 60, 220}), 2);
  // Outside it, as close: the global dataset's colour.
  done = gltest::renderComplete(r, {-30.0, -60.0, 4.0e5, 0.0, 0.0});
  ASSERT_TRUE(done.complete);
  EXPECT_LE(worstOff(r, done.pixels, kBaseRgb), 2);
  EXPECT_EQ(w.source.deepestLevel("global"), 2);
  EXPECT_GT(w.source.deepestLevel("region"), 2);
}

TEST(LayersGl, AnOverlayOnAnotherGridIsRefusedWithAReason) {
  ColourWorld w;
  fill(w);
  w.add("coarse", GridSpec{Sector{}, 20.0, 32, 32, 3});
  const Geodesy wgs;
  if (!haveDisplay()) GTEST_SKIP() << "no DISPLAY";
  auto made = Renderer::create(w.source, wgs, opts({{"coarse", "", 1.0, true, -1}}));
  ASSERT_FALSE(made.has_value());
  EXPECT_NE(made.error().find("grid"), std::string::npos) << made.error();
  made = Renderer::create(w.source, wgs, opts({{"nope", "", 1.0, true, -1}}));
  ASSERT_FALSE(made.has_value());
  made = Renderer::create(w.source, wgs, opts({{"blue", "", 2.0, true, -1}}));
  ASSERT_FALSE(made.has_value());
}

} // namespace
