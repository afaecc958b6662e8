// 8-bit PNG maps: the palette quantiser.

#include <tellus/codec/Quantize.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <set>

using namespace tellus::codec;

TEST(Quantize, FewColoursAreKeptExactly) {
  // 200 distinct colours whose values are multiples of 8 (one 5-bit bin each).
  std::vector<std::uint8_t> px;
  for (int i = 0; i < 1000; ++i) {
    const int k = i % 200;
    px.push_back(static_cast<std::uint8_t>((k % 8) * 32));
    px.push_back(static_cast<std::uint8_t>(((k / 8) % 5) * 48));
    px.push_back(static_cast<std::uint8_t>((k / 40) * 40));
  }
  const auto q = quantize(px.data(), 3, 1000);
  EXPECT_EQ(q.palette.size(), 200u);
  for (std::size_t i = 0; i < 1000; ++i) {
    const auto& c = q.palette[q.indices[i]];
    EXPECT_EQ(c[0], px[i * 3]);
    EXPECT_EQ(c[1], px[i * 3 + 1]);
    EXPECT_EQ(c[2], px[i * 3 + 2]);
    EXPECT_EQ(c[3], 255);
  }
}

TEST(Quantize, ManyColoursFitIn256WithSmallError) {
  // A smooth field of 65,536 colours, as imagery is.
  std::vector<std::uint8_t> px;
  for (int y = 0; y < 256; ++y)
    for (int x = 0; x < 256; ++x) {
      px.push_back(static_cast<std::uint8_t>(x));
      px.push_back(static_cast<std::uint8_t>(y));
      px.push_back(static_cast<std::uint8_t>((x + y) / 2));
    }
  const auto q = quantize(px.data(), 3, 65536);
  EXPECT_LE(q.palette.size(), 256u);
  EXPECT_GE(q.palette.size(), 200u) << "the palette is used";
  double err = 0;
  for (std::size_t i = 0; i < 65536; ++i)
    for (std::size_t c = 0; c < 3; ++c)
      err += std::abs(q.palette[q.indices[i]][c] - px[i * 3 + c]);
  EXPECT_LT(err / (65536.0 * 3), 8.0) << "mean absolute error per channel";
}

TEST(Quantize, TransparentPixelsShareEntryZero) {
  std::vector<std::uint8_t> px = {255, 0, 0, 255, 10, 20, 30, 0, 0, 0, 255, 200, 1, 2, 3, 100};
  const auto q = quantize(px.data(), 4, 4);
  ASSERT_GE(q.palette.size(), 3u);
  EXPECT_EQ(q.palette[0][3], 0);
  EXPECT_EQ(q.indices[1], 0);
  EXPECT_EQ(q.indices[3], 0) << "alpha below 128";
  EXPECT_NE(q.indices[0], 0);
  EXPECT_NE(q.indices[2], 0);
  EXPECT_EQ(q.palette[q.indices[0]], (std::array<std::uint8_t, 4>{255, 0, 0, 255}));
  // Nothing opaque at all, and nothing at all.
  std::vector<std::uint8_t> clear(16, 0);
  const auto c = quantize(clear.data(), 4, 4);
  EXPECT_EQ(c.palette.size(), 1u);
  EXPECT_EQ(quantize(clear.data(), 4, 0).indices.size(), 0u);
}
