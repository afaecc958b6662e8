// Fade-in (issue 23, "No popping"; label gl): a texture that arrives is mixed over what was drawn
// before it by the fraction of the fade time passed on the renderer's injected frame clock, the
// frame is not complete while a fade runs, and once settled the image is the one drawn without
// fading, bit for bit; heights that arrive fade in alike (HeightField::setFade). The probe of
// bench/popping.sh (Renderer::redrawLast) redraws the last frame's state and changes nothing.
#include "../support/FakeTileSource.hpp"
#include "GlTestSupport.hpp"

#include <tellus/planet_gl/Renderer.hpp>
#include <tellus/proxy/ImageCodec.hpp>

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <thread>

using namespace tellus;
using namespace tellus::planet;

namespace {

using tellus::planet::gltest::haveDisplay;
using tellus::test::FakeTileSource;

constexpr GridSpec kGrid{Sector{}, 36.0, 64, 64, 8};

/** One solid colour per level: a texture and its parent's differ everywhere by a known amount. */
TileResult levelTile(const TileAddress& a) {
  const int w = kGrid.tileWidth, h = kGrid.tileHeight, level = a.key.level;
  std::vector<std::uint8_t> px(static_cast<std::size_t>(w * h * 4));
  for (std::size_t i = 0; i < px.size(); i += 4) {
    px[i] = static_cast<std::uint8_t>(30 + 40 * level);
    px[i + 1] = 120;
    px[i + 2] = static_cast<std::uint8_t>(230 - 40 * level);
    px[i + 3] = 255;
  }
  return FakeTileSource::result(TileStatus::Ok, encodePngRgba(w, h, px), "image/png");
}

/** Frames of one pose until nothing is fetched, decoded or uploaded (the clock standing still). */
void settle(Renderer& r, const CameraPose& pose) {
  const auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < 2000; ++i) {
    r.frame(pose);
    if (!r.busy() && r.stats().uploadsPending == 0 && i > 3) break;
    if (std::chrono::steady_clock::now() - start > std::chrono::seconds(30)) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  r.frame(pose);
}

struct Rgb {
  int r, g, b;
};
Rgb centre(const Renderer& r, const std::vector<std::uint8_t>& px) {
  const auto* p = &px[static_cast<std::size_t>(((r.height() / 2) * r.width() + r.width() / 2) * 4)];
  return {p[0], p[1], p[2]};
}

TEST(FadeGl, AnArrivingTextureBlendsOverItsAncestorsByTheFractionOfTheFadeTime) {
  if (!haveDisplay()) GTEST_SKIP() << "no DISPLAY: run the gl label under xvfb-run";
  FakeTileSource world;
  world.addLayer({"imagery", kGrid, "image/png", levelTile});
  world.setDelivery(FakeTileSource::Delivery::Worker);
  const Geodesy wgs;
  const CameraPose pose{10.0, 20.0, 3.0e6, 0.0, 0.0};
  double clockS = 0.0;
  RendererOptions o;
  o.layer = "imagery";
  o.width = o.height = 128;
  o.fadeInSeconds = 1.0;
  o.frameClock = [&clockS] { return clockS; };
  auto made = Renderer::create(world, wgs, o);
  ASSERT_TRUE(made.has_value()) << made.error();
  Renderer& r = **made;
  // Everything arrives while the clock stands at 0: a texture waits while the one it would fade
  // from is fading itself, so the levels fade in one after the other, one a second (the fade
  // time): at whole seconds k one level is complete and the next starts (weight 0), at k + 0.25
  // that one is a quarter in. Not complete until the last has faded in.
  settle(r, pose);
  EXPECT_FALSE(r.complete());
  int checked = 0;
  Rgb at = centre(r, r.readPixels());
  std::vector<std::uint8_t> faded;
  for (int k = 0; k < 16 && !r.complete(); ++k) {
    clockS = k + 0.25;
    r.frame(pose);
    const Rgb quarter = centre(r, r.readPixels());
    clockS = k + 1.0;
    r.frame(pose);
    faded = r.readPixels();
    const Rgb next = centre(r, faded);
    if (std::abs(next.r - at.r) >= 30) { // a level's fade (40 apart in red and blue): can fail
      // mix(from, to, 0.25) per channel; 1.5: the 8-bit rounding of both textures and the result.
      EXPECT_NEAR(quarter.r, at.r + 0.25 * (next.r - at.r), 1.5) << "second " << k;
      EXPECT_NEAR(quarter.g, at.g + 0.25 * (next.g - at.g), 1.5) << "second " << k;
      EXPECT_NEAR(quarter.b, at.b + 0.25 * (next.b - at.b), 1.5) << "second " << k;
      ++checked;
    }
    at = next;
  }
  EXPECT_TRUE(r.complete());
  EXPECT_GE(checked, 1); // a level faded in (the root over the global texture differs less in red)

  // Settled, the image is the one a renderer without fading draws, bit for bit.
  FakeTileSource world2;
  world2.addLayer({"imagery", kGrid, "image/png", levelTile});
  world2.setDelivery(FakeTileSource::Delivery::Worker);
  RendererOptions plain = o;
  plain.fadeInSeconds = 0.0;
  plain.frameClock = {};
  auto made2 = Renderer::create(world2, wgs, plain);
  ASSERT_TRUE(made2.has_value()) << made2.error();
  settle(**made2, pose);
  EXPECT_TRUE((*made2)->complete());
  const std::vector<std::uint8_t> unfaded = (*made2)->readPixels();
  ASSERT_EQ(faded.size(), unfaded.size());
  std::size_t differ = 0;
  for (std::size_t i = 0; i < faded.size(); ++i)
    differ += faded[i] != unfaded[i] ? 1U : 0U;
  EXPECT_EQ(differ, 0u) << "a settled frame must not depend on fading";
}

constexpr GridSpec kHeightGrid{Sector{}, 20.0, 16, 16, 5};

/** Heights with relief at every level (metres, BIL16): ridges of 3 km and finer ones. */
TileResult heightTile(const TileAddress& a) {
  const Sector s = TileGrid::create(kHeightGrid)->sectorOf(a.key);
  const int w = kHeightGrid.tileWidth, h = kHeightGrid.tileHeight;
  std::vector<std::byte> bytes(static_cast<std::size_t>(w * h * 2));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double lat = s.north - (y + 0.5) * (s.north - s.south) / h;
      const double lon = s.west + (x + 0.5) * (s.east - s.west) / w;
      const auto m = static_cast<std::int16_t>(
          std::lround(1500.0 + 1500.0 * std::sin(lat * 0.9) * std::cos(lon * 1.7) +
                      (a.key.level + 1) * 150.0 * std::sin(lat * 7.0 + lon * 5.0)));
      std::memcpy(&bytes[static_cast<std::size_t>((y * w + x) * 2)], &m, 2); // little-endian
    }
  return FakeTileSource::result(TileStatus::Ok, bytes, "application/bil16");
}

std::size_t differing(const std::vector<std::uint8_t>& a, const std::vector<std::uint8_t>& b) {
  std::size_t n = 0;
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i)
    n += a[i] != b[i] ? 1U : 0U;
  return n;
}

/** Heights fade in with the textures: not complete while they do, and the settled image is the
 * one a renderer without fading draws, bit for bit. */
TEST(FadeGl, HeightsFadeInAndTheSettledImageIsTheUnfadedOne) {
  if (!haveDisplay()) GTEST_SKIP() << "no DISPLAY: run the gl label under xvfb-run";
  const CameraPose pose{10.0, 20.0, 4.0e5, 30.0, 50.0};
  auto world = [] {
    auto w = std::make_unique<FakeTileSource>();
    w->addLayer({"imagery", kGrid, "image/png", levelTile});
    w->addLayer({"heights", kHeightGrid, "application/bil16", heightTile});
    w->setDelivery(FakeTileSource::Delivery::Worker);
    return w;
  };
  const Geodesy wgs;
  double clockS = 0.0;
  RendererOptions o;
  o.layer = "imagery";
  o.elevationLayer = "heights";
  o.width = o.height = 128;
  o.fadeInSeconds = 1.0;
  o.frameClock = [&clockS] { return clockS; };
  const auto w1 = world();
  auto made = Renderer::create(*w1, wgs, o);
  ASSERT_TRUE(made.has_value()) << made.error();
  Renderer& r = **made;
  settle(r, pose); // everything arrives with the clock at 0: every fade at weight 0
  EXPECT_FALSE(r.complete());
  const double h0 = r.terrainHeight(pose.latDeg, pose.lonDeg);
  clockS = 0.5;
  r.frame(pose);
  const double hHalf = r.terrainHeight(pose.latDeg, pose.lonDeg);
  EXPECT_FALSE(r.complete());
  for (int k = 1; k <= 40 && !r.complete(); ++k) {
    clockS = 0.5 + k;
    r.frame(pose);
  }
  EXPECT_TRUE(r.complete());
  const double hEnd = r.terrainHeight(pose.latDeg, pose.lonDeg);
  EXPECT_NE(h0, hEnd); // the heights held came in fading
  EXPECT_NEAR(hHalf, 0.5 * (h0 + hEnd), std::abs(hEnd - h0) * 0.5 + 1e-9); // between, not at once
  const std::vector<std::uint8_t> faded = r.readPixels();

  RendererOptions plain = o;
  plain.fadeInSeconds = 0.0;
  plain.frameClock = {};
  const auto w2 = world();
  auto made2 = Renderer::create(*w2, wgs, plain);
  ASSERT_TRUE(made2.has_value()) << made2.error();
  settle(**made2, pose);
  EXPECT_TRUE((*made2)->complete());
  EXPECT_EQ(differing(faded, (*made2)->readPixels()), 0u) << "settled heights must not fade";
}

/** Renderer::redrawLast (bench/popping.sh's probe): from the last pose it draws the last frame bit
 * for bit; from another pose what the last frame culled stays background (no inside of the globe
 * through it); and it changes nothing: the next frame is what it would have been. */
TEST(RedrawLastGl, RedrawsTheLastStateAndChangesNothing) {
  if (!haveDisplay()) GTEST_SKIP() << "no DISPLAY: run the gl label under xvfb-run";
  FakeTileSource world;
  world.addLayer({"imagery", kGrid, "image/png", levelTile});
  world.setDelivery(FakeTileSource::Delivery::Worker);
  const Geodesy wgs;
  RendererOptions o;
  o.layer = "imagery";
  o.width = o.height = 128;
  o.background = {1.0, 0.0, 1.0};
  auto made = Renderer::create(world, wgs, o);
  ASSERT_TRUE(made.has_value()) << made.error();
  Renderer& r = **made;
  const CameraPose pose{10.0, 20.0, 2.0e5, 0.0, 40.0};
  settle(r, pose);
  ASSERT_TRUE(r.complete());
  const std::vector<std::uint8_t> drawn = r.readPixels();
  r.redrawLast(pose);
  EXPECT_EQ(differing(drawn, r.readPixels()), 0u);
  CameraPose turned = pose;
  turned.headingDeg = 120.0; // mostly outside what the last frame drew
  r.redrawLast(turned);
  const std::vector<std::uint8_t> probe = r.readPixels();
  std::size_t background = 0;
  for (std::size_t i = 0; i < probe.size(); i += 4)
    background += probe[i] == 255 && probe[i + 1] == 0 && probe[i + 2] == 255 ? 1U : 0U;
  EXPECT_GT(background, probe.size() / 4 / 10); // culled: background, not the globe's far side
  r.frame(pose);
  EXPECT_EQ(differing(drawn, r.readPixels()), 0u);
}

} // namespace
