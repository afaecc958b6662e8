// The legends of layers of values (issue 24), GL-free: where they go (bottom left of a view, at
// the bottom of a domemaster's circle with every corner inside it), their integer scale factor;
// and the value under the cursor: the pick of the globe (planet/Pick.hpp) and the value a value
// texture holds there (sampleValueTexture, values::sample's rule).

#include "LegendOverlay.hpp"
#include "ValueTexture.hpp"
#include "ViewerValues.hpp"

#include <tellus/planet/Pick.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

using namespace tellus;
using namespace tellus::planet;

namespace {

TEST(LegendOverlay, ScaleFactorGrowsWithTheFrame) {
  EXPECT_EQ(legendScaleFactor(256, 256), 1);
  EXPECT_EQ(legendScaleFactor(1024, 768), 1);
  EXPECT_EQ(legendScaleFactor(2048, 2048), 2);
  EXPECT_EQ(legendScaleFactor(4096, 4096), 4);
  EXPECT_EQ(legendScaleFactor(100000, 100000), 16);
}

TEST(LegendOverlay, AViewStacksThemFromTheBottomLeft) {
  const auto r = legendPlacement(1024, 768, false, 256, 56, 8, 3);
  ASSERT_EQ(r.size(), 3u);
  EXPECT_EQ(r[0].x, 8);
  EXPECT_EQ(r[0].y, 8);
  EXPECT_EQ(r[1].y, 8 + 56 + 8);
  EXPECT_TRUE(legendPlacement(200, 100, false, 256, 56, 8, 1).empty()); // does not fit
}

TEST(LegendOverlay, ADomeKeepsEveryCornerInsideTheCircle) {
  for (const int size : {512, 1024, 4096}) {
    const int f = legendScaleFactor(size, size);
    const auto rects = legendPlacement(size, size, true, 256 * f, 56 * f, 8 * f, 3);
    ASSERT_EQ(rects.size(), 3u) << size;
    const double c = size / 2.0, radius = size / 2.0;
    for (const LegendRect& r : rects)
      for (const int dx : {0, r.width})
        for (const int dy : {0, r.height})
          EXPECT_LE(std::hypot(r.x + dx - c, r.y + dy - c), radius) << size;
    EXPECT_NEAR(rects[0].x + rects[0].width / 2.0, c, 1.0); // centred
    EXPECT_LT(rects[0].y, c);                               // in the lower half
  }
}

std::vector<std::uint8_t> floats(const std::vector<float>& v) {
  std::vector<std::uint8_t> b(v.size() * 4);
  std::memcpy(b.data(), v.data(), b.size());
  return b;
}

TEST(ValueUnderCursor, SampleOfAValueTexture) {
  // 2 x 2 texels over [0, 10] x [0, 10]; rows from the south: 1 2 (south), 3 4 (north).
  const Sector s{0.0, 0.0, 10.0, 10.0};
  const auto b = floats({1.0f, 2.0f, 3.0f, 4.0f});
  EXPECT_FLOAT_EQ(sampleValueTexture(s, 2, 2, b, 7.5, 2.5), 3.0f); // the north-west centre
  EXPECT_FLOAT_EQ(sampleValueTexture(s, 2, 2, b, 2.5, 7.5), 2.0f);
  EXPECT_FLOAT_EQ(sampleValueTexture(s, 2, 2, b, 5.0, 5.0), 2.5f); // bilinear in between
  EXPECT_TRUE(std::isnan(sampleValueTexture(s, 2, 2, b, 11.0, 5.0)));
  EXPECT_TRUE(std::isnan(sampleValueTexture(s, 3, 2, b, 5.0, 5.0))); // malformed
}

// What `view` does with the cursor: the pixel's ray to the globe, then the value there.
TEST(ValueUnderCursor, PickAndSample) {
  const Geodesy wgs;
  const Camera cam(wgs, {5.0, 5.0, 1.0e6, 0.0, 0.0}, {200, 100});
  const Sector s{0.0, 0.0, 10.0, 10.0}; // west, south, east, north
  std::vector<float> v(100 * 100);
  for (int y = 0; y < 100; ++y)
    for (int x = 0; x < 100; ++x)
      v[static_cast<std::size_t>(y * 100 + x)] = static_cast<float>(x); // = 10 x longitude - 0.5
  const auto b = floats(v);
  for (const double dx : {-60.0, 0.0, 35.0}) {
    const auto g = pickGlobe(cam, wgs, dx, 10.0);
    ASSERT_TRUE(g);
    EXPECT_NEAR(
        sampleValueTexture(s, 100, 100, b, g->latDeg, g->lonDeg), 10.0 * g->lonDeg - 0.5, 1e-3);
  }
  EXPECT_FALSE(pickGlobe(Camera(wgs, {5.0, 5.0, 1.0e6, 0.0, 90.0}, {200, 100}), wgs, 0.0, 49.0));
}

// `view`'s keys on a value layer's scale: C the next map (round), Z/X narrow/widen about the
// middle, Q/E shift by a tenth of the width; log ranges in decades, always above 0.
TEST(ViewerValueKeys, MapCycleAndRangeNarrowWidenShift) {
  ValueLayerOptions o;
  o.colourMap = "terrain"; // the last map: the next is the first
  o.min = 0.0;
  o.max = 100.0;
  o.rangeFromData = true;
  EXPECT_EQ(adjustedScale(o, ScaleKey::NextMap).colourMap, "viridis");
  EXPECT_EQ(adjustedScale(adjustedScale(o, ScaleKey::NextMap), ScaleKey::NextMap).colourMap,
            "magma");
  const auto n = adjustedScale(o, ScaleKey::Narrow);
  EXPECT_DOUBLE_EQ(n.min, 10.0);
  EXPECT_DOUBLE_EQ(n.max, 90.0);
  EXPECT_FALSE(n.rangeFromData); // a key's range replaces range: data
  const auto w = adjustedScale(o, ScaleKey::Widen);
  EXPECT_DOUBLE_EQ(w.min, -12.5);
  EXPECT_DOUBLE_EQ(w.max, 112.5);
  const auto up = adjustedScale(o, ScaleKey::ShiftUp);
  EXPECT_DOUBLE_EQ(up.min, 10.0);
  EXPECT_DOUBLE_EQ(up.max, 110.0);
  EXPECT_DOUBLE_EQ(adjustedScale(o, ScaleKey::ShiftDown).min, -10.0);
  o.scaling = values::Scaling::Log;
  o.min = 1.0;
  o.max = 1.0e4;
  const auto lg = adjustedScale(o, ScaleKey::ShiftDown);
  EXPECT_NEAR(lg.min, std::pow(10.0, -0.4), 1e-12);
  EXPECT_GT(adjustedScale(lg, ScaleKey::Widen).min, 0.0);
}

} // namespace
