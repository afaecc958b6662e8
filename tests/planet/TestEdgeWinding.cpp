// Edge fixing's zero-area fans are wound like the grid's cells (issue 23's leftover: one-pixel
// cracks in frames drawn with back faces culled, Renderer::redrawLast). A mesh whose four sides
// all follow a coarser neighbour must be consistently oriented: every directed edge is used by at
// most one triangle (a fan triangle and the cell across our side traverse the side's segment in
// opposite directions). Before the fix, south and east fans used it in the cell's direction, so
// they faced inwards and a culled draw dropped the slivers between our side and the coarse chord.

#include <tellus/planet/Geodesy.hpp>
#include <tellus/planet/Terrain.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <map>
#include <utility>

namespace tellus::planet {
namespace {

double rugged(double lat, double lon) {
  return 2500.0 * std::sin(3.1 * lat) * std::cos(2.7 * lon) + 700.0 * std::sin(11.0 * lon);
}

TEST(EdgeFixing, FansAreWoundLikeTheCellsOnEverySide) {
  const Geodesy wgs;
  const int n = 9;
  const Sector fine{10.0, 20.0, 12.0, 22.0}; // the south-west child's child of {10, 20, 18, 28}
  std::array<EdgeAdapt, 4> edges{};
  edges[static_cast<std::size_t>(Direction::North)] = {true, Sector{8.0, 22.0, 12.0, 26.0}, {}};
  edges[static_cast<std::size_t>(Direction::South)] = {true, Sector{8.0, 16.0, 16.0, 20.0}, {}};
  edges[static_cast<std::size_t>(Direction::East)] = {true, Sector{12.0, 20.0, 16.0, 24.0}, {}};
  edges[static_cast<std::size_t>(Direction::West)] = {true, Sector{6.0, 18.0, 10.0, 22.0}, {}};
  const TerrainMesh m = buildTerrainMesh(wgs, fine, n, rugged, edges);
  ASSERT_GT(m.zeroAreaTriangles, 0u);
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
  for (std::size_t i = 0; i + 2 < m.indices.size(); i += 3)
    for (std::size_t e = 0; e < 3; ++e)
      ++directed[{m.indices[i + e], m.indices[i + (e + 1) % 3]}];
  int twice = 0;
  for (const auto& [edge, uses] : directed)
    twice += uses > 1 ? 1 : 0;
  EXPECT_EQ(twice, 0) << "directed edges used by two triangles: a fan faces inwards";
}

} // namespace
} // namespace tellus::planet
