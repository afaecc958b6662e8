// The one value-sampling rule (values/Sample.hpp: axisTexels, bilinearValue; the proxy's composed
// maps, the value at a point and planet.frag follow it): texel centres at +0.5 clamped to the
// edges, bilinear of the values, the point's own texel when one of the four is no data (ties to
// the second texel), in double and in float alike; and values::sample built on it (GetFeatureInfo,
// the renderer's cursor): NaN outside.
#include <tellus/values/Sample.hpp>
#include <tellus/values/ValueFormat.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

namespace tellus::values {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr double kNaNd = std::numeric_limits<double>::quiet_NaN();

TEST(ValueSampleRule, AxisTexelsPutCentresAtHalfAndClampAtTheEdges) {
  const auto mid = axisTexels(2.75, 8); // 0.25 past the centre of texel 2
  EXPECT_EQ(mid.i0, 2);
  EXPECT_EQ(mid.i1, 3);
  EXPECT_DOUBLE_EQ(mid.f, 0.25);
  const auto centre = axisTexels(3.5, 8); // exactly texel 3's centre
  EXPECT_EQ(centre.i0, 3);
  EXPECT_DOUBLE_EQ(centre.f, 0.0);
  for (const double x : {0.0, 0.2, 0.5}) { // the outer half texel on the west: texel 0 only
    const auto a = axisTexels(x, 8);
    EXPECT_EQ(a.i0, 0) << x;
    EXPECT_DOUBLE_EQ(a.f, 0.0) << x;
  }
  for (const double x : {7.5, 7.9, 8.0}) { // and on the east: texel 7 twice
    const auto a = axisTexels(x, 8);
    EXPECT_EQ(a.i0, 7) << x;
    EXPECT_EQ(a.i1, 7) << x;
    EXPECT_DOUBLE_EQ(a.f, 0.0) << x;
  }
  const auto one = axisTexels(0.9f, 1); // a single texel
  EXPECT_EQ(one.i0, 0);
  EXPECT_EQ(one.i1, 0);
  EXPECT_FLOAT_EQ(one.f, 0.0f);
}

TEST(ValueSampleRule, WeightsAreBilinearOfTheValues) {
  EXPECT_DOUBLE_EQ(bilinearValue(0.0, 10.0, 20.0, 30.0, 0.0, 0.0), 0.0);
  EXPECT_DOUBLE_EQ(bilinearValue(0.0, 10.0, 20.0, 30.0, 1.0, 0.0), 10.0);
  EXPECT_DOUBLE_EQ(bilinearValue(0.0, 10.0, 20.0, 30.0, 0.0, 1.0), 20.0);
  EXPECT_DOUBLE_EQ(bilinearValue(0.0, 10.0, 20.0, 30.0, 1.0, 1.0), 30.0);
  EXPECT_DOUBLE_EQ(bilinearValue(0.0, 10.0, 20.0, 30.0, 0.5, 0.5), 15.0);
  // Not separable in general: a saddle's centre is the mean of the four.
  EXPECT_DOUBLE_EQ(bilinearValue(1.0, 0.0, 0.0, 1.0, 0.5, 0.5), 0.5);
  EXPECT_DOUBLE_EQ(bilinearValue(0.0, 4.0, 8.0, 12.0, 0.25, 0.75), 7.0);
  // Infinite values are values (ColourScale treats them as out of range), not no data.
  EXPECT_TRUE(std::isinf(bilinearValue(0.0, HUGE_VAL, 0.0, 0.0, 0.5, 0.5)));
}

// Float (the shader's precision) and double give the same value to float rounding.
TEST(ValueSampleRule, FloatFollowsDouble) {
  std::mt19937 rng(24);
  std::uniform_real_distribution<double> value(-1000.0, 1000.0), weight(0.0, 1.0);
  for (int i = 0; i < 1000; ++i) {
    const double v[4] = {value(rng), value(rng), value(rng), value(rng)};
    const double fx = weight(rng), fy = weight(rng);
    const double d = bilinearValue(v[0], v[1], v[2], v[3], fx, fy);
    const float f =
        bilinearValue(float(v[0]), float(v[1]), float(v[2]), float(v[3]), float(fx), float(fy));
    EXPECT_NEAR(f, d, 1e-3) << i;
  }
}

// No data: the texel of the largest weight (the one the point lies in), ties to the second.
TEST(ValueSampleRule, NoDataTakesThePointsOwnTexel) {
  const double n = kNaNd;
  EXPECT_DOUBLE_EQ(bilinearValue(1.0, n, 3.0, 4.0, 0.4, 0.4), 1.0);
  EXPECT_TRUE(std::isnan(bilinearValue(1.0, n, 3.0, 4.0, 0.6, 0.4)));
  EXPECT_DOUBLE_EQ(bilinearValue(1.0, n, 3.0, 4.0, 0.4, 0.6), 3.0);
  EXPECT_DOUBLE_EQ(bilinearValue(1.0, n, 3.0, 4.0, 0.6, 0.6), 4.0);
  EXPECT_DOUBLE_EQ(bilinearValue(1.0, 2.0, 3.0, n, 0.5, 0.0), 2.0);   // a tie: the second column
  EXPECT_DOUBLE_EQ(bilinearValue(1.0, 2.0, 3.0, n, 0.0, 0.5), 3.0);   // and the second row
  EXPECT_TRUE(std::isnan(bilinearValue(1.0, 2.0, 3.0, n, 0.5, 0.5))); // both: the NaN texel
  EXPECT_TRUE(std::isnan(bilinearValue(n, n, n, n, 0.3, 0.7)));
  // Never a blend: next to no data the value is a texel's own, even at weight 0.01.
  EXPECT_DOUBLE_EQ(bilinearValue(5.0, 9.0, n, 9.0, 0.01, 0.01), 5.0);
  EXPECT_TRUE(std::isnan(bilinearValue(5.0f, 9.0f, kNaN, 9.0f, 0.2f, 0.9f)));
}

TEST(ValueSample, BilinearBetweenCentres) {
  const ValueRaster r{2, 2, {0, 10, 20, 30}};
  EXPECT_FLOAT_EQ(sample(r, 0.5, 0.5), 0.0f); // the centre of pixel (0, 0)
  EXPECT_FLOAT_EQ(sample(r, 1.5, 0.5), 10.0f);
  EXPECT_FLOAT_EQ(sample(r, 1.0, 1.0), 15.0f); // between all four
  EXPECT_FLOAT_EQ(sample(r, 1.0, 0.5), 5.0f);
  EXPECT_FLOAT_EQ(sample(r, 0.0, 0.0), 0.0f); // clamped at the edges
  EXPECT_FLOAT_EQ(sample(r, 2.0, 2.0), 30.0f);
  EXPECT_FLOAT_EQ(sample(r, 0.2, 1.0), 10.0f); // the outer half texel: along the edge only
}

TEST(ValueSample, NoDataNeighbourGivesThePointsOwnPixel) {
  const ValueRaster r{2, 2, {0, kNaN, 20, 30}};
  EXPECT_FLOAT_EQ(sample(r, 0.9, 0.9), 0.0f);   // pixel (0, 0)
  EXPECT_FLOAT_EQ(sample(r, 1.9, 1.9), 30.0f);  // (1, 1), its neighbours include NaN
  EXPECT_FLOAT_EQ(sample(r, 0.9, 1.1), 20.0f);  // (0, 1)
  EXPECT_TRUE(std::isnan(sample(r, 1.2, 0.2))); // the no-data pixel itself
  EXPECT_TRUE(std::isnan(sample(r, 1.0, 0.9))); // its west edge belongs to it
}

TEST(ValueSampleExtremes, OutsideOrEmptyIsNaN) {
  const ValueRaster r{2, 2, {0, 10, 20, 30}};
  EXPECT_TRUE(std::isnan(sample(r, -0.001, 1.0)));
  EXPECT_TRUE(std::isnan(sample(r, 1.0, 2.001)));
  EXPECT_TRUE(std::isnan(sample(r, std::nan(""), 1.0)));
  EXPECT_TRUE(std::isnan(sample(r, 1e300, 1.0)));
  EXPECT_TRUE(std::isnan(sample(ValueRaster{}, 0.0, 0.0)));
  const ValueRaster one{1, 1, {7}};
  EXPECT_FLOAT_EQ(sample(one, 0.0, 1.0), 7.0f);
  EXPECT_FLOAT_EQ(sample(one, 0.3, 0.6), 7.0f);
}

} // namespace
} // namespace tellus::values
