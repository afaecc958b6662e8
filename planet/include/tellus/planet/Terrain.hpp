#pragma once
/**
 * @file Terrain.hpp
 * @brief Heights on the quadtree (issue #6, thesis 3.4 and 4.5): the held elevation tiles as one
 * height function, and node meshes displaced by it with crack-free edges. GL-free.
 *
 * Heights are a pure function of (latitude, longitude, the set of elevation tiles held): at a point
 * the deepest held level wins and is sampled bilinearly across tile borders (a neighbour tile of
 * that level where it is held, the tile's own edge texels where it is not). Two nodes that evaluate
 * the same point therefore get the same height, whichever heightmap each of them "owns": same-level
 * neighbours share their edges bit for bit (thesis figure 19 without copying values around), and a
 * node without its own tiles reads an ancestor level's (thesis 4.5.1). Where neighbours differ in
 * level, the finer node's edge vertices are moved onto the coarser node's edge (its chords) by
 * linear interpolation, and zero-area triangles made of the coarse edge's vertices and the moved
 * ones close the T-junctions (thesis figures 20 and 21), so the mesh is watertight for the
 * rasterizer too. No skirts.
 */

#include <tellus/cache/TileGrid.hpp>
#include <tellus/cache/TileKey.hpp>
#include <tellus/planet/Geodesy.hpp>
#include <tellus/planet/Geoid.hpp>
#include <tellus/planet/Patch.hpp>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

namespace tellus::planet {

/** How an elevation tile's raw samples become metres: metres = raw * scale + offset; samples
 * equal to noData become 0 (sea level). */
struct HeightEncoding {
  double scale = 1.0;
  double offset = 0.0;
  std::optional<double> noData;
};

/** One elevation tile in metres: width x height samples, row 0 at the north, pixel-is-area over the
 * tile's sector (a sample is the centre of its cell, as WMS and World Wind deliver them). */
struct HeightTile {
  TileKey key;
  int width = 0;
  int height = 0;
  std::vector<float> metres;
  float minM = 0.0f;
  float maxM = 0.0f;
};

/** Raw samples (row 0 north) to a HeightTile: applies the encoding, sets min/max. Errors for a
 * size mismatch or a non-finite result. */
std::expected<HeightTile, std::string> heightTileFromSamples(const TileKey& key,
                                                             int width,
                                                             int height,
                                                             std::span<const double> raw,
                                                             const HeightEncoding& encoding);

/** World Wind's BIL16: little-endian signed 16-bit samples, row 0 north. */
std::expected<HeightTile, std::string> decodeBil16(const TileKey& key,
                                                   int width,
                                                   int height,
                                                   std::span<const std::byte> bytes,
                                                   const HeightEncoding& encoding);

/**
 * Moves a tile of mean-sea-level heights (H) onto the ellipsoid: each sample gets the geoid
 * undulation at its own centre (pixel-is-area over `sector`, the tile's sector), h = H + N, and
 * min/max follow. A pure function of the tile, its sector and the geoid, done once per tile where
 * raw values become metres (HeightStreamer's worker callback, `tellus height`), so heights stay a
 * pure function of the tiles held and neighbours still agree bit for bit (they evaluate the same
 * samples). Between samples the height field's bilinear interpolation interpolates N too: exact
 * inside a 30' geoid cell, centimetres off at its lines for deep levels, decimetres for level 0
 * (samples 0.13 degrees apart; docs/ACCURACY.md). With the datum off nothing changes.
 */
void applyVerticalDatum(HeightTile& tile, const Sector& sector, const VerticalDatum& datum);

/**
 * @brief The elevation tiles held, on their own grid (an elevation layer's grid need not be the
 * imagery's), and the height function over them. Not thread safe: the main thread owns it.
 */
class HeightField {
public:
  explicit HeightField(const TileGrid& grid);

  const TileGrid& grid() const noexcept { return grid_; }
  /** Adds or replaces a tile (its size must be the grid's tile size; otherwise ignored, false). */
  bool insert(HeightTile tile);
  bool contains(const TileKey& key) const noexcept { return tiles_.contains(key); }
  std::size_t size() const noexcept { return tiles_.size(); }
  /** Bumped by every insert, and by every setTime while a tile fades in. */
  std::uint64_t generation() const noexcept { return generation_; }

  /**
   * Fading in (issue 23, "No popping"; docs/design/popping.md): with fadeSeconds > 0 a tile
   * inserted at time t (the last setTime) blends in over [t, t + fadeSeconds]: where it is the
   * deepest level held, heightAt is h_below + w (h_tile - h_below), w = (now - t) / fadeSeconds
   * clamped to [0, 1] and h_below what the next coarser levels held give there (fading alike), so
   * a height tile that arrives moves the surface continuously instead of at once. Heights stay a
   * pure function of the tiles held and the time: two nodes that evaluate a point still agree.
   * 0 (the default): a tile shows at once.
   */
  void setFade(double fadeSeconds) noexcept { fadeS_ = fadeSeconds > 0.0 ? fadeSeconds : 0.0; }
  /** The time (seconds, any origin, not decreasing) of the next inserts and of heightAt; every
   * fading tile's sector counts as changed (changedSince) when the time moves, and a tile whose
   * fade has ended stops fading. */
  void setTime(double nowS);
  /** Some tile is fading in. */
  bool fading() const noexcept { return !fading_.empty(); }
  /** Some fading tile reaches the sector (its bilinear reach included). */
  bool fadingOver(const Sector& sector) const noexcept;

  /**
   * Height in metres at a point; 0 where no level holds a tile. NaN or infinite input gives NaN.
   * Latitude is clamped to [-90, 90]; at a pole the longitude is ignored (the pole is one point);
   * longitude wraps, and -180 and 180 are the same meridian.
   */
  double heightAt(double latDeg, double lonDeg) const noexcept;
  /** The level heightAt reads at a point (-1: none held). */
  int levelAt(double latDeg, double lonDeg) const noexcept;
  /** A range containing heightAt everywhere in the sector (0 included where some part may have no
   * tile). */
  std::pair<double, double> rangeOver(const Sector& sector) const;
  /** The lowest height of any tile held (0 if none is lower). */
  double lowest() const noexcept { return lowest_; }
  /** Whether heightAt may differ, anywhere in the sector, from what it was at generation g. */
  bool changedSince(std::uint64_t g, const Sector& sector) const noexcept;
  /** The coarsest level whose samples are at most spacingDeg apart (the deepest level if none),
   * i.e. the heightmap a node whose grid lines are spacingDeg apart needs (thesis 4.5.1: one
   * heightmap serves several node levels). */
  int levelForSpacing(double spacingDeg) const noexcept;

private:
  double sample(const HeightTile& tile, double latDeg, double lonDeg) const noexcept;
  /** The point normalised (latitude clamped, a pole one point, longitude wrapped). */
  void normalise(double& latDeg, double& lonDeg) const noexcept;
  /** The deepest tile held at a normalised point of a level at most maxLevel (null: none). */
  const HeightTile* deepestAt(double latDeg, double lonDeg, int maxLevel) const noexcept;
  /** heightAt at a normalised point from the levels up to maxLevel, fades applied. */
  double blendedAt(double latDeg, double lonDeg, int maxLevel) const noexcept;
  /** A tile's fade weight at the current time: 1 unless it is fading in. */
  double weight(const TileKey& key) const noexcept;
  /** The sector a tile's values reach (one sample beyond its own: the bilinear taps). */
  Sector reachOf(const TileKey& key) const;
  void recordChange(const Sector& sector);
  TileGrid grid_;
  bool globalLongitudes_ = false;
  std::unordered_map<TileKey, HeightTile, TileKeyHash> tiles_;
  std::vector<std::size_t> perLevel_;
  int deepest_ = -1;
  double lowest_ = 0.0;
  std::uint64_t generation_ = 0;
  struct Change {
    std::uint64_t generation;
    Sector sector; // the tile's sector grown by one sample each way (bilinear reach)
  };
  std::vector<Change> history_;
  std::uint64_t historyFloor_ = 0; // generations at or below this were compacted away
  double fadeS_ = 0.0;
  double nowS_ = 0.0;
  std::unordered_map<TileKey, double, TileKeyHash> fading_; ///< key -> the time it arrived
};

/** The node across one side whose edge is coarser than ours (the finer side adapts). */
struct EdgeAdapt {
  bool active = false;
  Sector coarse{}; ///< the coarser node's sector
  /** The coarser node's n vertices along the shared side as it draws them (its own edge fixing
   * included: a corner of it may lie on an even coarser node's chord), west to east or south to
   * north. Empty: computed from the height function at its grid points. */
  std::vector<glm::dvec3> coarseVertices;
  /** Geomorphing (Morph.hpp): the coarser node's morph of those vertices as it draws them, xyz its
   * morphDelta and w its morphExtentM. Empty: from coarseVertices (even ones 0, odd ones onto the
   * chord of their neighbours) with the coarse node's extent, when the mesh morphs at all. */
  std::vector<glm::dvec4> coarseMorph{};
  friend bool operator==(const EdgeAdapt&, const EdgeAdapt&) = default;
};

/** Heights in metres (already exaggerated) of the mesh's points. */
using HeightFunction = std::function<double(double latDeg, double lonDeg)>;

struct TerrainVertex {
  glm::dvec3 position{0.0}; ///< ECEF, metres (the GL layer splits it into two floats)
  glm::vec3 normal{0.0f};   ///< unit normal of the displaced surface
  glm::dvec2 uvNode{0.0};   ///< 0..1 across the node (u east, v north)
  /** Geomorphing (Morph.hpp): where the parent's coarser mesh puts this vertex, less its
   * position (ECEF metres), and that parent's north-south extent (metres; 0: no morph). */
  glm::dvec3 morphDelta{0.0};
  double morphExtentM = 0.0;
};

/**
 * An n x n grid (rows south to north, columns west to east) followed by any extra vertices the
 * zero-area triangles need, and the triangle list in four quadrant ranges (SW, SE, NW, NE) so a
 * node drawn in parts (children's textures) draws each part of its own geometry; each range also
 * holds the zero-area triangles along its outer edges.
 */
struct TerrainMesh {
  int n = 0;    ///< vertices a row (west to east)
  int rows = 0; ///< rows (south to north): n, or fewer for a polar cap (buildTerrainMesh's rows)
  std::vector<TerrainVertex> vertices;
  std::vector<std::uint32_t> indices;
  std::array<std::uint32_t, 5> quadrantStart{}; ///< index offsets of SW, SE, NW, NE; [4] = end
  std::size_t zeroAreaTriangles = 0;
  /** Triangles that fill a coarse edge's kink between two of our vertices (a polar cap's rim
   * vertex strictly between two of a ring node's): they have area. */
  std::size_t kinkTriangles = 0;
  double minHeightM = 0.0; ///< over the grid's vertices
  double maxHeightM = 0.0;
};

/**
 * Builds a node's mesh: grid points from edgeLerp over the sector, displaced along the ellipsoid
 * normal by height(lat, lon) (toEcef(lat, lon, h)); normals from the displaced surface (central
 * differences over a ring of points one step outside the node, so neighbours agree); edges[d]
 * (indexed by Direction: North, East, South, West) moves that edge onto the coarser neighbour's
 * chords and adds the zero-area triangles. n as buildPatchMesh (2^k + 1, 3..1025).
 * rows: the grid's rows when they differ from n (2^k + 1, 3..1025; 0 = n): a polar cap draws its
 * rim, a whole parallel, with n = 4 x 32 + 1 columns but its latitude span with the 33 rows every
 * node of its level has. Edge fixing needs a square grid (rows == n); a cap has no neighbour.
 * morphExtentM > 0 (a square grid): geomorphing's targets (Morph.hpp, setGridMorph) with that
 * extent; an adapted side's vertices then take the coarse node's morph (EdgeAdapt::coarseMorph)
 * like their positions: a coarse vertex its own, one between two its chord's (the odd end's
 * extent); onto a polar cap's rim none. 0: no morph (deltas 0), but adapted sides still follow a
 * coarse node's given coarseMorph.
 */
TerrainMesh buildTerrainMesh(const Geodesy& geodesy,
                             const Sector& sector,
                             int n,
                             const HeightFunction& height,
                             const std::array<EdgeAdapt, 4>& edges,
                             int rows = 0,
                             double morphExtentM = 0.0);

} // namespace tellus::planet
