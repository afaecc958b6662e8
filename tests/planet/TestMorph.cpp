// Geomorphing (issue 23, "No popping"; planet/Morph.hpp): a node's morph targets are its parent's
// mesh (even vertices unchanged, odd ones on the parent's chords), and the morph factor is a
// continuous function of the camera that is 1 where the parent splits and 0 where the node does,
// the same for a vertex in every node that holds it.
#include "PlanetTestSupport.hpp"

#include <tellus/planet/Morph.hpp>
#include <tellus/planet/Terrain.hpp>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace tellus::planet {
namespace {

const Geodesy& wgs84() {
  static const Geodesy g;
  return g;
}

double bumpy(double lat, double lon) {
  return 3000.0 * std::sin(lat * 0.7) * std::cos(lon * 1.3) + 40.0 * lat;
}

const TerrainVertex& at(const TerrainMesh& m, int r, int c) {
  return m.vertices[static_cast<std::size_t>(r * m.n + c)];
}

glm::dvec3 target(const TerrainVertex& v) {
  return v.position + v.morphDelta;
}

/** A child's morph targets against its parent's own mesh over the same heights: even vertices
 * are the parent's vertices (unchanged: delta exactly 0), odd ones lie on the chord the parent
 * draws between its two vertices around them (a row's, a column's, or a cell's SW-NE diagonal).
 * 1e-6 m: the parent's grid points come from its own edgeLerp (latitudes a few ulps apart). */
void expectParentsMesh(const Sector& child, const Sector& parent, int quadRow, int quadCol) {
  const int n = 9, h = (n - 1) / 2;
  const double extent = morphExtentOf(wgs84(), child);
  const TerrainMesh c = buildTerrainMesh(wgs84(), child, n, bumpy, {}, 0, extent);
  const TerrainMesh p = buildTerrainMesh(wgs84(), parent, n, bumpy, {});
  for (int r = 0; r < n; ++r)
    for (int col = 0; col < n; ++col) {
      const TerrainVertex& v = at(c, r, col);
      EXPECT_EQ(v.morphExtentM, extent);
      // The parent's vertices around this point: (pr0, pc0) to (pr1, pc1).
      const int pr0 = quadRow * h + r / 2, pc0 = quadCol * h + col / 2;
      const int pr1 = pr0 + (r & 1), pc1 = pc0 + (col & 1);
      const glm::dvec3 onParent = 0.5 * (at(p, pr0, pc0).position + at(p, pr1, pc1).position);
      if ((r & 1) == 0 && (col & 1) == 0) {
        EXPECT_EQ(v.morphDelta, glm::dvec3(0.0)) << r << " " << col;
      } else if (at(p, pr0, pc0).position != at(p, pr1, pc1).position) { // a pole row is a point
        EXPECT_GT(glm::length(v.morphDelta), 0.0) << r << " " << col;    // bumpy: off the chord
      }
      EXPECT_LT(glm::length(target(v) - onParent), 1e-6) << r << " " << col;
    }
}

TEST(MorphTargets, EvenVerticesUnchangedOddOnesOnTheParentsChords) {
  const TileGrid g = test::globalGrid();
  const TileKey parentKey{5, 70, 150};
  const Sector parent = g.sectorOf(parentKey);
  for (int qr = 0; qr < 2; ++qr)
    for (int qc = 0; qc < 2; ++qc) {
      const Sector child = g.sectorOf({6, 140 + qr, 300 + qc});
      expectParentsMesh(child, parent, qr, qc);
    }
}

TEST(MorphTargetsExtremes, PoleRowAndAntimeridian) {
  const TileGrid g = test::globalGrid();
  // The north-east corner at the pole and the antimeridian (level 3: 4.5 degrees).
  const std::int64_t rows = g.rowCount(3), cols = g.colCount(3);
  expectParentsMesh(
      g.sectorOf({3, rows - 1, cols - 1}), g.sectorOf({2, rows / 2 - 1, cols / 2 - 1}), 1, 1);
  expectParentsMesh(g.sectorOf({3, 0, 0}), g.sectorOf({2, 0, 0}), 0, 0);
}

TEST(MorphTargets, OffWithoutAnExtent) {
  const Sector s = test::globalGrid().sectorOf({6, 140, 300});
  const TerrainMesh m = buildTerrainMesh(wgs84(), s, 9, bumpy, {});
  for (const TerrainVertex& v : m.vertices) {
    EXPECT_EQ(v.morphDelta, glm::dvec3(0.0));
    EXPECT_EQ(v.morphExtentM, 0.0);
  }
}

TEST(MorphFactor, OneWhereTheParentSplitsZeroWhereTheNodeDoesContinuousBetween) {
  const double extent = 1.0e5, scale = morphScale(1000.0, 1.0, 512);
  const double range = extent * scale; // the parent's split distance
  EXPECT_DOUBLE_EQ(scale, 1000.0 / 512.0);
  EXPECT_EQ(morphFactor(range, extent, scale), 1.0);
  EXPECT_EQ(morphFactor(2.0 * range, extent, scale), 1.0);
  EXPECT_EQ(morphFactor(0.5 * range, extent, scale), 0.0);
  EXPECT_EQ(morphFactor(0.0, extent, scale), 0.0);
  EXPECT_DOUBLE_EQ(morphFactor(0.75 * range, extent, scale), 0.5);
  // Continuous and monotonic: Lipschitz with constant 2 / range.
  double last = 0.0;
  for (int i = 0; i <= 3000; ++i) {
    const double d = range * i / 1000.0;
    const double f = morphFactor(d, extent, scale);
    EXPECT_GE(f, last);
    EXPECT_LE(f - last, 2.0 / 1000.0 + 1e-12);
    last = f;
  }
}

TEST(MorphFactorExtremes, DistancesFromOneMetreToABillionAndBadInput) {
  const double scale = morphScale(665.0, 1.0, 512);
  const Geodesy& g = wgs84();
  const TileGrid grid = test::globalGrid();
  // A level-20 node's vertex 1 m away is its own (0); from 1e9 m a level-1 node's is its parent's.
  EXPECT_EQ(morphFactor(1.0, morphExtentOf(g, grid.sectorOf({20, 0, 0})), scale), 0.0);
  EXPECT_EQ(morphFactor(1e9, morphExtentOf(g, grid.sectorOf({1, 0, 0})), scale), 1.0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(morphFactor(nan, 1e5, scale), 0.0);
  EXPECT_EQ(morphFactor(inf, 1e5, scale), 0.0);
  EXPECT_EQ(morphFactor(10.0, 0.0, scale), 0.0); // no extent: no morph
  EXPECT_EQ(morphScale(1000.0, 0.0, 512), 0.0);
  EXPECT_EQ(morphScale(nan, 1.0, 512), 0.0);
  // The extent is a function of the level alone: every node of a level, poles included.
  EXPECT_EQ(morphExtentOf(g, grid.sectorOf({7, 0, 0})),
            morphExtentOf(g, grid.sectorOf({7, grid.rowCount(7) - 1, 17})));
}

/** Two same-level neighbours give their shared vertices the same position, offset and extent, bit
 * for bit: the factor, a function of those and the camera, is the same in both. */
TEST(MorphFactor, SharedVertexOfTwoNeighboursMorphsAlike) {
  const TileGrid g = test::globalGrid();
  const int n = 9;
  for (const TileKey k : {TileKey{5, 20, 40}, TileKey{3, 0, 79}, TileKey{4, 39, 0}}) {
    const Sector a = g.sectorOf(k);
    for (const Direction d : {Direction::East, Direction::North}) {
      const auto nk = g.neighbour(k, d);
      if (!nk) continue;
      const Sector b = g.sectorOf(*nk);
      const auto ma = buildTerrainMesh(wgs84(), a, n, bumpy, {}, 0, morphExtentOf(wgs84(), a));
      const auto mb = buildTerrainMesh(wgs84(), b, n, bumpy, {}, 0, morphExtentOf(wgs84(), b));
      for (int i = 0; i < n; ++i) {
        const auto& va = d == Direction::East ? at(ma, i, n - 1) : at(ma, n - 1, i);
        const auto& vb = d == Direction::East ? at(mb, i, 0) : at(mb, 0, i);
        EXPECT_EQ(va.position, vb.position);
        EXPECT_EQ(va.morphDelta, vb.morphDelta);
        EXPECT_EQ(va.morphExtentM, vb.morphExtentM);
        const glm::dvec3 eye = va.position * 1.001;
        const double scale = morphScale(665.0, 1.0, 512);
        EXPECT_EQ(morphFactor(glm::length(va.position - eye), va.morphExtentM, scale),
                  morphFactor(glm::length(vb.position - eye), vb.morphExtentM, scale));
      }
    }
  }
}

/** A finer node's side adapted to a coarser one: its copies of the coarse vertices carry the coarse
 * node's morph bit for bit, and its vertices between them the coarse chord's: at any common factor
 * they lie on the coarse node's morphed edge. */
TEST(MorphTargets, AnAdaptedSideFollowsTheCoarseNodesMorph) {
  const TileGrid g = test::globalGrid();
  const int n = 9;
  const Sector coarse = g.sectorOf({6, 140, 300});
  const auto cm =
      buildTerrainMesh(wgs84(), coarse, n, bumpy, {}, 0, morphExtentOf(wgs84(), coarse));
  std::vector<glm::dvec3> cpos;
  std::vector<glm::dvec4> cmorph;
  for (int i = 0; i < n; ++i) {
    const TerrainVertex& v = at(cm, i, n - 1); // its east side
    cpos.push_back(v.position);
    cmorph.push_back(glm::dvec4(v.morphDelta, v.morphExtentM));
  }
  const Sector fine = g.sectorOf({7, 281, 602}); // east of it, the north half of its edge
  std::array<EdgeAdapt, 4> edges{};
  edges[static_cast<std::size_t>(Direction::West)] = {true, coarse, cpos, cmorph};
  const auto fm = buildTerrainMesh(wgs84(), fine, n, bumpy, edges, 0, morphExtentOf(wgs84(), fine));
  // Without coarseMorph given, the same from the coarse vertices and extent.
  edges[static_cast<std::size_t>(Direction::West)] = {true, coarse, cpos, {}};
  const auto fd = buildTerrainMesh(wgs84(), fine, n, bumpy, edges, 0, morphExtentOf(wgs84(), fine));
  for (int i = 0; i < n; ++i) {
    const TerrainVertex& v = at(fm, i, 0);
    EXPECT_EQ(v.morphExtentM, morphExtentOf(wgs84(), coarse));
    EXPECT_LT(glm::length(at(fd, i, 0).morphDelta - v.morphDelta), 1e-9);
    const int u = (n - 1) + i; // fine steps from the coarse edge's south end: coarse j = u / 2
    if (u % 2 == 0) {
      EXPECT_EQ(v.position, cpos[static_cast<std::size_t>(u / 2)]);
      EXPECT_EQ(v.morphDelta, glm::dvec3(cmorph[static_cast<std::size_t>(u / 2)]));
    } else {
      for (const double f : {0.0, 0.3, 1.0}) {
        const auto j = static_cast<std::size_t>(u / 2);
        const glm::dvec3 a = cpos[j] + f * glm::dvec3(cmorph[j]);
        const glm::dvec3 b = cpos[j + 1] + f * glm::dvec3(cmorph[j + 1]);
        EXPECT_LT(glm::length(v.position + f * v.morphDelta - 0.5 * (a + b)), 1e-6);
      }
    }
  }
}

/** Edges morph (Morph.hpp): a fine side adapted to a coarse one 16 times its length, whose coarse
 * ends lie beyond the fine edge, carries the coarse side's morph as the coarse mesh draws it, in
 * its own edge vertices and in the fans' extra vertices (copies of the coarse vertices): at any
 * factor the fans' outer edge is the coarse node's morphed edge, so they stay closed. */
TEST(MorphEdges, TheFansExtraVerticesCarryTheCoarseMorph) {
  const TileGrid g = test::globalGrid();
  const int n = 9;
  const Sector coarse = g.sectorOf({6, 140, 300});
  const auto cm =
      buildTerrainMesh(wgs84(), coarse, n, bumpy, {}, 0, morphExtentOf(wgs84(), coarse));
  std::vector<glm::dvec3> cpos;
  std::vector<glm::dvec4> cmorph;
  for (int i = 0; i < n; ++i) {
    const TerrainVertex& v = at(cm, i, n - 1); // its east side
    cpos.push_back(v.position);
    cmorph.push_back(glm::dvec4(v.morphDelta, v.morphExtentM));
  }
  // East of it, 1/16 of its edge, the 5th (q = 4): its south end on coarse vertex 2, its north
  // end inside the segment to vertex 3 (odd), which the fans copy as an extra vertex.
  const Sector fine = g.sectorOf({10, 2244, 4816});
  std::array<EdgeAdapt, 4> edges{};
  edges[static_cast<std::size_t>(Direction::West)] = {true, coarse, cpos, cmorph};
  const auto m = buildTerrainMesh(wgs84(), fine, n, bumpy, edges, 0, morphExtentOf(wgs84(), fine));
  ASSERT_GT(m.vertices.size(), static_cast<std::size_t>(n * n));
  int odd = 0;
  for (std::size_t i = static_cast<std::size_t>(n * n); i < m.vertices.size(); ++i) {
    const TerrainVertex& v = m.vertices[i];
    std::size_t j = 0;
    while (j < cpos.size() && cpos[j] != v.position)
      ++j;
    ASSERT_LT(j, cpos.size()) << "an extra vertex that is no coarse vertex";
    EXPECT_EQ(v.morphDelta, glm::dvec3(cmorph[j]));
    EXPECT_EQ(v.morphExtentM, cmorph[j].w);
    odd += (j & 1U) != 0 ? 1 : 0;
  }
  EXPECT_GT(odd, 0); // an odd coarse vertex among them: a real offset, not only zeros
  // The coarse side's odd vertices morph (edges are no longer pinned).
  EXPECT_GT(glm::length(glm::dvec3(cmorph[1])), 0.0);
}

/** Near the poles a row of nodes merged across longitudes (span 2: level L + 1, twice as wide as
 * tall) borders level-L nodes of the same width at the same resolution along the side. Both give
 * the shared vertices the same position, offset and extent (the side's span, not the level:
 * morphEdgeExtent), so the same factor at any camera: no crack where the edge morphs. */
TEST(MorphEdgesExtremes, AMergedRowsSideMorphsLikeItsNeighbourOneLevelCoarser) {
  const TileGrid g = test::globalGrid();
  const int n = 9;
  const std::int64_t rows = g.rowCount(4);
  for (const TileKey k : {TileKey{4, rows - 2, 0}, TileKey{4, rows - 2, g.colCount(4) - 1}}) {
    const Sector below = g.sectorOf(k); // level L, south of the merged row
    const double h = 0.5 * (below.north - below.south);
    const Sector merged{below.west, below.north, below.east, below.north + h};
    const auto mb =
        buildTerrainMesh(wgs84(), below, n, bumpy, {}, 0, morphExtentOf(wgs84(), below));
    const auto mm =
        buildTerrainMesh(wgs84(), merged, n, bumpy, {}, 0, morphExtentOf(wgs84(), merged));
    EXPECT_EQ(morphEdgeExtent(morphExtentOf(wgs84(), merged), merged, true),
              morphExtentOf(wgs84(), below));
    for (int i = 0; i < n; ++i) {
      const TerrainVertex& a = at(mb, n - 1, i); // its north side
      const TerrainVertex& b = at(mm, 0, i);     // the merged node's south side
      EXPECT_EQ(a.position, b.position) << i;
      EXPECT_EQ(a.morphDelta, b.morphDelta) << i;
      EXPECT_EQ(a.morphExtentM, b.morphExtentM) << i;
      if (i % 2 == 1) {
        EXPECT_GT(glm::length(a.morphDelta), 0.0) << i;
      }
      const double scale = morphScale(665.0, 1.0, 512);
      for (const double far : {1.0001, 1.01, 1.5}) {
        const glm::dvec3 eye = a.position * far;
        EXPECT_EQ(morphFactor(glm::length(a.position - eye), a.morphExtentM, scale),
                  morphFactor(glm::length(b.position - eye), b.morphExtentM, scale));
      }
    }
    // The merged node's west and east sides (neighbours in its own row) keep its level's extent.
    EXPECT_EQ(at(mm, 3, 0).morphExtentM, morphExtentOf(wgs84(), merged));
  }
}

} // namespace
} // namespace tellus::planet
