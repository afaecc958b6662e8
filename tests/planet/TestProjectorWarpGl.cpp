// A projector channel's warp and blend on the GPU (issue 28, label gl; planet/gl/src/
// ProjectorWarp.hpp): the image a renderer presents through a curved warp mesh and a soft blend
// mask is the CPU pass's (planet::warpAndBlend of readPixels()) to rounding, and not the image of
// the same mesh upside down (GL counts rows from the bottom, the mesh and mask from the top).
#include "GlTestSupport.hpp"

#include <tellus/planet/ChannelWarp.hpp>
#include <tellus/planet/Geodesy.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

using namespace tellus;
using namespace tellus::planet;
using namespace tellus::planet::gltest;

namespace {

constexpr double kPi = std::numbers::pi;
constexpr int kWidth = 320, kHeight = 200; // not square: a transposed lookup shows

/** A mesh that is not affine: the rows bow down, the columns bend, more at the top. */
WarpMesh curvedMesh() {
  WarpMesh m{11, 8, {}};
  for (int j = 0; j < m.rows; ++j)
    for (int i = 0; i < m.columns; ++i) {
      const double x = static_cast<double>(i) / (m.columns - 1);
      const double y = static_cast<double>(j) / (m.rows - 1);
      m.uv.emplace_back(0.1 + 0.8 * x + 0.06 * std::sin(kPi * y) * (1.0 - y),
                        0.05 + 0.85 * y * y + 0.08 * std::sin(kPi * x));
    }
  return m;
}

/** The same mesh with its rows in the opposite order. */
WarpMesh flipped(const WarpMesh& m) {
  WarpMesh f{m.columns, m.rows, {}};
  for (int j = m.rows - 1; j >= 0; --j)
    for (int i = 0; i < m.columns; ++i)
      f.uv.push_back(m.uv[static_cast<std::size_t>(j * m.columns + i)]);
  return f;
}

/** Soft edges: 0 at the left and the top, 1 inside, ramps of a fifth of the image. */
std::vector<float> softMask() {
  std::vector<float> w;
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      const double a = std::clamp((x + 0.5) / (0.2 * kWidth), 0.0, 1.0);
      const double b = std::clamp((y + 0.5) / (0.2 * kHeight), 0.0, 1.0);
      w.push_back(static_cast<float>(a * a * (3 - 2 * a) * b * b * (3 - 2 * b)));
    }
  return w;
}

double psnr(const std::vector<std::uint8_t>& a, const std::vector<std::uint8_t>& b) {
  double se = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (i % 4 == 3) continue;
    const double d = static_cast<double>(a[i]) - static_cast<double>(b[i]);
    se += d * d;
  }
  const double mse = se / (static_cast<double>(a.size()) * 0.75);
  return mse == 0.0 ? 99.0 : 10.0 * std::log10(255.0 * 255.0 / mse);
}

struct Images {
  std::vector<std::uint8_t> scene, presented;
};

Images drawWarped(Renderer& r) {
  const CameraPose pose{20.0, 10.0, 2.0e6, 15.0, 50.0}; // the horizon: sky at the top only
  const Rendered out = renderComplete(r, pose, 120.0);
  EXPECT_TRUE(out.complete);
  return {out.pixels, r.readPresented()};
}

RendererOptions warpedOptions(std::optional<WarpMesh> mesh,
                              std::optional<std::vector<float>> w,
                              int renderWidth = kWidth,
                              int renderHeight = kHeight) {
  RendererOptions o = options("ramp", renderWidth, renderHeight);
  o.projectorWarp =
      RendererOptions::ProjectorCalibration{std::move(mesh), std::move(w), kWidth, kHeight};
  return o;
}

} // namespace

TEST(ProjectorWarpGl, PresentedImageIsTheCpuWarpAndBlend) {
  const Geodesy g(EarthModel::Wgs84);
  FakeTileSource source(rampLayer(GridSpec{Sector{}, 36.0, 256, 256, 8}));
  const WarpMesh mesh = curvedMesh();
  const std::vector<float> mask = softMask();
  OPEN_RENDERER(r, source, g, warpedOptions(mesh, mask));
  const Images im = drawWarped(r);
  const ChannelImage cpu = warpAndBlend({kWidth, kHeight, im.scene}, kWidth, kHeight, &mesh, &mask);
  ASSERT_EQ(im.presented.size(), cpu.rgba.size());
  const double p = psnr(im.presented, cpu.rgba);
  std::printf("GPU vs CPU warp and blend: PSNR %.2f dB\n", p);
  EXPECT_GE(p, 40.0);
  // The warp did something: the presented image is not the scene.
  EXPECT_LT(psnr(im.presented, im.scene), 30.0);
  // The mask's top-left corner is 0: black there.
  EXPECT_EQ(im.presented[0] + im.presented[1] + im.presented[2], 0);
}

TEST(ProjectorWarpGl, MeshAndMaskAreNotUpsideDown) {
  const Geodesy g(EarthModel::Wgs84);
  FakeTileSource source(rampLayer(GridSpec{Sector{}, 36.0, 256, 256, 8}));
  const WarpMesh mesh = curvedMesh();
  OPEN_RENDERER(r, source, g, warpedOptions(mesh, std::nullopt));
  const Images im = drawWarped(r);
  const WarpMesh upsideDown = flipped(mesh);
  const ChannelImage right =
      warpAndBlend({kWidth, kHeight, im.scene}, kWidth, kHeight, &mesh, nullptr);
  const ChannelImage wrong =
      warpAndBlend({kWidth, kHeight, im.scene}, kWidth, kHeight, &upsideDown, nullptr);
  const double good = psnr(im.presented, right.rgba), bad = psnr(im.presented, wrong.rgba);
  std::printf("mesh as given: PSNR %.2f dB; upside down: %.2f dB\n", good, bad);
  EXPECT_GE(good, 40.0);
  EXPECT_LT(bad, 25.0);
  // The mask alone, 0 on the top rows: the presented top row is black, the bottom row not.
  OPEN_RENDERER(m, source, g, warpedOptions(std::nullopt, softMask()));
  const Images masked = drawWarped(m);
  std::uint64_t top = 0;
  for (int x = 0; x < kWidth; ++x)
    for (int k = 0; k < 3; ++k)
      top += masked.presented[static_cast<std::size_t>(x * 4 + k)];
  EXPECT_LT(top, static_cast<std::uint64_t>(kWidth)); // the mask's top row: ~0.0006
  const std::vector<float> mask = softMask();
  const ChannelImage cpu =
      warpAndBlend({kWidth, kHeight, masked.scene}, kWidth, kHeight, nullptr, &mask);
  EXPECT_GE(psnr(masked.presented, cpu.rgba), 40.0);
}

TEST(ProjectorWarpGl, ARenderLargerThanTheProjectorIsWarpedDownAsOnTheCpu) {
  // Rendered at 1.5 x the projector's 320 x 200 (as `"render"` or --render-scale asks): the
  // projector's image is the CPU pass's of the larger scene, with the curved mesh and without.
  const Geodesy g(EarthModel::Wgs84);
  FakeTileSource source(rampLayer(GridSpec{Sector{}, 36.0, 256, 256, 8}));
  const int w = kWidth * 3 / 2, h = kHeight * 3 / 2;
  const WarpMesh mesh = curvedMesh();
  const std::vector<float> mask = softMask();
  for (const bool warped : {true, false}) {
    OPEN_RENDERER(r,
                  source,
                  g,
                  warpedOptions(warped ? std::optional(mesh) : std::nullopt,
                                warped ? std::optional(mask) : std::nullopt,
                                w,
                                h));
    const Images im = drawWarped(r);
    ASSERT_EQ(im.scene.size(), static_cast<std::size_t>(w * h * 4));
    ASSERT_EQ(im.presented.size(), static_cast<std::size_t>(kWidth * kHeight * 4));
    const ChannelImage cpu = warpAndBlend(
        {w, h, im.scene}, kWidth, kHeight, warped ? &mesh : nullptr, warped ? &mask : nullptr);
    const double p = psnr(im.presented, cpu.rgba);
    std::printf("%s: GPU vs CPU at 1.5x: PSNR %.2f dB\n", warped ? "warped" : "scaled", p);
    EXPECT_GE(p, 40.0);
  }
}

TEST(ProjectorWarpGl, ARenderFourTimesTheProjectorsIsFilteredAsOnTheCpu) {
  // Rendered at 4 x the projector's 320 x 200, a layer of one-texel checks drawn with texels of
  // up to 3 rendered pixels (so that a projector pixel's footprint spans checks): each projector
  // pixel is the mean of 2 x 2 bilinear samples over it (warpSubsamples), on the GPU as on the
  // CPU. One sample a pixel skips three rendered pixels in four and aliases the checks: 29-33 dB
  // from the CPU's filtered image.
  const Geodesy g(EarthModel::Wgs84);
  const GridSpec grid{Sector{}, 36.0, 256, 256, 8};
  FakeTileSource source({"checks", grid, "image/png", [grid](const TileAddress& a) {
                           const int w = grid.tileWidth, h = grid.tileHeight;
                           std::vector<std::uint8_t> px(static_cast<std::size_t>(w * h * 4));
                           for (int y = 0; y < h; ++y)
                             for (int x = 0; x < w; ++x) {
                               auto* p = &px[static_cast<std::size_t>((y * w + x) * 4)];
                               p[0] = p[1] = (x + y) % 2 == 0 ? 255 : 0;
                               p[2] = static_cast<std::uint8_t>(a.key.level * 20);
                               p[3] = 255;
                             }
                           return FakeTileSource::result(
                               TileStatus::Ok, encodePngRgba(w, h, px), "image/png");
                         }});
  const int w = kWidth * 4, h = kHeight * 4;
  ASSERT_EQ(warpSubsamples(w, h, kWidth, kHeight), 2);
  const WarpMesh mesh = curvedMesh();
  const std::vector<float> mask = softMask();
  for (const bool warped : {true, false}) {
    RendererOptions o = warpedOptions(warped ? std::optional(mesh) : std::nullopt,
                                      warped ? std::optional(mask) : std::nullopt,
                                      w,
                                      h);
    o.lodThreshold = 3.0; // texels of up to 3 rendered pixels: checks a projector pixel spans
    OPEN_RENDERER(r, source, g, o);
    const Images im = drawWarped(r);
    ASSERT_EQ(im.presented.size(), static_cast<std::size_t>(kWidth * kHeight * 4));
    const ChannelImage cpu = warpAndBlend(
        {w, h, im.scene}, kWidth, kHeight, warped ? &mesh : nullptr, warped ? &mask : nullptr);
    const double p = psnr(im.presented, cpu.rgba);
    std::printf("%s: GPU vs CPU at 4x: PSNR %.2f dB\n", warped ? "warped" : "scaled", p);
    EXPECT_GE(p, 40.0);
  }
}
