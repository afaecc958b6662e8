#pragma once
/**
 * @file Quadtree.hpp
 * @brief One layer's node tree (thesis 4.1, 4.7.2, 4.8.2): lazily created nodes, the per-frame
 * update pass (traversal, culling, texel-to-pixel LOD, draw list, statistics), neighbour pointers
 * and the node-count limit. GL-free.
 *
 * Nodes and tiles. Away from the poles a node is exactly one tile of the layer's grid. Near the
 * poles a node may span several columns of its level (NodeKey::span, a power of two): a geodetic
 * tile there is a sliver whose east-west extent is cos(latitude) times its north-south extent, so
 * the texel-to-pixel test, which must split for the north-south texels, would also halve an
 * east-west extent that is already far finer than needed. Children therefore split north-south
 * only where the row is that thin: a child row spans as many columns as keeps its east-west
 * ground extent at most its north-south extent (the largest power of two not above
 * 1/cos(equatorward latitude), never narrower than half nor wider than its parent;
 * QuadtreeParams::adaptivePolarSpans widens a merged row to its parent's width when the camera at
 * split time allows it). The LOD test still checks both projected axes against the node texture's
 * texel counts, so a texel is never larger than the threshold in pixels along either axis; the
 * texture of a wide node is composed from its `span` tiles (at most kMaxTextureTiles of them, see
 * below). See docs/design/poles.md.
 *
 * Polar caps (QuadtreeParams::polarCaps). Merged rows still leave one node per level-zero column
 * at the pole at any altitude (ten with 36-degree roots), since no node spans two roots. With caps
 * the whole top (and bottom) row of every level is one node, a cap: the roots of the polar rows
 * are the two level-zero caps; a cap's children are the cap of the next level (slot 0) and the
 * ring below it, the other half of the cap's row at the next level, cut into the nodes a root
 * column's merged row would have there (slots 1 and up, west to east). The ring nodes and
 * everything below them are ordinary nodes. A cap's texture is equirectangular like every node's,
 * kCapTextureWidthFactor times a tile's width: at the cap's rim a parallel is at most 2 pi times
 * the row's height, so its east-west texels are no larger than its north-south ones.
 */

#include <tellus/cache/TileGrid.hpp>
#include <tellus/planet/Camera.hpp>
#include <tellus/planet/Culling.hpp>
#include <tellus/planet/Lod.hpp>
#include <tellus/planet/Patch.hpp>

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <utility>
#include <vector>

namespace tellus::planet {

/** A node's address: a row of its level and `span` columns from `col` (span 1: one tile). */
/** A node's east-west edges at height 0, sampled at their ends and middles (south then north;
 * an edge on a pole is absent: it has length 0), with the surface normals there (to lift them to
 * the height the LOD test measures at). */
struct EastWestEdges {
  std::array<glm::dvec3, 6> points{};
  std::array<glm::dvec3, 6> normals{};
  std::array<bool, 2> present{};
};

struct NodeKey {
  std::int32_t level = 0;
  std::int64_t row = 0;
  std::int64_t col = 0;
  std::int64_t span = 1;
  friend constexpr auto operator<=>(const NodeKey&, const NodeKey&) = default;
  TileKey firstTile() const noexcept { return {level, row, col}; }
};

/**
 * The most tiles a node's texture is made of. Near the poles a merged row can span up to 2^level
 * columns (the top row of level 24 of a 36-degree grid spans 2^24 of them); asking for all of them
 * would send millions of requests for one node. Such a texture is made of kMaxTextureTiles tiles
 * instead: the middle tile of each of kMaxTextureTiles equal segments of the node, each stretched
 * over its segment (east-west sample and hold). Rows that wide lie within a few tile heights of the
 * pole, where a tile column is a sliver far narrower east-west than a texel of the node's texture,
 * so nothing the texture could show is lost. Narrower nodes use every one of their tiles.
 */
inline constexpr std::int64_t kMaxTextureTiles = 16;

/** How many tiles a node's texture is composed from: min(span, kMaxTextureTiles x the odd part
 * of span). Spans of merged rows are powers of two (odd part 1); a polar cap spans every column
 * of its level, the root columns times a power of two (ten: odd part 5, at most 80 tiles). */
constexpr std::int64_t textureTileCount(const NodeKey& k) noexcept {
  std::int64_t odd = k.span > 0 ? k.span : 1;
  while (odd % 2 == 0)
    odd /= 2;
  const std::int64_t most = kMaxTextureTiles * odd;
  return k.span < most ? k.span : most;
}
/** The i-th of them, west to east (the segments are exact: span / count is a power of two). */
constexpr TileKey textureTile(const NodeKey& k, std::int64_t i) noexcept {
  const std::int64_t segment = k.span / textureTileCount(k);
  return {k.level, k.row, k.col + i * segment + segment / 2};
}

struct NodeKeyHash {
  std::size_t operator()(const NodeKey& k) const noexcept {
    return TileKeyHash{}(k.firstTile()) ^ (static_cast<std::size_t>(k.span) * 0x9E3779B9u);
  }
};

/** Per-node texture state (thesis table 2, extended). The ITileSource hides whether a tile comes
 * from the cache or upstream, so a requested tile is CheckingCache until its bytes arrive. */
enum class TextureState : std::uint8_t {
  NoTexture,     ///< nothing requested (or a failure waiting for its retry)
  CheckingCache, ///< requested from the tile source
  Fetching,      ///< the source reported an upstream fetch (sources that can tell)
  Decoding,      ///< bytes arrived, decoding on a worker
  Uploading,     ///< decoded, being uploaded in bands
  Finished,      ///< resident and drawable
  Absent,        ///< no tile exists here (never asked for again in this session)
};

/** A cap's texture is this many tiles wide (and one tall). */
inline constexpr int kCapTextureWidthFactor = 8;
/** A cap's mesh has kCapMeshFactor x (meshSize - 1) + 1 columns (at most 1,025): its rim is a
 * whole parallel, which meshSize columns would draw as a polygon of 32 chords (0.5 % of the cap's
 * radius inside the circle at the chords' middles); four times as many keep that within 0.03 %,
 * and its rim columns about as far apart as a ring node's. Its rows are meshSize, as every node's
 * of its level (their latitude span is the same). */
inline constexpr int kCapMeshFactor = 4;

class Quadtree;

/** Children slots, a child's position in its parent. A row that is not split east-west has its
 * one child in the west slot (SW or NW) and the east slot empty. A polar cap's children are
 * numbered differently (the next cap in slot 0, then its ring; see the file comment). */
enum ChildSlot { ChildSW = 0, ChildSE = 1, ChildNW = 2, ChildNE = 3 };

class Node {
public:
  Node(const Geodesy& geodesy,
       const NodeKey& key,
       const Sector& sector,
       Node* parent,
       double minHeightM = 0.0,
       double maxHeightM = 0.0);
  Node(const Node&) = delete;
  Node& operator=(const Node&) = delete;
  ~Node();

  const NodeKey& key() const noexcept { return key_; }
  std::int32_t level() const noexcept { return key_.level; }
  const Sector& sector() const noexcept { return geometry_.sector(); }
  const NodeGeometry& geometry() const noexcept { return geometry_; }

  Node* parent() const noexcept { return parent_; }
  /** The child in a slot, null when empty or out of range. */
  Node* child(int slot) const noexcept {
    const auto i = static_cast<std::size_t>(slot);
    return slot >= 0 && i < children_.size() ? children_[i].get() : nullptr;
  }
  /** Child slots (4 for a split node, 0 for a leaf, one plus the ring for a split cap). */
  int childSlots() const noexcept { return static_cast<int>(children_.size()); }
  bool hasChildren() const noexcept { return childCount_ > 0; }
  int childCount() const noexcept { return childCount_; }
  /** A polar cap (QuadtreeParams::polarCaps): the whole top or bottom row of its level. */
  bool isCap() const noexcept { return cap_; }
  /** The vertices a row (west to east) of this node's mesh when nodes have meshSize x meshSize
   * (more for a cap, see kCapMeshFactor); every node's mesh has meshSize rows. */
  int meshSize(int meshSize) const noexcept {
    return cap_ ? std::min(1025, kCapMeshFactor * (meshSize - 1) + 1) : meshSize;
  }
  /** The deepest existing node of level <= this node's level across that side whose extent
   * along the shared edge contains this node's whole edge (same level, or coarser where the
   * same level does not exist). East and west wrap across the antimeridian. Null across the pole
   * (a top row's north, a bottom row's south: the pole is a point every polar node shares, there
   * is no edge to stitch) and outside a partial dataset. */
  Node* neighbour(Direction d) const noexcept { return neighbours_[static_cast<std::size_t>(d)]; }

  /** Frame numbers (Quadtree::frame()) when this node last passed culling, and was last drawn. */
  std::uint64_t lastVisibleFrame() const noexcept { return lastVisible_; }
  std::uint64_t lastDrawnFrame() const noexcept { return lastDrawn_; }

  /** (The largest texel of the node's own texture on screen / the LOD threshold)^2 when it was
   * last drawn (the larger of LodResult's two ratios), 0 before: at most about 1 for a drawn node.
   * An overview k times coarser suffices where k^2 times this is <= 1 (TextureFallback.hpp). */
  double drawnTexelRatioSquared() const noexcept { return drawnTexelRatioSquared_; }

  /** Owned by the texture layer (TextureStreamer, the GL layer); the tree only stores it. */
  TextureState texture = TextureState::NoTexture;

private:
  friend class Quadtree;
  NodeKey key_;
  NodeGeometry geometry_;
  Node* parent_;
  std::vector<std::unique_ptr<Node>> children_;
  std::array<Node*, 4> neighbours_{};
  int childCount_ = 0;
  bool cap_ = false;
  /** Wider than the static rule makes it (adaptivePolarSpans): its east-west edges' points at
   * height 0 (south edge west, middle, east, then the north edge's), for the test it keeps while
   * drawn; fixed for the node's life, so made once. Null for every other node. */
  std::unique_ptr<const EastWestEdges> widened_;
  std::uint64_t lastVisible_ = 0;
  std::uint64_t lastDrawn_ = 0;
  double drawnTexelRatioSquared_ = 0.0;
};

struct QuadtreeParams {
  LodParams lod{};
  /** Nodes created (splits) per update; past it the node is drawn unsplit this frame. */
  int maxSplitsPerFrame = 64;
  /** Node-count limit (thesis 4.7.2); nodes drawn this frame are never removed. */
  std::size_t maxNodes = 50000;
  /** The horizon occluder's height (at or below the lowest terrain). */
  double occluderHeightM = 0.0;
  /** Merge polar slivers east-west (the pole fix); off gives the plain one-tile-per-node tree. */
  bool polarMerge = true;
  /** With polarMerge, where a child row is merged at all (two or more columns: above ~60 degrees
   * of latitude), a split during update() makes the row as wide as the parent when each half of
   * that wider node's east-west edges projects within half of tileWidthPx x threshold pixels
   * from the camera then, or when the wider node will be split anyway and its children would be
   * fewer visible nodes than the row's static ones (a one-level lookahead): the static rule keeps
   * nodes no wider than tall, so a ring of the pole view may hold twice the nodes the texel test
   * needs. A widened node is refined while drawn once its half edges no longer fit. Splits
   * outside update() (split()) use the static rule. */
  bool adaptivePolarSpans = true;
  /** The frustum test: classifyNode (sphere, box, projected box, half boxes) when true; the
   * bounding sphere alone when false (for comparisons: it keeps nodes off the view's edges and
   * corners, and most of a pole view's ring just outside it). */
  bool tightFrustumCulling = true;
  /** With polarMerge, over a dataset covering every longitude: the top and bottom rows of every
   * level are single nodes, polar caps (see the file comment), instead of one merged node per
   * level-zero column at least. */
  bool polarCaps = true;
};

struct FrameStats {
  std::size_t visited = 0;
  std::size_t visible = 0; ///< passed all three culling tests
  std::size_t drawn = 0;
  std::size_t created = 0; ///< nodes created this frame
  std::size_t removed = 0; ///< nodes removed by the node-count limit this frame
  std::size_t culledBackFace = 0;
  std::size_t culledFrustum = 0;
  std::size_t culledHorizon = 0;
  std::size_t splitsDeferred = 0; ///< nodes drawn unsplit because of maxSplitsPerFrame
  std::size_t nodes = 0;          ///< nodes in the tree after the update
  std::int32_t maxLevel = 0;      ///< deepest drawn level
};

/**
 * @brief One layer's tree. Not thread safe: the main thread owns it. Nodes are owned by the tree;
 * a Node* stays valid until the node is removed (removeChildren, or the node-count limit in
 * update()).
 */
class Quadtree {
public:
  /** The roots are the grid's valid level-zero tiles. */
  Quadtree(const Geodesy& geodesy, const TileGrid& grid, QuadtreeParams params = {});
  ~Quadtree();
  Quadtree(const Quadtree&) = delete;
  Quadtree& operator=(const Quadtree&) = delete;

  const TileGrid& grid() const noexcept { return grid_; }
  const QuadtreeParams& params() const noexcept { return params_; }
  void setParams(const QuadtreeParams& p) noexcept { params_ = p; }

  /** One frame: traverse, cull, LOD, create children (up to the split limit), fill drawList(),
   * then enforce the node-count limit. No allocation once the tree and the list have grown,
   * apart from the nodes created. */
  const FrameStats& update(const Camera& camera);

  std::uint64_t frame() const noexcept { return frame_; }
  const std::vector<Node*>& drawList() const noexcept { return drawList_; }
  const FrameStats& stats() const noexcept { return stats_; }
  std::size_t nodeCount() const noexcept { return nodeCount_; }
  const std::vector<std::unique_ptr<Node>>& roots() const noexcept { return roots_; }

  /** The keys of a node's children (2 to 4; invalid tiles of a partial dataset left out), in
   * slot order with the slot of each; empty at the deepest level. A cap's: the next cap and its
   * ring (see the file comment). */
  struct ChildKeys {
    std::vector<NodeKey> keys = std::vector<NodeKey>(4);
    std::vector<char> present = std::vector<char>(4, 0);
  };
  ChildKeys childKeys(const NodeKey& key) const noexcept;
  /** The sector a key covers (from the grid's integer edges). */
  Sector sectorOf(const NodeKey& key) const noexcept;
  /** Whether this tree makes polar caps, and whether a key is one (a whole top or bottom row). */
  bool capsEnabled() const noexcept { return caps_; }
  bool isCapKey(const NodeKey& key) const noexcept;
  /** The LOD parameters for a node's texture: a cap's is kCapTextureWidthFactor tiles wide. */
  LodParams lodFor(const NodeKey& key) const noexcept;

  /** Creates the children of a leaf (no-op otherwise; false at the deepest level), with the keys
   * of childKeys() (the static layout). */
  bool split(Node& node);
  /** Removes every descendant of node; every pointer to a removed node is relinked (to the
   * nearest remaining coarser neighbour) or nulled. */
  void removeChildren(Node& node);
  /** The neighbour the tree would link now (what Node::neighbour must equal; for tests). */
  Node* findNeighbour(const Node& node, Direction d) const noexcept;
  /** Terrain (issue #6): the height range of a sector (metres, exaggerated; what the node's
   * bounds, frustum and horizon tests must contain) used for every node created from now on, and
   * the horizon occluder's height (at or below the lowest terrain). Null: heights 0. */
  using HeightRange = std::function<std::pair<double, double>(const Sector&)>;
  void setTerrain(HeightRange range, double occluderHeightM);
  /** How far the flat triangles of the roots' meshes (meshSize rows, Node::meshSize columns) reach
   * below the ellipsoid (gridChordDepthM): the most any node's do, since a child's grid cells are
   * no larger than its parent's. The horizon occluder must lie at least this much below the
   * lowest terrain (setTerrain). */
  double chordDepthM(int meshSize) const;
  /** Recomputes the bounds of the nodes for which changed(sector) holds (new height data);
   * returns how many nodes' bounds changed. */
  std::size_t refreshHeights(const std::function<bool(const Sector&)>& changed);
  /** Visits every node, parents before children. */
  template <class F> void forEach(F&& f) const {
    for (const auto& r : roots_)
      if (r) forEachIn(*r, f);
  }

private:
  template <class F> static void forEachIn(Node& n, F& f) {
    f(n);
    for (auto& c : n.children_)
      if (c) forEachIn(*c, f);
  }
  void visit(Node& node, bool insideFrustum, const Camera& camera);
  /** Back face, frustum (skipped while insideFrustum, which it updates) and horizon, in that
   * order; false (and the culling counted) when one of them culls the node. */
  bool passesCulling(const Node& node, bool& insideFrustum, const Camera& camera);
  /** Whether a visible node is to be refined: its LOD test, or a widened row's half edges. */
  bool refines(const Node& node, const LodResult& lod, const Camera& camera) const;
  /** Whether to visit the node's children instead of drawing it: made (narrower where the LOD
   * test asks for it) within maxSplitsPerFrame. */
  bool descends(Node& node, const LodResult& lod, bool refine);
  void linkNeighbours(Node& node) noexcept;
  void relinkAround(const Node& node) noexcept;
  void relinkBorderingIn(Node& subtree, const Node& around, Direction side) noexcept;
  bool borders(const Node& q, const Node& p, Direction side) const noexcept;
  Node* rootContaining(std::int32_t level, std::int64_t row, std::int64_t col) const noexcept;
  void enforceNodeLimit();
  std::int64_t
  spanFor(std::int32_t level, std::int64_t row, std::int64_t parentSpanInChildCols) const noexcept;
  /** What spanFor() gives a node made by the static rule (its parent's width; a ring node's is
   * its root column's, a cap being wider than any merged row). */
  std::int64_t staticSpanOf(const Node& node) const noexcept;
  ChildKeys childKeysFor(const NodeKey& key, const Camera* camera, bool narrow = false) const;
  bool splitWith(Node& node, bool narrow);
  bool childrenAsWide(const Node& node) const noexcept;
  EastWestEdges eastWestEdges(const NodeKey& key) const noexcept;
  /** liftM: the height the node's LOD test measures at (evaluateLod: the camera's altitude
   * clamped to the node's height range), so both tests see the same texels. */
  bool fitsEastWest(const EastWestEdges& edges, const Camera& camera, double liftM) const noexcept;
  /** For a node not made yet: its height range from the terrain, as makeNode() will give it. */
  bool fitsEastWest(const NodeKey& key, const Camera& camera) const;
  bool visibleNow(const NodeKey& key, const Camera& camera) const;
  bool widerPaysOff(const NodeKey& wide, std::int64_t span, const Camera& camera) const;

  std::unique_ptr<Node> makeNode(const NodeKey& key, Node* parent);
  const Geodesy& geodesy_;
  HeightRange heightRange_;
  TileGrid grid_;
  QuadtreeParams params_;
  HorizonOccluder occluder_;
  bool globalLongitudes_ = false;
  bool caps_ = false;
  std::int64_t rootCols_ = 0;
  std::vector<std::unique_ptr<Node>> roots_; // row-major from the south-west, null if invalid
  std::vector<Node*> drawList_;
  std::vector<Node*> scratch_;
  FrameStats stats_;
  std::uint64_t frame_ = 0;
  std::size_t nodeCount_ = 0;
  int splitsThisFrame_ = 0;
  const Camera* splitCamera_ = nullptr; ///< during update(): the camera adaptive spans look from
};

} // namespace tellus::planet
