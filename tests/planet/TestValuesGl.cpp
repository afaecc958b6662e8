// Layers of values in the renderer (issue 24, label gl): the GPU samples a layer of raw values by
// values/Sample.hpp's rule and colours them with the EXACT rule of values/ColourScale.hpp. Every
// screen pixel is traced to the point on the globe under it (planet/Pick.hpp) and so to its place
// in the tile the renderer samples there (ValueWorld.hpp knows each texel's value); its colour
// must be one that values::sample over the same tile bytes (clamped at the tile's edges, as a
// node's texture is) and values::colourOf give within 0.05 texel of that place (the mesh's planar
// triangles and the ray to the true ellipsoid disagree by a fraction of a pixel, and the values
// change by up to ~25 units a texel here), the grey base where the CPU says transparent. Pixels
// within 0.15 texel of a texel edge are left out (the value jumps there beside no data). Allowed
// besides: the documented one-bin difference where the CPU's t * 256 lies within 1e-4 of an
// integer. (tests/planet/TestValuesGetMapGl.cpp compares a render with a GetMap.)

#include "GlTestSupport.hpp"
#include "LegendOverlay.hpp"
#include "ValueWorld.hpp"

#include <tellus/planet/Pick.hpp>
#include <tellus/values/ColourMap.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

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

constexpr double kSlack = 0.05; // texels: how far the pick's point may be from the pixel's

/** The values values::sample gives within kSlack texel of (lat, lon) inside the tile there (a
 * 3 x 3 grid, clamped to the tile: the node's texture holds no neighbour texels); [4] is the
 * point's own. */
std::array<float, 9> valuesAround(double latDeg, double lonDeg) {
  const double fx = (lonDeg + 180.0) / 36.0, fy = (latDeg + 90.0) / 36.0;
  const auto col = static_cast<std::int64_t>(std::floor(fx));
  const auto row = static_cast<std::int64_t>(std::floor(fy));
  const double tx = (fx - static_cast<double>(col)) * 32.0;
  const double ty = (1.0 - (fy - static_cast<double>(row))) * 32.0; // from the north
  const auto raster = values::decode(bilTile(row, col), valueFormat(), 32, 32);
  std::array<float, 9> out{};
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i)
      out[static_cast<std::size_t>(j * 3 + i)] =
          values::sample(*raster,
                         std::clamp(tx + (i - 1) * kSlack, 0.0, 32.0),
                         std::clamp(ty + (j - 1) * kSlack, 0.0, 32.0));
  return out;
}

/** The colours the CPU's rule allows for those values: every index between the least and the
 * largest of them, and transparent where one of them is. */
std::vector<values::Rgba8> allowedColours(const values::ColourScale& s,
                                          const std::array<float, 9>& vs) {
  std::vector<values::Rgba8> out;
  int lo = 256, hi = -1;
  for (const float v : vs) {
    const int i = values::colourIndex(s, v);
    if (i < 0) {
      out.push_back({0, 0, 0, 0});
      continue;
    }
    lo = std::min(lo, i);
    hi = std::max(hi, i);
  }
  for (int i = lo; i <= hi; ++i) {
    const values::Rgb8 c = (*s.map->table)[static_cast<std::size_t>(i)];
    out.push_back({c[0], c[1], c[2], 255});
  }
  return out;
}

/** Every pixel of a complete render against the CPU's colours (over the grey base at opacity). */
Tally compare(
    Renderer& r, ValueWorld& w, const ValueLayerOptions& v, double opacity, int tolerance) {
  (void)w;
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
      const auto around = valuesAround(g->latDeg, g->lonDeg);
      const float value = around[4];
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
      int off = 1 << 20;
      std::array<double, 3> closest{};
      for (const auto& cpu : allowedColours(s, around)) {
        std::array<double, 3> want{};
        const double a = cpu[3] / 255.0 * opacity;
        int o = 0;
        for (std::size_t c = 0; c < 3; ++c) {
          want[c] = kGrey[c] * (1.0 - a) + cpu[c] * a;
          o = std::max(o, static_cast<int>(std::lround(std::abs(got[c] - want[c]))));
        }
        if (o < off) {
          off = o;
          closest = want;
        }
      }
      if (off <= tolerance) {
        ++t.exact;
      } else if (opacity == 1.0 && oneBinOff(s, value, got)) {
        ++t.oneBin;
      } else {
        if (t.wrong++ == 0)
          t.firstWrong = "pixel " + std::to_string(x) + "," + std::to_string(y) + " value " +
                         std::to_string(value) + ": got " + std::to_string(got[0]) + "," +
                         std::to_string(got[1]) + "," + std::to_string(got[2]) + " closest " +
                         std::to_string(closest[0]) + "," + std::to_string(closest[1]) + "," +
                         std::to_string(closest[2]);
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

// The legend (RendererOptions::legend): the picture values::renderLegend makes of the layer's
// scale, at its place (bottom left), exactly (it is copied, not drawn): every pixel of it, the
// colour bar with them. Off: that corner is the globe's background or the globe.
TEST(ValuesGl, TheLegendIsInTheFrameAtItsPlace) {
  ValueWorld w;
  const Geodesy wgs;
  ValueLayerOptions v;
  v.colourMap = "turbo";
  v.min = 0.0;
  v.max = 100.0;
  v.title = "ramp";
  RendererOptions o = valueOptions(v);
  o.width = 320;
  o.height = 240;
  o.legend = true;
  OPEN_RENDERER(r, w.source, wgs, o);
  const auto done = gltest::renderComplete(r, CameraPose{10.0, 20.0, 2.0e7, 0.0, 0.0});
  ASSERT_TRUE(done.complete);
  const auto img = legendImage({scaleOf(v), "K", "ramp"}, 1);
  ASSERT_TRUE(img);
  const auto rects = legendPlacement(320, 240, false, img->width, img->height, kLegendMargin, 1);
  ASSERT_EQ(rects.size(), 1u);
  int off = 0, barPixels = 0;
  const auto* turbo = values::findColourMap("turbo")->table;
  for (int y = 0; y < img->height; ++y)
    for (int x = 0; x < img->width; ++x) {
      const int fy = 240 - 1 - (rects[0].y + (img->height - 1 - y)); // frame row from the top
      const auto f = static_cast<std::size_t>((fy * 320 + rects[0].x + x) * 4);
      const auto l = static_cast<std::size_t>((y * img->width + x) * 4);
      for (std::size_t c = 0; c < 3; ++c)
        off += done.pixels[f + c] != img->pixels[l + c] ? 1 : 0;
      for (const auto& e : *turbo)
        if (done.pixels[f] == e[0] && done.pixels[f + 1] == e[1] && done.pixels[f + 2] == e[2]) {
          ++barPixels;
          break;
        }
    }
  EXPECT_EQ(off, 0);
  EXPECT_GT(barPixels, 256 * 8); // the bar: the table in order, several rows of it
  r.setLegend(false);
  const auto without = gltest::renderComplete(r, CameraPose{10.0, 20.0, 2.0e7, 0.0, 0.0});
  const auto f = static_cast<std::size_t>(((240 - 1 - rects[0].y - 5) * 320 + rects[0].x + 5) * 4);
  EXPECT_EQ(without.pixels[f], 0); // the black background where the legend was
}

// The value under the cursor: what the renderer holds at a picked point is the texel's value.
TEST(ValuesGl, TheValueUnderAPixelIsTheTexelsValue) {
  ValueWorld w;
  const Geodesy wgs;
  ValueLayerOptions v;
  OPEN_RENDERER(r, w.source, wgs, valueOptions(v));
  const auto done = gltest::renderComplete(r, kView);
  ASSERT_TRUE(done.complete);
  // The point under the image's centre holds a value (or is no data) once its texture is there.
  const auto g = pickGlobe(r.camera(r.drawnPose()), wgs, 0.0, 0.0);
  ASSERT_TRUE(g);
  EXPECT_TRUE(r.layerValueAt(1, g->latDeg, g->lonDeg));
  // Exactly the texel's value at its centre (the bilinear weights are 1 there).
  // Texel (20, 10) of tile row 2 (-18 .. 18 degrees), column 5 (0 .. 36), under the view.
  const double lat = 18.0 - 36.0 * (10.5 / 32.0), lon = 36.0 * (20.5 / 32.0);
  const auto texel = ValueWorld::texelAt(lat, lon);
  const auto got = r.layerValueAt(1, lat, lon);
  ASSERT_TRUE(got);
  EXPECT_EQ(texel.x, 20);
  EXPECT_EQ(texel.y, 10);
  EXPECT_FLOAT_EQ(*got, ValueWorld::valueOf(texel));
  EXPECT_FALSE(r.layerValueAt(0, lat, lon)); // the base is imagery
}

} // namespace
