// Unit tests of the World Wind style tile grid: counts, addressing, hierarchy, neighbours,
// coverage, WMS bbox matching, validation and regional sectors.

#include <tellus/cache/TileGrid.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

namespace tellus {

// Readable failure messages (internal linkage: other test files may define their own).
[[maybe_unused]] static void PrintTo(const TileKey& k, std::ostream* os) {
  *os << "{level " << k.level << ", row " << k.row << ", col " << k.col << "}";
}
[[maybe_unused]] static void PrintTo(const Sector& s, std::ostream* os) {
  *os << "{W " << s.west << ", S " << s.south << ", E " << s.east << ", N " << s.north << "}";
}

namespace {

TileGrid
makeGrid(double delta, std::int32_t numLevels = 4, Sector sector = {}, std::int32_t tile = 512) {
  GridSpec spec;
  spec.sector = sector;
  spec.levelZeroDeltaDeg = delta;
  spec.tileWidth = tile;
  spec.tileHeight = tile;
  spec.numLevels = numLevels;
  auto grid = TileGrid::create(spec);
  EXPECT_TRUE(grid.has_value()) << (grid ? std::string() : grid.error());
  return *grid;
}

std::string createError(const GridSpec& spec) {
  auto grid = TileGrid::create(spec);
  return grid ? std::string("<no error>") : grid.error();
}

TEST(TileGrid, RowAndColumnCountsPerLevel) {
  struct Case {
    double delta;
    std::int64_t rows0;
    std::int64_t cols0;
  };
  for (const Case c : {Case{36.0, 5, 10}, Case{45.0, 4, 8}, Case{20.0, 9, 18}}) {
    const TileGrid grid = makeGrid(c.delta);
    for (std::int32_t level = 0; level < 4; ++level) {
      SCOPED_TRACE("delta " + std::to_string(c.delta) + " level " + std::to_string(level));
      EXPECT_EQ(grid.rowCount(level), c.rows0 << level);
      EXPECT_EQ(grid.colCount(level), c.cols0 << level);
      EXPECT_EQ(grid.deltaDeg(level), c.delta / static_cast<double>(1 << level));
    }
  }
  const TileGrid grid = makeGrid(36.0);
  EXPECT_EQ(grid.rowCount(0), 5);
  EXPECT_EQ(grid.colCount(0), 10);
  EXPECT_EQ(grid.rowCount(3), 40);
  EXPECT_EQ(grid.colCount(3), 80);
  EXPECT_EQ(grid.numLevels(), 4);
  EXPECT_EQ(grid.spec().levelZeroDeltaDeg, 36.0);
}

TEST(TileGrid, CountsOutsideTheLevelRange) {
  const TileGrid grid = makeGrid(36.0, 4);
  EXPECT_EQ(grid.rowCount(-1), 0);
  EXPECT_EQ(grid.colCount(4), 0);
  EXPECT_TRUE(std::isnan(grid.deltaDeg(4)));
  EXPECT_TRUE(std::isnan(grid.deltaDeg(-1)));
}

TEST(TileGrid, SectorOfLevelZeroTiles) {
  const TileGrid grid = makeGrid(36.0);
  EXPECT_EQ(grid.sectorOf({0, 0, 0}), (Sector{-180.0, -90.0, -144.0, -54.0}));
  EXPECT_EQ(grid.sectorOf({0, 2, 5}), (Sector{0.0, -18.0, 36.0, 18.0}));
  EXPECT_EQ(grid.sectorOf({0, 4, 9}), (Sector{144.0, 54.0, 180.0, 90.0}));
  EXPECT_EQ(grid.sectorOf({1, 9, 19}), (Sector{162.0, 72.0, 180.0, 90.0}));

  const TileGrid grid45 = makeGrid(45.0);
  EXPECT_EQ(grid45.sectorOf({0, 1, 3}), (Sector{-45.0, -45.0, 0.0, 0.0}));
  EXPECT_EQ(grid45.sectorOf({2, 15, 31}), (Sector{168.75, 78.75, 180.0, 90.0}));

  const TileGrid grid20 = makeGrid(20.0);
  EXPECT_EQ(grid20.sectorOf({0, 4, 9}), (Sector{0.0, -10.0, 20.0, 10.0}));
  EXPECT_EQ(grid20.sectorOf({3, 0, 0}), (Sector{-180.0, -90.0, -177.5, -87.5}));
}

TEST(TileGrid, IsValid) {
  const TileGrid grid = makeGrid(36.0, 2);
  EXPECT_TRUE(grid.isValid({0, 0, 0}));
  EXPECT_TRUE(grid.isValid({0, 4, 9}));
  EXPECT_TRUE(grid.isValid({1, 9, 19}));
  EXPECT_FALSE(grid.isValid({0, 5, 0}));
  EXPECT_FALSE(grid.isValid({0, 0, 10}));
  EXPECT_FALSE(grid.isValid({0, -1, 0}));
  EXPECT_FALSE(grid.isValid({0, 0, -1}));
  EXPECT_FALSE(grid.isValid({2, 0, 0}));
  EXPECT_FALSE(grid.isValid({-1, 0, 0}));
}

TEST(TileGrid, KeyAtInteriorPoints) {
  const TileGrid grid = makeGrid(36.0);
  EXPECT_EQ(grid.keyAt(0.0, 0.0, 0), (TileKey{0, 2, 5}));
  EXPECT_EQ(grid.keyAt(-89.0, -179.0, 0), (TileKey{0, 0, 0}));
  EXPECT_EQ(grid.keyAt(45.5, 7.25, 0), (TileKey{0, 3, 5}));
  EXPECT_EQ(grid.keyAt(45.5, 7.25, 1), (TileKey{1, 7, 10}));
  EXPECT_EQ(grid.keyAt(45.5, 7.25, 3), (TileKey{3, 30, 41}));
  // On a tile edge: the tile to the north / east (half-open tiles).
  EXPECT_EQ(grid.keyAt(-18.0, -144.0, 0), (TileKey{0, 2, 1}));
  EXPECT_EQ(grid.keyAt(54.0, 144.0, 0), (TileKey{0, 4, 9}));

  const TileGrid grid20 = makeGrid(20.0);
  EXPECT_EQ(grid20.keyAt(-33.9, 151.2, 2), (TileKey{2, 11, 66}));
}

TEST(TileGrid, KeyAtClosedNorthAndEastEdge) {
  const TileGrid grid = makeGrid(36.0);
  for (std::int32_t level = 0; level < 4; ++level) {
    const std::int64_t lastRow = grid.rowCount(level) - 1;
    const std::int64_t lastCol = grid.colCount(level) - 1;
    EXPECT_EQ(grid.keyAt(90.0, 180.0, level), (TileKey{level, lastRow, lastCol}));
    EXPECT_EQ(grid.keyAt(90.0, -180.0, level), (TileKey{level, lastRow, 0}));
    EXPECT_EQ(grid.keyAt(-90.0, 180.0, level), (TileKey{level, 0, lastCol}));
    EXPECT_EQ(grid.keyAt(-90.0, -180.0, level), (TileKey{level, 0, 0}));
  }
}

TEST(TileGrid, KeyAtRejectsBadInput) {
  const TileGrid grid = makeGrid(36.0);
  EXPECT_EQ(grid.keyAt(90.5, 0.0, 0), std::nullopt);
  EXPECT_EQ(grid.keyAt(-90.5, 0.0, 0), std::nullopt);
  EXPECT_EQ(grid.keyAt(0.0, 180.5, 0), std::nullopt);
  EXPECT_EQ(grid.keyAt(0.0, -180.5, 0), std::nullopt);
  EXPECT_EQ(grid.keyAt(0.0, 0.0, -1), std::nullopt);
  EXPECT_EQ(grid.keyAt(0.0, 0.0, 4), std::nullopt);
}

TEST(TileGrid, ParentAndChildren) {
  const TileGrid grid = makeGrid(36.0);
  const TileKey k{1, 7, 10};
  EXPECT_EQ(grid.parent(k), (TileKey{0, 3, 5}));
  EXPECT_EQ(grid.parent({1, 6, 11}), (TileKey{0, 3, 5}));
  EXPECT_EQ(grid.parent({0, 3, 5}), std::nullopt);
  EXPECT_EQ(grid.parent({1, 10, 0}), std::nullopt); // invalid key

  const auto kids = grid.children(k);
  ASSERT_TRUE(kids.has_value());
  EXPECT_EQ((*kids)[0], (TileKey{2, 14, 20})); // SW
  EXPECT_EQ((*kids)[1], (TileKey{2, 14, 21})); // SE
  EXPECT_EQ((*kids)[2], (TileKey{2, 15, 20})); // NW
  EXPECT_EQ((*kids)[3], (TileKey{2, 15, 21})); // NE
  for (const TileKey& c : *kids)
    EXPECT_EQ(grid.parent(c), k);

  const Sector ps = grid.sectorOf(k);
  EXPECT_EQ(grid.sectorOf((*kids)[0]).west, ps.west);
  EXPECT_EQ(grid.sectorOf((*kids)[0]).south, ps.south);
  EXPECT_EQ(grid.sectorOf((*kids)[3]).east, ps.east);
  EXPECT_EQ(grid.sectorOf((*kids)[3]).north, ps.north);

  EXPECT_EQ(grid.children({3, 0, 0}), std::nullopt); // deepest level
  EXPECT_EQ(grid.children({0, 5, 0}), std::nullopt); // invalid key
}

TEST(TileGrid, Neighbours) {
  const TileGrid grid = makeGrid(36.0);
  const TileKey k{1, 4, 7};
  EXPECT_EQ(grid.neighbour(k, Direction::North), (TileKey{1, 5, 7}));
  EXPECT_EQ(grid.neighbour(k, Direction::South), (TileKey{1, 3, 7}));
  EXPECT_EQ(grid.neighbour(k, Direction::East), (TileKey{1, 4, 8}));
  EXPECT_EQ(grid.neighbour(k, Direction::West), (TileKey{1, 4, 6}));

  // Antimeridian wrap.
  EXPECT_EQ(grid.neighbour({1, 4, 19}, Direction::East), (TileKey{1, 4, 0}));
  EXPECT_EQ(grid.neighbour({1, 4, 0}, Direction::West), (TileKey{1, 4, 19}));
  EXPECT_EQ(grid.neighbour({0, 0, 9}, Direction::East), (TileKey{0, 0, 0}));
  // No wrap over the poles.
  EXPECT_EQ(grid.neighbour({1, 9, 3}, Direction::North), std::nullopt);
  EXPECT_EQ(grid.neighbour({1, 0, 3}, Direction::South), std::nullopt);
  // Invalid key.
  EXPECT_EQ(grid.neighbour({1, 10, 3}, Direction::South), std::nullopt);

  // Shared edges are bit-identical.
  EXPECT_EQ(grid.sectorOf(*grid.neighbour(k, Direction::North)).south, grid.sectorOf(k).north);
  EXPECT_EQ(grid.sectorOf(*grid.neighbour(k, Direction::East)).west, grid.sectorOf(k).east);
}

TEST(TileGrid, KeysCoveringNormalBox) {
  const TileGrid grid = makeGrid(36.0);
  const auto keys = grid.keysCovering({-10.0, -20.0, 40.0, 20.0}, 0);
  ASSERT_TRUE(keys.has_value());
  // Rows 1 (-54..-18), 2 (-18..18), 3 (18..54); columns 4 (-36..0), 5 (0..36), 6 (36..72).
  std::vector<TileKey> expected;
  for (std::int64_t r = 1; r <= 3; ++r)
    for (std::int64_t c = 4; c <= 6; ++c)
      expected.push_back({0, r, c});
  EXPECT_EQ(*keys, expected);

  const auto one = grid.keysCovering({1.0, 1.0, 2.0, 2.0}, 2);
  ASSERT_TRUE(one.has_value());
  EXPECT_EQ(*one, (std::vector<TileKey>{*grid.keyAt(1.5, 1.5, 2)}));

  const auto globe = grid.keysCovering({}, 1);
  ASSERT_TRUE(globe.has_value());
  EXPECT_EQ(globe->size(), 200u);
  EXPECT_EQ(globe->front(), (TileKey{1, 0, 0}));
  EXPECT_EQ(globe->back(), (TileKey{1, 9, 19}));
}

TEST(TileGrid, KeysCoveringEdgeTouchingBox) {
  const TileGrid grid = makeGrid(36.0);
  // Exactly one level-0 tile: the tiles beyond its edges are not included.
  const auto keys = grid.keysCovering({0.0, -18.0, 36.0, 18.0}, 0);
  ASSERT_TRUE(keys.has_value());
  EXPECT_EQ(*keys, (std::vector<TileKey>{{0, 2, 5}}));
  // The same box at level 1: exactly the four children.
  const auto kids = grid.keysCovering({0.0, -18.0, 36.0, 18.0}, 1);
  ASSERT_TRUE(kids.has_value());
  EXPECT_EQ(*kids, (std::vector<TileKey>{{1, 4, 10}, {1, 4, 11}, {1, 5, 10}, {1, 5, 11}}));
  // Zero-area boxes cover nothing.
  EXPECT_EQ(grid.keysCovering({0.0, -18.0, 0.0, 18.0}, 0), std::vector<TileKey>{});
  EXPECT_EQ(grid.keysCovering({0.0, 18.0, 36.0, 18.0}, 0), std::vector<TileKey>{});
  EXPECT_EQ(grid.keysCovering({0.0, 18.0, 36.0, -18.0}, 0), std::vector<TileKey>{});
}

TEST(TileGrid, KeysCoveringAntimeridianCrossingBox) {
  const TileGrid grid = makeGrid(36.0);
  // 170 .. 180 and -180 .. -170, lat 0 .. 10: row 2, columns 9 then 0 (walking east from the SW).
  const auto keys = grid.keysCovering({170.0, 0.0, -170.0, 10.0}, 0);
  ASSERT_TRUE(keys.has_value());
  EXPECT_EQ(*keys, (std::vector<TileKey>{{0, 2, 9}, {0, 2, 0}}));

  // Two rows, row-major.
  const auto two = grid.keysCovering({150.0, -30.0, -150.0, 30.0}, 0);
  ASSERT_TRUE(two.has_value());
  EXPECT_EQ(
      *two,
      (std::vector<TileKey>{{0, 1, 9}, {0, 1, 0}, {0, 2, 9}, {0, 2, 0}, {0, 3, 9}, {0, 3, 0}}));

  // Edge-aligned crossing box: west 144, east -144 -> exactly columns 9 and 0.
  const auto aligned = grid.keysCovering({144.0, -18.0, -144.0, 18.0}, 0);
  ASSERT_TRUE(aligned.has_value());
  EXPECT_EQ(*aligned, (std::vector<TileKey>{{0, 2, 9}, {0, 2, 0}}));

  // A crossing box spanning almost the whole globe lists every column once.
  const auto wide = grid.keysCovering({10.0, -18.0, 5.0, 18.0}, 0);
  ASSERT_TRUE(wide.has_value());
  EXPECT_EQ(wide->size(), 10u);
  EXPECT_EQ(wide->front(), (TileKey{0, 2, 5}));
  EXPECT_EQ(wide->back(), (TileKey{0, 2, 4}));

  // West exactly 180: only the part east of -180 remains.
  const auto west180 = grid.keysCovering({180.0, -18.0, -144.0, 18.0}, 0);
  ASSERT_TRUE(west180.has_value());
  EXPECT_EQ(*west180, (std::vector<TileKey>{{0, 2, 0}}));
}

TEST(TileGrid, KeysCoveringClippedBox) {
  const TileGrid grid = makeGrid(36.0);
  const auto keys = grid.keysCovering({-180.0, 60.0, -140.0, 120.0}, 0);
  ASSERT_TRUE(keys.has_value());
  EXPECT_EQ(*keys, (std::vector<TileKey>{{0, 4, 0}, {0, 4, 1}}));

  const auto south = grid.keysCovering({0.0, -200.0, 10.0, -80.0}, 0);
  ASSERT_TRUE(south.has_value());
  EXPECT_EQ(*south, (std::vector<TileKey>{{0, 0, 5}}));

  // Entirely outside the globe.
  EXPECT_EQ(grid.keysCovering({0.0, 95.0, 10.0, 100.0}, 0), std::vector<TileKey>{});
  // Longitudes beyond +-180 are clipped too.
  const auto lon = grid.keysCovering({170.0, 0.0, 200.0, 10.0}, 0);
  ASSERT_TRUE(lon.has_value());
  EXPECT_EQ(*lon, (std::vector<TileKey>{{0, 2, 9}}));
}

TEST(TileGrid, KeysCoveringBadLevelAndLimit) {
  const TileGrid grid = makeGrid(36.0);
  EXPECT_EQ(grid.keysCovering({}, -1), std::nullopt);
  EXPECT_EQ(grid.keysCovering({}, 4), std::nullopt);
  EXPECT_EQ(grid.keysCovering({}, 3, 3200)->size(), 3200u);
  EXPECT_EQ(grid.keysCovering({}, 3, 3199), std::nullopt);
  EXPECT_EQ(grid.keysCovering({0.0, 0.0, 0.0, 0.0}, 3, 0), std::vector<TileKey>{});
}

TEST(TileGrid, KeyForBboxAligned) {
  const TileGrid grid = makeGrid(36.0);
  EXPECT_EQ(grid.keyForBbox({0.0, -18.0, 36.0, 18.0}, 512, 512), (TileKey{0, 2, 5}));
  EXPECT_EQ(grid.keyForBbox({162.0, 72.0, 180.0, 90.0}, 512, 512), (TileKey{1, 9, 19}));
  EXPECT_EQ(grid.keyForBbox({-180.0, -90.0, -175.5, -85.5}, 512, 512), (TileKey{3, 0, 0}));
  // Within the tolerance.
  EXPECT_EQ(grid.keyForBbox({1e-9, -18.0, 36.0, 18.0 - 1e-9}, 512, 512), (TileKey{0, 2, 5}));
  EXPECT_EQ(grid.keyForBbox({1e-6, -18.0, 36.0, 18.0}, 512, 512, 1e-6), (TileKey{0, 2, 5}));
  // Level beyond numLevels.
  EXPECT_EQ(grid.keyForBbox({0.0, 0.0, 2.25, 2.25}, 512, 512), std::nullopt);
}

TEST(TileGrid, KeyForBboxUnaligned) {
  const TileGrid grid = makeGrid(36.0);
  EXPECT_EQ(grid.keyForBbox({18.0, -18.0, 54.0, 18.0}, 512, 512), std::nullopt);
  EXPECT_EQ(grid.keyForBbox({1e-6, -18.0, 36.0, 18.0}, 512, 512), std::nullopt);
  EXPECT_EQ(grid.keyForBbox({0.0, -18.0, 36.0, 18.1}, 512, 512), std::nullopt);
  EXPECT_EQ(grid.keyForBbox({0.0, -18.0, 30.0, 18.0}, 512, 512), std::nullopt); // not square
  EXPECT_EQ(grid.keyForBbox({0.0, -18.0, 72.0, 54.0}, 512, 512), std::nullopt); // two tiles
  EXPECT_EQ(grid.keyForBbox({36.0, -18.0, 0.0, 18.0}, 512, 512), std::nullopt); // reversed
  EXPECT_EQ(grid.keyForBbox({0.0, 18.0, 36.0, -18.0}, 512, 512), std::nullopt);
  EXPECT_EQ(grid.keyForBbox({0.0, -18.0, 36.0, 18.0}, 512, 512, -1.0), std::nullopt);
}

TEST(TileGrid, KeyForBboxWrongSize) {
  const TileGrid grid = makeGrid(36.0);
  EXPECT_EQ(grid.keyForBbox({0.0, -18.0, 36.0, 18.0}, 256, 512), std::nullopt);
  EXPECT_EQ(grid.keyForBbox({0.0, -18.0, 36.0, 18.0}, 512, 256), std::nullopt);
  EXPECT_EQ(grid.keyForBbox({0.0, -18.0, 36.0, 18.0}, 0, 0), std::nullopt);

  const TileGrid small = makeGrid(36.0, 4, {}, 150);
  EXPECT_EQ(small.keyForBbox({0.0, -18.0, 36.0, 18.0}, 150, 150), (TileKey{0, 2, 5}));
  EXPECT_EQ(small.keyForBbox({0.0, -18.0, 36.0, 18.0}, 512, 512), std::nullopt);
}

TEST(TileGrid, CreateAcceptsWorldWindGrids) {
  for (const double delta : {180.0, 90.0, 60.0, 45.0, 36.0, 30.0, 20.0, 10.0, 1.0, 0.5}) {
    GridSpec spec;
    spec.levelZeroDeltaDeg = delta;
    spec.numLevels = 31;
    EXPECT_TRUE(TileGrid::create(spec).has_value()) << delta;
  }
  GridSpec spec;
  spec.tileWidth = 1;
  spec.tileHeight = 65536;
  EXPECT_TRUE(TileGrid::create(spec).has_value());
}

TEST(TileGrid, NearlyWholeDeltaKeepsTheGlobeClosed) {
  // 180 / delta is 5 within the tolerance, but 5 * delta overshoots 180: the last row and column
  // still end exactly at 90 / 180.
  const TileGrid grid = makeGrid(36.0 + 1e-11, 8);
  for (std::int32_t level = 0; level < 8; ++level) {
    SCOPED_TRACE(level);
    const TileKey last{level, grid.rowCount(level) - 1, grid.colCount(level) - 1};
    EXPECT_EQ(grid.rowCount(level), 5 << level);
    EXPECT_EQ(grid.sectorOf(last).north, 90.0);
    EXPECT_EQ(grid.sectorOf(last).east, 180.0);
    EXPECT_EQ(grid.keyAt(90.0, 180.0, level), last);
    EXPECT_EQ(grid.keyForBbox(grid.sectorOf(last), 512, 512), last);
    EXPECT_EQ(grid.keysCovering(grid.sectorOf(last), level), std::vector<TileKey>{last});
  }
}

TEST(TileGrid, CreateValidationErrors) {
  const auto errorFor = [](auto mutate) {
    GridSpec spec;
    mutate(spec);
    return createError(spec);
  };
  const auto has = [](const std::string& msg, const char* field) {
    return msg.find(field) != std::string::npos;
  };

  for (const double delta : {0.0,
                             -36.0,
                             std::numeric_limits<double>::quiet_NaN(),
                             std::numeric_limits<double>::infinity(),
                             7.0,
                             25.0,
                             360.0,
                             1e300,
                             1e-300}) {
    const std::string msg = errorFor([&](GridSpec& s) { s.levelZeroDeltaDeg = delta; });
    EXPECT_TRUE(has(msg, "levelZeroDeltaDeg")) << delta << ": " << msg;
  }
  EXPECT_TRUE(has(errorFor([](GridSpec& s) { s.numLevels = 0; }), "numLevels"));
  EXPECT_TRUE(has(errorFor([](GridSpec& s) { s.numLevels = 32; }), "numLevels"));
  EXPECT_TRUE(has(errorFor([](GridSpec& s) { s.numLevels = -5; }), "numLevels"));
  // A tiny delta at 31 levels would exceed 2^53 columns.
  EXPECT_TRUE(has(errorFor([](GridSpec& s) {
                    s.levelZeroDeltaDeg = 180.0 / 8388608.0;
                    s.numLevels = 31;
                  }),
                  "numLevels"));
  EXPECT_TRUE(has(errorFor([](GridSpec& s) { s.tileWidth = 0; }), "tileWidth"));
  EXPECT_TRUE(has(errorFor([](GridSpec& s) { s.tileWidth = 65537; }), "tileWidth"));
  EXPECT_TRUE(has(errorFor([](GridSpec& s) { s.tileHeight = -1; }), "tileHeight"));
  EXPECT_TRUE(has(errorFor([](GridSpec& s) { s.tileHeight = 70000; }), "tileHeight"));
  EXPECT_TRUE(has(errorFor([](GridSpec& s) { s.sector.west = -181.0; }), "sector.west"));
  EXPECT_TRUE(has(errorFor([](GridSpec& s) { s.sector.east = 180.5; }), "sector.east"));
  EXPECT_TRUE(has(errorFor([](GridSpec& s) { s.sector.south = -91.0; }), "sector.south"));
  EXPECT_TRUE(has(errorFor([](GridSpec& s) { s.sector.north = 91.0; }), "sector.north"));
  EXPECT_TRUE(has(errorFor([](GridSpec& s) { s.sector.north = std::nan(""); }), "sector.north"));
  EXPECT_TRUE(has(errorFor([](GridSpec& s) { s.sector.south = 90.0; }), "sector.south"));
  EXPECT_TRUE(has(errorFor([](GridSpec& s) {
                    s.sector.west = 170.0;
                    s.sector.east = -170.0;
                  }),
                  "sector.west"));
  EXPECT_TRUE(has(errorFor([](GridSpec& s) { s.sector.east = -180.0; }), "sector.west"));
}

/** The regional sector of the brief: W=-10, S=30, E=40, N=60 on a 36-degree grid. */
TEST(TileGrid, RegionalSectorValidKeys) {
  const TileGrid grid = makeGrid(36.0, 4, {-10.0, 30.0, 40.0, 60.0});
  // Level 0: rows 3 (18..54) and 4 (54..90), columns 4 (-36..0), 5 (0..36), 6 (36..72).
  for (std::int64_t r = 0; r < 5; ++r) {
    for (std::int64_t c = 0; c < 10; ++c) {
      const bool inside = r >= 3 && c >= 4 && c <= 6;
      EXPECT_EQ(grid.isValid({0, r, c}), inside) << r << "," << c;
    }
  }
  const auto all = grid.keysCovering({}, 0);
  ASSERT_TRUE(all.has_value());
  EXPECT_EQ(
      *all,
      (std::vector<TileKey>{{0, 3, 4}, {0, 3, 5}, {0, 3, 6}, {0, 4, 4}, {0, 4, 5}, {0, 4, 6}}));
  for (std::int32_t level = 0; level < 4; ++level) {
    const auto keys = grid.keysCovering({}, level);
    ASSERT_TRUE(keys.has_value());
    for (const TileKey& k : *keys)
      EXPECT_TRUE(grid.isValid(k));
    // Every valid key of the level is listed (count from the corners).
    const TileKey sw = *grid.keyAt(30.0, -10.0, level);
    const TileKey ne = *grid.keyAt(60.0, 40.0, level);
    EXPECT_EQ(static_cast<std::int64_t>(keys->size()),
              (ne.row - sw.row + 1) * (ne.col - sw.col + 1));
  }

  EXPECT_EQ(grid.keyAt(30.0, -10.0, 0), (TileKey{0, 3, 4}));
  EXPECT_EQ(grid.keyAt(60.0, 40.0, 0), (TileKey{0, 4, 6}));
  EXPECT_EQ(grid.keyAt(29.999, 0.0, 0), std::nullopt);
  EXPECT_EQ(grid.keyAt(60.001, 0.0, 0), std::nullopt);
  EXPECT_EQ(grid.keyAt(45.0, -10.001, 0), std::nullopt);
  EXPECT_EQ(grid.keyAt(45.0, 40.001, 0), std::nullopt);
  EXPECT_EQ(grid.keyAt(90.0, 180.0, 0), std::nullopt);

  // Neighbours stop at the sector.
  EXPECT_EQ(grid.neighbour({0, 3, 6}, Direction::East), std::nullopt);
  EXPECT_EQ(grid.neighbour({0, 3, 4}, Direction::West), std::nullopt);
  EXPECT_EQ(grid.neighbour({0, 3, 4}, Direction::South), std::nullopt);
  EXPECT_EQ(grid.neighbour({0, 3, 4}, Direction::North), (TileKey{0, 4, 4}));
  EXPECT_EQ(grid.neighbour({0, 3, 4}, Direction::East), (TileKey{0, 3, 5}));

  // Children outside the sector are still returned.
  const auto kids = grid.children({0, 3, 4});
  ASSERT_TRUE(kids.has_value());
  EXPECT_FALSE(grid.isValid((*kids)[0])); // 18..36 lat, -36..-18 lon
  EXPECT_TRUE(grid.isValid((*kids)[3]));  // 36..54 lat, -18..0 lon

  // Outside tiles give no bbox key; inside tiles do.
  EXPECT_EQ(grid.keyForBbox({0.0, -18.0, 36.0, 18.0}, 512, 512), std::nullopt);
  EXPECT_EQ(grid.keyForBbox({0.0, 54.0, 36.0, 90.0}, 512, 512), (TileKey{0, 4, 5}));
  EXPECT_EQ(grid.parent({1, 5, 10}), std::nullopt); // invalid child (lat -18..0)
}

TEST(TileGrid, RegionalSectorClosedNorthEastEdge) {
  // A sector whose north/east edges lie on level-0 tile edges (54 N, 36 E).
  const TileGrid grid = makeGrid(36.0, 4, {-36.0, -18.0, 36.0, 54.0});
  EXPECT_EQ(grid.keyAt(54.0, 36.0, 0), (TileKey{0, 3, 5}));
  EXPECT_EQ(grid.keyAt(54.0, 0.0, 0), (TileKey{0, 3, 5}));
  EXPECT_EQ(grid.keyAt(18.0, 36.0, 0), (TileKey{0, 3, 5}));
  EXPECT_EQ(grid.keyAt(-18.0, -36.0, 0), (TileKey{0, 2, 4}));
  for (std::int32_t level = 0; level < 4; ++level) {
    const auto ne = grid.keyAt(54.0, 36.0, level);
    ASSERT_TRUE(ne.has_value());
    EXPECT_TRUE(grid.isValid(*ne));
    EXPECT_EQ(grid.sectorOf(*ne).north, 54.0);
    EXPECT_EQ(grid.sectorOf(*ne).east, 36.0);
    const auto sw = grid.keyAt(-18.0, -36.0, level);
    ASSERT_TRUE(sw.has_value());
    EXPECT_EQ(grid.sectorOf(*sw).south, -18.0);
    EXPECT_EQ(grid.sectorOf(*sw).west, -36.0);
  }
  EXPECT_FALSE(grid.isValid({0, 4, 5}));
  EXPECT_FALSE(grid.isValid({0, 3, 6}));
  EXPECT_FALSE(grid.isValid({0, 1, 4}));
  EXPECT_EQ(grid.neighbour({0, 3, 5}, Direction::North), std::nullopt);
  EXPECT_EQ(grid.keysCovering({}, 0)->size(), 4u);
}

} // namespace
} // namespace tellus
