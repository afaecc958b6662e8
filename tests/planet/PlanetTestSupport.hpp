#pragma once
// Helpers shared by the planet tests: a global grid (World Wind's 36-degree level zero, 25 levels)
// and the sectors a camera looks at.

#include <tellus/cache/TileGrid.hpp>
#include <tellus/planet/Camera.hpp>
#include <tellus/planet/Patch.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace tellus::planet::test {

inline TileGrid globalGrid() {
  GridSpec spec;
  spec.levelZeroDeltaDeg = 36.0;
  spec.numLevels = 25;
  auto g = TileGrid::create(spec);
  EXPECT_TRUE(g.has_value());
  return *g;
}

inline std::vector<Sector> levelZeroSectors(const TileGrid& grid) {
  std::vector<Sector> out;
  for (std::int64_t r = 0; r < grid.rowCount(0); ++r)
    for (std::int64_t c = 0; c < grid.colCount(0); ++c)
      out.push_back(grid.sectorOf({0, r, c}));
  return out;
}

/** The tile under (lat, lon) at a level and its eight neighbours (those that exist). */
inline std::vector<Sector> sectorsAround(const TileGrid& grid, double lat, double lon, int level) {
  std::vector<Sector> out;
  const auto key = grid.keyAt(lat, lon, level);
  if (!key) return out;
  for (std::int64_t dr = -1; dr <= 1; ++dr)
    for (std::int64_t dc = -1; dc <= 1; ++dc) {
      TileKey k{level, key->row + dr, key->col + dc};
      const std::int64_t cols = grid.colCount(level);
      k.col = ((k.col % cols) + cols) % cols; // wrap across the antimeridian
      if (k.row < 0 || k.row >= grid.rowCount(level)) continue;
      out.push_back(grid.sectorOf(k));
    }
  return out;
}

inline bool finite(const glm::dvec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

inline glm::dvec3 vec(const Ecef& e) {
  return {e.x, e.y, e.z};
}

/** Inside all five frustum planes. */
inline bool inFrustum(const Camera& cam, const glm::dvec3& p) {
  for (const Plane& pl : cam.frustum().planes)
    if (pl.signedDistance(p) < 0.0) return false;
  return true;
}

} // namespace tellus::planet::test
