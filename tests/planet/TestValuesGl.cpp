// Layers of values in the renderer (issue 24, label gl): the GPU colours a layer of raw values
// with the EXACT rule of values/ColourScale.hpp. Every screen pixel is traced to the point on the
// globe under it (planet/Pick.hpp) and so to the texel the renderer samples there (nearest
// texel: ValueWorld.hpp knows each texel's value); its colour must be the one values::apply gives
// that texel of the same tile bytes (the proxy's GetMap path), the grey base where the CPU says
// transparent. Pixels within 0.15 texel of a texel edge are left out (the mesh's planar triangles
// and the ray to the true ellipsoid disagree there by a fraction of a pixel). Allowed: exactly
// the documented one-bin difference where the CPU's t * 256 lies within 1e-4 of an integer.

#include "GlTestSupport.hpp"
#include "ValueWorld.hpp"

#include <tellus/planet/Pick.hpp>
#include <tellus/values/ColourMap.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <string>

using namespace tellus;
using namespace tellus::planet;
using namespace tellus::planet::valuetest;

namespace {

const CameraPose kView{10.0, 20.0, 2.0e6, 0.0, 0.0}; // texels of ~10 pixels across

RendererOptions valueOptions(ValueLayerOptions v, double opacity = 1.0) {
  RendererOptions o;
  o.layer = "base";
  o.width = 128;
  o.height = 128;
  v.format = valueFormat();
  LayerOptions l;
  l.layer = "vals";
  l.opacity = opacity;
  l.values = v;
  o.overlays.push_back(l);
  return o;
}

values::ColourScale scaleOf(const ValueLayerOptions& v) {
  return {values::findColourMap(v.colourMap), v.min, v.max, v.scaling, v.outOfRange};
}

struct Tally {
  int compared = 0, exact = 0, oneBin = 0, wrong = 0;
  int noData = 0, below = 0, above = 0; ///< compared pixels of each kind
  std::string firstWrong;
};

/** Whether the CPU's t * 256 for v lies within 1e-4 of an integer and the GPU's colour is the
 * neighbouring bin's. */
bool oneBinOff(const values::ColourScale& s, float v, const std::array<std::uint8_t, 4>& got) {
  const double t = values::scalePosition(s, v) * 256.0;
  if (!(std::abs(t - std::round(t)) < 1e-4)) return false;
  const int i = values::colourIndex(s, v);
  for (const int j : {i - 1, i + 1}) {
    if (j < 0 || j > 255) continue;
    const values::Rgb8 c = (*s.map->table)[static_cast<std::size_t>(j)];
    if (got[0] == c[0] && got[1] == c[1] && got[2] == c[2]) return true;
  }
  return false;
}

/** Every pixel of a complete render against the CPU's colour (over the grey base at opacity). */
Tally compare(
    Renderer& r, ValueWorld& w, const ValueLayerOptions& v, double opacity, int tolerance) {
  const auto done = gltest::renderComplete(r, kView);
  EXPECT_TRUE(done.complete);
  const Camera cam = r.camera(r.drawnPose());
  const Geodesy wgs;
  const values::ColourScale s = scaleOf(v);
  Tally t;
  for (int y = 0; y < r.height(); ++y)
    for (int x = 0; x < r.width(); ++x) {
      const auto g = pickGlobe(cam, wgs, x + 0.5 - r.width() / 2.0, r.height() / 2.0 - (y + 0.5));
      if (!g) continue;
      const auto texel = ValueWorld::texelAt(g->latDeg, g->lonDeg);
      if (texel.edge < 0.15) continue;
      const float value = ValueWorld::valueOf(texel);
      const auto cpu = w.cpuColour(s, texel);
      std::array<double, 3> want{};
      const double a = cpu[3] / 255.0 * opacity;
      for (std::size_t c = 0; c < 3; ++c)
        want[c] = kGrey[c] * (1.0 - a) + cpu[c] * a;
      const auto i = static_cast<std::size_t>((y * r.width() + x) * 4);
      const std::array<std::uint8_t, 4> got{
          done.pixels[i], done.pixels[i + 1], done.pixels[i + 2], 255};
      ++t.compared;
      if (std::isnan(value))
        ++t.noData;
      else if (values::scalePosition(s, value) < 0.0)
        ++t.below;
      else if (values::scalePosition(s, value) > 1.0)
        ++t.above;
      int off = 0;
      for (std::size_t c = 0; c < 3; ++c)
        off = std::max(off, static_cast<int>(std::lround(std::abs(got[c] - want[c]))));
      if (off <= tolerance) {
        ++t.exact;
      } else if (opacity == 1.0 && oneBinOff(s, value, got)) {
        ++t.oneBin;
      } else {
        if (t.wrong++ == 0)
          t.firstWrong = "pixel " + std::to_string(x) + "," + std::to_string(y) + " value " +
                         std::to_string(value) + ": got " + std::to_string(got[0]) + "," +
                         std::to_string(got[1]) + "," + std::to_string(got[2]) + " want " +
                         std::to_string(want[0]) + "," + std::to_string(want[1]) + "," +
                         std::to_string(want[2]);
      }
    }
  return t;
}

void expectMatches(const Tally& t) {
  EXPECT_GT(t.compared, 8000); // of 16384 pixels: most lie inside a texel
  EXPECT_EQ(t.wrong, 0) << t.firstWrong;
  EXPECT_LE(t.oneBin, t.compared / 100);
}

TEST(ValuesGl, LinearClampedColoursAreTheCpuRulePixelForPixel) {
  ValueWorld w;
  const Geodesy wgs;
  ValueLayerOptions v;
  v.colourMap = "viridis";
  v.min = 0.0;
  v.max = 100.0;
  OPEN_RENDERER(r, w.source, wgs, valueOptions(v));
  const Tally t = compare(r, w, v, 1.0, 0);
  expectMatches(t);
  EXPECT_GT(t.noData, 100); // no data: transparent, the grey base shows
  EXPECT_GT(t.below, 100);  // clamped to the ends' colours both ways
  EXPECT_GT(t.above, 100);
}

TEST(ValuesGl, OutOfRangeTransparentBothWaysShowsTheBase) {
  ValueWorld w;
  const Geodesy wgs;
  ValueLayerOptions v;
  v.colourMap = "turbo";
  v.min = 10.0;
  v.max = 90.0;
  v.outOfRange = values::OutOfRange::Transparent;
  OPEN_RENDERER(r, w.source, wgs, valueOptions(v));
  const Tally t = compare(r, w, v, 1.0, 0);
  expectMatches(t);
  EXPECT_GT(t.below, 100);
  EXPECT_GT(t.above, 100);
}

TEST(ValuesGl, LogScalingIsTheCpuRule) {
  ValueWorld w;
  const Geodesy wgs;
  ValueLayerOptions v;
  v.colourMap = "magma";
  v.min = 1.0;
  v.max = 100.0;
  v.scaling = values::Scaling::Log;
  OPEN_RENDERER(r, w.source, wgs, valueOptions(v));
  const Tally t = compare(r, w, v, 1.0, 0);
  expectMatches(t);
  EXPECT_GT(t.below, 100); // values <= 0 among them
}

// Opacity as for overlays: the colour mixed over the base (within 1 of 255 for the rounding of
// the mix), no data still the base alone.
TEST(ValuesGl, OpacityMixesTheColourOverTheBase) {
  ValueWorld w;
  const Geodesy wgs;
  ValueLayerOptions v;
  v.colourMap = "cividis";
  v.min = -30.0;
  v.max = 130.0;
  OPEN_RENDERER(r, w.source, wgs, valueOptions(v, 0.5));
  const Tally t = compare(r, w, v, 0.5, 1);
  EXPECT_GT(t.compared, 8000);
  EXPECT_EQ(t.wrong, 0) << t.firstWrong;
}

} // namespace
