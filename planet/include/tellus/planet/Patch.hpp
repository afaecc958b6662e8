#pragma once
/**
 * @file Patch.hpp
 * @brief Geometry of one quadtree node: a lat/long tile sector on the Geodesy model.
 *
 * Everything in double precision, ECEF metres. Corners are SW, SE, NE, NW. At a pole (north = 90
 * or south = -90) the two corners on that edge are both the pole, so a polar node has three
 * distinct corners. The vertex grid stores positions relative to the node's centre (the surface
 * point at the sector's middle latitude and longitude) so that the GL layer can convert them to
 * float without losing the centimetres.
 */

#include <tellus/cache/TileGrid.hpp>
#include <tellus/planet/Geodesy.hpp>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <array>
#include <vector>

namespace tellus::planet {

struct BoundingSphere {
  glm::dvec3 centre{0.0};
  double radius = 0.0;
  bool contains(const glm::dvec3& p) const noexcept;
};

/** A box with orthonormal axes (east, north, up at the node's centre for NodeGeometry::box()):
 * the points x with |(x - centre).axes[i]| <= halfExtents[i]. Much tighter than the sphere for a
 * flat, wide patch, and for the polar wedges whose spheres are inflated by their arcs. */
struct OrientedBox {
  glm::dvec3 centre{0.0};
  std::array<glm::dvec3, 3> axes{};
  glm::dvec3 halfExtents{0.0};
  bool contains(const glm::dvec3& p) const noexcept;
};

enum Corner { SW = 0, SE = 1, NE = 2, NW = 3 };

/** A surface point (height 0) of the ellipsoid with semi-axes a, b (a sphere when a == b) and its
 * partial derivatives: ECEF metres per degree of latitude and of longitude. Closed form (no
 * GeographicLib): for the texel-to-pixel test, which needs the local size of a texel. */
struct SurfaceFrame {
  glm::dvec3 position{0.0};
  glm::dvec3 perDegLat{0.0};
  glm::dvec3 perDegLon{0.0};
};
SurfaceFrame surfaceFrame(double a, double b, double latDeg, double lonDeg) noexcept;

/**
 * @brief Corners, centre, normals and a conservative bounding sphere and box of a node.
 *
 * Both contain every point of the patch at every height in [minHeightM, maxHeightM] (terrain
 * later): the sphere is the smallest sphere around the middle of the sampled points' box that
 * holds 17 x 17 samples at both heights, the box those samples' extent in the node's east/north/up
 * frame, each grown by a bound on how far the patch strays from the bilinear interpolant of a
 * sample cell (cell size squared times the surface's second derivatives, over 8).
 */
class NodeGeometry {
public:
  /** Throws std::invalid_argument unless -90 <= south < north <= 90, -180 <= west < east <= 180
   * (tiles never cross the antimeridian), all finite, and minHeightM <= maxHeightM. */
  NodeGeometry(const Geodesy& geodesy,
               const Sector& sector,
               double minHeightM = 0.0,
               double maxHeightM = 0.0);

  const Sector& sector() const noexcept { return sector_; }
  double minHeightM() const noexcept { return minHeight_; }
  double maxHeightM() const noexcept { return maxHeight_; }
  bool touchesNorthPole() const noexcept { return sector_.north == 90.0; }
  bool touchesSouthPole() const noexcept { return sector_.south == -90.0; }

  /** Surface (height 0) corners, SW, SE, NE, NW; their unit normals. */
  const std::array<glm::dvec3, 4>& corners() const noexcept { return corners_; }
  const std::array<glm::dvec3, 4>& cornerNormals() const noexcept { return cornerNormals_; }
  /** surfaceFrame() at the corners: ECEF metres per degree of latitude and longitude there (at a
   * pole corner the longitude derivative is zero). */
  const std::array<SurfaceFrame, 4>& cornerFrames() const noexcept { return cornerFrames_; }
  /** 4, or 3 at one pole (2 for a sector spanning pole to pole). */
  int distinctCornerCount() const noexcept { return distinctCorners_; }
  /** Surface point at the middle latitude/longitude, and its normal. */
  const glm::dvec3& centre() const noexcept { return centre_; }
  const glm::dvec3& centreNormal() const noexcept { return centreNormal_; }
  /** Largest angle (radians) between centreNormal() and any normal of the patch (attained at a
   * corner; slightly rounded up). */
  double normalConeHalfAngleRad() const noexcept { return normalCone_; }
  const BoundingSphere& bounds() const noexcept { return bounds_; }
  /** A box around the same samples in the node's east/north/up frame, grown by the same bound
   * on the distance from any patch point to its nearest sample: it contains the patch at every
   * height in [min, max] like bounds(), and is the frustum test's second, tighter chance. */
  const OrientedBox& box() const noexcept { return box_; }
  /** Boxes around the west and the east half of the same samples (each in its own frame at its
   * half's middle longitude), each grown the same way: together they contain the patch, and
   * fit a wide polar wedge's arc much better than box(). */
  const std::array<OrientedBox, 2>& halfBoxes() const noexcept { return halfBoxes_; }
  /** The model's semi-axes (what the node was built on). */
  double equatorialRadiusM() const noexcept { return a_; }
  double polarRadiusM() const noexcept { return b_; }

private:
  Sector sector_;
  double minHeight_;
  double maxHeight_;
  double a_ = 0.0;
  double b_ = 0.0;
  std::array<glm::dvec3, 4> corners_{};
  std::array<glm::dvec3, 4> cornerNormals_{};
  std::array<SurfaceFrame, 4> cornerFrames_{};
  int distinctCorners_ = 4;
  glm::dvec3 centre_{0.0};
  glm::dvec3 centreNormal_{0.0};
  double normalCone_ = 0.0;
  BoundingSphere bounds_;
  OrientedBox box_;
  std::array<OrientedBox, 2> halfBoxes_{};
};

struct PatchVertex {
  glm::dvec3 position{0.0}; ///< relative to PatchMesh::centre
  glm::dvec3 normal{0.0};   ///< unit surface normal
  glm::dvec2 uvNode{0.0};   ///< 0..1 across the node (u east, v north)
  glm::dvec2 uvGlobal{0.0}; ///< ((lon + 180) / 360, (lat + 90) / 180)
};

/** An n x n vertex grid, rows from south to north, columns from west to east. */
struct PatchMesh {
  int n = 0;
  glm::dvec3 centre{0.0}; ///< ECEF; equals NodeGeometry::centre() for the same sector
  std::vector<PatchVertex> vertices;
  const PatchVertex& at(int row, int col) const {
    return vertices[static_cast<std::size_t>(row * n + col)];
  }
};

/** a + (b - a) * i / (count - 1), with both ends exact so that neighbours share edges bit for bit:
 * the one formula for every grid line of a node (meshes, terrain, edge fixing). */
double edgeLerp(double a, double b, int i, int count) noexcept;

/** Builds the grid at height 0. n must be 2^k + 1 with 1 <= k <= 10 (std::invalid_argument
 * otherwise, or for a sector NodeGeometry refuses). Edge rows and columns use the sector's edges
 * exactly, so neighbouring nodes share bit-identical edge vertices; a pole row is all the pole. */
PatchMesh buildPatchMesh(const Geodesy& geodesy, const Sector& sector, int n);

/**
 * How far below the ellipsoid the flat triangles of a grid reach: cols x rows points from edgeLerp
 * over the sector at height 0 (a mesh's grid, whatever its edge fixing does with the points), and
 * both diagonals of every cell, so that the triangulation does not matter. The depth is what the
 * horizon occluder needs, (1 - s) x a with s the smallest norm of a triangle point in the space
 * where the ellipsoid is the unit sphere (semi-axes a, a, b): an occluder of semi-axes
 * (a + h, a + h, b + h) with h at most the lowest vertex height less this depth lies under every
 * triangle. 0 for a 36-degree level-zero tile is wrong by ~600 m (33 points a side: a cell
 * 1.125 degrees, its diagonal's middle 614 m below the surface). cols and rows are at least 2.
 */
double gridChordDepthM(const Geodesy& geodesy, const Sector& sector, int cols, int rows);

} // namespace tellus::planet
