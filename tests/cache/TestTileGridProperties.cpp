// Seeded random property tests of the tile grid over random keys at levels 0..30 on 36/45/20-degree
// grids. The seed is printed; set TELLUS_TEST_SEED=<n> to reproduce or vary a run. Every failure
// message carries the seed, the iteration and the key.

#include <tellus/cache/TileGrid.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <iostream>
#include <optional>
#include <ostream>
#include <random>
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

constexpr std::uint64_t kDefaultSeed = 20240611;
/** Iterations per property: 9 properties x 2250 is about 20k iterations, well under 1 s. */
constexpr int kIterations = 2250;

std::uint64_t testSeed() {
  static const std::uint64_t seed = [] {
    std::uint64_t s = kDefaultSeed;
    if (const char* env = std::getenv("TELLUS_TEST_SEED"); env != nullptr && *env != '\0') {
      char* end = nullptr;
      const unsigned long long v = std::strtoull(env, &end, 0);
      if (end != nullptr && *end == '\0')
        s = v;
      else
        std::cout << "[   SEED   ] ignoring malformed TELLUS_TEST_SEED='" << env << "'\n";
    }
    return s;
  }();
  return seed;
}

/** Announces the seed and seeds a generator private to one property (salted by its name). */
std::mt19937_64 propertyRng(const std::string& property) {
  const std::uint64_t seed = testSeed();
  std::cout << "[   SEED   ] " << property << ": TELLUS_TEST_SEED=" << seed << "\n";
  std::uint64_t salt = 1469598103934665603ULL; // FNV-1a of the property name
  for (const char c : property)
    salt = (salt ^ static_cast<unsigned char>(c)) * 1099511628211ULL;
  std::seed_seq seq{static_cast<std::uint32_t>(seed),
                    static_cast<std::uint32_t>(seed >> 32),
                    static_cast<std::uint32_t>(salt),
                    static_cast<std::uint32_t>(salt >> 32)};
  return std::mt19937_64(seq);
}

std::string seedTrace() {
  return "TELLUS_TEST_SEED=" + std::to_string(testSeed());
}

const std::array<TileGrid, 3>& grids() {
  static const std::array<TileGrid, 3> all = [] {
    const auto make = [](double delta) {
      GridSpec spec;
      spec.levelZeroDeltaDeg = delta;
      spec.tileWidth = 512;
      spec.tileHeight = 512;
      spec.numLevels = kMaxLevel + 1;
      return *TileGrid::create(spec);
    };
    return std::array<TileGrid, 3>{make(36.0), make(45.0), make(20.0)};
  }();
  return all;
}

/** A random index in [0, count), biased to the first and last index (the closed edges). */
std::int64_t randomIndex(std::mt19937_64& rng, std::int64_t count) {
  const int pick = std::uniform_int_distribution<int>(0, 7)(rng);
  if (pick == 0) return 0;
  if (pick == 1) return count - 1;
  return std::uniform_int_distribution<std::int64_t>(0, count - 1)(rng);
}

struct Sample {
  const TileGrid* grid;
  TileKey key;
};

Sample randomSample(std::mt19937_64& rng, std::int32_t maxLevel = kMaxLevel) {
  const TileGrid& grid = grids()[std::uniform_int_distribution<std::size_t>(0, 2)(rng)];
  const std::int32_t level = std::uniform_int_distribution<std::int32_t>(0, maxLevel)(rng);
  return {&grid,
          TileKey{level,
                  randomIndex(rng, grid.rowCount(level)),
                  randomIndex(rng, grid.colCount(level))}};
}

std::string describe(const Sample& s, int iteration) {
  return "iteration " + std::to_string(iteration) + " delta " +
         std::to_string(s.grid->spec().levelZeroDeltaDeg) + " key {" + std::to_string(s.key.level) +
         ", " + std::to_string(s.key.row) + ", " + std::to_string(s.key.col) + "}";
}

TEST(TileGridProperties, KeyAtCentreOfSectorIsTheKey) {
  auto rng = propertyRng("KeyAtCentreOfSectorIsTheKey");
  SCOPED_TRACE(seedTrace());
  for (int i = 0; i < kIterations; ++i) {
    const Sample s = randomSample(rng);
    SCOPED_TRACE(describe(s, i));
    const TileGrid& g = *s.grid;
    ASSERT_TRUE(g.isValid(s.key));
    const Sector sec = g.sectorOf(s.key);
    ASSERT_LT(sec.south, sec.north);
    ASSERT_LT(sec.west, sec.east);
    const double lat = 0.5 * (sec.south + sec.north);
    const double lon = 0.5 * (sec.west + sec.east);
    ASSERT_EQ(g.keyAt(lat, lon, s.key.level), s.key);
    // The south-west corner belongs to the tile (half-open tiles).
    ASSERT_EQ(g.keyAt(sec.south, sec.west, s.key.level), s.key);
  }
}

TEST(TileGridProperties, ParentOfEachChildIsTheKey) {
  auto rng = propertyRng("ParentOfEachChildIsTheKey");
  SCOPED_TRACE(seedTrace());
  for (int i = 0; i < kIterations; ++i) {
    const Sample s = randomSample(rng, kMaxLevel - 1);
    SCOPED_TRACE(describe(s, i));
    const auto kids = s.grid->children(s.key);
    ASSERT_TRUE(kids.has_value());
    for (const TileKey& c : *kids) {
      ASSERT_TRUE(s.grid->isValid(c));
      ASSERT_EQ(s.grid->parent(c), s.key);
    }
    ASSERT_EQ((*kids)[0], (TileKey{s.key.level + 1, 2 * s.key.row, 2 * s.key.col}));
    ASSERT_EQ((*kids)[3], (TileKey{s.key.level + 1, 2 * s.key.row + 1, 2 * s.key.col + 1}));
  }
}

TEST(TileGridProperties, ChildrenExactlyTileTheParent) {
  auto rng = propertyRng("ChildrenExactlyTileTheParent");
  SCOPED_TRACE(seedTrace());
  for (int i = 0; i < kIterations; ++i) {
    const Sample s = randomSample(rng, kMaxLevel - 1);
    SCOPED_TRACE(describe(s, i));
    const TileGrid& g = *s.grid;
    const auto kids = g.children(s.key);
    ASSERT_TRUE(kids.has_value());
    const Sector p = g.sectorOf(s.key);
    const Sector sw = g.sectorOf((*kids)[0]);
    const Sector se = g.sectorOf((*kids)[1]);
    const Sector nw = g.sectorOf((*kids)[2]);
    const Sector ne = g.sectorOf((*kids)[3]);
    // Outer edges: bit-identical to the parent's.
    ASSERT_EQ(sw.south, p.south);
    ASSERT_EQ(se.south, p.south);
    ASSERT_EQ(nw.north, p.north);
    ASSERT_EQ(ne.north, p.north);
    ASSERT_EQ(sw.west, p.west);
    ASSERT_EQ(nw.west, p.west);
    ASSERT_EQ(se.east, p.east);
    ASSERT_EQ(ne.east, p.east);
    // Inner edges: shared bit-identically between siblings, strictly inside the parent.
    ASSERT_EQ(sw.north, nw.south);
    ASSERT_EQ(se.north, ne.south);
    ASSERT_EQ(sw.north, se.north);
    ASSERT_EQ(sw.east, se.west);
    ASSERT_EQ(nw.east, ne.west);
    ASSERT_EQ(sw.east, nw.east);
    ASSERT_LT(p.south, sw.north);
    ASSERT_LT(sw.north, p.north);
    ASSERT_LT(p.west, sw.east);
    ASSERT_LT(sw.east, p.east);
  }
}

TEST(TileGridProperties, NeighboursShareBitIdenticalEdges) {
  auto rng = propertyRng("NeighboursShareBitIdenticalEdges");
  SCOPED_TRACE(seedTrace());
  for (int i = 0; i < kIterations; ++i) {
    const Sample s = randomSample(rng);
    SCOPED_TRACE(describe(s, i));
    const TileGrid& g = *s.grid;
    const Sector sec = g.sectorOf(s.key);
    const std::int64_t lastRow = g.rowCount(s.key.level) - 1;
    const std::int64_t lastCol = g.colCount(s.key.level) - 1;

    const auto north = g.neighbour(s.key, Direction::North);
    ASSERT_EQ(north.has_value(), s.key.row < lastRow);
    if (north) {
      ASSERT_EQ(g.sectorOf(*north).south, sec.north);
    }
    const auto south = g.neighbour(s.key, Direction::South);
    ASSERT_EQ(south.has_value(), s.key.row > 0);
    if (south) {
      ASSERT_EQ(g.sectorOf(*south).north, sec.south);
    }

    const auto east = g.neighbour(s.key, Direction::East);
    const auto west = g.neighbour(s.key, Direction::West);
    ASSERT_TRUE(east.has_value());
    ASSERT_TRUE(west.has_value());
    if (s.key.col == lastCol) {
      ASSERT_EQ(sec.east, 180.0);
      ASSERT_EQ(g.sectorOf(*east).west, -180.0);
      ASSERT_EQ(east->col, 0);
    } else {
      ASSERT_EQ(g.sectorOf(*east).west, sec.east);
    }
    if (s.key.col == 0) {
      ASSERT_EQ(sec.west, -180.0);
      ASSERT_EQ(g.sectorOf(*west).east, 180.0);
      ASSERT_EQ(west->col, lastCol);
    } else {
      ASSERT_EQ(g.sectorOf(*west).east, sec.west);
    }
  }
}

TEST(TileGridProperties, NeighbourRoundTrips) {
  auto rng = propertyRng("NeighbourRoundTrips");
  SCOPED_TRACE(seedTrace());
  for (int i = 0; i < kIterations; ++i) {
    const Sample s = randomSample(rng);
    SCOPED_TRACE(describe(s, i));
    const TileGrid& g = *s.grid;
    const auto east = g.neighbour(s.key, Direction::East);
    ASSERT_TRUE(east.has_value());
    ASSERT_NE(*east, s.key);
    ASSERT_EQ(g.neighbour(*east, Direction::West), s.key);
    const auto west = g.neighbour(s.key, Direction::West);
    ASSERT_TRUE(west.has_value());
    ASSERT_EQ(g.neighbour(*west, Direction::East), s.key);
    if (const auto north = g.neighbour(s.key, Direction::North)) {
      ASSERT_EQ(g.neighbour(*north, Direction::South), s.key);
    }
    if (const auto south = g.neighbour(s.key, Direction::South)) {
      ASSERT_EQ(g.neighbour(*south, Direction::North), s.key);
    }
  }
}

TEST(TileGridProperties, KeyForBboxOfSectorIsTheKey) {
  auto rng = propertyRng("KeyForBboxOfSectorIsTheKey");
  SCOPED_TRACE(seedTrace());
  for (int i = 0; i < kIterations; ++i) {
    const Sample s = randomSample(rng);
    SCOPED_TRACE(describe(s, i));
    const TileGrid& g = *s.grid;
    const Sector sec = g.sectorOf(s.key);
    ASSERT_EQ(g.keyForBbox(sec, g.spec().tileWidth, g.spec().tileHeight), s.key);
    ASSERT_EQ(g.keyForBbox(sec, g.spec().tileWidth + 1, g.spec().tileHeight), std::nullopt);
  }
}

TEST(TileGridProperties, KeysCoveringSectorIsTheKey) {
  auto rng = propertyRng("KeysCoveringSectorIsTheKey");
  SCOPED_TRACE(seedTrace());
  for (int i = 0; i < kIterations; ++i) {
    const Sample s = randomSample(rng);
    SCOPED_TRACE(describe(s, i));
    const TileGrid& g = *s.grid;
    const Sector sec = g.sectorOf(s.key);
    ASSERT_EQ(g.keysCovering(sec, s.key.level), std::vector<TileKey>{s.key});
    // One level up the same box is exactly the four children.
    if (s.key.level < kMaxLevel) {
      const auto kids = g.children(s.key);
      ASSERT_TRUE(kids.has_value());
      ASSERT_EQ(g.keysCovering(sec, s.key.level + 1),
                (std::vector<TileKey>{kids->begin(), kids->end()}));
    }
  }
}

TEST(TileGridProperties, RandomPointsLieInTheirTile) {
  auto rng = propertyRng("RandomPointsLieInTheirTile");
  SCOPED_TRACE(seedTrace());
  std::uniform_real_distribution<double> latDist(-90.0, 90.0);
  std::uniform_real_distribution<double> lonDist(-180.0, 180.0);
  for (int i = 0; i < kIterations; ++i) {
    const TileGrid& g = grids()[std::uniform_int_distribution<std::size_t>(0, 2)(rng)];
    const std::int32_t level = std::uniform_int_distribution<std::int32_t>(0, kMaxLevel)(rng);
    const double lat = latDist(rng);
    const double lon = lonDist(rng);
    SCOPED_TRACE(testing::Message() << "iteration " << i << " delta " << g.spec().levelZeroDeltaDeg
                                    << " level " << level << " lat " << lat << " lon " << lon);
    const auto k = g.keyAt(lat, lon, level);
    ASSERT_TRUE(k.has_value());
    const Sector sec = g.sectorOf(*k);
    ASSERT_LE(sec.south, lat);
    ASSERT_LT(lat, sec.north);
    ASSERT_LE(sec.west, lon);
    ASSERT_LT(lon, sec.east);
    // A one-ulp box at the point is covered by that tile alone.
    const auto keys =
        g.keysCovering({lon, lat, std::nextafter(lon, 180.0), std::nextafter(lat, 90.0)}, level);
    ASSERT_EQ(keys, std::vector<TileKey>{*k});
  }
}

/** Grids whose deltas are not exact binary fractions (edges are rounded): the invariants still
 * hold because every edge comes from the same integer formula. */
TEST(TileGridProperties, OddDeltaGridsKeepTheInvariants) {
  auto rng = propertyRng("OddDeltaGridsKeepTheInvariants");
  SCOPED_TRACE(seedTrace());
  const auto make = [](double delta, std::int32_t numLevels) {
    GridSpec spec;
    spec.levelZeroDeltaDeg = delta;
    spec.numLevels = numLevels;
    auto grid = TileGrid::create(spec);
    EXPECT_TRUE(grid.has_value()) << delta;
    return *grid;
  };
  const std::array<TileGrid, 4> odd{
      make(180.0 / 7.0, 31), make(0.3, 31), make(1.8, 31), make(180.0 / 11.0, 31)};
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int i = 0; i < kIterations; ++i) {
    const TileGrid& g = odd[std::uniform_int_distribution<std::size_t>(0, odd.size() - 1)(rng)];
    const std::int32_t level = std::uniform_int_distribution<std::int32_t>(0, kMaxLevel - 1)(rng);
    const Sample s{
        &g,
        TileKey{level, randomIndex(rng, g.rowCount(level)), randomIndex(rng, g.colCount(level))}};
    SCOPED_TRACE(describe(s, i));
    const Sector sec = g.sectorOf(s.key);
    ASSERT_LT(sec.south, sec.north);
    ASSERT_LT(sec.west, sec.east);
    ASSERT_EQ(g.keyAt(sec.south, sec.west, level), s.key);
    ASSERT_EQ(g.keyAt(0.5 * (sec.south + sec.north), 0.5 * (sec.west + sec.east), level), s.key);
    ASSERT_EQ(g.keyForBbox(sec, 512, 512), s.key);
    ASSERT_EQ(g.keysCovering(sec, level), std::vector<TileKey>{s.key});
    if (const auto north = g.neighbour(s.key, Direction::North)) {
      ASSERT_EQ(g.sectorOf(*north).south, sec.north);
      ASSERT_EQ(g.keyAt(sec.north, sec.west, level), north);
    } else {
      ASSERT_EQ(sec.north, 90.0);
    }
    const auto kids = g.children(s.key);
    ASSERT_TRUE(kids.has_value());
    ASSERT_EQ(g.sectorOf((*kids)[0]).south, sec.south);
    ASSERT_EQ(g.sectorOf((*kids)[3]).north, sec.north);
    ASSERT_EQ(g.sectorOf((*kids)[0]).west, sec.west);
    ASSERT_EQ(g.sectorOf((*kids)[3]).east, sec.east);
    // A random point inside the tile maps to it.
    const double lat =
        std::min(sec.south + unit(rng) * (sec.north - sec.south), std::nextafter(sec.north, -90.0));
    const double lon =
        std::min(sec.west + unit(rng) * (sec.east - sec.west), std::nextafter(sec.east, -180.0));
    ASSERT_EQ(g.keyAt(lat, lon, level), s.key) << lat << "," << lon;
  }
}

} // namespace
} // namespace tellus
