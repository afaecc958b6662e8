// The colour scale's index rule (ColourScale.hpp) at bin edges and at the extremes: NaN and
// infinities, min == max, log of values <= 0, out of range clamped or transparent.
#include <tellus/values/ColourScale.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace tellus::values {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

ColourScale linear(double min, double max, OutOfRange o = OutOfRange::Clamp) {
  return {findColourMap("viridis"), min, max, Scaling::Linear, o};
}

TEST(ColourScale, IndexIsFloorOfT256) {
  const ColourScale s = linear(0.0, 256.0);
  EXPECT_EQ(colourIndex(s, 0.0f), 0);
  EXPECT_EQ(colourIndex(s, 0.999f), 0);
  EXPECT_EQ(colourIndex(s, 1.0f), 1); // exactly on the edge: the upper bin
  EXPECT_EQ(colourIndex(s, 127.5f), 127);
  EXPECT_EQ(colourIndex(s, 128.0f), 128);
  EXPECT_EQ(colourIndex(s, 255.0f), 255);
  EXPECT_EQ(colourIndex(s, 256.0f), 255); // v == max: inside, the last entry
}

TEST(ColourScale, ColourIsTheTableEntryOpaque) {
  const ColourScale s = linear(-1.0, 1.0);
  const Rgba8 c = colourOf(s, 0.0f); // t = 0.5 -> index 128
  const Rgb8& e = (*s.map->table)[128];
  EXPECT_EQ(c, (Rgba8{e[0], e[1], e[2], 255}));
  EXPECT_DOUBLE_EQ(scalePosition(s, 0.5f), 0.75);
}

TEST(ColourScale, ReversedRangeRunsTheTableBackwards) {
  const ColourScale s = linear(10.0, 0.0);
  EXPECT_EQ(colourIndex(s, 10.0f), 0);
  EXPECT_EQ(colourIndex(s, 0.0f), 255);
}

TEST(ColourScale, LogScaleUsesDecades) {
  const ColourScale s{findColourMap("magma"), 1.0, 1e4, Scaling::Log, OutOfRange::Clamp};
  EXPECT_DOUBLE_EQ(scalePosition(s, 100.0f), 0.5);
  EXPECT_EQ(colourIndex(s, 100.0f), 128);
  EXPECT_EQ(colourIndex(s, 1.0f), 0);
  EXPECT_EQ(colourIndex(s, 1e4f), 255);
}

TEST(ColourScale, CheckRefusesBadScales) {
  EXPECT_TRUE(checkScale(linear(0, 1)));
  EXPECT_FALSE(checkScale(ColourScale{nullptr, 0, 1, Scaling::Linear, OutOfRange::Clamp}));
  EXPECT_FALSE(checkScale(linear(0, std::numeric_limits<double>::infinity())));
  EXPECT_FALSE(checkScale(linear(std::nan(""), 1)));
  const auto log0 =
      checkScale({findColourMap("viridis"), 0.0, 10.0, Scaling::Log, OutOfRange::Clamp});
  ASSERT_FALSE(log0);
  EXPECT_NE(log0.error().find("above 0"), std::string::npos);
}

TEST(ColourScale, ApplyColoursEveryPixel) {
  ValueRaster r{3, 1, {0.0f, kNaN, 1.0f}};
  auto image = apply(r, linear(0.0, 1.0));
  ASSERT_TRUE(image) << image.error();
  EXPECT_EQ(image->channels, 4);
  ASSERT_EQ(image->pixels.size(), 12u);
  EXPECT_EQ(image->pixels[3], 255);
  EXPECT_EQ(image->pixels[7], 0); // no data: transparent
  EXPECT_EQ(image->pixels[8], (*findColourMap("viridis")->table)[255][0]);
  EXPECT_FALSE(apply(r, ColourScale{}));
}

TEST(ColourScale, RangeFromDataMinMaxAndPercentiles) {
  std::vector<float> v;
  for (int i = 0; i <= 100; ++i)
    v.push_back(static_cast<float>(i));
  v.push_back(kNaN);
  v.push_back(kInf);
  auto all = rangeFromData(v);
  ASSERT_TRUE(all);
  EXPECT_EQ(all->min, 0.0);
  EXPECT_EQ(all->max, 100.0);
  auto p = rangeFromData(v, 2.0, 98.0);
  ASSERT_TRUE(p);
  EXPECT_EQ(p->min, 2.0);
  EXPECT_EQ(p->max, 98.0);
  auto positive = rangeFromData(v, 0.0, 100.0, true);
  ASSERT_TRUE(positive);
  EXPECT_EQ(positive->min, 1.0);
  EXPECT_FALSE(rangeFromData(std::vector<float>{kNaN, -kInf}));
  EXPECT_FALSE(rangeFromData(v, 60.0, 40.0));
  EXPECT_FALSE(rangeFromData(v, -1.0, 100.0));
}

TEST(ColourScale, NamesRoundTrip) {
  EXPECT_EQ(parseScaling("log"), Scaling::Log);
  EXPECT_EQ(parseScaling(scalingName(Scaling::Linear)), Scaling::Linear);
  EXPECT_FALSE(parseScaling("Log"));
  EXPECT_EQ(parseOutOfRange("transparent"), OutOfRange::Transparent);
  EXPECT_EQ(parseOutOfRange(outOfRangeName(OutOfRange::Clamp)), OutOfRange::Clamp);
  EXPECT_FALSE(parseOutOfRange("wrap"));
}

TEST(ColourScaleExtremes, NaNIsTransparentWhateverTheScale) {
  for (const OutOfRange o : {OutOfRange::Clamp, OutOfRange::Transparent}) {
    EXPECT_EQ(colourIndex(linear(0, 1, o), kNaN), -1);
    EXPECT_EQ(colourOf(linear(0, 1, o), kNaN), (Rgba8{0, 0, 0, 0}));
  }
}

TEST(ColourScaleExtremes, InfinitiesAreOutOfRange) {
  EXPECT_EQ(colourIndex(linear(0, 1), kInf), 255);
  EXPECT_EQ(colourIndex(linear(0, 1), -kInf), 0);
  EXPECT_EQ(colourIndex(linear(0, 1, OutOfRange::Transparent), kInf), -1);
  EXPECT_EQ(colourIndex(linear(0, 1, OutOfRange::Transparent), -kInf), -1);
}

TEST(ColourScaleExtremes, OutOfRangeClampOrTransparent) {
  EXPECT_EQ(colourIndex(linear(0, 1), -0.5f), 0);
  EXPECT_EQ(colourIndex(linear(0, 1), 7.0f), 255);
  EXPECT_EQ(colourIndex(linear(0, 1, OutOfRange::Transparent), -0.5f), -1);
  EXPECT_EQ(colourIndex(linear(0, 1, OutOfRange::Transparent), 7.0f), -1);
  // The range's own ends are inside.
  EXPECT_EQ(colourIndex(linear(0, 1, OutOfRange::Transparent), 0.0f), 0);
  EXPECT_EQ(colourIndex(linear(0, 1, OutOfRange::Transparent), 1.0f), 255);
  EXPECT_EQ(colourIndex(linear(0, 1, OutOfRange::Transparent), std::nextafter(1.0f, 2.0f)), -1);
}

TEST(ColourScaleExtremes, MinEqualsMaxGivesTheMiddleColour) {
  EXPECT_EQ(colourIndex(linear(5, 5), 5.0f), 128);
  EXPECT_EQ(colourIndex(linear(5, 5), 4.0f), 0);
  EXPECT_EQ(colourIndex(linear(5, 5), 6.0f), 255);
  EXPECT_EQ(colourIndex(linear(5, 5, OutOfRange::Transparent), 6.0f), -1);
  EXPECT_TRUE(checkScale(linear(5, 5)));
}

TEST(ColourScaleExtremes, LogOfZeroAndNegativesIsBelowTheRange) {
  ColourScale s{findColourMap("viridis"), 1e-3, 1e4, Scaling::Log, OutOfRange::Clamp};
  EXPECT_EQ(colourIndex(s, 0.0f), 0);
  EXPECT_EQ(colourIndex(s, -5.0f), 0);
  EXPECT_EQ(colourIndex(s, -0.0f), 0);
  s.outOfRange = OutOfRange::Transparent;
  EXPECT_EQ(colourIndex(s, 0.0f), -1);
  EXPECT_EQ(colourIndex(s, -5.0f), -1);
  EXPECT_EQ(colourIndex(s, 1e-3f), 0);
}

// The GPU computes t in float: off by one bin only where t * 256 lies within 1e-4 of an integer.
TEST(ColourScaleExtremes, FloatAndDoubleAgreeAwayFromBinEdges) {
  const ColourScale s = linear(-2.5, 31.7);
  const auto fmin = static_cast<float>(s.min), fmax = static_cast<float>(s.max);
  int edges = 0;
  for (int i = 0; i <= 100000; ++i) {
    const float v = fmin + (fmax - fmin) * static_cast<float>(i) / 100000.0f;
    const float tf = (v - fmin) / (fmax - fmin);
    const int gpu = std::clamp(static_cast<int>(std::floor(tf * 256.0f)), 0, 255);
    const double t256 = scalePosition(s, v) * 256.0;
    const bool nearEdge = std::fabs(t256 - std::round(t256)) < 1e-4;
    if (nearEdge) ++edges;
    if (!nearEdge)
      EXPECT_EQ(gpu, colourIndex(s, v)) << v;
    else
      EXPECT_LE(std::abs(gpu - colourIndex(s, v)), 1) << v;
  }
  EXPECT_LT(edges, 1000);
}

} // namespace
} // namespace tellus::values
