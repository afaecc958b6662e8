// The proxy's composed value maps (composeValues) follow the one sampling rule of
// values/Sample.hpp across tile edges: each pixel is values::sample of the tiles stitched into one
// raster (bilinear of the values; beside no data the pixel's own texel), in double.

#include <tellus/proxy/Compose.hpp>
#include <tellus/values/ValueFormat.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

using namespace tellus;

namespace {

TEST(ComposeValues, AcrossATileEdgeItIsTheSharedRuleOnTheStitchedTiles) {
  const TileGrid g = *TileGrid::create(GridSpec{Sector{}, 36.0, 4, 4, 1}); // 9-degree texels
  // Tiles (row 2, col 5) and (row 2, col 6): 0 .. 72 E, 18 S .. 18 N; one raster of 8 x 4 texels,
  // value 3 i + 10 j + (i j) / 4 (not linear: the weights show), no data at two texels.
  values::ValueRaster whole{8, 4, {}};
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 8; ++i)
      whole.values.push_back(static_cast<float>(3 * i + 10 * j + i * j / 4.0));
  whole.values[1 * 8 + 4] = std::numeric_limits<float>::quiet_NaN(); // the east tile's first column
  whole.values[2 * 8 + 2] = std::numeric_limits<float>::quiet_NaN();
  std::vector<float> west, east;
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 8; ++i)
      (i < 4 ? west : east).push_back(whole.at(i, j));
  const TileSamples a{4, 4, 1, nullptr, nullptr, west.data()};
  const TileSamples b{4, 4, 1, nullptr, nullptr, east.data()};
  const auto lookup = [&](const TileKey& k) -> const TileSamples* {
    if (k.level != 0 || k.row != 2) return nullptr;
    return k.col == 5 ? &a : k.col == 6 ? &b : nullptr;
  };
  const Sector box{0.0, -18.0, 72.0, 18.0};
  const int w = 97, h = 41; // pixel centres never on a texel centre or edge
  std::vector<float> out;
  composeValues(g, box, w, h, 0, 0, lookup, out);
  int compared = 0, noData = 0, nearEdge = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double tx = (x + 0.5) * 8.0 / w, ty = (y + 0.5) * 4.0 / h;
      // Outside the texel centres' hull the proxy would sample the missing neighbour tiles.
      if (tx < 0.5 || tx > 7.5 || ty < 0.5 || ty > 3.5) continue;
      const float want = values::sample(whole, tx, ty);
      const float got = out[static_cast<std::size_t>(y * w + x)];
      ++compared;
      nearEdge += std::abs(tx - 4.0) < 0.5 ? 1 : 0;
      if (std::isnan(want)) {
        ++noData;
        EXPECT_TRUE(std::isnan(got)) << x << "," << y;
      } else {
        EXPECT_NEAR(got, want, 1e-4) << x << "," << y;
      }
    }
  EXPECT_GT(compared, 2500);
  EXPECT_GT(noData, 100);
  EXPECT_GT(nearEdge, 300); // the half texels each side of the tiles' edge, interpolated across
}

} // namespace
