// Layers of values in the renderer, GL-free (issue 24): a node's tiles of raw samples become one
// level of floats (rows from the south, NaN where no data or no tile), merged polar nodes take
// the nearest column (never an average), and a layer's scale becomes the shader's uniforms.

#include "ValueTexture.hpp"

#include <tellus/values/ColourMap.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

using namespace tellus;
using namespace tellus::planet;

namespace {

std::vector<std::byte> bil(int w, int h, int (*f)(int, int)) {
  std::vector<std::byte> b;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const auto v = static_cast<std::uint16_t>(static_cast<std::int16_t>(f(x, y)));
      b.push_back(static_cast<std::byte>(v & 0xFF));
      b.push_back(static_cast<std::byte>(v >> 8));
    }
  return b;
}

float texel(const DecodedTexture& d, int x, int yFromSouth) {
  float v = 0.0f;
  const auto& l = d.levels.front();
  std::memcpy(&v, l.rgba.data() + (static_cast<std::size_t>(yFromSouth * l.width + x)) * 4, 4);
  return v;
}

DecodeJob job(int width, int tiles) {
  DecodeJob j;
  j.width = width;
  j.height = 4;
  j.tileWidth = 4;
  j.tileHeight = 4;
  values::ValueFormat f;
  f.scale = 0.5;
  f.noData = -1;
  j.valueFormat = f;
  for (int i = 0; i < tiles; ++i)
    j.tiles.emplace_back(
        bil(4, 4, [](int x, int y) { return x == 3 && y == 0 ? -1 : 10 * y + x; }));
  return j;
}

TEST(ValueTexture, OneLevelOfFloatsRowsFromTheSouthNoDataNaN) {
  const DecodedTexture d = decodeTexture(job(4, 1));
  ASSERT_TRUE(d.ok) << d.error;
  EXPECT_TRUE(d.values);
  ASSERT_EQ(d.levels.size(), 1u); // never mip-mapped: read by texelFetch
  EXPECT_EQ(d.bytes, 4u * 4u * 4u);
  EXPECT_EQ(texel(d, 0, 3), 0.0f);  // the tile's north-west sample is the texture's last row
  EXPECT_EQ(texel(d, 2, 0), 16.0f); // (10 * 3 + 2) * 0.5
  EXPECT_TRUE(std::isnan(texel(d, 3, 3)));
  EXPECT_EQ(d.sample.size(), 15u); // the finite values (fewer than the bound)
}

TEST(ValueTexture, MergedNodeTakesTheNearestColumnAndAbsentTilesAreNoData) {
  DecodeJob j = job(4, 2); // two 4-wide tiles into 4 columns: every other column
  j.tiles[1] = std::nullopt;
  const DecodedTexture d = decodeTexture(j);
  ASSERT_TRUE(d.ok);
  EXPECT_EQ(texel(d, 0, 3), 0.5f); // column 1 of tile 0 (nearest to the texel's centre), * 0.5
  EXPECT_TRUE(std::isnan(texel(d, 1, 3))); // column 3 of the north row: no data
  EXPECT_EQ(texel(d, 1, 2), 6.5f);         // column 3, row 1: (10 + 3) * 0.5
  EXPECT_TRUE(std::isnan(texel(d, 2, 0)));
  EXPECT_TRUE(std::isnan(texel(d, 3, 0)));
}

TEST(ValueTexture, UndecodableTilesAreAnError) {
  DecodeJob j = job(4, 1);
  j.tiles[0] = std::vector<std::byte>(7);
  const DecodedTexture d = decodeTexture(j);
  EXPECT_FALSE(d.ok);
  EXPECT_NE(d.error.find("BIL"), std::string::npos) << d.error;
}

TEST(ValueTexture, TheSampleIsBounded) {
  std::vector<float> v(10000, 1.0f);
  v[5] = std::nanf("");
  EXPECT_EQ(finiteSample(v, 256).size(), 256u);
}

TEST(ValueTexture, ScaleUniformsNameTheMapRowAndLogRange) {
  ValueLayerOptions o;
  o.colourMap = "turbo";
  o.min = 1.0;
  o.max = 1000.0;
  o.scaling = values::Scaling::Log;
  o.outOfRange = values::OutOfRange::Transparent;
  const ValueScaleUniform u = valueScaleUniform(colourScaleFor(o, std::nullopt));
  EXPECT_EQ(values::colourMaps()[static_cast<std::size_t>(u.mapRow)].name, "turbo");
  EXPECT_TRUE(u.log);
  EXPECT_TRUE(u.transparentOut);
  EXPECT_DOUBLE_EQ(u.low, 0.0);
  EXPECT_DOUBLE_EQ(u.high, 3.0);
  o.rangeFromData = true; // the data's range replaces the fixed one; an unfit one does not
  EXPECT_DOUBLE_EQ(colourScaleFor(o, values::ValueRange{10.0, 20.0}).max, 20.0);
  EXPECT_DOUBLE_EQ(colourScaleFor(o, values::ValueRange{-5.0, 20.0}).min, 1.0);
  o.colourMap = "no-such-map"; // the default map, never a null one
  EXPECT_EQ(colourScaleFor(o, std::nullopt).map->name, values::kDefaultColourMap);
}

} // namespace
