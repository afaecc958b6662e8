// The statistics line of `tellus view` as pixels (planet/gl/src/TextOverlay.cpp): pure CPU, no
// display, so the sanitizer runs cover it.
#include "../../planet/gl/src/TextOverlay.hpp"

#include <gtest/gtest.h>

#include <string>

using namespace tellus::planet;

namespace {

bool ink(const TextImage& t, int x, int yFromTop) {
  const int y = t.height - 1 - yFromTop;
  return t.rgba[(static_cast<std::size_t>(y) * static_cast<std::size_t>(t.width) +
                 static_cast<std::size_t>(x)) *
                4] > 128;
}

int inkCount(const TextImage& t) {
  int n = 0;
  for (int y = 0; y < t.height; ++y)
    for (int x = 0; x < t.width; ++x)
      n += ink(t, x, y);
  return n;
}

} // namespace

TEST(TextOverlay, CellsGlyphsAndScale) {
  const TextImage one = rasterizeText("1", 1);
  EXPECT_EQ(one.width, 6 + 4);
  EXPECT_EQ(one.height, 9 + 4);
  ASSERT_EQ(one.rgba.size(), static_cast<std::size_t>(one.width * one.height * 4));
  // The "1": its stem is the glyph's middle column (x = margin 2 + 2), rows 1..7 of the cell.
  for (int row = 0; row < 7; ++row)
    EXPECT_TRUE(ink(one, 4, 3 + row)) << row;
  EXPECT_FALSE(ink(one, 2, 3));    // top-left of the glyph is blank
  EXPECT_EQ(inkCount(one), 5 + 5); // the stem (7) + the flag (1) + the foot's two ends (2)
  // Opaque dark strip everywhere else.
  for (std::size_t i = 3; i < one.rgba.size(); i += 4)
    ASSERT_EQ(one.rgba[i], 255);
  const TextImage two = rasterizeText("1", 2);
  EXPECT_EQ(two.width, 2 * one.width);
  EXPECT_EQ(inkCount(two), 4 * inkCount(one));
}

TEST(TextOverlay, CaseUnknownCharactersAndTheStatisticsLine) {
  EXPECT_EQ(rasterizeText("fps", 1).rgba, rasterizeText("FPS", 1).rgba);
  EXPECT_EQ(inkCount(rasterizeText("~", 1)), 0); // no glyph: a blank cell
  EXPECT_EQ(inkCount(rasterizeText(" ", 1)), 0);
  EXPECT_EQ(rasterizeText("", 1).width, 4);
  const std::string line = "60 fps  123 nodes  level 7  4 tiles in flight  120 MB  "
                           "-45.1234, 179.9999  2000 m  heading -90  tilt 45";
  for (const char c : line)
    EXPECT_TRUE(c == ' ' || hasGlyph(c)) << "no glyph for '" << c << "'";
  // Different digits look different.
  for (char a = '0'; a <= '9'; ++a)
    for (char b = static_cast<char>(a + 1); b <= '9'; ++b)
      EXPECT_NE(rasterizeText(std::string(1, a), 1).rgba, rasterizeText(std::string(1, b), 1).rgba)
          << a << b;
}
