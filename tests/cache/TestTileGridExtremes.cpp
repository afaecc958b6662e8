// Extreme inputs of the tile grid: poles, antimeridian, -0.0, NaN/inf, level bounds, level 30 on
// 36/45/20-degree grids, huge coverage requests, tolerance at the deepest level.

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

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr std::int64_t k2p30 = std::int64_t{1} << 30;

TileGrid makeGrid(double delta, Sector sector = {}, std::int32_t numLevels = kMaxLevel + 1) {
  GridSpec spec;
  spec.sector = sector;
  spec.levelZeroDeltaDeg = delta;
  spec.tileWidth = 512;
  spec.tileHeight = 512;
  spec.numLevels = numLevels;
  auto grid = TileGrid::create(spec);
  EXPECT_TRUE(grid.has_value()) << (grid ? std::string() : grid.error());
  return *grid;
}

const std::vector<double> kDeltas{36.0, 45.0, 20.0};

std::string where(double delta, std::int32_t level) {
  return "delta " + std::to_string(delta) + " level " + std::to_string(level);
}

/** Half-open containment (closed at 90 / 180), the rule keyAt implements. */
bool contains(const Sector& s, double lat, double lon) {
  const bool inLat = s.south <= lat && (lat < s.north || (lat == 90.0 && s.north == 90.0));
  const bool inLon = s.west <= lon && (lon < s.east || (lon == 180.0 && s.east == 180.0));
  return inLat && inLon;
}

TEST(TileGridExtremes, PolesAndAntimeridianAtEveryLevel) {
  for (const double delta : kDeltas) {
    const TileGrid grid = makeGrid(delta);
    for (std::int32_t level = 0; level <= kMaxLevel; ++level) {
      SCOPED_TRACE(where(delta, level));
      const std::int64_t lastRow = grid.rowCount(level) - 1;
      const std::int64_t lastCol = grid.colCount(level) - 1;
      const TileKey ne{level, lastRow, lastCol};
      const TileKey sw{level, 0, 0};
      EXPECT_EQ(grid.keyAt(90.0, 180.0, level), ne);
      EXPECT_EQ(grid.keyAt(-90.0, -180.0, level), sw);
      EXPECT_EQ(grid.keyAt(90.0, -180.0, level), (TileKey{level, lastRow, 0}));
      EXPECT_EQ(grid.keyAt(-90.0, 180.0, level), (TileKey{level, 0, lastCol}));

      const Sector neS = grid.sectorOf(ne);
      EXPECT_EQ(neS.north, 90.0);
      EXPECT_EQ(neS.east, 180.0);
      EXPECT_LT(neS.south, 90.0);
      EXPECT_LT(neS.west, 180.0);
      const Sector swS = grid.sectorOf(sw);
      EXPECT_EQ(swS.south, -90.0);
      EXPECT_EQ(swS.west, -180.0);
      EXPECT_GT(swS.north, -90.0);
      EXPECT_GT(swS.east, -180.0);

      // The closed edge tile still starts where its neighbours end.
      EXPECT_EQ(grid.sectorOf({level, lastRow - 1, lastCol}).north, neS.south);
      EXPECT_EQ(grid.sectorOf({level, lastRow, lastCol - 1}).east, neS.west);
      EXPECT_EQ(grid.keyAt(neS.south, neS.west, level), ne);
      EXPECT_EQ(grid.keyAt(swS.north, swS.east, level), (TileKey{level, 1, 1}));

      EXPECT_EQ(grid.keysCovering(neS, level), std::vector<TileKey>{ne});
      EXPECT_EQ(grid.keysCovering(swS, level), std::vector<TileKey>{sw});
      EXPECT_EQ(grid.keyForBbox(neS, 512, 512), ne);
      EXPECT_EQ(grid.keyForBbox(swS, 512, 512), sw);

      EXPECT_EQ(grid.neighbour(ne, Direction::East), (TileKey{level, lastRow, 0}));
      EXPECT_EQ(grid.neighbour(ne, Direction::North), std::nullopt);
      EXPECT_EQ(grid.neighbour(sw, Direction::West), (TileKey{level, 0, lastCol}));
      EXPECT_EQ(grid.neighbour(sw, Direction::South), std::nullopt);
    }
  }
}

TEST(TileGridExtremes, NegativeZero) {
  for (const double delta : kDeltas) {
    const TileGrid grid = makeGrid(delta);
    for (std::int32_t level = 0; level <= kMaxLevel; ++level) {
      SCOPED_TRACE(where(delta, level));
      const auto zero = grid.keyAt(0.0, 0.0, level);
      ASSERT_TRUE(zero.has_value());
      EXPECT_EQ(grid.keyAt(-0.0, -0.0, level), zero);
      EXPECT_EQ(grid.keyAt(-0.0, 0.0, level), zero);
      EXPECT_EQ(grid.keyAt(0.0, -0.0, level), zero);
      EXPECT_EQ(zero->row, grid.rowCount(level) / 2);
      EXPECT_EQ(zero->col, grid.colCount(level) / 2);

      // Where 0 is a tile edge, -0.0 is that edge too: the box [-0, d] is exactly one tile and
      // [-d, -0] the one to the south-west of it.
      const bool zeroIsEdge = grid.rowCount(level) % 2 == 0;
      if (!zeroIsEdge) continue;
      const double d = grid.deltaDeg(level);
      EXPECT_EQ(grid.sectorOf(*zero).south, 0.0);
      EXPECT_EQ(grid.sectorOf(*zero).west, 0.0);
      EXPECT_EQ(grid.keysCovering({-0.0, -0.0, d, d}, level), std::vector<TileKey>{*zero});
      EXPECT_EQ(grid.keysCovering({-d, -d, -0.0, -0.0}, level),
                (std::vector<TileKey>{{level, zero->row - 1, zero->col - 1}}));
      EXPECT_EQ(grid.keyForBbox({-0.0, -0.0, d, d}, 512, 512), zero);
      EXPECT_EQ(grid.keyForBbox({-d, -d, -0.0, -0.0}, 512, 512),
                (TileKey{level, zero->row - 1, zero->col - 1}));
    }
  }

  // A sector whose north and east edges are 0: -0.0 is on the closed edge.
  const TileGrid regional = makeGrid(45.0, {-45.0, -45.0, 0.0, 0.0});
  for (std::int32_t level = 0; level <= kMaxLevel; ++level) {
    SCOPED_TRACE(level);
    const auto k = regional.keyAt(-0.0, -0.0, level);
    ASSERT_TRUE(k.has_value());
    EXPECT_EQ(k, regional.keyAt(0.0, 0.0, level));
    EXPECT_EQ(k->row, regional.rowCount(level) / 2 - 1);
    EXPECT_EQ(k->col, regional.colCount(level) / 2 - 1);
    EXPECT_TRUE(regional.isValid(*k));
  }
}

TEST(TileGridExtremes, NonFiniteInputs) {
  const TileGrid grid = makeGrid(36.0);
  const TileKey tile{0, 2, 5};
  const Sector tileSector = grid.sectorOf(tile);
  ASSERT_EQ(grid.keyForBbox(tileSector, 512, 512), tile);
  for (const double bad : {kNaN, kInf, -kInf, -kNaN}) {
    SCOPED_TRACE(bad);
    for (const std::int32_t level : {0, 15, 30}) {
      EXPECT_EQ(grid.keyAt(bad, 0.0, level), std::nullopt);
      EXPECT_EQ(grid.keyAt(0.0, bad, level), std::nullopt);
      EXPECT_EQ(grid.keyAt(bad, bad, level), std::nullopt);
    }
    for (int field = 0; field < 4; ++field) {
      SCOPED_TRACE(field);
      Sector box{-10.0, -10.0, 10.0, 10.0};
      Sector bbox = tileSector;
      double* const boxFields[] = {&box.west, &box.south, &box.east, &box.north};
      double* const bboxFields[] = {&bbox.west, &bbox.south, &bbox.east, &bbox.north};
      *boxFields[field] = bad;
      *bboxFields[field] = bad;
      const auto keys = grid.keysCovering(box, 0);
      ASSERT_TRUE(keys.has_value());
      EXPECT_TRUE(keys->empty());
      EXPECT_EQ(grid.keyForBbox(bbox, 512, 512), std::nullopt);
    }
    EXPECT_EQ(grid.keysCovering({bad, bad, bad, bad}, 3), std::vector<TileKey>{});
    EXPECT_EQ(grid.keyForBbox(tileSector, 512, 512, bad), std::nullopt);
  }
}

TEST(TileGridExtremes, LevelOutOfRange) {
  for (const std::int32_t numLevels : {1, 5, kMaxLevel + 1}) {
    const TileGrid grid = makeGrid(36.0, {}, numLevels);
    SCOPED_TRACE(numLevels);
    for (const std::int32_t level : {-1,
                                     numLevels,
                                     std::numeric_limits<std::int32_t>::min(),
                                     std::numeric_limits<std::int32_t>::max()}) {
      SCOPED_TRACE(level);
      EXPECT_EQ(grid.keyAt(0.0, 0.0, level), std::nullopt);
      EXPECT_EQ(grid.keysCovering({}, level), std::nullopt);
      EXPECT_FALSE(grid.isValid({level, 0, 0}));
      EXPECT_EQ(grid.parent({level, 0, 0}), std::nullopt);
      EXPECT_EQ(grid.children({level, 0, 0}), std::nullopt);
      EXPECT_EQ(grid.neighbour({level, 0, 0}, Direction::East), std::nullopt);
      EXPECT_EQ(grid.rowCount(level), 0);
      EXPECT_EQ(grid.colCount(level), 0);
    }
    const std::int32_t deepest = numLevels - 1;
    EXPECT_TRUE(grid.keyAt(0.0, 0.0, deepest).has_value());
    EXPECT_EQ(grid.children({deepest, 0, 0}), std::nullopt);
    // A bbox of a level just below the deepest does not match.
    const double d = grid.deltaDeg(deepest) / 2.0;
    EXPECT_EQ(grid.keyForBbox({-180.0, -90.0, -180.0 + d, -90.0 + d}, 512, 512), std::nullopt);
  }
  // Extreme indices.
  const TileGrid grid = makeGrid(20.0);
  const std::int64_t big = std::numeric_limits<std::int64_t>::max();
  EXPECT_FALSE(grid.isValid({30, big, 0}));
  EXPECT_FALSE(grid.isValid({30, 0, big}));
  EXPECT_FALSE(grid.isValid({30, -big, 0}));
  EXPECT_FALSE(grid.isValid({30, 9 * k2p30, 0}));
  EXPECT_FALSE(grid.isValid({30, 0, 18 * k2p30}));
  EXPECT_TRUE(grid.isValid({30, 9 * k2p30 - 1, 18 * k2p30 - 1}));
  EXPECT_EQ(grid.neighbour({30, big, 0}, Direction::North), std::nullopt);
}

TEST(TileGridExtremes, Level30CountsAreExact) {
  const TileGrid g36 = makeGrid(36.0);
  const TileGrid g45 = makeGrid(45.0);
  const TileGrid g20 = makeGrid(20.0);
  EXPECT_EQ(g36.rowCount(30), 5 * k2p30);
  EXPECT_EQ(g36.colCount(30), 10 * k2p30);
  EXPECT_EQ(g45.rowCount(30), 4 * k2p30);
  EXPECT_EQ(g45.colCount(30), 8 * k2p30);
  EXPECT_EQ(g20.rowCount(30), 9 * k2p30);
  EXPECT_EQ(g20.colCount(30), 18 * k2p30);
  EXPECT_EQ(g20.rowCount(30), std::int64_t{9663676416});
  EXPECT_GT(g20.colCount(30), std::int64_t{std::numeric_limits<std::uint32_t>::max()});
  EXPECT_EQ(g36.deltaDeg(30), 36.0 / 1073741824.0);
  EXPECT_EQ(g45.deltaDeg(30), 45.0 / 1073741824.0);
  EXPECT_EQ(g20.deltaDeg(30), 20.0 / 1073741824.0);
  for (const double delta : kDeltas) {
    const TileGrid grid = makeGrid(delta);
    for (std::int32_t level = 1; level <= kMaxLevel; ++level) {
      EXPECT_EQ(grid.deltaDeg(level) * 2.0, grid.deltaDeg(level - 1));
      EXPECT_EQ(grid.rowCount(level), grid.rowCount(level - 1) * 2);
    }
  }
}

TEST(TileGridExtremes, DeepestTileCornersAreDistinctAndInside) {
  for (const double delta : kDeltas) {
    const TileGrid grid = makeGrid(delta);
    SCOPED_TRACE(delta);
    const std::int32_t level = kMaxLevel;
    const std::int64_t lastRow = grid.rowCount(level) - 1;
    const std::int64_t lastCol = grid.colCount(level) - 1;
    const double d = grid.deltaDeg(level);
    for (const TileKey k : {TileKey{level, 0, 0},
                            TileKey{level, 0, lastCol},
                            TileKey{level, lastRow, 0},
                            TileKey{level, lastRow, lastCol},
                            TileKey{level, lastRow / 2, lastCol / 2},
                            TileKey{level, lastRow / 3, lastCol / 7}}) {
      SCOPED_TRACE(testing::PrintToString(k.row) + "," + testing::PrintToString(k.col));
      ASSERT_TRUE(grid.isValid(k));
      const Sector s = grid.sectorOf(k);
      EXPECT_LT(s.south, s.north);
      EXPECT_LT(s.west, s.east);
      EXPECT_GE(s.south, -90.0);
      EXPECT_LE(s.north, 90.0);
      EXPECT_GE(s.west, -180.0);
      EXPECT_LE(s.east, 180.0);
      // 36/45/20-degree edges are exact at level 30: every tile spans exactly delta.
      EXPECT_EQ(s.north - s.south, d);
      EXPECT_EQ(s.east - s.west, d);
      EXPECT_EQ(grid.keyAt(s.south, s.west, level), k);
      EXPECT_EQ(grid.keyAt(0.5 * (s.south + s.north), 0.5 * (s.west + s.east), level), k);
      EXPECT_EQ(grid.keyAt(std::nextafter(s.north, -90.0), std::nextafter(s.east, -180.0), level),
                k);
      // The ancestor chain ends at the level-0 tile holding the centre.
      TileKey a = k;
      for (std::int32_t l = level; l > 0; --l)
        a = *grid.parent(a);
      EXPECT_EQ(a, grid.keyAt(0.5 * (s.south + s.north), 0.5 * (s.west + s.east), 0));
    }
  }
}

TEST(TileGridExtremes, HugeKeysCoveringReturnsNullopt) {
  for (const double delta : kDeltas) {
    const TileGrid grid = makeGrid(delta);
    SCOPED_TRACE(delta);
    EXPECT_EQ(grid.keysCovering({}, 30), std::nullopt);
    EXPECT_EQ(grid.keysCovering({}, 30, std::numeric_limits<std::size_t>::max()), std::nullopt);
    EXPECT_EQ(grid.keysCovering(
                  {170.0, -90.0, -170.0, 90.0}, 30, std::numeric_limits<std::size_t>::max()),
              std::nullopt);
    EXPECT_EQ(grid.keysCovering({-180.0, 0.0, 180.0, 1e-6}, 30), std::nullopt);
    EXPECT_EQ(grid.keysCovering({}, 12), std::nullopt);

    // 1024 x 1024 tiles at level 30: exactly the default cap, then one column more.
    const double d = grid.deltaDeg(30);
    const Sector box{0.0, 0.0, 1024.0 * d, 1024.0 * d};
    const auto keys = grid.keysCovering(box, 30);
    ASSERT_TRUE(keys.has_value());
    EXPECT_EQ(keys->size(), std::size_t{1} << 20);
    EXPECT_EQ(keys->front(), grid.keyAt(0.0, 0.0, 30));
    EXPECT_EQ(keys->back(),
              grid.keyAt(std::nextafter(box.north, 0.0), std::nextafter(box.east, 0.0), 30));
    EXPECT_EQ(grid.keysCovering({0.0, 0.0, 1024.5 * d, 1024.0 * d}, 30), std::nullopt);
    EXPECT_EQ(grid.keysCovering(box, 30, (std::size_t{1} << 20) - 1), std::nullopt);
  }
}

TEST(TileGridExtremes, NearlyPolesAndAntimeridian) {
  const double lats[] = {89.9999999, -89.9999999, 0.0, 90.0, -90.0};
  const double lons[] = {-179.9999999, 179.9999999, 180.0, -180.0};
  for (const double delta : kDeltas) {
    const TileGrid grid = makeGrid(delta);
    for (std::int32_t level = 0; level <= kMaxLevel; ++level) {
      SCOPED_TRACE(where(delta, level));
      for (const double lat : lats) {
        for (const double lon : lons) {
          const auto k = grid.keyAt(lat, lon, level);
          ASSERT_TRUE(k.has_value()) << lat << "," << lon;
          EXPECT_TRUE(contains(grid.sectorOf(*k), lat, lon)) << lat << "," << lon;
        }
      }
      const double d = grid.deltaDeg(level);
      const std::int64_t lastRow = grid.rowCount(level) - 1;
      const std::int64_t lastCol = grid.colCount(level) - 1;
      if (d > 1e-6) { // 1e-7 from the edge is still the edge tile
        EXPECT_EQ(grid.keyAt(89.9999999, -179.9999999, level), (TileKey{level, lastRow, 0}));
        EXPECT_EQ(grid.keyAt(89.9999999, 179.9999999, level), (TileKey{level, lastRow, lastCol}));
        EXPECT_EQ(grid.keyAt(-89.9999999, 179.9999999, level), (TileKey{level, 0, lastCol}));
      }
    }
  }
  const TileGrid g36 = makeGrid(36.0);
  // 1e-7 is about 2.98 level-30 tiles of a 36-degree grid.
  EXPECT_EQ(g36.keyAt(89.9999999, 179.9999999, 30), (TileKey{30, 5 * k2p30 - 3, 10 * k2p30 - 3}));
  EXPECT_EQ(g36.keyAt(-89.9999999, -179.9999999, 30), (TileKey{30, 2, 2}));
}

TEST(TileGridExtremes, KeyForBboxLevel30Tolerance) {
  for (const double delta : kDeltas) {
    const TileGrid grid = makeGrid(delta);
    SCOPED_TRACE(delta);
    const std::int32_t level = 30;
    const double d = grid.deltaDeg(level);
    // The tile whose south-west corner is (0, 0): its coordinates are tiny, so a perturbation of
    // 1e-9 of the span is representable.
    const TileKey k{level, grid.rowCount(level) / 2, grid.colCount(level) / 2};
    const Sector s = grid.sectorOf(k);
    ASSERT_EQ(s, (Sector{0.0, 0.0, d, d}));
    ASSERT_EQ(grid.keyForBbox(s, 512, 512, 1e-9), k);
    for (int field = 0; field < 4; ++field) {
      for (const double sign : {1.0, -1.0}) {
        SCOPED_TRACE(testing::Message() << "field " << field << " sign " << sign);
        Sector small = s;
        Sector large = s;
        double* const smallFields[] = {&small.west, &small.south, &small.east, &small.north};
        double* const largeFields[] = {&large.west, &large.south, &large.east, &large.north};
        *smallFields[field] += sign * 0.5e-9 * d;
        *largeFields[field] += sign * 2e-9 * d;
        EXPECT_EQ(grid.keyForBbox(small, 512, 512, 1e-9), k);
        EXPECT_EQ(grid.keyForBbox(large, 512, 512, 1e-9), std::nullopt);
      }
    }
    // A translation by 0.5e-9 of the span keeps the size: accepted; by 2e-9: rejected.
    const double half = 0.5e-9 * d;
    const double two = 2e-9 * d;
    EXPECT_EQ(grid.keyForBbox({half, half, d + half, d + half}, 512, 512, 1e-9), k);
    EXPECT_EQ(grid.keyForBbox({two, 0.0, d + two, d}, 512, 512, 1e-9), std::nullopt);
    EXPECT_EQ(grid.keyForBbox({0.0, -two, d, d - two}, 512, 512, 1e-9), std::nullopt);

    // Exact deep sectors far from the origin match too (their edges are the same doubles).
    for (const TileKey far : {TileKey{level, grid.rowCount(level) - 1, grid.colCount(level) - 1},
                              TileKey{level, 12345678901 % grid.rowCount(level), 987654321}}) {
      EXPECT_EQ(grid.keyForBbox(grid.sectorOf(far), 512, 512), far);
    }
  }
}

TEST(TileGridExtremes, AntimeridianCrossingBoxesAtSeveralLevels) {
  for (const double delta : kDeltas) {
    const TileGrid grid = makeGrid(delta);
    for (const std::int32_t level : {0, 1, 2, 7, 15, 23, 30}) {
      SCOPED_TRACE(where(delta, level));
      const std::int64_t lastCol = grid.colCount(level) - 1;
      const std::int64_t r = grid.rowCount(level) / 2;
      const Sector west = grid.sectorOf({level, r, lastCol});
      const Sector east = grid.sectorOf({level, r, 0});
      ASSERT_EQ(west.east, 180.0);
      ASSERT_EQ(east.west, -180.0);

      // Edge-aligned: exactly the last and the first column.
      const Sector aligned{west.west, west.south, east.east, west.north};
      EXPECT_EQ(grid.keysCovering(aligned, level),
                (std::vector<TileKey>{{level, r, lastCol}, {level, r, 0}}));
      EXPECT_EQ(grid.keyForBbox(aligned, 512, 512), std::nullopt);

      // Half a tile inside the neighbours: two rows of four columns, row-major from the SW.
      const double d = grid.deltaDeg(level);
      const Sector wide{
          west.west - 0.5 * d, west.south + 0.5 * d, east.east + 0.5 * d, west.north + 0.5 * d};
      if (r + 1 < grid.rowCount(level)) {
        EXPECT_EQ(grid.keysCovering(wide, level),
                  (std::vector<TileKey>{{level, r, lastCol - 1},
                                        {level, r, lastCol},
                                        {level, r, 0},
                                        {level, r, 1},
                                        {level, r + 1, lastCol - 1},
                                        {level, r + 1, lastCol},
                                        {level, r + 1, 0},
                                        {level, r + 1, 1}}));
      }
      // Touching the antimeridian from both sides only.
      EXPECT_EQ(grid.keysCovering({180.0, west.south, -180.0, west.north}, level),
                std::vector<TileKey>{});
    }
  }
}

TEST(TileGridExtremes, UnalignedBoxes) {
  for (const double delta : kDeltas) {
    const TileGrid grid = makeGrid(delta);
    for (const std::int32_t level : {0, 1, 5, 12, 20, 30}) {
      SCOPED_TRACE(where(delta, level));
      const double d = grid.deltaDeg(level);
      const TileKey k = *grid.keyAt(10.0, 20.0, level);
      const Sector s = grid.sectorOf(k);
      const TileKey northEast{level, k.row + 1, k.col + 1};

      // Shifted by half a tile: not a tile; covers 2 x 2 tiles.
      const Sector half{s.west + 0.5 * d, s.south + 0.5 * d, s.east + 0.5 * d, s.north + 0.5 * d};
      EXPECT_EQ(grid.keyForBbox(half, 512, 512), std::nullopt);
      EXPECT_EQ(grid.keysCovering(half, level),
                (std::vector<TileKey>{
                    k, {level, k.row, k.col + 1}, {level, k.row + 1, k.col}, northEast}));

      // Shifted east by 1e-6 of the span (only representable where the span is not tiny compared
      // with the coordinates): not a tile; covers the tile and its east neighbour.
      const double shift = 1e-6 * d;
      const Sector nudged{s.west + shift, s.south, s.east + shift, s.north};
      if (nudged.west != s.west && nudged.east != s.east) {
        EXPECT_EQ(grid.keyForBbox(nudged, 512, 512), std::nullopt);
        EXPECT_EQ(grid.keysCovering(nudged, level),
                  (std::vector<TileKey>{k, {level, k.row, k.col + 1}}));
      }
      // Shrunk by 1e-6 of the span on every side: not a tile; covers just the tile.
      const Sector shrunk{s.west + shift, s.south + shift, s.east - shift, s.north - shift};
      if (shrunk.west != s.west) {
        EXPECT_EQ(grid.keyForBbox(shrunk, 512, 512), std::nullopt);
      }
      EXPECT_EQ(grid.keysCovering(shrunk, level), std::vector<TileKey>{k});
    }
    // Level 0: the 1e-6 shift is always representable.
    const TileGrid g = makeGrid(delta);
    const Sector s0 = g.sectorOf({0, 1, 1});
    const double shift0 = 1e-6 * g.deltaDeg(0);
    EXPECT_EQ(g.keyForBbox({s0.west + shift0, s0.south, s0.east + shift0, s0.north}, 512, 512),
              std::nullopt);
    EXPECT_EQ(g.keyForBbox({s0.west, s0.south - shift0, s0.east, s0.north - shift0}, 512, 512),
              std::nullopt);
  }
}

} // namespace
} // namespace tellus
