// The dome rendered (issue #7, label gl): the domemaster's geometry by pixels (black corners, the
// circle at radius N / 2, the Earth's limb where the camera's altitude puts it), no seams at the
// cube faces' borders on a flat-colour dataset, and the same image twice with --wait-complete;
// each for both methods (DomeMethod::Direct and Cube). Then the two methods against each other on
// Blue Marble, and the direct method's fallback to the cube near the ground of a shallow dataset.
#include "GlTestSupport.hpp"

#include <tellus/planet/Geodesy.hpp>

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <string>

using namespace tellus;
using namespace tellus::planet;
using namespace tellus::planet::gltest;

namespace {

constexpr double kPi = std::numbers::pi;

/** Every tile the same colour, at any level: the layer of a FakeTileSource for every name. */
FakeTileSource::Layer solidLayer(GridSpec grid, std::array<std::uint8_t, 3> rgb) {
  std::vector<std::uint8_t> px(static_cast<std::size_t>(grid.tileWidth * grid.tileHeight) * 4);
  for (std::size_t i = 0; i < px.size(); i += 4) {
    px[i] = rgb[0];
    px[i + 1] = rgb[1];
    px[i + 2] = rgb[2];
    px[i + 3] = 255;
  }
  return {"solid",
          grid,
          "image/png",
          FakeTileSource::bytes(encodePngRgba(grid.tileWidth, grid.tileHeight, px), "image/png")};
}

constexpr std::array<std::uint8_t, 3> kSolid{200, 120, 40};
constexpr std::array<std::uint8_t, 3> kSky{255, 0, 255};

GridSpec solidGrid() {
  return GridSpec{Sector{}, 36.0, 256, 256, 20};
}

RendererOptions domeOptions(int n, double fov, DomeMethod method, double tilt = 0.0) {
  RendererOptions o = options("solid", n, n);
  o.globalImage.clear(); // no Blue Marble under a node still loading
  o.background = {kSky[0] / 255.0, kSky[1] / 255.0, kSky[2] / 255.0};
  o.dome = DomeOptions{fov, tilt, 0.64};
  o.dome->method = method;
  return o;
}

const char* methodName(DomeMethod m) {
  return m == DomeMethod::Direct ? "direct" : "cube";
}

/** PSNR (dB) of two RGBA images over the pixels inside the circle, RGB only. */
double psnrInCircle(const std::vector<std::uint8_t>& a, const std::vector<std::uint8_t>& b, int n) {
  double se = 0.0;
  std::size_t count = 0;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      if (std::hypot(x + 0.5 - 0.5 * n, y + 0.5 - 0.5 * n) > 0.5 * n) continue;
      const auto i = (static_cast<std::size_t>(y) * static_cast<std::size_t>(n) +
                      static_cast<std::size_t>(x)) *
                     4;
      for (std::size_t c = 0; c < 3; ++c) {
        const double d = static_cast<double>(a[i + c]) - static_cast<double>(b[i + c]);
        se += d * d;
        ++count;
      }
    }
  const double mse = se / static_cast<double>(count);
  return mse == 0.0 ? 99.0 : 10.0 * std::log10(255.0 * 255.0 / mse);
}

struct Pixel {
  int r, g, b;
};
Pixel at(const std::vector<std::uint8_t>& px, int n, int x, int y) {
  const auto i =
      (static_cast<std::size_t>(y) * static_cast<std::size_t>(n) + static_cast<std::size_t>(x)) * 4;
  return {px[i], px[i + 1], px[i + 2]};
}
bool near(const Pixel& p, const std::array<std::uint8_t, 3>& c, int tol) {
  return std::abs(p.r - c[0]) <= tol && std::abs(p.g - c[1]) <= tol && std::abs(p.b - c[2]) <= tol;
}
/** The distance in pixels of pixel (x, y)'s centre from the image's centre (rows from the top). */
double radiusOf(int n, int x, int y) {
  return std::hypot(x + 0.5 - 0.5 * n, y + 0.5 - 0.5 * n);
}

class DomeGl : public ::testing::TestWithParam<DomeMethod> {};

} // namespace

TEST_P(DomeGl, CircleCornersAndTheLimbWhereTheAltitudePutsIt) {
  const Geodesy g(EarthModel::Sphere);
  FakeTileSource source(solidLayer(solidGrid(), kSolid));
  const int n = 400;
  for (const double fov : {180.0, 220.0}) {
    OPEN_RENDERER(r, source, g, domeOptions(n, fov, GetParam()));
    const double h = 2e6; // the limb 49.56 degrees from the nadir
    const Rendered out = renderComplete(r, {10.0, 20.0, h, 0.0, 0.0});
    ASSERT_TRUE(out.complete);
    EXPECT_EQ(out.stats.domeMethod, methodName(GetParam()));
    const std::vector<std::uint8_t>& px = out.pixels;
    // Black outside the circle, exactly; inside it is sky or ground, never black.
    int outside = 0, inside = 0;
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const double rad = radiusOf(n, x, y);
        const Pixel p = at(px, n, x, y);
        if (rad > 0.5 * n) {
          ++outside;
          ASSERT_TRUE(p.r == 0 && p.g == 0 && p.b == 0) << x << "," << y;
        } else {
          ++inside;
          ASSERT_FALSE(p.r == 0 && p.g == 0 && p.b == 0) << x << "," << y;
        }
      }
    EXPECT_NEAR(inside, kPi / 4.0 * n * n, 2.0 * kPi * 0.5 * n); // within a pixel of the circle
    EXPECT_GT(outside, 0);
    for (const auto& [cx, cy] : {std::pair{0, 0}, {n - 1, 0}, {0, n - 1}, {n - 1, n - 1}}) {
      const Pixel p = at(px, n, cx, cy);
      EXPECT_TRUE(p.r == 0 && p.g == 0 && p.b == 0);
    }
    // The circle's edge on the centre row and column: the outermost pixels are inside.
    EXPECT_TRUE(near(at(px, n, 0, n / 2), kSky, 0));
    EXPECT_TRUE(near(at(px, n, n - 1, n / 2), kSky, 0));
    EXPECT_TRUE(near(at(px, n, n / 2, 0), kSky, 0));
    EXPECT_TRUE(near(at(px, n, n / 2, n - 1), kSky, 0));
    // The limb: asin(R / (R + h)) from the nadir, at that angle / (FOV / 2) x N / 2 pixels.
    const double R = g.equatorialRadius();
    const double limb = std::asin(R / (R + h));
    const double expected = limb / (0.5 * fov * kPi / 180.0) * 0.5 * n;
    for (int k = 0; k < 16; ++k) {
      const double phi = 2.0 * kPi * k / 16.0;
      double found = -1.0;
      for (double s = 0.0; s < 0.5 * n; s += 0.25) {
        const int x = static_cast<int>(std::floor(0.5 * n + s * std::cos(phi)));
        const int y = static_cast<int>(std::floor(0.5 * n + s * std::sin(phi)));
        const Pixel p = at(px, n, x, y);
        // Closer to the sky than to the ground: past the limb.
        const int toSky =
            std::abs(p.r - kSky[0]) + std::abs(p.g - kSky[1]) + std::abs(p.b - kSky[2]);
        const int toGround =
            std::abs(p.r - kSolid[0]) + std::abs(p.g - kSolid[1]) + std::abs(p.b - kSolid[2]);
        if (toSky < toGround) {
          found = radiusOf(n, x, y);
          break;
        }
      }
      EXPECT_NEAR(found, expected, 1.5) << "fov " << fov << " direction " << k;
    }
  }
}

// A flat colour everywhere: every pixel whose ray meets the ground away from the limb is that
// colour within 1, across the borders of the cube faces (front and side faces at 45-55 degrees
// from the axis, the back face of a 220-degree dome looking at the horizon).
TEST_P(DomeGl, FlatColourShowsNoSeams) {
  const Geodesy g(EarthModel::Sphere);
  FakeTileSource source(solidLayer(solidGrid(), kSolid));
  const int n = 320;
  struct View {
    double fov, tiltDeg;
  };
  for (const View v : {View{180.0, 0.0}, View{220.0, 90.0}, View{200.0, 45.0}}) {
    OPEN_RENDERER(r, source, g, domeOptions(n, v.fov, GetParam()));
    const double h = 3000.0;
    const CameraPose pose{30.0, 40.0, h, 20.0, v.tiltDeg};
    const Rendered out = renderComplete(r, pose, 120.0);
    ASSERT_TRUE(out.complete) << v.fov;
    EXPECT_EQ(out.stats.domeMethod, methodName(GetParam())) << out.stats.domeErrorPx;
    const Camera cam = r.camera(r.drawnPose());
    const glm::dvec3 upLocal = glm::normalize(cam.position());
    const double dip = std::acos(g.equatorialRadius() / (g.equatorialRadius() + h));
    int ground = 0, sky = 0, bad = 0;
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const double px = (x + 0.5 - 0.5 * n) / (0.5 * n), py = (0.5 * n - y - 0.5) / (0.5 * n);
        const double rr = std::hypot(px, py);
        if (rr > 0.995) continue; // the circle's edge blends with black
        const double theta = rr * cam.fisheyeHalfAngleRad();
        glm::dvec3 d = std::cos(theta) * cam.forward();
        if (rr > 0.0) d += std::sin(theta) / rr * (px * cam.right() + py * cam.up());
        const double elevation = std::asin(glm::dot(d, upLocal));
        const Pixel p = at(out.pixels, n, x, y);
        if (elevation < -dip - 0.03) {
          ++ground;
          if (!near(p, kSolid, 1)) ++bad;
        } else if (elevation > 0.01) {
          ++sky;
          if (!near(p, kSky, 0)) ++bad;
        }
      }
    EXPECT_EQ(bad, 0) << "fov " << v.fov << " tilt " << v.tiltDeg;
    EXPECT_GT(ground, n * n / 4);
    if (v.tiltDeg > 0.0) {
      EXPECT_GT(sky, n * n / 8);
    }
  }
}

TEST_P(DomeGl, WaitCompleteTwiceGivesTheSameImage) {
  BlueMarbleService bm("dome-gl");
  ASSERT_TRUE(bm.service);
  const Geodesy g;
  std::vector<std::uint8_t> first;
  for (int run = 0; run < 2; ++run) {
    RendererOptions o = options("bluemarble", 256, 256);
    o.dome = DomeOptions{200.0, 20.0, 0.64};
    o.dome->method = GetParam();
    OPEN_RENDERER(r, *bm.service, g, o);
    const Rendered out = renderComplete(r, {45.0, 7.0, 8e5, 30.0, 60.0});
    ASSERT_TRUE(out.complete);
    if (run == 0)
      first = out.pixels;
    else
      EXPECT_TRUE(out.pixels == first);
  }
}

INSTANTIATE_TEST_SUITE_P(Methods,
                         DomeGl,
                         ::testing::Values(DomeMethod::Direct, DomeMethod::Cube),
                         [](const auto& p) {
                           return std::string(p.param == DomeMethod::Direct ? "Direct" : "Cube");
                         });

// The two methods on Blue Marble (the bundled 2048 x 1024 image as three levels of 512-pixel
// tiles), the same views: they draw the same planar triangles, the direct method through the
// fisheye map at each vertex (straight edges: its error estimate stays under half a pixel here),
// the cube method resampling five faces of 0.64 N bilinearly. Each view at FOV 180 and 220 (the
// same frames as bench/dome.sh: the horizon from 500 km, straight down from 2,000 km).
TEST(DomeMethodsGl, DirectMatchesCubeOnBlueMarble) {
  BlueMarbleService bm("dome-methods-gl");
  ASSERT_TRUE(bm.service);
  const Geodesy g;
  const int n = 384;
  struct View {
    CameraPose pose;
    double fov;
  };
  for (const View& v : {View{{45.5, 7.5, 5e5, 0.0, 90.0}, 180.0},
                        View{{20.0, 10.0, 2e6, 0.0, 0.0}, 180.0},
                        View{{45.5, 7.5, 5e5, 0.0, 90.0}, 220.0}}) {
    std::vector<std::uint8_t> images[2];
    for (const DomeMethod m : {DomeMethod::Direct, DomeMethod::Cube}) {
      RendererOptions o = options("bluemarble", n, n);
      o.dome = DomeOptions{v.fov, 0.0, 0.64};
      o.dome->method = m;
      OPEN_RENDERER(r, *bm.service, g, o);
      const Rendered out = renderComplete(r, v.pose);
      ASSERT_TRUE(out.complete);
      EXPECT_EQ(out.stats.domeMethod, methodName(m));
      if (m == DomeMethod::Direct) {
        EXPECT_LE(out.stats.domeErrorPx, 0.5);
      }
      images[m == DomeMethod::Direct ? 0 : 1] = out.pixels;
    }
    const double psnr = psnrInCircle(images[0], images[1], n);
    // The cube's own resampling: its image against itself moved by one pixel.
    std::vector<std::uint8_t> shifted = images[1];
    const auto side = static_cast<std::size_t>(n);
    for (std::size_t y = 0; y < side; ++y)
      for (std::size_t x = side - 1; x > 0; --x)
        for (std::size_t c = 0; c < 4; ++c)
          shifted[(y * side + x) * 4 + c] = images[1][(y * side + x - 1) * 4 + c];
    const double shiftPsnr = psnrInCircle(images[1], shifted, n);
    RecordProperty("psnr_" + std::to_string(static_cast<int>(v.fov)) + "_" +
                       std::to_string(static_cast<int>(v.pose.altitudeM)),
                   std::to_string(psnr));
    std::printf("direct vs cube: fov %.0f alt %.0f: PSNR %.2f dB (cube vs cube moved 1 px: %.2f)\n",
                v.fov,
                v.pose.altitudeM,
                psnr,
                shiftPsnr);
    EXPECT_GT(psnr, shiftPsnr + 3.0) << v.fov << " " << v.pose.altitudeM;
    // The corners and outside: black in both.
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x)
        if (radiusOf(n, x, y) > 0.5 * n) {
          const Pixel p = at(images[0], n, x, y);
          ASSERT_TRUE(p.r == 0 && p.g == 0 && p.b == 0) << x << "," << y;
        }
  }
}

// Near the ground of a shallow dataset (3 levels: the deepest nodes are 9 degrees wide, triangles
// of 31 km seen from 30 m) the direct method's straight edges would be hundreds of pixels off:
// its estimate says so, and the frame is drawn with the cube method, the same image a cube
// renderer draws. Over a deep dataset at the same place it stays direct.
TEST(DomeMethodsGl, DirectFallsBackToTheCubeWhereTrianglesAreLarge) {
  const Geodesy g(EarthModel::Sphere);
  FakeTileSource shallow(solidLayer(GridSpec{Sector{}, 36.0, 256, 256, 3}, kSolid));
  FakeTileSource deep(solidLayer(solidGrid(), kSolid));
  const int n = 256;
  const CameraPose pose{30.0, 40.0, 30.0, 20.0, 80.0};
  std::vector<std::uint8_t> images[2];
  std::size_t faceBytes[2] = {};
  for (const DomeMethod m : {DomeMethod::Direct, DomeMethod::Cube}) {
    OPEN_RENDERER(r, shallow, g, domeOptions(n, 220.0, m, 30.0));
    const Rendered out = renderComplete(r, pose);
    ASSERT_TRUE(out.complete);
    EXPECT_EQ(out.stats.domeMethod, "cube");
    EXPECT_EQ(out.stats.domeError, "");
    if (m == DomeMethod::Direct) {
      EXPECT_GT(out.stats.domeErrorPx, 0.5);
    }
    images[m == DomeMethod::Direct ? 0 : 1] = out.pixels;
    faceBytes[m == DomeMethod::Direct ? 0 : 1] = out.stats.domeFaceBytes;
  }
  EXPECT_TRUE(images[0] == images[1]);
  // The fallback made the faces the cube renderer made when it was created.
  EXPECT_GT(faceBytes[1], 0u);
  EXPECT_EQ(faceBytes[0], faceBytes[1]);
  OPEN_RENDERER(r, deep, g, domeOptions(n, 220.0, DomeMethod::Direct, 30.0));
  const Rendered out = renderComplete(r, pose, 120.0);
  ASSERT_TRUE(out.complete);
  EXPECT_EQ(out.stats.domeMethod, "direct") << out.stats.domeErrorPx;
  // A direct dome that never fell back holds no cube faces.
  EXPECT_EQ(out.stats.domeFaceBytes, 0u);
}

// The direct map starts from the camera-relative position either vertex path computes: the
// two-float path (OpenGL 3.3's, or fp64Vertices off) draws the same dome as the double one.
TEST(DomeMethodsGl, DirectOnTheTwoFloatPathDrawsTheSameDome) {
  const Geodesy g(EarthModel::Sphere);
  FakeTileSource source(solidLayer(solidGrid(), kSolid));
  const int n = 256;
  std::vector<std::uint8_t> images[2];
  for (const bool fp64 : {true, false}) {
    RendererOptions o = domeOptions(n, 200.0, DomeMethod::Direct, 20.0);
    o.fp64Vertices = fp64;
    OPEN_RENDERER(r, source, g, o);
    const Rendered out = renderComplete(r, {30.0, 40.0, 5e5, 20.0, 70.0});
    ASSERT_TRUE(out.complete);
    EXPECT_EQ(out.stats.domeMethod, "direct");
    images[fp64 ? 0 : 1] = out.pixels;
  }
  int differ = 0;
  for (std::size_t i = 0; i < images[0].size(); i += 4)
    if (images[0][i] != images[1][i] || images[0][i + 1] != images[1][i + 1] ||
        images[0][i + 2] != images[1][i + 2])
      ++differ;
  // The limb may round differently at a few of its ~500 pixels; nothing else.
  EXPECT_LE(differ, 20);
}

// `tellus view --dome` in a window that is not square: the circle of diameter min(width, height)
// in the middle, exact black around it (the direct method's mask covers the wider framebuffer),
// the same pixels inside as the cube method's.
TEST(DomeMethodsGl, AWideFramebufferKeepsTheCircleInTheMiddle) {
  const Geodesy g(EarthModel::Sphere);
  FakeTileSource source(solidLayer(solidGrid(), kSolid));
  const int w = 300, h = 200;
  std::vector<std::uint8_t> images[2];
  for (const DomeMethod m : {DomeMethod::Direct, DomeMethod::Cube}) {
    RendererOptions o = domeOptions(h, 180.0, m);
    o.width = w;
    OPEN_RENDERER(r, source, g, o);
    const Rendered out = renderComplete(r, {10.0, 20.0, 2e6, 0.0, 0.0});
    ASSERT_TRUE(out.complete);
    EXPECT_EQ(out.stats.domeMethod, methodName(m));
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const auto i = (static_cast<std::size_t>(y) * w + static_cast<std::size_t>(x)) * 4;
        const bool black = out.pixels[i] == 0 && out.pixels[i + 1] == 0 && out.pixels[i + 2] == 0;
        const double rad = std::hypot(x + 0.5 - 0.5 * w, y + 0.5 - 0.5 * h);
        ASSERT_EQ(black, rad > 0.5 * h) << methodName(m) << " " << x << "," << y;
      }
    images[m == DomeMethod::Direct ? 0 : 1] = out.pixels;
  }
  int differ = 0; // at the limb, where the cube's resampling blends ground and sky
  for (std::size_t i = 0; i < images[0].size(); i += 4)
    if (std::abs(images[0][i] - images[1][i]) > 1) ++differ;
  // The limb lies asin(R / (R + h)) = 49.6 degrees from the nadir: 55 px, 346 px around.
  EXPECT_LT(differ, 346) << differ;
  std::printf("wide dome: %d pixels differ between the methods\n", differ);
}
