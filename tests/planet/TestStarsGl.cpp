// The stars pass (planet/gl/src/StarsPass.hpp), rendered: named bright stars of the bundled
// catalogue land on the pixels the CPU predicts (catalogue place -> astro::celestialToEcef at a
// known time -> the renderer's camera, Camera::projectPx) in the flat view and the dome (direct and
// cube), the brighter star is brighter, a star's summed energy holds as the camera turns by
// fractions of a pixel, and the globe drawn after the stars hides them.
#include "GlTestSupport.hpp"

#include <tellus/planet/StarCatalogue.hpp>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

using namespace tellus;
using namespace tellus::planet;
using namespace tellus::planet::gltest;

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
// 2026-01-15T03:00:00Z: the test's scene time (Orion high over the Atlantic at night).
constexpr double kTime = 1768446000.0;
constexpr int kSirius = 32349, kPolaris = 11767, kBetelgeuse = 27989, kCanopus = 30438;

std::shared_ptr<const StarCatalogue> bundled() {
  static const auto c = [] {
    auto r =
        StarCatalogue::open(std::filesystem::path(TELLUS_TEST_DATA_DIR) / kStarCatalogueFileName);
    if (!r) throw std::runtime_error(r.error());
    return std::make_shared<const StarCatalogue>(std::move(*r));
  }();
  return c;
}

GridSpec grid() {
  return GridSpec{Sector{}, 36.0, 256, 256, 10};
}

RendererOptions starOptions(int w, int h, double magnitudeLimit) {
  RendererOptions o = options("absent", w, h);
  o.globalImage.clear();
  o.verticalFovDeg = 30.0;
  o.stars = bundled();
  o.starMagnitudeLimit = magnitudeLimit;
  o.timeUnixSeconds = kTime;
  return o;
}

/** Where a star should be: window pixels from the top left (pixel i covers [i, i + 1)). */
bool predict(const Camera& cam, int hip, double& x, double& y, double time = kTime) {
  const glm::dvec3 d = starDirectionEcef(*bundled()->find(hip), time);
  glm::dvec2 px;
  if (!cam.projectPx(cam.position() + d * 1e3, px)) return false;
  x = 0.5 * cam.viewport().width + px.x;
  y = 0.5 * cam.viewport().height - px.y; // a domemaster's circle is centred too
  return true;
}

/** What a star left in a window of radius 5 pixels around (x, y): each channel's sum (in full
 * pixels), the largest of them (the energy: a star's colour has a largest channel of 1), and the
 * centroid of the pixel centres weighted by that channel. */
struct Blob {
  std::array<double, 3> sum{};
  double energy = 0.0, cx = 0.0, cy = 0.0, peak = 0.0;
};
Blob measure(const std::vector<std::uint8_t>& px, int w, int h, double x, double y) {
  Blob b;
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  std::array<double, 3> mx{}, my{};
  for (int j = y0 - 5; j <= y0 + 5; ++j)
    for (int i = x0 - 5; i <= x0 + 5; ++i) {
      if (i < 0 || j < 0 || i >= w || j >= h) continue;
      const auto* p = &px[static_cast<std::size_t>((j * w + i) * 4)];
      for (std::size_t c = 0; c < 3; ++c) {
        const double v = p[c] / 255.0;
        b.sum[c] += v;
        mx[c] += v * (i + 0.5);
        my[c] += v * (j + 0.5);
        b.peak = std::max(b.peak, v);
      }
    }
  std::size_t top = 0;
  for (std::size_t c = 1; c < 3; ++c)
    if (b.sum[c] > b.sum[top]) top = c;
  b.energy = b.sum[top];
  if (b.energy > 0.0) {
    b.cx = mx[top] / b.energy;
    b.cy = my[top] / b.energy;
  }
  return b;
}

/** A pose far out (2e7 m) looking straight up from a point offset from under the star. */
CameraPose lookingUpNear(int hip, double dLat, double dLon, double heading) {
  const glm::dvec3 d = starDirectionEcef(*bundled()->find(hip), kTime);
  return {std::asin(d.z) / kDeg + dLat, std::atan2(d.y, d.x) / kDeg + dLon, 2e7, heading, 180.0};
}

TEST(StarsGl, NamedStarsLandOnTheirPredictedPixelsInTheFlatView) {
  // 128 x 128 at 30 degrees (0.23 degree a pixel); stars to V = 4 (few neighbours to bias the
  // centroid). Each star off the centre by several degrees in a turned view (heading 30), so a
  // mirrored or turned sky would miss. Tolerance 0.1 pixel (llvmpipe: within 0.013 px): the
  // footprint's centroid (sigma 0.8 px, 8-bit values) is within a few hundredths of a pixel of its
  // centre; float directions add 1e-7 rad; the rest is margin for other GL rasterisers.
  const int n = 128;
  FakeTileSource source(absentLayer(grid()));
  const Geodesy g(EarthModel::Wgs84);
  OPEN_RENDERER(r, source, g, starOptions(n, n, 4.0));
  struct Case {
    int hip;
    double dLat, dLon;
  };
  for (const Case c : {Case{kSirius, 4.0, 5.0},
                       Case{kPolaris, -5.0, 40.0},
                       Case{kBetelgeuse, -3.0, -6.0},
                       Case{kCanopus, 5.0, -4.0}}) {
    const Rendered out = renderComplete(r, lookingUpNear(c.hip, c.dLat, c.dLon, 30.0));
    ASSERT_TRUE(out.complete);
    double x = 0.0, y = 0.0;
    ASSERT_TRUE(predict(r.camera(r.drawnPose()), c.hip, x, y));
    ASSERT_TRUE(x > 10 && x < n - 10 && y > 10 && y < n - 10) << c.hip << " at " << x << "," << y;
    EXPECT_GT(std::hypot(x - n / 2.0, y - n / 2.0), 10.0) << c.hip; // off the centre
    const Blob b = measure(out.pixels, n, n, x, y);
    EXPECT_NEAR(b.cx, x, 0.1) << c.hip;
    EXPECT_NEAR(b.cy, y, 0.1) << c.hip;
    // The summed energy is the mapping's (starEnergy) within 3% (llvmpipe: 0.3%): 8-bit rounding
    // of ~30 pixels and the tail below half a level (under 1% of the energy) that rounds to 0.
    const Star& s = *bundled()->find(c.hip);
    EXPECT_NEAR(b.energy, starEnergy(s.vmag, 1.0), 0.03 * starEnergy(s.vmag, 1.0)) << c.hip;
    // Betelgeuse (3,800 K) is orange-red, Sirius (10,000 K) blue-white.
    if (c.hip == kBetelgeuse) {
      EXPECT_GT(b.sum[0], 1.4 * b.sum[2]);
    }
    if (c.hip == kSirius) {
      EXPECT_NEAR(b.sum[2] / b.sum[0], 1.25, 0.1); // (0.80, 0.85, 1)
    }
  }
}

class StarsDomeGl : public ::testing::TestWithParam<DomeMethod> {};

TEST_P(StarsDomeGl, NamedStarsLandOnTheirPredictedPixelsAndTheBrighterIsBrighter) {
  // A 256 x 256 domemaster (180 degrees: 0.70 degree a pixel) looking up from 10 N under
  // Betelgeuse's meridian: Betelgeuse near the zenith, Sirius and Canopus to the south, Polaris
  // 80 degrees north. Stars to V = 2 (no neighbour within the 5-pixel window: 3.5 degrees here).
  // Tolerance: 0.1 px direct (as flat); 0.3 px cube (the faces' footprints are resampled
  // bilinearly by the warp).
  const int n = 256;
  FakeTileSource source(absentLayer(grid()));
  const Geodesy g(EarthModel::Wgs84);
  RendererOptions o = starOptions(n, n, 2.0);
  o.dome = DomeOptions{180.0, 0.0, 0.64};
  o.dome->method = GetParam();
  OPEN_RENDERER(r, source, g, o);
  CameraPose pose = lookingUpNear(kBetelgeuse, 0.0, 0.0, 0.0);
  pose.latDeg = 10.0;
  const Rendered out = renderComplete(r, pose);
  ASSERT_TRUE(out.complete);
  EXPECT_EQ(out.stats.domeMethod, GetParam() == DomeMethod::Direct ? "direct" : "cube");
  const double tol = GetParam() == DomeMethod::Direct ? 0.1 : 0.3;
  const Camera cam = r.camera(r.drawnPose());
  std::map<int, Blob> blobs;
  for (const int hip : {kSirius, kCanopus, kBetelgeuse, kPolaris}) {
    double x = 0.0, y = 0.0;
    ASSERT_TRUE(predict(cam, hip, x, y));
    ASSERT_LT(std::hypot(x - n / 2.0, y - n / 2.0), 0.5 * n - 8) << hip; // inside the circle
    const Blob b = measure(out.pixels, n, n, x, y);
    EXPECT_NEAR(b.cx, x, tol) << hip;
    EXPECT_NEAR(b.cy, y, tol) << hip;
    blobs[hip] = b;
  }
  // V: Sirius -1.44, Canopus -0.62, Betelgeuse 0.45, Polaris 1.97 (Hipparcos).
  EXPECT_GT(blobs[kSirius].energy, 1.1 * blobs[kCanopus].energy);
  EXPECT_GT(blobs[kCanopus].energy, 1.1 * blobs[kBetelgeuse].energy);
  EXPECT_GT(blobs[kBetelgeuse].energy, 1.1 * blobs[kPolaris].energy);
  EXPECT_EQ(out.pixels[0], 0); // outside the circle: black
}

INSTANTIATE_TEST_SUITE_P(Methods,
                         StarsDomeGl,
                         ::testing::Values(DomeMethod::Direct, DomeMethod::Cube),
                         [](const auto& p) {
                           return std::string(p.param == DomeMethod::Direct ? "Direct" : "Cube");
                         });

TEST(StarsGl, SummedEnergyHoldsAsTheCameraTurnsBySubPixelSteps) {
  // Sirius alone (limit -1), the camera tilted by 0.02 degree a frame (0.085 px at 0.234 degree
  // a pixel) over two pixels: the peak pixel rises and falls as the star crosses pixel borders,
  // while the sum stays within 1% of its mean (8-bit rounding; llvmpipe: 0.4%) and the centroid
  // follows the prediction within 0.05 px (llvmpipe: 0.006): no shimmer, no jumps.
  const int n = 128;
  FakeTileSource source(absentLayer(grid()));
  const Geodesy g(EarthModel::Wgs84);
  OPEN_RENDERER(r, source, g, starOptions(n, n, -1.0));
  CameraPose pose = lookingUpNear(kSirius, 3.0, 4.0, 10.0);
  std::vector<double> sums, peaks;
  for (int k = 0; k <= 24; ++k) {
    pose.tiltDeg = 176.0 + 0.02 * k;
    const Rendered out = renderComplete(r, pose);
    ASSERT_TRUE(out.complete);
    double x = 0.0, y = 0.0;
    ASSERT_TRUE(predict(r.camera(r.drawnPose()), kSirius, x, y));
    const Blob b = measure(out.pixels, n, n, x, y);
    EXPECT_NEAR(b.cx, x, 0.05) << k;
    EXPECT_NEAR(b.cy, y, 0.05) << k;
    sums.push_back(b.energy);
    peaks.push_back(b.peak);
  }
  double mean = 0.0;
  for (const double s : sums)
    mean += s / static_cast<double>(sums.size());
  for (std::size_t k = 0; k < sums.size(); ++k)
    EXPECT_NEAR(sums[k], mean, 0.01 * mean) << k;
  const auto [lo, hi] = std::minmax_element(peaks.begin(), peaks.end());
  EXPECT_GT(*hi - *lo, 0.1) << "the star should have crossed pixel borders";
}

TEST(StarsGl, ExtremesOneMetreAMillionKilometresThePoleAndFarDates) {
  // Only the direction enters the stars' projection: from 1 m above the ground (2 m after the
  // terrain clearance) and from 1e9 m, at the north pole looking up at Polaris, in 1600 and 2400
  // (precession moves Polaris by degrees), each star lands where the CPU predicts (0.1 px, as
  // above) with its energy (3%).
  const int n = 128;
  FakeTileSource source(absentLayer(grid()));
  const Geodesy g(EarthModel::Wgs84);
  struct Case {
    int hip;
    double lat, lon, alt, time;
  };
  const double y1600 = -11676096000.0, y2400 = 13569465600.0; // 1600-01-01, 2400-01-01 UTC
  for (const Case c : {Case{kSirius, -14.0, 0.0, 1.0, kTime},
                       Case{kSirius, -14.0, 0.0, 1e9, kTime},
                       Case{kPolaris, 90.0, 0.0, 1.0, kTime},
                       Case{kPolaris, 90.0, 0.0, 1.0, y1600},
                       Case{kPolaris, 90.0, 0.0, 1e9, y2400}}) {
    RendererOptions o = starOptions(n, n, 2.5);
    o.timeUnixSeconds = c.time;
    OPEN_RENDERER(r, source, g, o);
    CameraPose pose{c.lat, c.lon, c.alt, 0.0, 180.0};
    if (c.hip == kSirius) { // under Sirius at this time, a few degrees off
      const glm::dvec3 d = starDirectionEcef(*bundled()->find(kSirius), c.time);
      pose.lonDeg = std::atan2(d.y, d.x) / kDeg + 3.0;
    }
    const Rendered out = renderComplete(r, pose);
    ASSERT_TRUE(out.complete);
    double x = 0.0, y = 0.0;
    ASSERT_TRUE(predict(r.camera(r.drawnPose()), c.hip, x, y, c.time));
    ASSERT_TRUE(x > 8 && x < n - 8 && y > 8 && y < n - 8) << c.hip << " at " << x << "," << y;
    const Blob b = measure(out.pixels, n, n, x, y);
    EXPECT_NEAR(b.cx, x, 0.1) << c.alt << " " << c.time;
    EXPECT_NEAR(b.cy, y, 0.1) << c.alt << " " << c.time;
    const double e = starEnergy(bundled()->find(c.hip)->vmag, 1.0);
    EXPECT_NEAR(b.energy, e, 0.03 * e) << c.alt << " " << c.time;
  }
}

TEST(StarsGl, TheGlobeHidesTheStarsBehindIt) {
  // Looking down at the Earth from 2e7 m: with stars and without, the disc's pixels are the same
  // (the globe drawn after the stars covers them) and the sky around it differs.
  const int n = 128;
  FakeTileSource source(absentLayer(grid()));
  const Geodesy g(EarthModel::Wgs84);
  const CameraPose pose{20.0, -30.0, 2e7, 0.0, 0.0};
  RendererOptions with = starOptions(n, n, 6.5), without = with;
  without.stars.reset();
  std::vector<std::uint8_t> a, b;
  {
    OPEN_RENDERER(r, source, g, with);
    a = renderComplete(r, pose).pixels;
  }
  std::optional<Camera> cam;
  {
    OPEN_RENDERER(r, source, g, without);
    b = renderComplete(r, pose).pixels;
    cam.emplace(r.camera(r.drawnPose()));
  }
  int disc = 0, discDiffer = 0, skyDiffer = 0;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const auto i = static_cast<std::size_t>((y * n + x) * 4);
      const bool differ = a[i] != b[i] || a[i + 1] != b[i + 1] || a[i + 2] != b[i + 2];
      if (rayHitsEarth(*cam, g, x, y, 0.01)) {
        ++disc;
        discDiffer += differ;
      } else if (!rayHitsEarth(*cam, g, x, y, -0.01)) {
        skyDiffer += differ;
      }
    }
  EXPECT_GT(disc, 1000);
  EXPECT_EQ(discDiffer, 0);
  EXPECT_GT(skyDiffer, 50);
}

} // namespace
