#pragma once
/**
 * @file DomeDirect.hpp
 * @brief The direct dome method (issue #7): the fisheye map that shaders/planet.vert applies to
 * each vertex (TELLUS_FISHEYE), mirrored in double, and the error its straight triangle edges make.
 *
 * The direct method draws the domemaster in one pass: each node vertex goes through the angular
 * fisheye (azimuthal equidistant) map itself, and the rasteriser joins the vertices with straight
 * lines. The fisheye image of a straight 3D edge (a great-circle arc of directions) is curved, so
 * every drawn triangle is an approximation; the attributes are interpolated with w = the
 * distance from the eye, which is exact to first order in the edge's angle (the perspective-
 * correct weight of a segment seen under a small angle). directChordErrorPx() estimates what is
 * left for the nodes of a frame; the renderer draws the frame with the cube method when that
 * exceeds DomeOptions::directMaxErrorPx (docs/ACCURACY.md, "The direct dome").
 */

#include <tellus/planet/Camera.hpp>
#include <tellus/planet/Patch.hpp>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <span>

namespace tellus::planet {

class Node;

/** The clip margin beyond the rim, in pixels of the fisheye (gl_ClipDistance[0] = half-FOV +
 * margin - theta): triangles crossing the rim are cut a little outside the circle, which the mask
 * then paints black. */
inline constexpr double kDirectClipMarginPx = 4.0;

/** A point through the fisheye map, as the vertex shader computes it (in double here). */
struct FisheyeMapped {
  glm::dvec2 xy{0.0}; ///< image position in units of the circle's radius (1 = the rim)
  double theta = 0.0; ///< angle from the dome's axis, radians, [0, pi]
  double dist = 0.0;  ///< distance from the eye (the clip w: perspective-correct attributes)
};

/** q: a point relative to the eye in the dome's frame (x right, y up, the axis along -z).
 * theta = atan2(|q.xy|, -q.z) (stable near 0 and pi, unlike acos); xy = theta / halfAngleRad x
 * q.xy / |q.xy|, with the limit q.xy / |q| / halfAngleRad where |q.xy| <= 1e-6 |q| (there |q| =
 * -q.z to 1e-12 and theta / sin(theta) -> 1; -0.0 maps to the centre); behind the eye with
 * |q.xy| <= 1e-6 |q| (within 0.00006 degrees of straight behind) theta / (1e-6 |q|) instead:
 * finite, and clipped there in any case. */
FisheyeMapped fisheyeMap(const glm::dvec3& q, double halfAngleRad) noexcept;

/** A world (ECEF) point relative to a fisheye camera's eye in its dome frame (x = right(), y =
 * up(), z = -forward()): what the vertex shader's rotation uniform computes. */
glm::dvec3 toDomeFrame(const Camera& fisheye, const glm::dvec3& world) noexcept;

/** The error of one straight edge a-b (world points) in the direct method, in the fisheye's
 * pixels: the rasteriser puts the middle of the drawn edge at the middle of the two mapped ends,
 * and the perspective-correct attributes there belong to the edge's point at t = da / (da + db);
 * that point's true image lies this far away. 0 when the edge lies wholly beyond the clip angle
 * (its ends and its middle); +infinity when an end or that point cannot be mapped (nearer than the
 * near distance, or within 0.1 degree of straight behind) while the edge reaches into the cone,
 * or when both ends are beyond the clip angle and the middle is not (the clip would drop it). */
double directEdgeErrorPx(const Camera& fisheye, const glm::dvec3& a, const glm::dvec3& b) noexcept;

/** The largest directEdgeErrorPx() over a sample of a node's mesh cells (meshRows x meshSize
 * vertices; meshRows 0: meshSize x meshSize): 5 x 5 cells spread evenly over the node (its corners,
 * edges and centre among them) and the 3 x 3 cells around the point of the node nearest the camera
 * (where cells look largest), each cell's south and west sides and both diagonals (within 6% of
 * every cell's largest on the views of tests/planet/TestDome.cpp), the vertices at the height of
 * the ground below the camera (groundBelowM, metres above the model; terrain heights vary within a
 * node, so the estimate takes one representative height: the cells nearest the camera are the ones
 * that matter, and they lie near that height) clamped to the node's height range. 0 for a camera
 * that is not a fisheye. */
double directChordErrorPx(const Camera& fisheye,
                          const NodeGeometry& node,
                          int meshSize,
                          double groundBelowM = 0.0,
                          int meshRows = 0) noexcept;

/** The largest directChordErrorPx() over a frame's drawn nodes. */
double directChordErrorPx(const Camera& fisheye,
                          std::span<Node* const> nodes,
                          int meshSize,
                          double groundBelowM = 0.0) noexcept;

} // namespace tellus::planet
