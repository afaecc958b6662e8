// The value at a point (GetFeatureInfo, the renderer's cursor): bilinear between pixel centres,
// nearest when a neighbour is no data, NaN outside.
#include <tellus/values/ValueFormat.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace tellus::values {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

TEST(ValueSample, BilinearBetweenCentres) {
  const ValueRaster r{2, 2, {0, 10, 20, 30}};
  EXPECT_FLOAT_EQ(sample(r, 0.5, 0.5), 0.0f); // the centre of pixel (0, 0)
  EXPECT_FLOAT_EQ(sample(r, 1.5, 0.5), 10.0f);
  EXPECT_FLOAT_EQ(sample(r, 1.0, 1.0), 15.0f); // between all four
  EXPECT_FLOAT_EQ(sample(r, 1.0, 0.5), 5.0f);
  EXPECT_FLOAT_EQ(sample(r, 0.0, 0.0), 0.0f); // clamped at the edges
  EXPECT_FLOAT_EQ(sample(r, 2.0, 2.0), 30.0f);
}

TEST(ValueSample, NoDataNeighbourGivesTheNearestPixel) {
  const ValueRaster r{2, 2, {0, kNaN, 20, 30}};
  EXPECT_FLOAT_EQ(sample(r, 0.9, 0.9), 0.0f);   // nearest pixel (0, 0)
  EXPECT_FLOAT_EQ(sample(r, 1.9, 1.9), 30.0f);  // nearest (1, 1), its neighbours include NaN
  EXPECT_TRUE(std::isnan(sample(r, 1.2, 0.2))); // nearest is the no-data pixel
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
