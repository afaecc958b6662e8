// Node meshes (planet/gl/src/NodeMeshes.hpp): the sides finer neighbours adapt to, a cap's seam,
// which sides adapt to a coarser drawn neighbour (GL-free), and the GPU meshes built once, kept
// while used and dropped after 120 unused frames (GL).

#include "../../planet/gl/src/FrameUpdate.hpp"
#include "../../planet/gl/src/NodeMeshes.hpp"
#include "GlContextSupport.hpp"
#include "LayerTestSupport.hpp"

#include <gtest/gtest.h>

using namespace tellus;
using namespace tellus::planet;
using namespace tellus::planet::layertest;

namespace {

constexpr auto kNorth = static_cast<std::size_t>(Direction::North);
constexpr auto kEast = static_cast<std::size_t>(Direction::East);
constexpr auto kSouth = static_cast<std::size_t>(Direction::South);
constexpr auto kWest = static_cast<std::size_t>(Direction::West);

TerrainMesh flatMesh(const Geodesy& g, const Sector& s, int n) {
  return buildTerrainMesh(
      g, s, n, [](double, double) { return 0.0; }, {}, n);
}

} // namespace

TEST(NodeMeshes, SidesAreTheGridsBorderWestToEastAndSouthToNorth) {
  const Geodesy g;
  const TerrainMesh mesh = flatMesh(g, Sector{10.0, 20.0, 30.0, 40.0}, 5);
  const auto sides = sideVerticesOf(mesh);
  ASSERT_EQ(sides[kNorth].size(), 5u);
  ASSERT_EQ(sides[kWest].size(), static_cast<std::size_t>(mesh.rows));
  EXPECT_EQ(sides[kSouth].front(), sides[kWest].front()) << "south-west corner";
  EXPECT_EQ(sides[kSouth].back(), sides[kEast].front()) << "south-east corner";
  EXPECT_EQ(sides[kNorth].front(), sides[kWest].back()) << "north-west corner";
  EXPECT_EQ(sides[kNorth].back(), sides[kEast].back()) << "north-east corner";
  EXPECT_EQ(sides[kSouth][2], mesh.vertices[2].position);
  EXPECT_EQ(sides[kEast][1], mesh.vertices[5 + 4].position);
}

TEST(NodeMeshes, ACapsSeamColumnsAreMadeBitIdentical) {
  const Geodesy g;
  TerrainMesh mesh = flatMesh(g, Sector{-180.0, 72.0, 180.0, 90.0}, 9);
  closeCap(mesh);
  for (int r = 0; r < mesh.rows; ++r) {
    const auto row = static_cast<std::size_t>(r * mesh.n);
    EXPECT_EQ(mesh.vertices[row].position, mesh.vertices[row + 8].position) << r;
  }
}

TEST(NodeMeshes, OnlySidesBorderedByACoarserDrawnNodeAdapt) {
  FakeTileSource source;
  addLayer(source, "base", grid36(10));
  Layers l(source, layerOptions("base"));
  Quadtree& tree = l.set->geo();
  const Camera cam(l.geodesy, CameraPose{46.0, 8.0, 20000.0, 0.0, 60.0}, Viewport{640, 480});
  for (int frame = 0; frame < 10; ++frame)
    updateLayers(*l.set, cam, frame * 0.1);
  const auto& drawn = tree.drawList();
  std::array<std::vector<glm::dvec3>, 4> fakeSides;
  fakeSides[kSouth] = {glm::dvec3(1.0), glm::dvec3(2.0)};
  const SideLookup sides = [&](const NodeKey&) { return &fakeSides; };
  std::size_t adapted = 0;
  for (const Node* n : drawn) {
    const auto edges = adaptedEdges(*n, tree.frame(), sides);
    for (int d = 0; d < 4; ++d) {
      const EdgeAdapt& e = edges[static_cast<std::size_t>(d)];
      if (!e.active) continue;
      ++adapted;
      // The coarse sector is a drawn node's, larger than ours along the shared side.
      const auto it = std::find_if(drawn.begin(), drawn.end(), [&](const Node* o) {
        return o->sector().west == e.coarse.west && o->sector().south == e.coarse.south &&
               o->sector().east == e.coarse.east && o->sector().north == e.coarse.north;
      });
      EXPECT_NE(it, drawn.end());
      const Sector& s = n->sector();
      const bool alongLon = d == 0 || d == 2;
      EXPECT_GT(alongLon ? e.coarse.east - e.coarse.west : e.coarse.north - e.coarse.south,
                alongLon ? s.east - s.west : s.north - s.south);
      // Its side facing us, as it draws it.
      EXPECT_EQ(e.coarseVertices, fakeSides[static_cast<std::size_t>((d + 2) % 4)]);
    }
  }
  EXPECT_GT(adapted, 0u) << "a tilted low view draws neighbours of different levels";
}

TEST(NodeMeshesGl, AMeshIsBuiltOnceKeptWhileUsedAndDroppedAfter120Frames) {
  OPEN_GL_CONTEXT(context);
  FakeTileSource source;
  addLayer(source, "base", grid36(3));
  Layers l(source, layerOptions("base"));
  TerrainState terrain(l.opt);
  NodeMeshes meshes(l.geodesy, terrain, 9, true, context.capabilities().gl45);
  updateLayers(*l.set, cameraAt(l.geodesy, 0.0, 0.0, 2e7), 0.0);
  const auto& drawn = l.set->geo().drawList();
  RenderStats stats;
  meshes.beginFrame(l.set->geo().frame(), 1);
  meshes.buildFor(drawn, stats);
  const std::size_t built = stats.meshesBuilt;
  EXPECT_GE(built, drawn.size());
  EXPECT_EQ(meshes.size(), drawn.size());
  meshes.buildFor(drawn, stats);
  EXPECT_EQ(stats.meshesBuilt, built) << "nothing changed: nothing rebuilt";
  const GpuMesh* m = meshes.find(drawn.front()->key());
  ASSERT_NE(m, nullptr);
  EXPECT_TRUE(glIsVertexArray(m->vao.id()));
  EXPECT_EQ(m->quadrantStart[0], 0u);
  EXPECT_GT(m->quadrantStart[4], m->quadrantStart[3]);
  const GLuint vao = m->vao.id();
  meshes.meshFor(*drawn.front(), stats);
  EXPECT_EQ(stats.meshesBuilt, built);
  meshes.beginFrame(l.set->geo().frame(), 120);
  meshes.meshFor(*drawn.front(), stats); // used in frame 120
  meshes.sweep();
  EXPECT_EQ(meshes.size(), drawn.size()) << "119 frames unused: kept";
  meshes.beginFrame(l.set->geo().frame(), 121);
  meshes.sweep();
  EXPECT_EQ(meshes.size(), 1u);
  EXPECT_EQ(meshes.find(drawn.front()->key())->vao.id(), vao);
  meshes.erase(drawn.front()->key());
  EXPECT_FALSE(glIsVertexArray(vao));
  EXPECT_EQ(glGetError(), GLenum{GL_NO_ERROR});
}
