// The legend: tick choice (1-2-5 steps, decades on log scales), labels, and the image: the bar's
// colours in the table's order, text present, sizes and upscaling.
#include <tellus/values/Legend.hpp>

#include <gtest/gtest.h>

#include <cmath>

namespace tellus::values {
namespace {

TEST(LegendTicks, UnitRangeInFifths) {
  EXPECT_EQ(legendTicks(0, 1, Scaling::Linear, 6),
            (std::vector<double>{0, 0.2, 0.4, 0.6000000000000001, 0.8, 1}));
}

TEST(LegendTicks, AwkwardRangeGetsRoundSteps) {
  EXPECT_EQ(legendTicks(-2.5, 31.7, Scaling::Linear, 6), (std::vector<double>{0, 10, 20, 30}));
  EXPECT_EQ(legendTicks(-2.5, 31.7, Scaling::Linear, 8),
            (std::vector<double>{0, 5, 10, 15, 20, 25, 30}));
  EXPECT_EQ(legendTicks(-11000, 8800, Scaling::Linear, 5),
            (std::vector<double>{-10000, -5000, 0, 5000}));
}

TEST(LegendTicks, LogScaleInDecades) {
  EXPECT_EQ(legendTicks(1e-3, 1e4, Scaling::Log, 8).size(), 8u);
  const auto t = legendTicks(1e-3, 1e4, Scaling::Log, 4);
  ASSERT_EQ(t.size(), 4u);
  EXPECT_DOUBLE_EQ(t[0], 1e-3);
  EXPECT_DOUBLE_EQ(t[1], 1e-1);
  const auto few = legendTicks(3, 70, Scaling::Log, 8); // 1 decade: 5, 10, 20, 50
  EXPECT_EQ(few, (std::vector<double>{5, 10, 20, 50}));
}

TEST(LegendTicks, Labels) {
  EXPECT_EQ(formatTickLabel(0.6000000000000001, 0.2), "0.6");
  EXPECT_EQ(formatTickLabel(30, 10), "30");
  EXPECT_EQ(formatTickLabel(-2.5, 0), "-2.5");
  EXPECT_EQ(formatTickLabel(31.7, 0), "31.7");
  EXPECT_EQ(formatTickLabel(1e-3, 0), "0.001");
  EXPECT_EQ(formatTickLabel(1e-4, 0), "1e-4");
  EXPECT_EQ(formatTickLabel(2.5e6, 0), "2.5e6");
  EXPECT_EQ(formatTickLabel(-1e-12, 0.2), "0");
  EXPECT_EQ(formatTickLabel(10000, 5000), "10000");
}

TEST(LegendTicksExtremes, DegenerateRangesGiveNoTicks) {
  EXPECT_TRUE(legendTicks(1, 1, Scaling::Linear, 5).empty());
  EXPECT_TRUE(legendTicks(2, 1, Scaling::Linear, 5).empty());
  EXPECT_TRUE(legendTicks(0, 10, Scaling::Log, 5).empty());
  EXPECT_TRUE(legendTicks(0, INFINITY, Scaling::Linear, 5).empty());
  EXPECT_LE(legendTicks(0, 1e-300, Scaling::Linear, 5).size(), 5u);
  EXPECT_LE(legendTicks(-1e300, 1e300, Scaling::Linear, 5).size(), 5u);
}

std::array<std::uint8_t, 4> pixel(const codec::Image& im, int x, int y) {
  const auto at = (std::size_t(y) * std::size_t(im.width) + std::size_t(x)) * 4;
  return {im.pixels[at], im.pixels[at + 1], im.pixels[at + 2], im.pixels[at + 3]};
}

/** The table index of an opaque pixel's colour, -1 when it is no table entry. */
int indexOf(const ColourTable& t, const std::array<std::uint8_t, 4>& p) {
  for (std::size_t i = 0; i < 256; ++i)
    if (t[i][0] == p[0] && t[i][1] == p[1] && t[i][2] == p[2]) return int(i);
  return -1;
}

TEST(Legend, HorizontalBarHasTheTableInOrder) {
  const ColourScale s{findColourMap("turbo"), -2.5, 31.7, Scaling::Linear, OutOfRange::Clamp};
  auto im = renderLegend(s, "°C", "Sea surface temperature");
  ASSERT_TRUE(im) << im.error();
  EXPECT_EQ(im->width, 256);
  EXPECT_EQ(im->height, 56);
  // A row through the middle of the bar: the entries rise from left to right, from near 0 to 255.
  const int y = 26;
  int previous = -1, first = -1, count = 0;
  for (int x = 0; x < im->width; ++x) {
    const int i = indexOf(*s.map->table, pixel(*im, x, y));
    if (i < 0) continue;
    if (first < 0) first = i;
    EXPECT_GE(i, previous) << x;
    previous = i;
    ++count;
  }
  EXPECT_LE(first, 1);
  EXPECT_EQ(previous, 255);
  EXPECT_GT(count, 230);
  // Text (black on white) is drawn in the title row and under the bar.
  int dark = 0;
  for (int yy = 0; yy < 17; ++yy)
    for (int x = 0; x < im->width; ++x)
      dark += pixel(*im, x, yy)[0] == 0;
  EXPECT_GT(dark, 100);
}

TEST(Legend, VerticalBarRunsUpAndUpscales) {
  const ColourScale s{findColourMap("viridis"), 1e-3, 1e4, Scaling::Log, OutOfRange::Clamp};
  LegendOptions o;
  o.width = 80;
  o.height = 200;
  o.scaleFactor = 3;
  o.background = {0, 0, 0, 160};
  o.foreground = {255, 255, 255, 255};
  auto im = renderLegend(s, "mg/m³", "", o);
  ASSERT_TRUE(im) << im.error();
  EXPECT_EQ(im->width, 240);
  EXPECT_EQ(im->height, 600);
  EXPECT_EQ(pixel(*im, 0, 0), (std::array<std::uint8_t, 4>{0, 0, 0, 160}));
  const int x = 3 * 10; // inside the bar (logical x 5..25)
  const int low = indexOf(*s.map->table, pixel(*im, x, im->height - 3 * 12));
  const int high = indexOf(*s.map->table, pixel(*im, x, 3 * 22));
  EXPECT_GE(low, 0);
  EXPECT_GT(high, low);
  // Upscaling is by whole pixels: 3 x 3 blocks of one colour.
  EXPECT_EQ(pixel(*im, 30, 300), pixel(*im, 32, 302));
}

TEST(Legend, WithoutLabelsOnlyTheTitleAndBar) {
  const ColourScale s{findColourMap("viridis"), 0, 1, Scaling::Linear, OutOfRange::Clamp};
  auto with = renderLegend(s, "", "");
  auto without = renderLegend(s, "", "", LegendOptions{.labels = false});
  ASSERT_TRUE(with && without);
  auto darkBelowBar = [](const codec::Image& im) {
    int n = 0;
    for (int y = 40; y < im.height; ++y)
      for (int x = 0; x < im.width; ++x)
        n += pixel(im, x, y)[0] == 0;
    return n;
  };
  EXPECT_GT(darkBelowBar(*with), 20);
  EXPECT_EQ(darkBelowBar(*without), 0);
}

TEST(LegendExtremes, BadSizesAndScalesAreRefused) {
  const ColourScale s{findColourMap("viridis"), 0, 1, Scaling::Linear, OutOfRange::Clamp};
  EXPECT_FALSE(renderLegend(s, "", "", LegendOptions{.width = 8}));
  EXPECT_FALSE(renderLegend(s, "", "", LegendOptions{.width = 5000}));
  EXPECT_FALSE(renderLegend(s, "", "", LegendOptions{.scaleFactor = 0}));
  EXPECT_FALSE(renderLegend(s, "", "", LegendOptions{.scaleFactor = 17}));
  EXPECT_FALSE(renderLegend(ColourScale{}, "", ""));
  EXPECT_FALSE(
      renderLegend({findColourMap("viridis"), 0, 1, Scaling::Log, OutOfRange::Clamp}, "", ""));
  // min == max and a title far wider than the image still draw.
  EXPECT_TRUE(renderLegend({findColourMap("magma"), 5, 5, Scaling::Linear, OutOfRange::Clamp},
                           "m",
                           std::string(500, 'x'),
                           LegendOptions{.width = 32, .height = 40}));
  // Invalid UTF-8 in the unit draws as '?'.
  EXPECT_TRUE(renderLegend(s, "\xff\xfe", "t"));
}

} // namespace
} // namespace tellus::values
