// Issue #8's extremes, rendered (suite RenderExtremesGl: labels gl + extremes, run under xvfb-run
// with Mesa llvmpipe): the exact poles looking down and tilted, the antimeridian from both sides
// and across, -0.0, the camera 1 m and 0.1 m above the ellipsoid (no terrain yet), 1e9 m out (a
// small disc of the predicted size) and a 1 mm camera step at 1 m. Holes are found with a magenta
// clear colour: inside the Earth's outline (a ray cast per pixel against the model, shrunk by
// 0.2 %) no pixel may be magenta. Small images (128-256 px) keep the suite lean.

#include "../support/CacheFixtures.hpp"
#include "../support/TempDir.hpp"
#include "GlTestSupport.hpp"

#include <tellus/planet/Camera.hpp>
#include <tellus/planet_gl/Renderer.hpp>
#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/TileService.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <numbers>
#include <thread>

using namespace tellus;
using namespace tellus::planet;
using namespace tellus::planet::gltest;

namespace {

/** The shared options with a magenta background: a hole shows. */
RendererOptions extremesOptions(const std::string& layer, int w, int h) {
  RendererOptions o = options(layer, w, h);
  o.background = {1.0, 0.0, 1.0};
  return o;
}

const std::filesystem::path kOutDir =
    std::filesystem::path(TELLUS_TEST_TMP_DIR) / "render-extremes-gl";
constexpr double kDeg = std::numbers::pi / 180.0;

/** A ramp grid down to the deepest level the cache allows (30: 3.7 mm tiles). */
GridSpec deepGrid() {
  return GridSpec{Sector{}, 36.0, 256, 256, kMaxLevel + 1};
}

void save(const std::string& name, const Renderer& r, const std::vector<std::uint8_t>& px) {
  std::filesystem::create_directories(kOutDir);
  std::string err;
  writePngRgb(kOutDir / (name + ".png"), r.width(), r.height(), px, &err);
}

bool magenta(const std::vector<std::uint8_t>& px, int w, int x, int y) {
  const auto* p = &px[static_cast<std::size_t>((y * w + x) * 4)];
  return p[0] == 255 && p[1] == 0 && p[2] == 255;
}

double channel(const std::vector<std::uint8_t>& px, int w, int x, int y, int c) {
  return px[static_cast<std::size_t>((y * w + x) * 4 + c)];
}

/** Magenta pixels inside the outline (holes) and how many pixels the outline holds. */
struct Holes {
  int inside = 0;
  int holes = 0;
  int drawn = 0; ///< pixels that are not magenta
};
Holes findHoles(const Renderer& r, const Geodesy& g, const CameraPose& pose, const Rendered& out) {
  const Camera cam = r.camera(pose);
  Holes h;
  for (int y = 0; y < r.height(); ++y)
    for (int x = 0; x < r.width(); ++x) {
      const bool m = magenta(out.pixels, r.width(), x, y);
      h.drawn += !m;
      if (!rayHitsEarth(cam, g, x, y, 0.002)) continue;
      ++h.inside;
      h.holes += m;
    }
  return h;
}

std::string describe(const CameraPose& p) {
  char s[128];
  std::snprintf(s,
                sizeof s,
                "%.7g,%.7g,%.3g,%.4g,%.4g",
                p.latDeg,
                p.lonDeg,
                p.altitudeM,
                p.headingDeg,
                p.tiltDeg);
  return s;
}

void expectFiniteStats(const RenderStats& s) {
  EXPECT_TRUE(std::isfinite(s.updateMs) && std::isfinite(s.frameMs));
}

/** Mean absolute difference of two RGBA images (RGB only). */
double meanAbsDiff(const std::vector<std::uint8_t>& a, const std::vector<std::uint8_t>& b) {
  double sum = 0.0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < a.size(); i += 4)
    for (std::size_t c = 0; c < 3; ++c, ++n)
      sum += std::abs(static_cast<double>(a[i + c]) - static_cast<double>(b[i + c]));
  return sum / static_cast<double>(n);
}

} // namespace

// The exact poles and 0.0001 degrees off them, straight down and tilted, at several headings and
// longitudes: no hole, something drawn, finite statistics; and the pole and the pose 11 m beside
// it look the same (no flip of the frame or of the textures at the pole).
TEST(RenderExtremesGl, ExactPolesLookingDownAndTiltedHaveNoHoles) {
  const Geodesy geodesy;
  BlueMarbleService bm{"render-extremes-gl"};
  ASSERT_TRUE(bm.service);
  auto o = extremesOptions("bluemarble", 160, 120);
  OPEN_RENDERER(r, *bm.service, geodesy, o);
  const std::vector<CameraPose> poses = {
      {90.0, 0.0, 1.0e6, 0.0, 0.0},
      {-90.0, 0.0, 1.0e6, 0.0, 0.0},
      {90.0, 0.0, 1.0e5, 0.0, 60.0},
      {-90.0, 120.0, 1.0e5, 200.0, 60.0},
      {90.0, -180.0, 1.0e4, 90.0, 80.0},
      {-90.0, 180.0, 1.0, 0.0, 0.0},
      {90.0, 33.0, 1.0, 300.0, 70.0},
  };
  for (const CameraPose& p : poses) {
    SCOPED_TRACE(describe(p));
    const Rendered out = renderComplete(r, p);
    EXPECT_TRUE(out.complete);
    save("pole-" + describe(p), r, out.pixels);
    const Holes h = findHoles(r, geodesy, p, out);
    EXPECT_GT(h.inside, 0);
    EXPECT_EQ(h.holes, 0) << "magenta pixels inside the Earth's outline";
    EXPECT_GT(h.drawn, 0);
    expectFiniteStats(out.stats);
    // 0.0001 degrees off the pole towards the same meridian: nearly the same image.
    CameraPose off = p;
    off.latDeg = p.latDeg > 0 ? 89.9999 : -89.9999;
    const Rendered beside = renderComplete(r, off);
    EXPECT_TRUE(beside.complete);
    const Holes hb = findHoles(r, geodesy, off, beside);
    EXPECT_EQ(hb.holes, 0) << "holes at " << describe(off);
    if (p.altitudeM >= 1e4) { // 11 m is less than a pixel there
      EXPECT_LT(meanAbsDiff(out.pixels, beside.pixels), 3.0)
          << "the pole and 0.0001 degrees beside it look different";
    }
  }
}

// lon 180 and -180 are one camera: the same bytes; -0.0 is 0.0: the same bytes. 179.9999 looking
// east and -179.9999 looking west (across the line), low and tilted: no holes.
TEST(RenderExtremesGl, AntimeridianFromBothSidesAndAcrossAndNegativeZero) {
  const Geodesy geodesy;
  BlueMarbleService bm{"render-extremes-gl"};
  ASSERT_TRUE(bm.service);
  auto o = extremesOptions("bluemarble", 160, 120);
  OPEN_RENDERER(r, *bm.service, geodesy, o);
  const auto same = [&](const CameraPose& a, const CameraPose& b) {
    const Rendered ra = renderComplete(r, a);
    const Rendered rb = renderComplete(r, b);
    EXPECT_TRUE(ra.complete && rb.complete);
    EXPECT_TRUE(ra.pixels == rb.pixels) << describe(a) << " and " << describe(b) << " differ";
  };
  same({10.0, 180.0, 2.0e5, 45.0, 50.0}, {10.0, -180.0, 2.0e5, 45.0, 50.0});
  same({-65.0, 180.0, 5.0e6, 0.0, 0.0}, {-65.0, -180.0, 5.0e6, 0.0, 0.0});
  same({0.0, 0.0, 3.0e6, 0.0, 0.0}, {-0.0, -0.0, 3.0e6, -0.0, -0.0});
  const std::vector<CameraPose> poses = {
      {0.0, 179.9999, 1.0e5, 90.0, 60.0},
      {0.0, -179.9999, 1.0e5, 270.0, 60.0},
      {30.0, 179.9999, 1.0, 90.0, 80.0},
      {-30.0, -179.9999, 1.0, 270.0, 80.0},
      {0.0, 180.0, 2.0e7, 0.0, 0.0},
      {89.9999, 179.9999, 1.0e3, 90.0, 45.0},
  };
  for (const CameraPose& p : poses) {
    SCOPED_TRACE(describe(p));
    const Rendered out = renderComplete(r, p);
    EXPECT_TRUE(out.complete);
    save("antimeridian-" + describe(p), r, out.pixels);
    const Holes h = findHoles(r, geodesy, p, out);
    EXPECT_GT(h.inside, 0);
    EXPECT_EQ(h.holes, 0) << "magenta pixels inside the Earth's outline";
    expectFiniteStats(out.stats);
  }
}

namespace {
/** Low views over tiles of every level down to 30 (the deepest the cache allows), looking down
 * and tilted, at the equator, on the antimeridian and at the poles: no hole and, straight down,
 * every pixel drawn. */
void expectNoHolesInLowViews(double alt, bool fp64Vertices = true) {
  const Geodesy geodesy;
  FakeTileSource ramp(rampLayer(deepGrid(), 8, 248));
  auto o = extremesOptions("ramp", 128, 128);
  o.fp64Vertices = fp64Vertices;
  OPEN_RENDERER(r, ramp, geodesy, o);
  {
    for (const CameraPose& base : {CameraPose{-6.0, 12.0, 0.0, 0.0, 0.0},
                                   CameraPose{45.3, -179.9999, 0.0, 60.0, 60.0},
                                   CameraPose{89.9999, 10.0, 0.0, 0.0, 30.0},
                                   CameraPose{90.0, 0.0, 0.0, 0.0, 0.0},
                                   CameraPose{-90.0, 135.0, 0.0, 250.0, 45.0}}) {
      CameraPose p = base;
      p.altitudeM = alt;
      SCOPED_TRACE(describe(p));
      const Rendered out = renderComplete(r, p, 120.0);
      EXPECT_TRUE(out.complete);
      save("low-" + describe(p), r, out.pixels);
      const Holes h = findHoles(r, geodesy, p, out);
      std::printf("%s: level %d, %zu nodes drawn, %d of %d pixels inside the outline magenta\n",
                  describe(p).c_str(),
                  out.stats.maxLevel,
                  out.stats.nodesDrawn,
                  h.holes,
                  h.inside);
      EXPECT_GT(h.inside, 0);
      EXPECT_EQ(h.holes, 0) << "magenta pixels inside the Earth's outline";
      if (p.tiltDeg == 0.0) {
        EXPECT_EQ(h.inside, o.width * o.height) << "straight down, the ground fills the view";
      }
      EXPECT_GE(out.stats.maxLevel, alt < 0.5 ? 22 : 20);
      // With the near plane at 0.1 m, the ground 0.1 m below was at it: the LOD took the corners
      // for points behind the eye and split to level 30 (523 nodes for 128 x 128 px).
      EXPECT_LE(out.stats.maxLevel, alt < 0.5 ? 27 : 24);
      EXPECT_LT(out.stats.nodesDrawn, 64u);
      expectFiniteStats(out.stats);
    }
  }
}
} // namespace

// 1 m above the ellipsoid (levels 22-23).
TEST(RenderExtremesGl, OneMetreAboveTheEllipsoidHasNoHoles) {
  expectNoHolesInLowViews(1.0);
}

// 0.1 m above the ellipsoid (levels 25-26). Failed after the terrain merge (1,543 of 16,384 pixels
// holes at -6, 12 looking down, all of them at the poles) while the vertices went as high/low
// float pairs, which GCC 12 had packed with the low floats zeroed (docs/ACCURACY.md, findings 4
// and 7).
TEST(RenderExtremesGl, ATenthOfAMetreAboveTheEllipsoidHasNoHoles) {
  expectNoHolesInLowViews(0.1);
}

// 1e9 m out the Earth is a small disc: its radius in pixels is the focal length times the tangent
// of the angular radius asin(R / (R + h)), within 1 px, both across (a) and up (b) the view. In the
// default 45-degree view that is ~2 px (measured as the radius of a disc of the drawn area); in a
// 2-degree view ~47 px (measured as half the drawn width of the middle row and column).
TEST(RenderExtremesGl, BillionMetresOutTheEarthIsADiscOfThePredictedRadius) {
  const Geodesy geodesy;
  BlueMarbleService bm{"render-extremes-gl"};
  ASSERT_TRUE(bm.service);
  const CameraPose pose{0.0, 0.0, 1.0e9, 0.0, 0.0};
  for (const double fov : {45.0, 2.0}) {
    SCOPED_TRACE("field of view " + std::to_string(fov));
    auto o = extremesOptions("bluemarble", 256, 256);
    o.verticalFovDeg = fov;
    OPEN_RENDERER(r, *bm.service, geodesy, o);
    const Rendered out = renderComplete(r, pose);
    ASSERT_TRUE(out.complete);
    save("billion-fov" + std::to_string(static_cast<int>(fov)), r, out.pixels);
    const double focal = 128.0 / std::tan(fov * kDeg / 2.0);
    const auto predicted = [&](double radius) {
      return focal * std::tan(std::asin(radius / (radius + pose.altitudeM)));
    };
    const double across = predicted(geodesy.equatorialRadius());
    const double up = predicted(geodesy.polarRadius());
    int drawn = 0, rowFirst = -1, rowLast = -1, colFirst = -1, colLast = -1;
    for (int y = 0; y < 256; ++y)
      for (int x = 0; x < 256; ++x) {
        if (magenta(out.pixels, 256, x, y)) continue;
        ++drawn;
        if (y == 128) {
          if (rowFirst < 0) rowFirst = x;
          rowLast = x;
        }
        if (x == 128) {
          if (colFirst < 0) colFirst = y;
          colLast = y;
        }
      }
    ASSERT_GT(drawn, 0) << "nothing drawn";
    const double discRadius = std::sqrt(drawn / std::numbers::pi);
    std::printf("fov %.0f: predicted %.3f x %.3f px; drawn %d px (radius %.3f), row %.1f, column "
                "%.1f\n",
                fov,
                across,
                up,
                drawn,
                discRadius,
                (rowLast - rowFirst + 1) / 2.0,
                (colLast - colFirst + 1) / 2.0);
    EXPECT_NEAR(discRadius, std::sqrt(across * up), 1.0);
    if (fov < 10.0) {
      EXPECT_NEAR((rowLast - rowFirst + 1) / 2.0, across, 1.0);
      EXPECT_NEAR((colLast - colFirst + 1) / 2.0, up, 1.0);
      EXPECT_NEAR((rowFirst + rowLast + 1) / 2.0, 128.0, 1.0) << "disc centre";
      EXPECT_NEAR((colFirst + colLast + 1) / 2.0, 128.0, 1.0) << "disc centre";
    }
    expectFiniteStats(out.stats);
  }
}

// Jitter: 1 m above the ground, the camera moves 1 mm east. Looking straight down a pixel covers
// 2 h tan(fov / 2) / 256 = 3.24 mm of ground, so the image must move west by 0.309 px, and not
// north or south. The shift is measured from the two renders by the gradient method (least
// squares of the difference against the image's own gradient) on the ramp's texel coordinates
// (red east, green north), away from tile edges; a camera snapped to a float grid (0.5 m at
// ECEF magnitudes) would move 0 or many pixels.
//
// On the float-pair path with GCC 12's miscompiled packing (findings 5 and 7 of docs/ACCURACY.md)
// the step moved the image 0.041 px: the camera's sub-millimetre motion was lost.
namespace {
void expectOneMillimetreStepMovesTheImage(bool fp64Vertices) {
  const Geodesy geodesy;
  FakeTileSource ramp(rampLayer(deepGrid(), 8, 248));
  const int size = 256;
  auto o = extremesOptions("ramp", size, size);
  o.fp64Vertices = fp64Vertices;
  OPEN_RENDERER(r, ramp, geodesy, o);
  const double lat = -6.0, lon0 = 12.0, alt = 1.0;
  const double metreLon = 1.0 / (geodesy.equatorialRadius() * std::cos(lat * kDeg) * kDeg);
  const Rendered a = renderComplete(r, {lat, lon0, alt, 0.0, 0.0}, 120.0);
  const Rendered b = renderComplete(r, {lat, lon0 + 0.001 * metreLon, alt, 0.0, 0.0}, 120.0);
  ASSERT_TRUE(a.complete && b.complete);
  save("jitter-a", r, a.pixels);
  save("jitter-b", r, b.pixels);
  const double expected = 0.001 / (2.0 * alt * std::tan(22.5 * kDeg) / size);
  // Image b(x) = a(x + s): b - a = s da/dx, for the east shift s from red, north from green.
  const auto shift = [&](int c, bool alongX) {
    double num = 0.0, den = 0.0;
    int used = 0;
    for (int y = size / 4; y < 3 * size / 4; ++y)
      for (int x = size / 4; x < 3 * size / 4; ++x) {
        const double g =
            alongX ? (channel(a.pixels, size, x + 1, y, c) - channel(a.pixels, size, x - 1, y, c)) /
                         2.0
                   : (channel(a.pixels, size, x, y + 1, c) - channel(a.pixels, size, x, y - 1, c)) /
                         2.0;
        const double d = channel(b.pixels, size, x, y, c) - channel(a.pixels, size, x, y, c);
        const bool sameLevel = channel(a.pixels, size, x, y, 2) == channel(b.pixels, size, x, y, 2);
        if (std::abs(g) > 8.0 || std::abs(d) > 8.0 || !sameLevel) continue; // a tile edge
        num += d * g;
        den += g * g;
        ++used;
      }
    EXPECT_GT(used, size * size / 8);
    return den > 0.0 ? num / den : 0.0;
  };
  const double east = shift(0, true);   // red grows to the right (east, heading 0)
  const double north = shift(1, false); // green grows upwards in the texture, down the image rows
  std::printf("level %d: 1 mm east moved the image %.3f px (expected %.3f), %.3f px north-south\n",
              b.stats.maxLevel,
              east,
              expected,
              north);
  EXPECT_GE(b.stats.maxLevel, 20);
  EXPECT_NEAR(east, expected, 0.25 * expected) << "the image did not move by the step";
  EXPECT_NEAR(north, 0.0, 0.05) << "an east step moved the image north-south";
}
} // namespace

TEST(RenderExtremesGl, OneMillimetreStepAtOneMetreMovesTheImageByTheExpectedSubPixelAmount) {
  expectOneMillimetreStepMovesTheImage(true);
}

// The same two extremes on the OpenGL 3.3 vertex path (high/low float pairs, the eye subtracted
// in float in the shader): this path lost its low floats to a GCC 12 vectoriser bug in the
// packing loop (docs/ACCURACY.md, finding 7) and then snapped every position to 0.5 m.
TEST(RenderExtremesGl, FloatPairVerticesATenthOfAMetreAboveTheEllipsoidHaveNoHoles) {
  expectNoHolesInLowViews(0.1, false);
}
TEST(RenderExtremesGl, FloatPairVerticesOneMillimetreStepMovesTheImage) {
  expectOneMillimetreStepMovesTheImage(false);
}

// The sphere (renderer.earth: sphere) at the same extremes: no holes at the exact poles, across the
// antimeridian, 1 m above it over the deepest tiles, and its 1e9 m disc has the sphere's radius.
// (0.1 m was in it and passed before terrain's merge; see DISABLED_ATenthOfAMetre... above.)
TEST(RenderExtremesGl, SphereModelHasNoHolesAtTheExtremes) {
  const Geodesy sphere(EarthModel::Sphere);
  BlueMarbleService bm{"render-extremes-gl"};
  ASSERT_TRUE(bm.service);
  FakeTileSource ramp(rampLayer(deepGrid(), 8, 248));
  for (int source = 0; source < 2; ++source) {
    auto o = extremesOptions(source == 0 ? "bluemarble" : "ramp", 128, 128);
    ITileSource& s =
        source == 0 ? static_cast<ITileSource&>(*bm.service) : static_cast<ITileSource&>(ramp);
    OPEN_RENDERER(r, s, sphere, o);
    const std::vector<CameraPose> poses =
        source == 0 ? std::vector<CameraPose>{{90.0, 0.0, 1.0e6, 0.0, 0.0},
                                              {-90.0, 45.0, 1.0e5, 120.0, 60.0},
                                              {0.0, 179.9999, 1.0e5, 90.0, 60.0},
                                              {0.0, 0.0, 1.0e9, 0.0, 0.0}}
                    : std::vector<CameraPose>{{-6.0, 12.0, 1.0, 0.0, 0.0},
                                              {89.9999, -180.0, 1.0, 0.0, 30.0}};
    for (const CameraPose& p : poses) {
      SCOPED_TRACE(describe(p));
      const Rendered out = renderComplete(r, p, 120.0);
      EXPECT_TRUE(out.complete);
      save("sphere-" + describe(p), r, out.pixels);
      const Holes h = findHoles(r, sphere, p, out);
      EXPECT_GT(h.inside, 0);
      EXPECT_EQ(h.holes, 0) << "magenta pixels inside the sphere's outline";
      expectFiniteStats(out.stats);
      if (p.altitudeM == 1.0e9) {
        const double focal = 64.0 / std::tan(22.5 * kDeg);
        const double r0 = sphere.equatorialRadius();
        const double predicted = focal * std::tan(std::asin(r0 / (r0 + p.altitudeM)));
        EXPECT_NEAR(std::sqrt(h.drawn / std::numbers::pi), predicted, 1.0);
      }
    }
  }
}

namespace {

/** Layer "heights": a flat plateau `plateauM` above the ellipsoid (BIL16 tiles of one value at
 * every level); over the ramp imagery of deepGrid() the camera's height above the terrain is known
 * exactly. */
FakeTileSource::Layer plateauLayer(std::int16_t plateauM) {
  std::vector<std::byte> heights(16 * 16 * 2);
  for (std::size_t i = 0; i < 16 * 16; ++i) {
    const auto v = static_cast<std::uint16_t>(plateauM);
    heights[2 * i] = static_cast<std::byte>(v & 0xff);
    heights[2 * i + 1] = static_cast<std::byte>(v >> 8);
  }
  return {"heights",
          GridSpec{Sector{}, 36.0, 16, 16, 16},
          "application/bil16",
          FakeTileSource::bytes(std::move(heights), "application/bil16")};
}

} // namespace

namespace {
/** 1 m and 0.1 m above a plateau 1,000 m above the ellipsoid (altitudes 1,001 m and 1,000.1 m),
 * looking down and tilted at each pose: no holes; and, with `checkLevel`, the LOD as deep as over
 * the bare ellipsoid at the same height above the ground. */
void expectNoHolesAboveThePlateau(const std::vector<CameraPose>& poses, bool checkLevel) {
  const Geodesy geodesy;
  FakeTileSource source(rampLayer(deepGrid()));
  source.addLayer(plateauLayer(1000));
  auto o = extremesOptions("ramp", 128, 128);
  o.elevationLayer = "heights";
  o.terrainClearanceM = 0.05; // let the camera down to 0.1 m above the terrain
  OPEN_RENDERER(r, source, geodesy, o);
  for (const double above : {1.0, 0.1})
    for (const CameraPose& base : poses) {
      CameraPose p = base;
      p.altitudeM = 1000.0 + above;
      SCOPED_TRACE(describe(p));
      const Rendered out = renderComplete(r, p, 120.0);
      EXPECT_TRUE(out.complete);
      save("terrain-" + describe(p), r, out.pixels);
      EXPECT_NEAR(r.terrainHeight(p.latDeg, p.lonDeg), 1000.0, 1e-9);
      EXPECT_FALSE(out.stats.cameraLifted);
      const Holes h = findHoles(r, geodesy, p, out);
      std::printf("%s over a 1,000 m plateau: level %d, %zu nodes, %d magenta of %d inside\n",
                  describe(p).c_str(),
                  out.stats.maxLevel,
                  out.stats.nodesDrawn,
                  h.holes,
                  h.inside);
      EXPECT_EQ(h.holes, 0) << "magenta pixels inside the Earth's outline";
      if (p.tiltDeg == 0.0) {
        EXPECT_EQ(h.drawn, o.width * o.height) << "straight down, the ground fills the view";
      }
      if (checkLevel) {
        EXPECT_GE(out.stats.maxLevel, above < 0.5 ? 22 : 20);
      }
      expectFiniteStats(out.stats);
    }
}
} // namespace

// Terrain: the near plane follows the height above the terrain under the camera, not above the
// ellipsoid (Renderer::camera): 0.1 m above a 1,000 m plateau the ground is not cut.
TEST(RenderExtremesGl, OneMetreAndATenthOfAMetreAboveTerrainHaveNoHoles) {
  expectNoHolesAboveThePlateau(
      {CameraPose{-6.0, 12.0, 0.0, 0.0, 0.0}, CameraPose{-6.0, 12.0, 0.0, 30.0, 30.0}}, false);
}

// Found with terrain (issue #6, the renderer as merged): 1 m and 0.1 m above the plateau the LOD
// stops at levels 12-13 (over the bare ellipsoid at 1 m: 22-23), as if the camera were 1,000 m
// up (likely, not verified: the texel-to-pixel test measures the nodes' corners on the ellipsoid).
// At 89.9999 N, 0.1 m above the plateau, 16,304 of 16,384 pixels are holes. Fixed by measuring the
// LOD at the node's height nearest the camera (docs/ACCURACY.md, finding 6).
TEST(RenderExtremesGl, TerrainLodAndThePoleOverAPlateau) {
  expectNoHolesAboveThePlateau(
      {CameraPose{-6.0, 12.0, 0.0, 0.0, 0.0}, CameraPose{89.9999, 179.9999, 0.0, 0.0, 30.0}}, true);
}
