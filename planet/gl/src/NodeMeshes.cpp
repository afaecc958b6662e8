#include "NodeMeshes.hpp"

#include <tellus/planet/GpuVertex.hpp>
#include <tellus/planet/Morph.hpp>
#include <tellus/planet/Patch.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>

namespace tellus::planet {

namespace {

constexpr bool alongLongitude(int d) noexcept {
  return d == static_cast<int>(Direction::North) || d == static_cast<int>(Direction::South);
}

/** The drawn node across `dir` from a node of sector s, starting at its neighbour pointer. */
const Node* drawnAcross(const Node* nb, Direction dir, const Sector& s, std::uint64_t frame) {
  const bool alongLon = alongLongitude(static_cast<int>(dir));
  while (nb != nullptr && nb->lastDrawnFrame() != frame) {
    const Node* next = nullptr;
    const Sector& p = nb->sector();
    for (int slot = 0; slot < nb->childSlots() && next == nullptr; ++slot) {
      const Node* c = nb->child(slot);
      if (c == nullptr) continue;
      const Sector& cs = c->sector();
      const bool facing = dir == Direction::North   ? cs.south == p.south
                          : dir == Direction::South ? cs.north == p.north
                          : dir == Direction::East  ? cs.west == p.west
                                                    : cs.east == p.east;
      const bool contains = alongLon ? cs.west <= s.west && s.east <= cs.east
                                     : cs.south <= s.south && s.north <= cs.north;
      if (facing && contains) next = c;
    }
    nb = next;
  }
  return nb;
}

} // namespace

namespace {

/** The vertex index of the i-th vertex of side d (west to east, south to north). */
std::size_t sideIndex(const TerrainMesh& mesh, int d, int i) {
  const int n = mesh.n, rows = mesh.rows;
  const int r = d == static_cast<int>(Direction::North)   ? rows - 1
                : d == static_cast<int>(Direction::South) ? 0
                                                          : i;
  const int c = d == static_cast<int>(Direction::East)   ? n - 1
                : d == static_cast<int>(Direction::West) ? 0
                                                         : i;
  return static_cast<std::size_t>(r * n + c);
}

} // namespace

std::array<std::vector<glm::dvec4>, 4> sideMorphsOf(const TerrainMesh& mesh) {
  std::array<std::vector<glm::dvec4>, 4> sides;
  for (int d = 0; d < 4; ++d) {
    auto& side = sides[static_cast<std::size_t>(d)];
    side.resize(static_cast<std::size_t>(alongLongitude(d) ? mesh.n : mesh.rows));
    for (int i = 0; i < static_cast<int>(side.size()); ++i) {
      const TerrainVertex& v = mesh.vertices[sideIndex(mesh, d, i)];
      side[static_cast<std::size_t>(i)] = glm::dvec4(v.morphDelta, v.morphExtentM);
    }
  }
  return sides;
}

std::array<std::vector<glm::dvec3>, 4> sideVerticesOf(const TerrainMesh& mesh) {
  std::array<std::vector<glm::dvec3>, 4> sides;
  const int n = mesh.n, rows = mesh.rows;
  for (int d = 0; d < 4; ++d) {
    auto& side = sides[static_cast<std::size_t>(d)];
    side.resize(static_cast<std::size_t>(alongLongitude(d) ? n : rows));
    for (int i = 0; i < static_cast<int>(side.size()); ++i) {
      const int r = d == static_cast<int>(Direction::North)   ? rows - 1
                    : d == static_cast<int>(Direction::South) ? 0
                                                              : i;
      const int c = d == static_cast<int>(Direction::East)   ? n - 1
                    : d == static_cast<int>(Direction::West) ? 0
                                                             : i;
      side[static_cast<std::size_t>(i)] =
          mesh.vertices[static_cast<std::size_t>(r * n + c)].position;
    }
  }
  return sides;
}

void closeCap(TerrainMesh& mesh) {
  const int n = mesh.n;
  for (int r = 0; r < mesh.rows; ++r) {
    const auto row = static_cast<std::size_t>(r * n);
    mesh.vertices[row + static_cast<std::size_t>(n - 1)].position = mesh.vertices[row].position;
  }
}

std::array<EdgeAdapt, 4> adaptedEdges(const Node& node,
                                      std::uint64_t drawnFrame,
                                      const SideLookup& sides,
                                      const SideMorphLookup& morphs) {
  std::array<EdgeAdapt, 4> e{};
  const Sector& s = node.sector();
  for (int d = 0; d < 4; ++d) {
    const auto dir = static_cast<Direction>(d);
    const bool alongLon = alongLongitude(d);
    const Node* nb = drawnAcross(node.neighbour(dir), dir, s, drawnFrame);
    if (nb == nullptr) continue;
    const Sector& o = nb->sector();
    const double mine = alongLon ? s.east - s.west : s.north - s.south;
    const double theirs = alongLon ? o.east - o.west : o.north - o.south;
    if (!(theirs > mine)) continue;
    EdgeAdapt& a = e[static_cast<std::size_t>(d)];
    a.active = true;
    a.coarse = o;
    // Its side facing us, as it draws it (meshes are built coarse first: NodeMeshes::buildFor).
    const auto opposite = static_cast<std::size_t>((d + 2) % 4);
    if (const auto* theirSides = sides(nb->key())) a.coarseVertices = (*theirSides)[opposite];
    if (morphs)
      if (const auto* theirMorphs = morphs(nb->key())) a.coarseMorph = (*theirMorphs)[opposite];
  }
  return e;
}

std::array<EdgeAdapt, 4> NodeMeshes::edgesOf(const Node& node) const {
  if (!fixEdges_) return {};
  return adaptedEdges(
      node,
      drawnFrame_,
      [this](const NodeKey& k) {
        const GpuMesh* m = find(k);
        return m != nullptr ? &m->sideVertices : nullptr;
      },
      [this](const NodeKey& k) {
        const GpuMesh* m = find(k);
        return m != nullptr && geomorph_ ? &m->sideMorphs : nullptr;
      });
}

const GpuMesh* NodeMeshes::find(const NodeKey& key) const {
  const auto it = meshes_.find(key);
  return it == meshes_.end() ? nullptr : &it->second;
}

const GpuMesh& NodeMeshes::meshFor(const Node& node, RenderStats& stats) {
  auto [it, inserted] = meshes_.try_emplace(node.key());
  GpuMesh& m = it->second;
  m.lastUsed = frame_;
  const std::array<EdgeAdapt, 4> edges = edgesOf(node);
  // Stale when heights changed under the node, or under a coarser neighbour its edges follow
  // (whose chord ends may lie beyond this node's edge).
  const HeightField* field = terrain_.field();
  bool stale = m.reliefOff != terrain_.reliefOff() ||
               (field && field->changedSince(m.heightGeneration, node.sector()));
  for (const EdgeAdapt& e : edges)
    stale = stale || (field && e.active && field->changedSince(m.heightGeneration, e.coarse));
  if (!inserted && edges == m.edges && !stale) return m;
  const auto t0 = std::chrono::steady_clock::now();
  TerrainMesh mesh = buildTerrainMesh(
      geodesy_,
      node.sector(),
      node.meshSize(meshSize_),
      [this](double lat, double lon) { return terrain_.heightAt(lat, lon); },
      edges,
      meshSize_,
      geomorph_ && node.level() > 0 && !node.isCap() ? morphExtentOf(geodesy_, node.sector())
                                                     : 0.0);
  if (node.isCap()) closeCap(mesh);
  m.edges = edges;
  m.reliefOff = terrain_.reliefOff();
  m.heightGeneration = field ? field->generation() : 0;
  m.quadrantStart = mesh.quadrantStart;
  m.zeroAreaTriangles = mesh.zeroAreaTriangles;
  m.fixed = std::any_of(edges.begin(), edges.end(), [](const EdgeAdapt& a) { return a.active; });
  m.sideVertices = sideVerticesOf(mesh);
  m.sideMorphs = sideMorphsOf(mesh);
  upload(m, mesh);
  ++stats.meshesBuilt;
  ++stats.meshesBuiltLast;
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  stats.meshMs += ms;
  stats.meshMsTotal += ms;
  return m;
}

void NodeMeshes::upload(GpuMesh& m, const TerrainMesh& mesh) const {
  // Positions reach the shader relative to the camera without a float ever holding an
  // Earth-sized coordinate, and two nodes that hold the same point draw it at the same place bit
  // for bit (GpuVertex.hpp).
  std::vector<float> v;
  packVertices(mesh.vertices, fp64_ ? VertexPositions::Doubles : VertexPositions::FloatPairs, v);
  if (!m.vao.created()) {
    m.vao = GlVertexArray();
    m.vbo = GlBuffer();
    m.ebo = GlBuffer();
  }
  glBindVertexArray(m.vao.id());
  glBindBuffer(GL_ARRAY_BUFFER, m.vbo.id());
  glBufferData(
      GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(v.size() * sizeof(float)), v.data(), GL_STATIC_DRAW);
  constexpr auto stride = static_cast<GLsizei>(kFloatsPerVertex * sizeof(float));
  const auto at = [](std::size_t floats) {
    return reinterpret_cast<const void*>(floats * sizeof(float));
  };
  glEnableVertexAttribArray(0);
  if (fp64_) {
    glVertexAttribLPointer(0, 3, GL_DOUBLE, stride, at(0));
    glDisableVertexAttribArray(1);
  } else {
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride, at(0));
    glEnableVertexAttribArray(1);
    glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, stride, at(3));
  }
  glEnableVertexAttribArray(2);
  glVertexAttribPointer(2, 3, GL_FLOAT, GL_FALSE, stride, at(6));
  glEnableVertexAttribArray(3);
  glVertexAttribPointer(3, 2, GL_FLOAT, GL_FALSE, stride, at(9));
  glEnableVertexAttribArray(4); // geomorphing: offset to the parent's position, its extent
  glVertexAttribPointer(4, 4, GL_FLOAT, GL_FALSE, stride, at(11));
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, m.ebo.id());
  glBufferData(GL_ELEMENT_ARRAY_BUFFER,
               static_cast<GLsizeiptr>(mesh.indices.size() * sizeof(std::uint32_t)),
               mesh.indices.data(),
               GL_STATIC_DRAW);
  glBindVertexArray(0);
}

void NodeMeshes::buildFor(const std::vector<Node*>& drawList, RenderStats& stats) {
  stats.edgesFixed = 0;
  stats.zeroAreaTriangles = 0;
  byLevel_.assign(drawList.begin(), drawList.end());
  std::stable_sort(byLevel_.begin(), byLevel_.end(), [](const Node* a, const Node* b) {
    return a->level() < b->level();
  });
  for (const Node* n : byLevel_)
    meshFor(*n, stats);
  // A second pass for the rare neighbour that is coarser along an edge at a deeper level (merged
  // polar rows): its mesh was not yet final when the first pass reached the finer node.
  for (const Node* n : byLevel_) {
    const GpuMesh& g = meshFor(*n, stats);
    for (const EdgeAdapt& e : g.edges)
      stats.edgesFixed += e.active ? 1 : 0;
    stats.zeroAreaTriangles += g.zeroAreaTriangles;
  }
}

void NodeMeshes::sweep() {
  std::erase_if(meshes_, [&](const auto& e) { return frame_ - e.second.lastUsed >= 120; });
}

double
NodeMeshes::surfaceHeightAt(double lat, double lon, const std::vector<Node*>& drawList) const {
  double h = terrain_.heightAt(lat, lon);
  if (!std::isfinite(h)) return h;
  lon = std::remainder(lon, 360.0);
  for (const Node* node : drawList) {
    const Sector& s = node->sector();
    if (lat < s.south || lat > s.north || lon < s.west || lon > s.east) continue;
    const int n = node->meshSize(meshSize_), rows = meshSize_;
    const int r =
        std::clamp(static_cast<int>(std::floor((lat - s.south) / (s.north - s.south) * (rows - 1))),
                   0,
                   rows - 2);
    const int c = std::clamp(
        static_cast<int>(std::floor((lon - s.west) / (s.east - s.west) * (n - 1))), 0, n - 2);
    for (int dr = 0; dr < 2; ++dr)
      for (int dc = 0; dc < 2; ++dc)
        h = std::max(h,
                     terrain_.heightAt(edgeLerp(s.south, s.north, r + dr, rows),
                                       edgeLerp(s.west, s.east, c + dc, n)));
    if (const GpuMesh* m = find(node->key()))
      for (int d = 0; d < 4; ++d) {
        const EdgeAdapt& e = m->edges[static_cast<std::size_t>(d)];
        if (!e.active) continue;
        const bool alongLon = alongLongitude(d);
        const double a = alongLon ? e.coarse.west : e.coarse.south,
                     b = alongLon ? e.coarse.east : e.coarse.north;
        const double p = alongLon ? lon : lat;
        // The coarse side's own vertex count (a polar cap's rim has more than n).
        const int cn = e.coarseVertices.size() >= 2 ? static_cast<int>(e.coarseVertices.size()) : n;
        const int j =
            std::clamp(static_cast<int>(std::floor((p - a) / (b - a) * (cn - 1))), 0, cn - 2);
        const double fixedCoord = d == static_cast<int>(Direction::North)   ? s.north
                                  : d == static_cast<int>(Direction::South) ? s.south
                                  : d == static_cast<int>(Direction::East)  ? s.east
                                                                            : s.west;
        for (int k = 0; k < 2; ++k) {
          const double q = edgeLerp(a, b, j + k, cn);
          h = std::max(
              h, alongLon ? terrain_.heightAt(fixedCoord, q) : terrain_.heightAt(q, fixedCoord));
        }
      }
    break;
  }
  return h;
}

} // namespace tellus::planet
