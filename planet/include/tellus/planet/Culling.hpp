#pragma once
/**
 * @file Culling.hpp
 * @brief The three per-node culling tests (thesis 4.3), all conservative: a node any point of
 * which the camera can see is never culled.
 */

#include <tellus/planet/Camera.hpp>
#include <tellus/planet/Patch.hpp>

namespace tellus::planet {

enum class FrustumResult { Outside, Intersecting, Inside };

/** Sphere against the five planes of the infinite frustum. Inside means the children need no
 * frustum test. */
FrustumResult classify(const Frustum& frustum, const BoundingSphere& sphere) noexcept;

/** The box against the five planes (its support along each plane normal). */
FrustumResult classify(const Frustum& frustum, const OrientedBox& box) noexcept;

/** True when the box lies wholly in front of the near plane and its projection misses the
 * viewport: the separating-axis test in screen space over the viewport's axes and the normals of
 * the box's twelve projected edges (the projected box's outline is made of them), exact for the
 * projected box. Catches what plane tests cannot: a node off a corner of the view, outside no
 * single plane. False (not provably outside) when a box corner is at or behind the near plane. */
bool projectsOutsideViewport(const Camera& camera, const OrientedBox& box) noexcept;

/** A fisheye camera's frustum test: the sphere against the cone of half-angle fov / 2 around the
 * view axis (the directions the domemaster shows; for a FOV over 180 degrees not convex, all but a
 * cone behind). Outside when every direction to the sphere is more than the half-angle from the
 * axis, Inside when every one is within it; a sphere around the eye intersects. */
FrustumResult classifyCone(const Camera& camera, const BoundingSphere& sphere) noexcept;

/** The frustum test of a node (a fisheye camera: classifyCone on its sphere): its sphere, then,
 * when the sphere only intersects, its box against the planes, then the projected box against the
 * viewport, then its two half boxes (planes and viewport). Outside or Inside when any of them says
 * so (all contain the patch; Outside for the halves when both are). */
FrustumResult classifyNode(const Camera& camera, const NodeGeometry& node) noexcept;

/**
 * @brief Back-face test on the node's normals.
 *
 * True (cull) only when the camera is below the tangent plane of every point of the patch: the
 * patch's normals lie in a cone around the centre normal whose half-angle is the largest corner
 * normal's angle (NodeGeometry::normalConeHalfAngleRad, the margin for curvature), and for a
 * point p with normal n on the ellipsoid n.p is at least the smallest support value over the
 * sector's latitudes; the test requires n.camera < that for every n in the cone. On a convex
 * surface such a point is hidden by the body itself (so a camera below the ellipsoid sees no
 * relief-free node). With relief (maxHeight > minHeight) terrain normals are not ellipsoid
 * normals and a peak can be seen over the limb, so the test then never culls and leaves it to the
 * horizon test.
 */
bool isBackFacing(const Camera& camera, const NodeGeometry& node) noexcept;

/**
 * @brief Horizon culling against an occluder ellipsoid with semi-axes (a + h, a + h, b + h).
 *
 * h (occluderHeightM) must be at or below the lowest terrain anywhere on the planet (0 for the
 * imagery-only globe, e.g. -11000 with bathymetry), less the depth of the meshes' chords under the
 * ellipsoid (gridChordDepthM, Quadtree::chordDepthM: ~600 m for 36-degree tiles of 33 x 33). In the
 * occluder's scaled space (the occluder is the unit sphere) the node's bounding sphere is enlarged
 * to a sphere by the largest scale, and culled only when it lies strictly inside the camera's
 * shadow cone of the unit sphere and strictly beyond the plane of the tangent circle. A camera
 * inside the occluder (below it), or inside the node's sphere, culls nothing.
 */
struct HorizonOccluder {
  double equatorialRadiusM = 0.0;
  double polarRadiusM = 0.0;
  HorizonOccluder(const Geodesy& geodesy, double occluderHeightM = 0.0) noexcept;
  bool isOccluded(const glm::dvec3& cameraEcef, const BoundingSphere& sphere) const noexcept;
  /** True when the segment from camera to point passes through the occluder's interior (the
   * brute-force reference the tests compare against). */
  bool segmentHitsOccluder(const glm::dvec3& cameraEcef, const glm::dvec3& point) const noexcept;
  /** For a polar cap (a node spanning every longitude from a pole): true when the whole cap, at
   * every height up to its maximum, lies beyond the horizon. Exact where the sphere test is
   * loose: in scaled space the cap is the part of a sphere of radius r (the cap's highest point's
   * scaled distance from the centre, bounded over its latitudes) within angle rho of the pole, and
   * a point of it is visible only if its angle from the camera's direction is at most
   * acos(1 / |camera|) + acos(1 / r). False for any other node. */
  bool isCapOccluded(const glm::dvec3& cameraEcef, const NodeGeometry& node) const noexcept;
};

/** All three, the order of the thesis: back-face, frustum, horizon. */
struct CullResult {
  bool visible = false;
  FrustumResult frustum = FrustumResult::Outside;
};
CullResult
cullNode(const Camera& camera, const NodeGeometry& node, const HorizonOccluder& occluder) noexcept;

} // namespace tellus::planet
