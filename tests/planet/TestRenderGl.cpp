// Rendered tests of the planet renderer's GL layer (label gl: run under xvfb-run with Mesa
// llvmpipe). They skip only when no display is named at all; with DISPLAY set, failing to open a
// context is a failure.

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
#include <cstdlib>
#include <map>
#include <mutex>
#include <thread>

using namespace tellus;
using namespace tellus::planet;
using namespace tellus::planet::gltest;

namespace {

const std::filesystem::path kOutDir = std::filesystem::path(TELLUS_TEST_TMP_DIR) / "render-gl";

void save(const std::string& name, const Renderer& r, const std::vector<std::uint8_t>& px) {
  std::filesystem::create_directories(kOutDir);
  std::string err;
  writePngRgb(kOutDir / (name + ".png"), r.width(), r.height(), px, &err);
}

struct Rgb {
  double r, g, b;
};

Rgb pixelAt(const std::vector<std::uint8_t>& px, int w, int x, int y) {
  const auto* p = &px[static_cast<std::size_t>((y * w + x) * 4)];
  return {static_cast<double>(p[0]), static_cast<double>(p[1]), static_cast<double>(p[2])};
}

/** Mean and largest deviation of the bundled image in a (2k+1)^2 window around lat/lon. */
struct Sample {
  Rgb mean;
  double spread;
};
Sample sampleImage(const RgbaImage& img, double lat, double lon, int k) {
  const double fx = (lon + 180.0) / 360.0 * img.width - 0.5;
  const double fy = (90.0 - lat) / 180.0 * img.height - 0.5;
  const int cx = static_cast<int>(std::lround(fx)), cy = static_cast<int>(std::lround(fy));
  Rgb sum{0, 0, 0};
  int n = 0;
  double lo[3] = {255, 255, 255}, hi[3] = {0, 0, 0};
  for (int y = cy - k; y <= cy + k; ++y)
    for (int x = cx - k; x <= cx + k; ++x) {
      const Rgb c = pixelAt(
          img.pixels, img.width, std::clamp(x, 0, img.width - 1), std::clamp(y, 0, img.height - 1));
      sum.r += c.r;
      sum.g += c.g;
      sum.b += c.b;
      const double v[3] = {c.r, c.g, c.b};
      for (int i = 0; i < 3; ++i) {
        lo[i] = std::min(lo[i], v[i]);
        hi[i] = std::max(hi[i], v[i]);
      }
      ++n;
    }
  return {{sum.r / n, sum.g / n, sum.b / n},
          std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]})};
}

/** The pixel (x right, y down) where a world point projects; false when behind the camera. */
bool project(const Camera& cam, const glm::dvec3& p, double* x, double* y) {
  const glm::dvec4 c = cam.toClip(p);
  if (c.w <= 0.0) return false;
  *x = (c.x / c.w * 0.5 + 0.5) * cam.viewport().width;
  *y = (0.5 - c.y / c.w * 0.5) * cam.viewport().height;
  return true;
}

int countColour(const std::vector<std::uint8_t>& px,
                std::uint8_t r,
                std::uint8_t g,
                std::uint8_t b) {
  int n = 0;
  for (std::size_t i = 0; i < px.size(); i += 4)
    n += px[i] == r && px[i + 1] == g && px[i + 2] == b;
  return n;
}

} // namespace

// The globe from 20,000 km over (0, 0): a disc whose radius is what the field of view and the
// Earth's radius give, and whose colours are the bundled image's at known places. Both through the
// tile service (tiles resampled from the image) and with every tile absent (the global texture).
TEST(RenderGl, GlobeFrom20000kmIsADiscOfTheExpectedRadiusWithTheBundledColours) {
  const Geodesy geodesy;
  BlueMarbleService bm;
  ASSERT_TRUE(bm.service);
  FakeTileSource absent(absentLayer(GridSpec{Sector{}, 36.0, 512, 512, 3}));
  const auto image = readImageFile(kBlueMarble);
  ASSERT_TRUE(image.has_value()) << image.error();
  for (int variant = 0; variant < 2; ++variant) {
    SCOPED_TRACE(variant == 0 ? "tile service" : "global texture only");
    ITileSource& source =
        variant == 0 ? static_cast<ITileSource&>(*bm.service) : static_cast<ITileSource&>(absent);
    auto o = options(variant == 0 ? "bluemarble" : "absent", 640, 480);
    o.background = {1.0, 0.0, 1.0};
    OPEN_RENDERER(r, source, geodesy, o);
    const CameraPose pose{0.0, 0.0, 2.0e7, 0.0, 0.0};
    const Rendered out = renderComplete(r, pose);
    ASSERT_TRUE(out.complete);
    save(variant == 0 ? "globe-20000km" : "globe-20000km-global", r, out.pixels);
    if (variant == 0) {
      EXPECT_GT(out.stats.texturesUploaded, 0u);
    } else {
      EXPECT_EQ(out.stats.texturesUploaded, 0u);
    }

    // Radius: the disc's half-width along the middle row against the limb's angle.
    const Camera cam = r.camera(pose);
    const double d = geodesy.equatorialRadius() + pose.altitudeM;
    const double halfAngle = std::asin(geodesy.equatorialRadius() / d);
    const double focal = (o.height / 2.0) / std::tan(cam.verticalFovDeg() * M_PI / 360.0);
    const double expected = focal * std::tan(halfAngle);
    const int row = o.height / 2;
    int first = -1, last = -1;
    for (int x = 0; x < o.width; ++x) {
      const Rgb c = pixelAt(out.pixels, o.width, x, row);
      if (!(c.r == 255 && c.g == 0 && c.b == 255)) {
        if (first < 0) first = x;
        last = x;
      }
    }
    ASSERT_GE(first, 0) << "nothing drawn";
    const double measured = (last - first + 1) / 2.0;
    EXPECT_NEAR(measured, expected, 1.5) << "disc radius in pixels";
    EXPECT_NEAR((first + last + 1) / 2.0, o.width / 2.0, 1.0) << "disc centre";

    // Colours at places where the bundled image is locally uniform (oceans, deserts, forests).
    int checked = 0, bad = 0;
    for (double lat = -50.0; lat <= 50.0; lat += 5.0)
      for (double lon = -50.0; lon <= 50.0; lon += 5.0) {
        const Sample s = sampleImage(*image, lat, lon, 3);
        if (s.spread > 24.0) continue;
        const Ecef e = geodesy.toEcef(lat, lon, 0.0);
        double x = 0, y = 0;
        ASSERT_TRUE(project(cam, {e.x, e.y, e.z}, &x, &y));
        const Rgb c =
            pixelAt(out.pixels, o.width, static_cast<int>(std::floor(x)), static_cast<int>(y));
        ++checked;
        const double diff = std::max(
            {std::abs(c.r - s.mean.r), std::abs(c.g - s.mean.g), std::abs(c.b - s.mean.b)});
        if (diff > 20.0) {
          ++bad;
          ADD_FAILURE() << "lat " << lat << " lon " << lon << ": rendered " << c.r << "," << c.g
                        << "," << c.b << " image " << s.mean.r << "," << s.mean.g << ","
                        << s.mean.b;
        }
      }
    EXPECT_GE(checked, 30);
    EXPECT_EQ(bad, 0);
  }
}

// Near the poles nodes span several tiles (NodeKey::span): their textures are composed from those
// tiles side by side. Seen from above the pole, the colours still match the bundled image.
TEST(RenderGl, MergedPolarTexturesMatchTheBundledImage) {
  const Geodesy geodesy;
  BlueMarbleService bm;
  ASSERT_TRUE(bm.service);
  const auto image = readImageFile(kBlueMarble);
  ASSERT_TRUE(image.has_value()) << image.error();
  auto o = options("bluemarble", 640, 480);
  OPEN_RENDERER(r, *bm.service, geodesy, o);
  for (const CameraPose& pose :
       {CameraPose{90.0, 0.0, 3.0e6, 0.0, 0.0}, CameraPose{-90.0, 0.0, 3.0e6, 0.0, 0.0}}) {
    SCOPED_TRACE("latitude " + std::to_string(pose.latDeg));
    const Rendered out = renderComplete(r, pose);
    ASSERT_TRUE(out.complete);
    save(pose.latDeg > 0 ? "north-pole-3000km" : "south-pole-3000km", r, out.pixels);
    EXPECT_GT(out.stats.mergedNodesDrawn, 0u);
    EXPECT_GT(out.stats.maxLevel, 0);
    const Camera cam = r.camera(pose);
    int checked = 0, bad = 0;
    const double sign = pose.latDeg > 0 ? 1.0 : -1.0;
    for (double lat = 62.0; lat <= 86.0; lat += 2.0)
      for (double lon = -180.0; lon < 180.0; lon += 10.0) {
        const Sample s = sampleImage(*image, sign * lat, lon + 5.0, 3);
        if (s.spread > 24.0) continue;
        const Ecef e = geodesy.toEcef(sign * lat, lon + 5.0, 0.0);
        double x = 0, y = 0;
        if (!project(cam, {e.x, e.y, e.z}, &x, &y) || x < 1 || y < 1 || x >= o.width - 1 ||
            y >= o.height - 1)
          continue;
        const Rgb c =
            pixelAt(out.pixels, o.width, static_cast<int>(std::floor(x)), static_cast<int>(y));
        ++checked;
        const double diff = std::max(
            {std::abs(c.r - s.mean.r), std::abs(c.g - s.mean.g), std::abs(c.b - s.mean.b)});
        if (diff > 20.0) {
          ++bad;
          ADD_FAILURE() << "lat " << sign * lat << " lon " << lon + 5.0 << ": rendered " << c.r
                        << "," << c.g << "," << c.b << " image " << s.mean.r << "," << s.mean.g
                        << "," << s.mean.b;
        }
      }
    EXPECT_GE(checked, 30);
    EXPECT_EQ(bad, 0);
  }
}

TEST(RenderGl, WaitCompleteTwiceGivesTheIdenticalImage) {
  const Geodesy geodesy;
  BlueMarbleService bm;
  ASSERT_TRUE(bm.service);
  const CameraPose pose{45.5, 7.5, 2.0e6, 30.0, 40.0};
  std::vector<std::uint8_t> first;
  for (int run = 0; run < 2; ++run) {
    OPEN_RENDERER(r, *bm.service, geodesy, options("bluemarble", 400, 300));
    const Rendered out = renderComplete(r, pose);
    ASSERT_TRUE(out.complete);
    EXPECT_GT(out.stats.maxLevel, 0);
    if (run == 0) {
      first = out.pixels;
      save("alps-tilted", r, out.pixels);
    } else {
      EXPECT_TRUE(out.pixels == first) << "two complete renders of one view differ";
    }
  }
}

// Views of both poles (exactly and 0.0001 degrees off), the antimeridian and a low tilted view:
// with a magenta background no magenta pixel may lie inside the Earth's outline (a hole), and
// something must have been drawn.
TEST(RenderGl, PolesAndAntimeridianHaveNoHoles) {
  const Geodesy geodesy;
  BlueMarbleService bm;
  ASSERT_TRUE(bm.service);
  auto o = options("bluemarble", 320, 240);
  o.background = {1.0, 0.0, 1.0};
  OPEN_RENDERER(r, *bm.service, geodesy, o);
  const std::vector<CameraPose> poses = {
      {90.0, 0.0, 2.0e7, 0.0, 0.0},
      {-90.0, 0.0, 2.0e7, 0.0, 0.0},
      {89.9999, 0.0, 1.0e6, 0.0, 0.0},
      {-89.9999, 45.0, 1.0e6, 0.0, 0.0},
      {90.0, 0.0, 1.0e5, 0.0, 0.0},
      {-90.0, 0.0, 1.0e4, 0.0, 0.0},
      {89.9999, 0.0, 3.0e5, 0.0, 60.0},
      {0.0, 180.0, 1.0e6, 0.0, 0.0},
      {0.0, -180.0, 2.0e7, 0.0, 0.0},
      {10.0, 179.9999, 5.0e4, 90.0, 70.0},
      {-89.9999, 180.0, 1.0, 0.0, 80.0},
      {60.0, -179.99, 1.0e9, 0.0, 0.0},
  };
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const CameraPose& p = poses[i];
    SCOPED_TRACE("pose " + std::to_string(i) + ": " + std::to_string(p.latDeg) + "," +
                 std::to_string(p.lonDeg) + "," + std::to_string(p.altitudeM));
    const Rendered out = renderComplete(r, p);
    EXPECT_TRUE(out.complete);
    save("holes-" + std::to_string(i), r, out.pixels);
    const Camera cam = r.camera(p);
    int inside = 0, holes = 0;
    for (int y = 0; y < o.height; ++y)
      for (int x = 0; x < o.width; ++x) {
        if (!rayHitsEarth(cam, geodesy, x, y, 0.002)) continue;
        ++inside;
        const Rgb c = pixelAt(out.pixels, o.width, x, y);
        holes += c.r == 255 && c.g == 0 && c.b == 255;
      }
    EXPECT_GT(inside, 0);
    EXPECT_EQ(holes, 0) << "magenta pixels inside the Earth's outline";
    EXPECT_LT(countColour(out.pixels, 255, 0, 255), o.width * o.height) << "nothing drawn";
    EXPECT_TRUE(std::isfinite(out.stats.updateMs) && std::isfinite(out.stats.frameMs));
  }
}

// Where nodes of different levels meet, a coarse node's edge is a chord below its finer
// neighbour's: without skirts the background shows through. Deep trees (24 levels), low and tilted
// views, many level changes on screen; the poles' merged rows meet unmerged ones too.
TEST(RenderGl, NoCracksWhereLevelsMeet) {
  const Geodesy geodesy;
  FakeTileSource ramp(rampLayer(GridSpec{Sector{}, 36.0, 256, 256, 24}));
  auto o = options("ramp", 320, 240);
  o.background = {1.0, 0.0, 1.0};
  OPEN_RENDERER(r, ramp, geodesy, o);
  const std::vector<CameraPose> poses = {
      {10.3, 20.7, 2.0e5, 30.0, 75.0},
      {45.0, 7.0, 3.0e4, 200.0, 80.0},
      {-33.0, 151.0, 2.0e3, 90.0, 85.0},
      {88.0, 10.0, 2.0e5, 0.0, 70.0},
      {-89.5, 100.0, 5.0e4, 180.0, 80.0},
      {0.0, 179.99, 1.0e6, 90.0, 60.0},
      {60.0, 0.0, 5.0e6, 0.0, 30.0},
  };
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const CameraPose& p = poses[i];
    SCOPED_TRACE("pose " + std::to_string(i));
    const Rendered out = renderComplete(r, p);
    EXPECT_TRUE(out.complete);
    save("cracks-" + std::to_string(i), r, out.pixels);
    const Camera cam = r.camera(p);
    int holes = 0;
    for (int y = 0; y < o.height; ++y)
      for (int x = 0; x < o.width; ++x) {
        if (!rayHitsEarth(cam, geodesy, x, y, 0.002)) continue;
        const Rgb c = pixelAt(out.pixels, o.width, x, y);
        holes += c.r == 255 && c.g == 0 && c.b == 255;
      }
    std::printf("pose %zu: level %d, %zu nodes, %d background pixels inside\n",
                i,
                out.stats.maxLevel,
                out.stats.nodesDrawn,
                holes);
    EXPECT_EQ(holes, 0) << "cracks between nodes";
  }
}

// Tiles whose texels carry their own column and row: the rendered image's change of texel
// coordinate per pixel is the texel-to-pixel ratio the LOD kept. At threshold T a texel is at most
// T pixels (and a coarser level would have broken that, so not much smaller than T / 2).
TEST(RenderGl, TexelToPixelRatioIsKeptNearTheThreshold) {
  const Geodesy geodesy;
  FakeTileSource ramp(rampLayer(GridSpec{Sector{}, 36.0, 256, 256, 24}));
  for (const double threshold : {1.0, 2.0}) {
    auto o = options("ramp", 320, 240);
    o.lodThreshold = threshold;
    OPEN_RENDERER(r, ramp, geodesy, o);
    for (const double alt : {3.0e6, 2.0e5, 1.5e4, 800.0}) {
      SCOPED_TRACE("threshold " + std::to_string(threshold) + " altitude " + std::to_string(alt));
      const CameraPose pose{10.3, 20.7, alt, 0.0, 0.0};
      const Rendered out = renderComplete(r, pose);
      ASSERT_TRUE(out.complete);
      save("ramp-t" + std::to_string(static_cast<int>(threshold)) + "-" +
               std::to_string(static_cast<int>(alt)),
           r,
           out.pixels);
      // The middle 80 x 80 pixels: mean |d texel| per pixel step along x (red) and y (green),
      // leaving out steps across a tile edge (where the ramp wraps).
      double sx = 0, sy = 0;
      int nx = 0, ny = 0;
      for (int y = o.height / 2 - 40; y < o.height / 2 + 40; ++y)
        for (int x = o.width / 2 - 40; x < o.width / 2 + 40; ++x) {
          const Rgb c = pixelAt(out.pixels, o.width, x, y);
          const Rgb cx = pixelAt(out.pixels, o.width, x + 1, y);
          const Rgb cy = pixelAt(out.pixels, o.width, x, y + 1);
          if (std::abs(cx.r - c.r) < 100 && cx.b == c.b) {
            sx += std::abs(cx.r - c.r);
            ++nx;
          }
          if (std::abs(cy.g - c.g) < 100 && cy.b == c.b) {
            sy += std::abs(cy.g - c.g);
            ++ny;
          }
        }
      ASSERT_GT(nx, 1000);
      ASSERT_GT(ny, 1000);
      const double texelPxX = nx / sx, texelPxY = ny / sy; // pixels per texel
      std::printf("threshold %.1f altitude %.0f m: level %d, a texel is %.3f x %.3f pixels\n",
                  threshold,
                  alt,
                  out.stats.maxLevel,
                  texelPxX,
                  texelPxY);
      EXPECT_LE(texelPxX, threshold * 1.05);
      EXPECT_LE(texelPxY, threshold * 1.05);
      EXPECT_GE(std::max(texelPxX, texelPxY), threshold * 0.4);
    }
  }
}

// The same at the poles, looked at straight down, where a polar cap and its ring are drawn: along
// the row through the pole (left out: the 4 pixels around it) the radial direction is x, so green
// (a tile's rows: every node's texture is one tile tall) per x step gives the north-south texel.
// (Red cannot give the east-west one there: a cap's and a merged row's textures shrink many tiles
// into a few tile widths. QuadtreeExtremes.PolarCapsKeepThePoleWithinOneAndAHalfTheEquator checks
// it on the geometry: at most 0.95 px.)
TEST(RenderGl, TexelToPixelRatioIsKeptAtThePoles) {
  const Geodesy geodesy;
  FakeTileSource ramp(rampLayer(GridSpec{Sector{}, 36.0, 256, 256, 24}));
  for (const double threshold : {1.0, 2.0}) {
    auto o = options("ramp", 320, 240);
    o.lodThreshold = threshold;
    OPEN_RENDERER(r, ramp, geodesy, o);
    for (const double lat : {90.0, -90.0})
      for (const double alt : {3.0e6, 1.5e4, 800.0}) {
        SCOPED_TRACE("threshold " + std::to_string(threshold) + " latitude " + std::to_string(lat) +
                     " altitude " + std::to_string(alt));
        const Rendered out = renderComplete(r, {lat, 0.0, alt, 0.0, 0.0});
        ASSERT_TRUE(out.complete);
        save("ramp-t" + std::to_string(static_cast<int>(threshold)) + "-pole" +
                 std::to_string(static_cast<int>(lat)) + "-" +
                 std::to_string(static_cast<int>(alt)),
             r,
             out.pixels);
        const int cx = o.width / 2, cy = o.height / 2;
        double sum = 0;
        int steps = 0;
        for (int dx = 4; dx < 110; ++dx)
          for (const int x : {cx + dx, cx - 1 - dx}) {
            const Rgb c = pixelAt(out.pixels, o.width, x, cy);
            const Rgb next = pixelAt(out.pixels, o.width, x + 1, cy);
            if (std::abs(next.g - c.g) < 100 && next.b == c.b) { // not across a node's edge
              sum += std::abs(next.g - c.g);
              ++steps;
            }
          }
        ASSERT_GT(steps, 150);
        const double texelPx = steps / sum; // pixels per texel, north-south
        std::printf("threshold %.1f pole %+.0f altitude %.0f m: level %d, a texel is %.3f px "
                    "north-south\n",
                    threshold,
                    lat,
                    alt,
                    out.stats.maxLevel,
                    texelPx);
        EXPECT_LE(texelPx, threshold * 1.05);
        EXPECT_GE(texelPx, threshold * 0.4);
      }
  }
}

// No jitter at 1 m: the camera 1 m above the ground moves east in 2 mm steps; the ramp texture's
// texel coordinate under the screen's centre must move by the same amount each step (matrices are
// built in double relative to the camera; ECEF in float would snap to ~0.5 m). The place is a third
// of the way into a tile at every level, so the centre stays far from a tile edge.
TEST(RenderGl, NoJitterOneMetreAboveTheGround) {
  const Geodesy geodesy;
  FakeTileSource ramp(rampLayer(GridSpec{Sector{}, 36.0, 256, 256, 24}));
  auto o = options("ramp", 160, 120);
  OPEN_RENDERER(r, ramp, geodesy, o);
  const double lat = -6.0, lon0 = 12.0, alt = 1.0;
  const double metre = 180.0 / (M_PI * geodesy.equatorialRadius() * std::cos(lat * M_PI / 180.0));
  std::vector<double> centre;
  int level = 0;
  for (int k = 0; k < 6; ++k) {
    const CameraPose pose{lat, lon0 + k * 0.002 * metre, alt, 0.0, 0.0};
    const Rendered out = renderComplete(r, pose);
    ASSERT_TRUE(out.complete);
    level = out.stats.maxLevel;
    double sum = 0.0;
    for (int y = o.height / 2 - 8; y < o.height / 2 + 8; ++y)
      for (int x = o.width / 2 - 8; x < o.width / 2 + 8; ++x)
        sum += pixelAt(out.pixels, o.width, x, y).r;
    centre.push_back(sum / 256.0);
  }
  std::printf("level %d, red under the centre:", level);
  for (double c : centre)
    std::printf(" %.2f", c);
  std::printf("\n");
  EXPECT_GE(level, 20);
  std::vector<double> steps;
  for (std::size_t k = 1; k < centre.size(); ++k)
    steps.push_back(centre[k] - centre[k - 1]);
  double mean = 0.0;
  for (double d : steps)
    mean += d / static_cast<double>(steps.size());
  // 2 mm is about half a texel at this level: the image must move.
  EXPECT_GT(std::abs(mean), 0.3) << "2 mm steps do not move the image";
  for (double d : steps)
    EXPECT_TRUE(d / mean > 0.5 && d / mean < 1.5)
        << "uneven step " << d << " (mean " << mean << "): the image jitters";
}

// A renderer asked for a layer the source does not know refuses to start, with the name.
TEST(RenderGl, UnknownLayerIsRefused) {
  const Geodesy geodesy;
  BlueMarbleService bm;
  ASSERT_TRUE(bm.service);
  if (!haveDisplay()) GTEST_SKIP() << "no DISPLAY";
  auto made = Renderer::create(*bm.service, geodesy, options("nope", 64, 64));
  ASSERT_FALSE(made.has_value());
  EXPECT_NE(made.error().find("nope"), std::string::npos);
}

// Small budgets change the path, not the result: a texture budget far below what a flight needs
// (textures are evicted, recycled from the pool and fetched again) and uploads of 64 KiB a frame
// (a 512 x 512 texture takes ~22 frames) end in the same complete image as generous budgets.
TEST(RenderGl, SmallBudgetsEvictReuseAndStillGiveTheSameCompleteImage) {
  const Geodesy geodesy;
  BlueMarbleService bm;
  ASSERT_TRUE(bm.service);
  const CameraPose target{-33.9, 18.4, 3.0e5, 0.0, 0.0};
  std::vector<std::uint8_t> reference;
  {
    OPEN_RENDERER(r, *bm.service, geodesy, options("bluemarble", 256, 192));
    const Rendered out = renderComplete(r, target);
    ASSERT_TRUE(out.complete);
    reference = out.pixels;
  }
  auto o = options("bluemarble", 256, 192);
  const std::size_t textureBytes = 512 * 512 * 4 * 4 / 3 + 16; // one texture with its mips
  o.textureBudgetBytes = 20 * textureBytes; // fewer than the flight draws (issue 29: only the
                                            // roots drawn are fetched, not all 50)
  o.uploadBytesPerFrame = 64 * 1024;
  OPEN_RENDERER(r, *bm.service, geodesy, o);
  // A flight over several places first, so the LRU has to let textures go.
  for (const CameraPose& p : {CameraPose{0.0, 0.0, 3.0e6, 0.0, 0.0},
                              CameraPose{40.0, 100.0, 2.0e6, 0.0, 30.0},
                              CameraPose{-60.0, -60.0, 1.0e6, 0.0, 0.0},
                              CameraPose{70.0, 170.0, 5.0e5, 0.0, 45.0}})
    ASSERT_TRUE(renderComplete(r, p).complete);
  const Rendered out = renderComplete(r, target);
  ASSERT_TRUE(out.complete);
  std::printf("uploaded %zu, evicted %zu, reused %zu, resident %zu (%zu bytes)\n",
              out.stats.texturesUploaded,
              out.stats.texturesEvicted,
              out.stats.texturesReused,
              out.stats.texturesResident,
              out.stats.textureBytes);
  EXPECT_GT(out.stats.texturesEvicted, 0u);
  EXPECT_GT(out.stats.texturesReused, 0u);
  EXPECT_LE(out.stats.textureBytes, o.textureBudgetBytes);
  EXPECT_TRUE(out.pixels == reference) << "the same view differs after evictions";
}
