// GetMap for any box: level choice, the tiles a map needs, bilinear sampling, the antimeridian,
// the poles, coarser fallback, opacity and heights, on synthetic tiles whose texels encode their
// own global position (so every sampled value says where it came from).

#include <tellus/proxy/Compose.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <tuple>

using namespace tellus;

namespace {

TileGrid grid(std::int32_t tile = 4, std::int32_t levels = 3, Sector sector = {}) {
  return *TileGrid::create(GridSpec{sector, 36.0, tile, tile, levels});
}

/** Tiles whose texel (x, y) at level L holds R = global column mod 256, G = global row from the
 * north mod 256, B = 10 * L (imagery), or height = 100 * L + global column (heights). */
struct Synthetic {
  const TileGrid& g;
  std::map<std::tuple<int, std::int64_t, std::int64_t>, std::unique_ptr<TileSamples>> tiles;
  std::vector<std::unique_ptr<std::vector<std::uint8_t>>> rgb;
  std::vector<std::unique_ptr<std::vector<std::int16_t>>> heights;
  bool withHeights = false;

  void add(const TileKey& k) {
    const auto w = g.spec().tileWidth;
    const auto h = g.spec().tileHeight;
    auto s = std::make_unique<TileSamples>();
    s->width = w;
    s->height = h;
    const std::int64_t gx0 = k.col * w;
    const std::int64_t gy0 = (g.rowCount(k.level) - 1 - k.row) * h;
    if (withHeights) {
      auto v = std::make_unique<std::vector<std::int16_t>>(static_cast<std::size_t>(w * h));
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          (*v)[static_cast<std::size_t>(y * w + x)] =
              static_cast<std::int16_t>(100 * k.level + gx0 + x);
      s->channels = 1;
      s->heights = v->data();
      heights.push_back(std::move(v));
    } else {
      auto v = std::make_unique<std::vector<std::uint8_t>>(static_cast<std::size_t>(w * h * 3));
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          auto* p = &(*v)[static_cast<std::size_t>((y * w + x) * 3)];
          p[0] = static_cast<std::uint8_t>((gx0 + x) % 256);
          p[1] = static_cast<std::uint8_t>((gy0 + y) % 256);
          p[2] = static_cast<std::uint8_t>(10 * k.level);
        }
      s->channels = 3;
      s->rgb = v->data();
      rgb.push_back(std::move(v));
    }
    tiles[{k.level, k.row, k.col}] = std::move(s);
  }
  void addLevel(std::int32_t level) {
    for (std::int64_t r = 0; r < g.rowCount(level); ++r)
      for (std::int64_t c = 0; c < g.colCount(level); ++c)
        if (g.isValid(TileKey{level, r, c})) add(TileKey{level, r, c});
  }
  TileLookup lookup() const {
    return [this](const TileKey& k) -> const TileSamples* {
      const auto it = tiles.find({k.level, k.row, k.col});
      return it == tiles.end() ? nullptr : it->second.get();
    };
  }
};

const std::uint8_t* px(const std::vector<std::uint8_t>& canvas, int width, int i, int j) {
  return &canvas[static_cast<std::size_t>((j * width + i) * 4)];
}

} // namespace

TEST(Compose, LevelIsTheCoarsestWithinSqrt2OfTheMap) {
  const auto g = grid(512, 10);
  // Level 0: 36 deg / 512 px. A map of exactly that resolution takes level 0.
  EXPECT_EQ(composeLevel(g, Sector{0, 0, 36, 36}, 512, 512, 0), 0);
  // A little finer than level 0 is still level 0 (magnified 1.002 times: within kMaxUpsampling);
  // finer than that by more than sqrt 2 needs level 1; a little coarser is still level 0.
  EXPECT_EQ(composeLevel(g, Sector{0, 0, 36, 36}, 513, 513, 0), 0);
  EXPECT_EQ(composeLevel(g, Sector{0, 0, 36, 36}, 725, 725, 0), 1);
  EXPECT_EQ(composeLevel(g, Sector{0, 0, 36, 36}, 300, 300, 0), 0);
  // The finer of the two axes decides.
  EXPECT_EQ(composeLevel(g, Sector{0, 0, 36, 36}, 100, 2048, 0), 2);
  // Finer than the deepest level: the deepest; never above the first level.
  EXPECT_EQ(composeLevel(g, Sector{0, 0, 0.001, 0.001}, 4096, 4096, 0), 9);
  EXPECT_EQ(composeLevel(g, Sector{-180, -90, 180, 90}, 64, 32, 3), 3);
}

TEST(Compose, AlignedBoxGivesTheTexelsExactly) {
  const auto g = grid(4, 3);
  Synthetic s{g, {}, {}, {}};
  s.addLevel(1);
  // Level 1: 18-degree tiles of 4 texels (4.5 degrees each). A box of 6 x 3 texels that starts
  // on a texel edge inside tile (row 7, col 11) and runs into the next tiles.
  const Sector box{18.0 + 2 * 4.5, 36.0 - 3 * 4.5, 18.0 + 8 * 4.5, 36.0};
  std::vector<std::uint8_t> canvas;
  const auto level = composeLevel(g, box, 6, 3, 0);
  ASSERT_EQ(level, 1);
  const auto stats = composeImagery(g, box, 6, 3, level, 0, s.lookup(), 1.0, canvas);
  EXPECT_EQ(stats.fallbackPixels, 0u);
  EXPECT_EQ(stats.missingPixels, 0u);
  const int gx0 = static_cast<int>((box.west + 180.0) / 4.5);
  const int gy0 = static_cast<int>((90.0 - box.north) / 4.5);
  for (int j = 0; j < 3; ++j) {
    for (int i = 0; i < 6; ++i) {
      const auto* p = px(canvas, 6, i, j);
      EXPECT_EQ(p[0], (gx0 + i) % 256) << i << "," << j;
      EXPECT_EQ(p[1], (gy0 + j) % 256) << i << "," << j;
      EXPECT_EQ(p[2], 10);
      EXPECT_EQ(p[3], 255);
    }
  }
}

TEST(Compose, BilinearBetweenTexels) {
  const auto g = grid(4, 1);
  Synthetic s{g, {}, {}, {}};
  s.addLevel(0);
  // Level 0 texels are 9 degrees. Pixels of 9 degrees centred on texel edges: halfway values.
  const Sector box{-180.0 + 4.5, 90.0 - 9.0 - 4.5, -180.0 + 4.5 + 18.0, 90.0 - 4.5};
  std::vector<std::uint8_t> canvas;
  composeImagery(g, box, 2, 1, 0, 0, s.lookup(), 1.0, canvas);
  // Pixel 0 is centred between texel columns 0 and 1 (R 0 and 1): 0.5 rounds to 1 in 1/256 steps.
  EXPECT_NEAR(px(canvas, 2, 0, 0)[0], 0.5, 0.51);
  EXPECT_NEAR(px(canvas, 2, 1, 0)[0], 1.5, 0.51);
  EXPECT_NEAR(px(canvas, 2, 0, 0)[1], 0.5, 0.51);
}

TEST(ComposeExtremes, AntimeridianWrapsAndJoinsSeamlessly) {
  const auto g = grid(4, 2);
  Synthetic s{g, {}, {}, {}};
  s.addLevel(0);
  // 160 .. 200 degrees of longitude: the east part is -180 .. -160 (columns 0 and 1 of texels).
  const Sector box{162.0, 0.0, 198.0, 36.0};
  const auto keys = composeTiles(g, box, 4, 4, 0, 100);
  ASSERT_TRUE(keys);
  std::vector<std::int64_t> cols;
  for (const auto& t : *keys)
    cols.push_back(t.key.col);
  EXPECT_NE(std::find(cols.begin(), cols.end(), 9), cols.end());
  EXPECT_NE(std::find(cols.begin(), cols.end(), 0), cols.end());
  std::vector<std::uint8_t> canvas;
  const auto stats = composeImagery(g, box, 4, 4, 0, 0, s.lookup(), 1.0, canvas);
  EXPECT_EQ(stats.missingPixels, 0u);
  // Texel centres: pixel 0 at 166.5 = texel 38 (of 40), pixel 3 at 193.5 = -166.5 = texel 1.
  EXPECT_EQ(px(canvas, 4, 0, 0)[0], 38);
  EXPECT_EQ(px(canvas, 4, 1, 0)[0], 39);
  EXPECT_EQ(px(canvas, 4, 2, 0)[0], 0);
  EXPECT_EQ(px(canvas, 4, 3, 0)[0], 1);
  // Exactly on the antimeridian (pixel centre at 180): halfway between the last and first texel.
  std::vector<std::uint8_t> seam;
  composeImagery(g, Sector{175.5, 0, 184.5, 9}, 1, 1, 0, 0, s.lookup(), 1.0, seam);
  EXPECT_NEAR(seam[0], (39 + 0) / 2.0, 0.51);
  // The same box written from the west side (-200 .. -160) gives the same map.
  std::vector<std::uint8_t> west;
  composeImagery(
      g, Sector{162.0 - 360.0, 0.0, 198.0 - 360.0, 36.0}, 4, 4, 0, 0, s.lookup(), 1.0, west);
  EXPECT_EQ(west, canvas);
}

TEST(ComposeExtremes, PastThePolesIsLeftEmptyAndThePoleRowIsClamped) {
  const auto g = grid(4, 1);
  Synthetic s{g, {}, {}, {}};
  s.addLevel(0);
  std::vector<std::uint8_t> canvas(4 * 32 * 4, 7); // the background
  // 9-degree pixels from lat 126 down to -162: rows 0..3 are past the north pole.
  const Sector box{0.0, -162.0, 36.0, 126.0};
  const auto stats = composeImagery(g, box, 4, 32, 0, 0, s.lookup(), 1.0, canvas);
  EXPECT_EQ(stats.missingPixels, 0u);
  for (int j = 0; j < 32; ++j) {
    const double lat = 126.0 - (j + 0.5) * 9.0;
    const auto* p = px(canvas, 4, 0, j);
    if (lat > 90.0 || lat < -90.0) {
      EXPECT_EQ(p[3], 7) << "row " << j << " at " << lat << " is past a pole";
    } else {
      EXPECT_EQ(p[3], 255) << "row " << j;
      EXPECT_EQ(p[1], static_cast<int>((90.0 - lat) / 9.0)) << "row " << j;
    }
  }
  // At the pole itself: a pixel centred on lat 90 repeats the first row (clamped, not wrapped).
  std::vector<std::uint8_t> pole;
  composeImagery(g, Sector{0, 85.5, 9, 94.5}, 1, 1, 0, 0, s.lookup(), 1.0, pole);
  EXPECT_EQ(pole[1], 0);
  composeImagery(g, Sector{0, -94.5, 9, -85.5}, 1, 1, 0, 0, s.lookup(), 1.0, pole);
  EXPECT_EQ(pole[1], 19); // the last texel row from the north (20 rows of 9 degrees)
}

TEST(ComposeExtremes, NegativeZeroAndTheClosedEdges) {
  const auto g = grid(4, 1);
  Synthetic s{g, {}, {}, {}};
  s.addLevel(0);
  std::vector<std::uint8_t> a, b;
  composeImagery(g, Sector{-0.0, -0.0, 36.0, 36.0}, 4, 4, 0, 0, s.lookup(), 1.0, a);
  composeImagery(g, Sector{0.0, 0.0, 36.0, 36.0}, 4, 4, 0, 0, s.lookup(), 1.0, b);
  EXPECT_EQ(a, b);
  // The whole world at one pixel per texel: every texel once, no wrap artefacts at +-180.
  std::vector<std::uint8_t> world;
  const auto stats =
      composeImagery(g, Sector{-180, -90, 180, 90}, 40, 20, 0, 0, s.lookup(), 1.0, world);
  EXPECT_EQ(stats.missingPixels, 0u);
  EXPECT_EQ(px(world, 40, 0, 0)[0], 0);
  EXPECT_EQ(px(world, 40, 39, 19)[0], 39);
  EXPECT_EQ(px(world, 40, 39, 19)[1], 19);
}

TEST(Compose, TileLimitAndDeepestLevel) {
  const auto g = grid(512, 25);
  // A 4096-pixel-wide map of the world is level 0 (0.088 degree pixels): 10 x 5 tiles.
  const Sector world{-180, -90, 180, 90};
  const auto level = composeLevel(g, world, 4096, 2048, 0);
  EXPECT_EQ(level, 0);
  const auto tooMany = composeTiles(g, world, 4096, 2048, level, 16);
  ASSERT_FALSE(tooMany);
  EXPECT_EQ(tooMany.error(), 50u);
  EXPECT_TRUE(composeTiles(g, world, 4096, 2048, level, 50));
  // At the deepest level (24) a tiny box needs a handful of tiles, with exact indices.
  const double d = 36.0 / (1 << 24);
  const double lon0 = -180.0 + 50000000.0 * d;
  const double lat0 = -90.0 + 30000000.0 * d;
  const Sector tiny{lon0 + d * 0.25, lat0 + d * 0.25, lon0 + d * 1.75, lat0 + d * 1.75};
  const auto deep = composeLevel(g, tiny, 768, 768, 0);
  EXPECT_EQ(deep, 24);
  const auto keys = composeTiles(g, tiny, 768, 768, deep, 16);
  ASSERT_TRUE(keys);
  EXPECT_EQ(keys->size(), 4u);
  for (const auto& t : *keys) {
    EXPECT_TRUE(g.isValid(t.key));
    EXPECT_EQ(t.key.level, 24);
  }
}

TEST(Compose, RegionsCoverExactlyTheTexelsSampled) {
  const auto g = grid(512, 4);
  // 20 x 10 degrees at 0.05 degree pixels: level 1 (0.035 deg texels), within tile (row 5, col 10).
  const Sector box{1.0, 1.0, 11.0, 6.0};
  const auto keys = composeTiles(g, box, 200, 100, 1, 16);
  ASSERT_TRUE(keys);
  ASSERT_EQ(keys->size(), 1u);
  const auto& t = keys->front();
  EXPECT_EQ(t.key.row, 5);
  EXPECT_EQ(t.key.col, 10);
  const double texel = 18.0 / 512;
  // Columns: from the texel left of the first pixel centre to the one right of the last.
  EXPECT_EQ(t.region[0], static_cast<int>(std::floor((1.0 + 0.025) / texel - 0.5)));
  EXPECT_EQ(t.region[2], static_cast<int>(std::floor((11.0 - 0.025) / texel - 0.5)) + 2);
  // Rows from the top of the tile (lat 18): 6 - 0.025 is the first pixel centre.
  EXPECT_EQ(t.region[1], static_cast<int>(std::floor((18.0 - 6.0 + 0.025) / texel - 0.5)));
  EXPECT_EQ(t.region[3], static_cast<int>(std::floor((18.0 - 1.0 - 0.025) / texel - 0.5)) + 2);
  // A box across tiles: each tile's region is clipped to that tile.
  const auto two = composeTiles(g, Sector{10.0, 1.0, 26.0, 6.0}, 320, 100, 1, 16);
  ASSERT_TRUE(two);
  ASSERT_EQ(two->size(), 2u);
  EXPECT_EQ(two->at(0).region[2], 512);
  EXPECT_EQ(two->at(1).region[0], 0);
}

TEST(Compose, MissingTilesFallBackToTheNearestCoarserLevel) {
  const auto g = grid(4, 4);
  Synthetic s{g, {}, {}, {}};
  s.addLevel(0);
  // Level 2 present except one tile; level 1 absent entirely.
  s.addLevel(2);
  const TileKey hole{2, 9, 21};
  s.tiles.erase({hole.level, hole.row, hole.col});
  const Sector tileBox = g.sectorOf(hole);
  std::vector<std::uint8_t> canvas;
  const auto stats = composeImagery(g, tileBox, 4, 4, 2, 0, s.lookup(), 1.0, canvas);
  EXPECT_EQ(stats.missingPixels, 0u);
  EXPECT_EQ(stats.fallbackPixels, 16u);
  for (int p = 0; p < 16; ++p)
    EXPECT_EQ(canvas[static_cast<std::size_t>(p * 4 + 2)], 0) << "level 0's blue";
  // Its neighbour (all four texels present) is drawn from level 2.
  const auto next =
      composeImagery(g, g.sectorOf(TileKey{2, 9, 23}), 4, 4, 2, 0, s.lookup(), 1.0, canvas);
  EXPECT_EQ(next.fallbackPixels, 0u);
  EXPECT_EQ(canvas[2], 20);
  // Nothing anywhere: pixels are counted missing and left as they were.
  Synthetic none{g, {}, {}, {}};
  std::vector<std::uint8_t> empty(16 * 4, 3);
  const auto nothing = composeImagery(g, tileBox, 4, 4, 2, 0, none.lookup(), 1.0, empty);
  EXPECT_EQ(nothing.missingPixels, 16u);
  EXPECT_EQ(empty[0], 3);
}

TEST(Compose, OpacityBlendsOverTheCanvas) {
  const auto g = grid(4, 1);
  std::vector<std::uint8_t> red(4 * 4 * 3), blue(4 * 4 * 3);
  for (std::size_t i = 0; i < red.size(); i += 3) {
    red[i] = 255;
    blue[i + 2] = 255;
  }
  TileSamples r{4, 4, 3, red.data(), nullptr};
  TileSamples b{4, 4, 3, blue.data(), nullptr};
  const Sector box = g.sectorOf(TileKey{0, 2, 5});
  std::vector<std::uint8_t> canvas(4 * 4 * 4, 0);
  composeImagery(
      g, box, 4, 4, 0, 0, [&](const TileKey&) { return &r; }, 1.0, canvas);
  composeImagery(
      g, box, 4, 4, 0, 0, [&](const TileKey&) { return &b; }, 0.5, canvas);
  EXPECT_NEAR(canvas[0], 127.5, 1.0);
  EXPECT_EQ(canvas[1], 0);
  EXPECT_NEAR(canvas[2], 127.5, 1.0);
  EXPECT_EQ(canvas[3], 255);
  // Over a transparent canvas, a half-opaque layer keeps its colour and half its alpha.
  std::vector<std::uint8_t> clear(4 * 4 * 4, 0);
  composeImagery(
      g, box, 4, 4, 0, 0, [&](const TileKey&) { return &b; }, 0.5, clear);
  EXPECT_EQ(clear[2], 255);
  EXPECT_NEAR(clear[3], 127.5, 1.0);
  // Opacity 0 draws nothing; NaN is treated as opaque rather than poisoning the map.
  std::vector<std::uint8_t> zero(4 * 4 * 4, 9);
  composeImagery(
      g, box, 4, 4, 0, 0, [&](const TileKey&) { return &b; }, 0.0, zero);
  EXPECT_EQ(zero[0], 9);
  composeImagery(
      g,
      box,
      4,
      4,
      0,
      0,
      [&](const TileKey&) { return &b; },
      std::numeric_limits<double>::quiet_NaN(),
      zero);
  EXPECT_EQ(zero[2], 255);
}

TEST(Compose, HeightsAreExactWhenAlignedAndNoDataNeverBlends) {
  const auto g = grid(4, 2);
  Synthetic s{g, {}, {}, {}, true};
  s.addLevel(1);
  // Aligned with level 1's texels (4.5 degrees), not with its tiles.
  const Sector box{-180.0 + 3 * 4.5, 0.0, -180.0 + 9 * 4.5, 9.0};
  std::vector<std::int16_t> h;
  composeHeights(g, box, 6, 2, 1, 0, s.lookup(), -32768, h);
  for (int i = 0; i < 6; ++i)
    EXPECT_EQ(h[static_cast<std::size_t>(i)], 100 + 3 + i);
  // Halfway between texels: the mean (rounded).
  std::vector<std::int16_t> half;
  composeHeights(
      g, Sector{-180.0 + 2.25, 0.0, -180.0 + 6.75, 4.5}, 1, 1, 1, 0, s.lookup(), -32768, half);
  EXPECT_EQ(half[0], 101); // (100 + 101) / 2 = 100.5 rounds away from zero
  // A no-data texel: the nearest texel's value, never a blend with -32768.
  std::vector<std::int16_t> v(16, 500);
  v[1] = -32768;
  TileSamples t{4, 4, 1, nullptr, v.data()};
  std::vector<std::int16_t> out;
  const Sector tile = g.sectorOf(TileKey{0, 2, 5});
  composeHeights(
      g,
      Sector{tile.west + 4.5, tile.north - 9.0, tile.west + 13.5, tile.north},
      1,
      1,
      0,
      0,
      [&](const TileKey&) { return &t; },
      -32768,
      out);
  EXPECT_EQ(out[0], 500);
}

TEST(ComposeExtremes, RegionalLayerLeavesTheOutsideAlone) {
  const auto g = grid(4, 2, Sector{-36, -36, 36, 36});
  Synthetic s{g, {}, {}, {}};
  s.addLevel(0);
  std::vector<std::uint8_t> canvas(8 * 8 * 4, 5);
  const auto stats =
      composeImagery(g, Sector{-72, -72, 72, 72}, 8, 8, 0, 0, s.lookup(), 1.0, canvas);
  EXPECT_EQ(stats.missingPixels, 0u);
  EXPECT_EQ(px(canvas, 8, 0, 0)[3], 5) << "outside the sector";
  EXPECT_EQ(px(canvas, 8, 3, 3)[3], 255) << "inside";
  // Tiles are only asked for inside the sector.
  const auto keys = composeTiles(g, Sector{-180, -90, 180, 90}, 40, 20, 0, 100);
  ASSERT_TRUE(keys);
  EXPECT_EQ(keys->size(), 6u) << "two columns (-36..0, 0..36), three rows (-54..-18 .. 18..54)";
}

TEST(ComposeExtremes, OnePlaneGivesTheRgbPathsValuesExactly) {
  // A plane (the YCbCr path's Y, Cb or Cr) is sampled with the same integer arithmetic as RGB,
  // through the vectorised horizontal pass where it can: the R channel of the RGB path, exactly,
  // over random boxes and sizes, across the antimeridian, past the poles, magnified (deepest
  // level) and with missing tiles filled from the coarser level.
  const TileGrid g = grid(64, 3);
  Synthetic s{g, {}, {}, {}};
  s.addLevel(0);
  s.addLevel(1);
  s.addLevel(2);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  // Every tenth level-2 tile missing.
  std::vector<TileKey> gone;
  for (const auto& [k, t] : s.tiles)
    if (std::get<0>(k) == 2 && u(rng) < 0.1) gone.push_back({2, std::get<1>(k), std::get<2>(k)});
  for (const auto& k : gone)
    s.tiles.erase({k.level, k.row, k.col});
  // The planes: R of each tile.
  std::map<std::tuple<int, std::int64_t, std::int64_t>, std::vector<std::uint8_t>> planes;
  std::map<std::tuple<int, std::int64_t, std::int64_t>, TileSamples> views;
  for (const auto& [k, t] : s.tiles) {
    auto& p = planes[k];
    p.resize(64 * 64);
    for (std::size_t i = 0; i < p.size(); ++i)
      p[i] = t->rgb[i * 3];
    views[k] = TileSamples{64, 64, 1, p.data(), nullptr};
  }
  const TileLookup plane = [&](const TileKey& k) -> const TileSamples* {
    const auto it = views.find({k.level, k.row, k.col});
    return it == views.end() ? nullptr : &it->second;
  };
  for (int c = 0; c < 60; ++c) {
    const double span = c < 50 ? 2 + u(rng) * 100 : 0.5 + u(rng); // the last ten magnified
    const double west = -180 + u(rng) * 400;
    const double hs = span * (0.25 + u(rng));
    const double south = -100 + u(rng) * (200 - hs);
    const int width = 8 + static_cast<int>(u(rng) * 700);
    const int height = 8 + static_cast<int>(u(rng) * 300);
    const Sector box{west, south, west + span, south + hs};
    SCOPED_TRACE(::testing::Message() << west << "," << south << " " << span << " x " << hs << " "
                                      << width << "x" << height);
    const int level = composeLevel(g, box, width, height, 0);
    std::vector<std::uint8_t> rgb(static_cast<std::size_t>(width * height * 3), 7);
    std::vector<std::uint8_t> one(static_cast<std::size_t>(width * height), 7);
    const ComposeStats a = composeImagery(g, box, width, height, level, 0, s.lookup(), 1.0, rgb, 3);
    const ComposeStats b = composeImagery(g, box, width, height, level, 0, plane, 1.0, one, 1);
    EXPECT_EQ(a.fallbackPixels, b.fallbackPixels);
    EXPECT_EQ(a.missingPixels, b.missingPixels);
    int bad = 0;
    for (std::size_t p = 0; p < one.size(); ++p)
      bad += one[p] != rgb[p * 3];
    EXPECT_EQ(bad, 0);
  }
}

TEST(ComposeExtremes, PlaneSamplerMatchesAPlainBilinearOnRandomTexels) {
  // The plane sampler (vertical blend, then the horizontal pass in segments of 8 or 16 columns
  // with SIMD where the CPU has it, scalar elsewhere) against bilinear filtering written out per
  // pixel from the definition in Compose.hpp, on tiles of random texels (so no two neighbours
  // agree by accident): exactly equal, over odd widths, boxes across the antimeridian and past the
  // poles, minified up to 2 texels per pixel and magnified, and the last columns of a row.
  const TileGrid g = grid(64, 3);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::map<std::tuple<int, std::int64_t, std::int64_t>, std::vector<std::uint8_t>> texels;
  std::map<std::tuple<int, std::int64_t, std::int64_t>, TileSamples> views;
  for (int level = 0; level < 3; ++level)
    for (std::int64_t r = 0; r < g.rowCount(level); ++r)
      for (std::int64_t c = 0; c < g.colCount(level); ++c) {
        auto& t = texels[{level, r, c}];
        t.resize(64 * 64);
        for (auto& v : t)
          v = static_cast<std::uint8_t>(rng() & 0xFF);
        views[{level, r, c}] = TileSamples{64, 64, 1, t.data(), nullptr};
      }
  const TileLookup lookup = [&](const TileKey& k) -> const TileSamples* {
    const auto it = views.find({k.level, k.row, k.col});
    return it == views.end() ? nullptr : &it->second;
  };
  // Texel (x, y) of a level, x from -180 and y from +90 (rows of tiles count from the south).
  const auto texel = [&](int level, std::int64_t x, std::int64_t y) -> std::int32_t {
    const std::int64_t row = g.rowCount(level) - 1 - y / 64;
    return texels.at({level, row, x / 64})[static_cast<std::size_t>((y % 64) * 64 + x % 64)];
  };
  const std::uint8_t background = 77;
  for (int c = 0; c < 80; ++c) {
    const bool magnified = c % 5 == 4;
    const int width = (1 + static_cast<int>(u(rng) * 900)) | 1; // odd
    const int height = 1 + static_cast<int>(u(rng) * 120);
    // Minified: 1 to 2 texels per pixel at the level composeLevel picks; magnified: the deepest
    // level at less than one.
    const double perPixel = magnified ? 0.3 + 0.6 * u(rng) : 1.0 + u(rng);
    const int level = magnified ? 2 : static_cast<int>(u(rng) * 3);
    const double res = g.deltaDeg(level) / 64;
    const double span = width * res * perPixel;
    const double hs = height * res * (magnified ? perPixel : 1.0 + u(rng));
    const double west = -180 + u(rng) * 500;
    const double north = -60 + u(rng) * 170;
    const Sector box{west, north - hs, west + span, north};
    SCOPED_TRACE(::testing::Message()
                 << "box " << west << "," << north - hs << " " << span << " x " << hs << ", "
                 << width << "x" << height << ", level " << level);
    std::vector<std::uint8_t> plane;
    const ComposeStats stats =
        composePlane(g, box, width, height, level, 0, lookup, background, plane);
    EXPECT_EQ(stats.fallbackPixels, 0u);
    EXPECT_EQ(stats.missingPixels, 0u);
    // The same plane through composeImagery over a filled canvas.
    std::vector<std::uint8_t> filled(static_cast<std::size_t>(width * height), background);
    composeImagery(g, box, width, height, level, 0, lookup, 1.0, filled, 1);
    EXPECT_EQ(plane, filled);
    const std::int64_t total = g.colCount(level) * 64;
    const std::int64_t rows = g.rowCount(level) * 64;
    const double dx = (box.east - box.west) / width;
    const double dy = (box.north - box.south) / height;
    int bad = 0;
    for (int j = 0; j < height; ++j) {
      const double lat = box.north - (j + 0.5) * dy;
      for (int i = 0; i < width; ++i) {
        std::int32_t expected = background;
        if (lat <= 90.0 && lat >= -90.0) {
          double w = std::fmod(box.west + (i + 0.5) * dx + 180.0, 360.0);
          if (w < 0.0) w += 360.0;
          if (w >= 360.0) w = 0.0;
          const double lon = w - 180.0; // into [-180, 180)
          const double gx = (lon + 180.0) / res - 0.5, gy = (90.0 - lat) / res - 0.5;
          const auto x0 = static_cast<std::int64_t>(std::floor(gx));
          const auto y0 = static_cast<std::int64_t>(std::floor(gy));
          const auto wx = static_cast<std::int32_t>(std::lround((gx - std::floor(gx)) * 256.0));
          const auto wy = static_cast<std::int32_t>(std::lround((gy - std::floor(gy)) * 256.0));
          const std::int64_t xa = (x0 % total + total) % total, xb = (xa + 1) % total;
          const std::int64_t ya = std::clamp<std::int64_t>(y0, 0, rows - 1);
          const std::int64_t yb = std::clamp<std::int64_t>(y0 + 1, 0, rows - 1);
          expected =
              (texel(level, xa, ya) * (256 - wx) * (256 - wy) +
               texel(level, xb, ya) * wx * (256 - wy) + texel(level, xa, yb) * (256 - wx) * wy +
               texel(level, xb, yb) * wx * wy + 32768) >>
              16;
        }
        const std::int32_t got = plane[static_cast<std::size_t>(j * width + i)];
        if (got != expected && ++bad <= 5)
          ADD_FAILURE() << "pixel " << i << "," << j << ": " << got << " != " << expected;
      }
    }
    EXPECT_EQ(bad, 0);
  }
}
