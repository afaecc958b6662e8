// Sunlight and the night side (issue 23, label gl): the day side lit by the sun of the scene's
// time, the brightest point where the sun stands overhead (and it moves with the time), and a
// night layer that shows on the night side only, blended across the terminator by the sun's
// elevation, in the flat view and the direct dome. One-colour layers through the tests' fake
// tile source make every expected pixel a number (shaders/planet.frag's formulas).

#include "../support/FakeTileSource.hpp"
#include "GlTestSupport.hpp"

#include <tellus/planet/Astronomy.hpp>
#include <tellus/planet/Camera.hpp>
#include <tellus/planet/SceneTime.hpp>
#include <tellus/planet_gl/Renderer.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

using namespace tellus;
using namespace tellus::planet;

namespace {

using Rgb = std::array<int, 3>;

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr GridSpec kGrid{Sector{}, 36.0, 32, 32, 4};
constexpr Rgb kGrey{120, 120, 120};
constexpr Rgb kLights{250, 200, 40};
constexpr int kSize = 256;

/** A layer of one colour (opaque), every tile the same PNG. */
test::FakeTileSource::Layer solidLayer(const std::string& name, Rgb c) {
  std::vector<std::uint8_t> px(static_cast<std::size_t>(kGrid.tileWidth * kGrid.tileHeight * 4));
  for (std::size_t i = 0; i < px.size(); i += 4) {
    px[i] = static_cast<std::uint8_t>(c[0]);
    px[i + 1] = static_cast<std::uint8_t>(c[1]);
    px[i + 2] = static_cast<std::uint8_t>(c[2]);
    px[i + 3] = 255;
  }
  return {name,
          kGrid,
          "image/png",
          test::FakeTileSource::bytes(encodePngRgba(kGrid.tileWidth, kGrid.tileHeight, px),
                                      "image/png")};
}

double sceneTime(const char* iso) {
  return parseSceneTime(iso, 0.0).value();
}

/** The subsolar point's geocentric latitude and longitude (degrees) at a time. */
std::array<double, 2> subsolar(double t) {
  const glm::dvec3 s = astro::sunDirectionEcef(t);
  return {std::asin(s.z) / kDeg, std::atan2(s.y, s.x) / kDeg};
}

RendererOptions sunOptions(bool night, bool dome = false) {
  RendererOptions o;
  o.layer = "grey";
  o.width = o.height = kSize;
  o.sunlight = true;
  o.timeUnixSeconds = sceneTime("2024-03-20T12:00:00Z");
  if (night) {
    LayerOptions l;
    l.layer = "lights";
    l.night = true;
    o.overlays.push_back(l);
  }
  if (dome) o.dome = DomeOptions{};
  return o;
}

Rgb pixelAt(const std::vector<std::uint8_t>& px, const Camera& cam, double lat, double lon) {
  const Geodesy g;
  const Ecef p = g.toEcef(lat, lon, 0.0);
  glm::dvec2 xy;
  EXPECT_TRUE(cam.projectPx({p.x, p.y, p.z}, xy));
  const auto col = static_cast<std::size_t>(std::lround(kSize / 2.0 + xy.x - 0.5));
  const auto row = static_cast<std::size_t>(std::lround(kSize / 2.0 - xy.y - 0.5));
  const std::size_t i = (row * kSize + col) * 4;
  return {px[i], px[i + 1], px[i + 2]};
}

/** Renders the terminator's neighbourhood with and without the night layer and checks points on
 * the equator at known sun elevations (the camera over the evening terminator). */
void checkNightSide(bool dome) {
  test::FakeTileSource source;
  source.addLayer(solidLayer("grey", kGrey));
  source.addLayer(solidLayer("lights", kLights));
  const Geodesy wgs;
  const double lon0 = subsolar(*sunOptions(false).timeUnixSeconds)[1];
  // Dusk is east of the subsolar point: over it by 90 degrees the sun is on the horizon.
  const CameraPose pose{0.0, lon0 + 90.0, 8.0e6, 0.0, 0.0};
  OPEN_RENDERER(with, source, wgs, sunOptions(true, dome));
  const auto lit = gltest::renderComplete(with, pose);
  ASSERT_TRUE(lit.complete);
  EXPECT_TRUE(lit.stats.sunlight);
  EXPECT_EQ(lit.stats.sceneTimeUnixSeconds, sunOptions(false).timeUnixSeconds);
  ASSERT_EQ(lit.stats.layers.size(), 2u);
  EXPECT_TRUE(lit.stats.layers[1].night);
  OPEN_RENDERER(without, source, wgs, sunOptions(false, dome));
  const auto day = gltest::renderComplete(without, pose);
  ASSERT_TRUE(day.complete);
  const Camera cam = with.camera(pose);
  // The sun's elevation at (0, lon0 + 90 - e) is e (the subsolar latitude is 0.0 at the
  // equinox; the pixel's centre is within 0.3 degree of the point).
  for (const double e : {25.0, 10.0, 2.0}) {
    const Rgb a = pixelAt(lit.pixels, cam, 0.0, lon0 + 90.0 - e);
    const Rgb b = pixelAt(day.pixels, cam, 0.0, lon0 + 90.0 - e);
    EXPECT_EQ(a, b) << "day side, the sun " << e << " degrees up: the lit imagery alone";
    EXPECT_GT(b[0], kGrey[0] * std::sin((e - 1.0) * kDeg)) << "lit by the sun's elevation";
  }
  for (const double e : {-10.0, -25.0}) {
    const Rgb a = pixelAt(lit.pixels, cam, 0.0, lon0 + 90.0 - e);
    const Rgb b = pixelAt(day.pixels, cam, 0.0, lon0 + 90.0 - e);
    for (std::size_t c = 0; c < 3; ++c) {
      // 4% ambient of the grey (5) under the lights' full colour; 2 for rounding.
      EXPECT_NEAR(b[c], 0.04 * kGrey[c], 1.0) << "night side without lights";
      EXPECT_NEAR(a[c], std::min(255, b[c] + kLights[c]), 2) << "night side: the lights";
    }
  }
  // Civil twilight, the sun 3 degrees down: halfway (weight 1 - smoothstep(-0.105, 0,
  // sin(-3 deg)) = 0.497; 0.3 degree of pixel offset moves it by 0.05).
  const Rgb a = pixelAt(lit.pixels, cam, 0.0, lon0 + 93.0);
  const Rgb b = pixelAt(day.pixels, cam, 0.0, lon0 + 93.0);
  EXPECT_NEAR(a[0] - b[0], 0.497 * kLights[0], 0.06 * kLights[0]) << "blended at dusk";
}

TEST(SunGl, NightLayerShowsOnTheNightSideOnlyBlendedAcrossTheTerminator) {
  checkNightSide(false);
}

TEST(SunGl, NightLayerShowsOnTheNightSideOnlyInTheDirectDomeToo) {
  checkNightSide(true);
}

/** The centroid (pixels, x right, y down) of the brightest pixels of the globe. */
std::array<double, 2> brightestCentroid(const std::vector<std::uint8_t>& px) {
  int best = 0;
  for (std::size_t i = 0; i < px.size(); i += 4)
    best = std::max(best, int(px[i]) + px[i + 1] + px[i + 2]);
  double sx = 0.0, sy = 0.0, n = 0.0;
  for (std::size_t i = 0; i < px.size(); i += 4)
    if (int(px[i]) + px[i + 1] + px[i + 2] == best) {
      sx += static_cast<double>((i / 4) % kSize) + 0.5;
      sy += static_cast<double>((i / 4) / kSize) + 0.5;
      n += 1.0;
    }
  return {sx / n, sy / n};
}

TEST(SunGl, TheSubsolarPointIsTheBrightestAndFollowsTheTime) {
  test::FakeTileSource source;
  source.addLayer(solidLayer("grey", Rgb{200, 200, 200}));
  const Geodesy wgs;
  OPEN_RENDERER(r, source, wgs, sunOptions(false));
  const double t1 = *sunOptions(false).timeUnixSeconds;
  const CameraPose pose{10.0, subsolar(t1)[1] - 15.0, 8.0e6, 0.0, 0.0};
  const Camera cam = r.camera(pose);
  for (const double t : {t1, t1 + 2.0 * 3600.0}) { // two hours later: 30 degrees further west
    r.setTime(t);
    const auto done = gltest::renderComplete(r, pose);
    ASSERT_TRUE(done.complete);
    EXPECT_EQ(r.time(), t);
    const auto [lat, lon] = subsolar(t);
    const Ecef p = wgs.toEcef(lat, lon, 0.0);
    glm::dvec2 xy;
    ASSERT_TRUE(cam.projectPx({p.x, p.y, p.z}, xy));
    const auto c = brightestCentroid(done.pixels);
    // The brightest pixels (within 0.5 of a level of 200: the sun within 4 degrees of the
    // zenith) are a disc around the subsolar point, 1.9 px a degree here: its centroid within
    // 2 px of the point's projection.
    EXPECT_NEAR(c[0], kSize / 2.0 + xy.x, 2.0) << formatSceneTime(t);
    EXPECT_NEAR(c[1], kSize / 2.0 - xy.y, 2.0) << formatSceneTime(t);
  }
}

TEST(SunGl, WithoutSunlightTheImageryKeepsItsColoursAndNightLayersHide) {
  test::FakeTileSource source;
  source.addLayer(solidLayer("grey", kGrey));
  source.addLayer(solidLayer("lights", kLights));
  const Geodesy wgs;
  RendererOptions o = sunOptions(true);
  o.sunlight = false; // the library's default: a time alone places the sky, it lights nothing
  OPEN_RENDERER(r, source, wgs, o);
  const double lon0 = subsolar(*o.timeUnixSeconds)[1];
  const auto done = gltest::renderComplete(r, CameraPose{0.0, lon0 + 90.0, 8.0e6, 0.0, 0.0});
  ASSERT_TRUE(done.complete);
  EXPECT_FALSE(done.stats.sunlight);
  const Camera cam = r.camera(CameraPose{0.0, lon0 + 90.0, 8.0e6, 0.0, 0.0});
  for (const double e : {20.0, 0.0, -20.0})
    EXPECT_EQ(pixelAt(done.pixels, cam, 0.0, lon0 + 90.0 - e), kGrey) << e;
}

} // namespace
