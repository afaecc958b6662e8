// Other bodies rendered (issue 26, label gl): the Moon and Mars from orbit, a one-colour layer
// through the tests' fake tile source. The disc's radius in pixels is the body's for the camera
// (the Earth's radius would make it far larger); no air glows around the Moon, Mars's thin
// atmosphere glows just outside its limb.

#include "../support/FakeTileSource.hpp"
#include "GlTestSupport.hpp"

#include <tellus/planet/Body.hpp>
#include <tellus/planet/Camera.hpp>
#include <tellus/planet_gl/Renderer.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

using namespace tellus;
using namespace tellus::planet;

namespace {

constexpr GridSpec kGrid{Sector{}, 36.0, 32, 32, 3};
constexpr int kSize = 256;
constexpr int kGrey = 150;

test::FakeTileSource::Layer greyLayer() {
  std::vector<std::uint8_t> px(static_cast<std::size_t>(kGrid.tileWidth * kGrid.tileHeight * 4));
  for (std::size_t i = 0; i < px.size(); i += 4) {
    px[i] = px[i + 1] = px[i + 2] = static_cast<std::uint8_t>(kGrey);
    px[i + 3] = 255;
  }
  return {"grey",
          kGrid,
          "image/png",
          test::FakeTileSource::bytes(encodePngRgba(kGrid.tileWidth, kGrid.tileHeight, px),
                                      "image/png")};
}

RendererOptions bodyOptions(bool air) {
  RendererOptions o;
  o.layer = "grey";
  o.width = o.height = kSize;
  if (air) {
    o.atmosphere = RendererOptions::Atmosphere{};
    o.atmosphere->resolutionDivisor = 1;
    o.sunLatLon = std::array<double, 2>{0.0, 0.0}; // overhead under the camera: the limb side-lit
  }
  return o;
}

int brightness(const std::vector<std::uint8_t>& px, int x, int y) {
  const auto* p = &px[static_cast<std::size_t>((y * kSize + x) * 4)];
  return std::max({int(p[0]), int(p[1]), int(p[2])});
}

/** The disc's radius in pixels for a camera `altitudeM` above a sphere-like body of equatorial
 * radius r, looking at its centre (vertical field of view 45 degrees). */
double expectedRadiusPx(double r, double altitudeM) {
  const double alpha = std::asin(r / (r + altitudeM));
  return std::tan(alpha) / std::tan(22.5 * std::numbers::pi / 180.0) * kSize / 2.0;
}

/** Pixels from the centre to the right along the middle row brighter than `above`. */
int discRadiusPx(const std::vector<std::uint8_t>& px, int above) {
  int n = 0;
  for (int x = kSize / 2; x < kSize && brightness(px, x, kSize / 2) > above; ++x)
    ++n;
  return n;
}

/** The brightest pixel of the ring from `inner` to `outer` pixels from the centre. */
int ringMax(const std::vector<std::uint8_t>& px, double inner, double outer) {
  int best = 0;
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      const double d = std::hypot(x + 0.5 - kSize / 2.0, y + 0.5 - kSize / 2.0);
      if (d >= inner && d <= outer) best = std::max(best, brightness(px, x, y));
    }
  return best;
}

void checkDisc(const Body& body, double altitudeM) {
  test::FakeTileSource source(greyLayer());
  const Geodesy g(body);
  OPEN_RENDERER(r, source, g, bodyOptions(false));
  const auto done = gltest::renderComplete(r, CameraPose{0.0, 0.0, altitudeM, 0.0, 0.0});
  ASSERT_TRUE(done.complete);
  const double want = expectedRadiusPx(body.radiusA, altitudeM);
  EXPECT_NEAR(discRadiusPx(done.pixels, kGrey / 2), want, 1.5) << body.name;
  // The Earth's radius at the same altitude would fill far more of the frame.
  const double earth = expectedRadiusPx(6378137.0, altitudeM);
  EXPECT_GT(earth - want, 20.0);
  EXPECT_EQ(brightness(done.pixels, kSize / 2, kSize / 2), kGrey);
}

} // namespace

TEST(BodiesGl, TheMoonsDiscHasTheMoonsRadius) {
  checkDisc(moonBody(), 4.0e6);
}

TEST(BodiesGl, MarssDiscHasMarssRadius) {
  checkDisc(marsBody(), 6.0e6);
}

TEST(BodiesGl, NoAirGlowsAroundTheMoon) {
  test::FakeTileSource source(greyLayer());
  const Geodesy g(moonBody());
  OPEN_RENDERER(r, source, g, bodyOptions(true));
  const auto done = gltest::renderComplete(r, CameraPose{0.0, 0.0, 4.0e6, 0.0, 0.0});
  ASSERT_TRUE(done.complete);
  EXPECT_EQ(done.stats.atmospherePrecomputeMs, 0.0); // no atmosphere pass at all
  const double rim = expectedRadiusPx(moonBody().radiusA, 4.0e6);
  EXPECT_GT(brightness(done.pixels, kSize / 2, kSize / 2), 50); // lit
  EXPECT_EQ(ringMax(done.pixels, rim + 2.0, rim + 12.0), 0);    // black sky right past the limb
}

TEST(BodiesGl, MarssThinAtmosphereGlowsAtTheLimb) {
  test::FakeTileSource source(greyLayer());
  const Geodesy g(marsBody());
  OPEN_RENDERER(r, source, g, bodyOptions(true));
  const auto done = gltest::renderComplete(r, CameraPose{0.0, 0.0, 6.0e6, 0.0, 0.0});
  ASSERT_TRUE(done.complete);
  EXPECT_GT(done.stats.atmospherePrecomputeMs, 0.0);
  const double rim = expectedRadiusPx(marsBody().radiusA, 6.0e6);
  // The shell is 77 km thick: ~2 pixels at this distance. It glows there, and not far beyond.
  EXPECT_GT(ringMax(done.pixels, rim + 0.7, rim + 3.0), 8);
  EXPECT_LE(ringMax(done.pixels, rim + 12.0, rim + 30.0), 2);
}
