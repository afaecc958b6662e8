#pragma once
/**
 * @file NodeMeshes.hpp
 * @brief The frame's mesh phase and the GPU meshes of drawn nodes (issue #6): per node key an
 * N x N grid from buildTerrainMesh (displaced by the heights, edge-fixed, normals, node uv) in one
 * vertex array + vertex buffer + index buffer (its index range in four quadrants, plus the
 * zero-area triangles of its fixed edges).
 *
 * - Edge fixing: a node's side that a coarser drawn node borders moves onto that node's chords,
 *   exactly as that node draws them (adaptedEdges); meshes are therefore built coarse levels
 *   first each frame (thesis 4.5.2), then once more for the rare neighbour that is coarser along
 *   an edge at a deeper level (merged polar rows). No skirts.
 * - A mesh is rebuilt when its heights change (HeightField::changedSince, under it or under a
 *   coarser neighbour its edges follow), when the relief switches on or off, or when its edges'
 *   neighbours change (split, merged, refitted); dropped 120 frames after its last use.
 * - Precision: 44 bytes a vertex (GpuVertex.hpp): the position as three doubles (fp64, OpenGL
 *   4.x) or as high and low floats, then the normal and the node uv as floats.
 *
 * Issue 26 (other bodies): the meshes take the body through the Geodesy given here. GL objects:
 * main thread, context current (GlObjects.hpp).
 */

#include "GlObjects.hpp"
#include "TerrainState.hpp"

#include <tellus/planet/Quadtree.hpp>
#include <tellus/planet/Terrain.hpp>
#include <tellus/planet_gl/Renderer.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <unordered_map>
#include <vector>

namespace tellus::planet {

/** A node's mesh on the GPU and what it was built from. */
struct GpuMesh {
  GlVertexArray vao{NoCreate};
  GlBuffer vbo{NoCreate};
  GlBuffer ebo{NoCreate};
  std::array<std::uint32_t, 5> quadrantStart{};
  std::size_t zeroAreaTriangles = 0;
  std::array<EdgeAdapt, 4> edges{};
  bool reliefOff = false; ///< built on the bare ellipsoid (TerrainState::reliefOff)
  std::uint64_t heightGeneration = 0;
  std::uint64_t lastUsed = 0;
  bool fixed = false; ///< some side adapted
  /** The vertices along each side (Direction order) as drawn: what finer neighbours adapt to. */
  std::array<std::vector<glm::dvec3>, 4> sideVertices;
  /** Their morph (delta, extent; Morph.hpp), likewise. */
  std::array<std::vector<glm::dvec4>, 4> sideMorphs;
};

/** The vertices along each side of a mesh (Direction order: n along north and south, its rows
 * along east and west; west to east, south to north). */
std::array<std::vector<glm::dvec3>, 4> sideVerticesOf(const TerrainMesh& mesh);
/** The same vertices' morph: (morphDelta, morphExtentM). */
std::array<std::vector<glm::dvec4>, 4> sideMorphsOf(const TerrainMesh& mesh);

/** A cap's mesh made whole: its two seam columns (longitude -180 and 180) bit-identical. (The
 * ring's nodes put their edges onto its rim's chords: buildTerrainMesh.) */
void closeCap(TerrainMesh& mesh);

/** The side vertices a drawn node's mesh has (null: no mesh yet). */
using SideLookup = std::function<const std::array<std::vector<glm::dvec3>, 4>*(const NodeKey& key)>;
/** The side vertices' morph (EdgeAdapt::coarseMorph) a drawn node's mesh has (null: none). */
using SideMorphLookup =
    std::function<const std::array<std::vector<glm::dvec4>, 4>*(const NodeKey& key)>;

/** The drawn node across each side whose edge is coarser than ours along it (drawnFrame: the
 * tree's frame): that side adapts. Along east/west sides a node's extent is its latitude span,
 * along north/south its longitude span. The neighbour pointer gives the deepest node of our level
 * or coarser whose edge contains ours; when it is not drawn, the drawn node across is found among
 * its descendants whose edge still contains ours: near the poles a finer node of a merged row can
 * be wider than we are, i.e. coarser along the shared edge. GL-free. */
std::array<EdgeAdapt, 4> adaptedEdges(const Node& node,
                                      std::uint64_t drawnFrame,
                                      const SideLookup& sides,
                                      const SideMorphLookup& morphs = {});

class NodeMeshes {
public:
  /** geodesy and terrain must outlive the meshes. fp64: positions as doubles (GpuVertex.hpp). */
  NodeMeshes(const Geodesy& geodesy,
             const TerrainState& terrain,
             int meshSize,
             bool fixEdges,
             bool fp64,
             bool geomorph = false)
      : geodesy_(geodesy), terrain_(terrain), meshSize_(meshSize), fixEdges_(fixEdges), fp64_(fp64),
        geomorph_(geomorph) {}

  /** The frame meshes are used in: drawnFrame is the base tree's (which nodes are drawn), frame
   * the renderer's (RenderStats::frames; a mesh unused for 120 of them goes). */
  void beginFrame(std::uint64_t drawnFrame, std::uint64_t frame) noexcept {
    drawnFrame_ = drawnFrame;
    frame_ = frame;
  }
  /** The mesh phase: every drawn node's mesh up to date, coarse first (then once more); fills
   * stats.edgesFixed and zeroAreaTriangles. */
  void buildFor(const std::vector<Node*>& drawList, RenderStats& stats);
  /** The node's mesh, built or rebuilt when stale (stats: meshesBuilt, meshMs). */
  const GpuMesh& meshFor(const Node& node, RenderStats& stats);
  const GpuMesh* find(const NodeKey& key) const;
  void erase(const NodeKey& key) { meshes_.erase(key); }
  /** Drops the meshes unused for 120 frames. */
  void sweep();
  std::size_t size() const noexcept { return meshes_.size(); }

  /** The height of the surface as drawn, conservatively: the data's height at the point, and the
   * heights of the grid cell's corners of the drawn node over it (a coarse node's flat cell can
   * lie above the data's valley), including the coarse chord's ends where that side is
   * edge-fixed. */
  double surfaceHeightAt(double latDeg, double lonDeg, const std::vector<Node*>& drawList) const;

private:
  std::array<EdgeAdapt, 4> edgesOf(const Node& node) const;
  void upload(GpuMesh& m, const TerrainMesh& mesh) const;

  const Geodesy& geodesy_;
  const TerrainState& terrain_;
  int meshSize_;
  bool fixEdges_;
  bool fp64_;
  bool geomorph_; ///< meshes carry morph targets (Morph.hpp; below level 1 and for caps none)
  std::uint64_t drawnFrame_ = 0;
  std::uint64_t frame_ = 0;
  std::unordered_map<NodeKey, GpuMesh, NodeKeyHash> meshes_;
  std::vector<const Node*> byLevel_;
};

} // namespace tellus::planet
