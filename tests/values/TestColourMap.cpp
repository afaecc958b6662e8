// The colour maps' tables against their published colours, and the properties they are chosen
// for: lightness that only rises (viridis, magma, cividis), a cyclic map whose ends meet, a
// diverging map symmetric in lightness about its centre.
#include <tellus/values/ColourMap.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <string>

namespace tellus::values {
namespace {

std::string hex(const Rgb8& c) {
  char buffer[8];
  std::snprintf(buffer, sizeof buffer, "#%02x%02x%02x", c[0], c[1], c[2]);
  return buffer;
}

const ColourTable& table(std::string_view name) {
  const ColourMap* map = findColourMap(name);
  EXPECT_NE(map, nullptr) << name;
  return *map->table;
}

/** CIELAB L* of an sRGB8 colour (D65). */
double lightness(const Rgb8& c) {
  auto linear = [](std::uint8_t v) {
    const double s = v / 255.0;
    return s <= 0.04045 ? s / 12.92 : std::pow((s + 0.055) / 1.055, 2.4);
  };
  const double y = 0.2126 * linear(c[0]) + 0.7152 * linear(c[1]) + 0.0722 * linear(c[2]);
  return y > 0.008856 ? 116.0 * std::cbrt(y) - 16.0 : 903.3 * y;
}

TEST(ColourMap, NamesAreStableAndUnique) {
  std::vector<std::string> names;
  for (const ColourMap& m : colourMaps())
    names.emplace_back(m.name);
  EXPECT_EQ(names,
            (std::vector<std::string>{
                "viridis", "magma", "cividis", "coolwarm", "twilight", "turbo", "terrain"}));
  EXPECT_EQ(findColourMap("jet"), nullptr);
  EXPECT_EQ(findColourMap("Viridis"), nullptr);
  EXPECT_NE(findColourMap(kDefaultColourMap), nullptr);
}

// Published end colours: matplotlib's viridis/magma/cividis docs and the _cm_listed.py data
// (viridis #440154 .. #fde725, magma #000004 .. #fcfdbf, cividis #00224e .. #fee838); Google's
// turbo table (Mikhailov 2019: first {48,18,59}, last {122,4,3}); Moreland 2009 coolwarm
// endpoints (59,76,192) and (180,4,38), his table's middle (221,221,221) within 2 per channel.
TEST(ColourMap, EndsAreThePublishedColours) {
  EXPECT_EQ(hex(table("viridis")[0]), "#440154");
  EXPECT_EQ(hex(table("viridis")[255]), "#fde725");
  EXPECT_EQ(hex(table("viridis")[128]), "#21918c");
  EXPECT_EQ(hex(table("magma")[0]), "#000004");
  EXPECT_EQ(hex(table("magma")[255]), "#fcfdbf");
  EXPECT_EQ(hex(table("cividis")[0]), "#00224e");
  EXPECT_EQ(hex(table("cividis")[255]), "#fee838");
  EXPECT_EQ(hex(table("turbo")[0]), "#30123b");
  EXPECT_EQ(hex(table("turbo")[255]), "#7a0403");
  EXPECT_EQ(hex(table("coolwarm")[0]), "#3b4cc0");
  EXPECT_EQ(hex(table("coolwarm")[255]), "#b40426");
  for (const std::size_t i : {127u, 128u})
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(table("coolwarm")[i][std::size_t(c)], 221, 2) << i;
}

TEST(ColourMap, SequentialMapsRiseInLightness) {
  for (const char* name : {"viridis", "magma", "cividis"}) {
    const ColourTable& t = table(name);
    for (std::size_t i = 1; i < 256; ++i)
      EXPECT_GT(lightness(t[i]), lightness(t[i - 1]) - 0.05) << name << " at " << i;
    EXPECT_GT(lightness(t[255]) - lightness(t[0]), 60.0) << name;
  }
}

TEST(ColourMap, CyclicMapsEndsMeet) {
  const ColourTable& t = table("twilight");
  for (std::size_t c = 0; c < 3; ++c)
    EXPECT_NEAR(t[0][c], t[255][c], 2);
  // ... and it is no constant: its darkest entry lies near the middle.
  EXPECT_LT(lightness(t[128]), 30.0);
}

TEST(ColourMap, DivergingMapIsSymmetricInLightness) {
  const ColourTable& t = table("coolwarm");
  for (std::size_t i = 0; i < 128; ++i)
    EXPECT_NEAR(lightness(t[i]), lightness(t[255 - i]), 1.5) << i;
  for (std::size_t i = 1; i < 128; ++i)
    EXPECT_GE(lightness(t[i]), lightness(t[i - 1]) - 0.3);
}

// cmocean topo: blues below the middle (sea), greens/browns above (land).
TEST(ColourMap, TerrainHasSeaBelowItsMiddleAndLandAbove) {
  const ColourTable& t = table("terrain");
  EXPECT_GT(t[100][2], t[100][0]);
  EXPECT_GT(t[140][1], t[140][2]);
}

TEST(ColourMap, EveryTableIsFullAndNotConstant) {
  for (const ColourMap& m : colourMaps()) {
    std::set<std::array<std::uint8_t, 3>> distinct(m.table->begin(), m.table->end());
    EXPECT_GT(distinct.size(), 150u) << m.name;
    EXPECT_FALSE(m.title.empty());
  }
}

} // namespace
} // namespace tellus::values
