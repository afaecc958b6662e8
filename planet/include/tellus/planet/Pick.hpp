#pragma once
/**
 * @file Pick.hpp
 * @brief The point on the globe under a pixel (issue 24: the value under the cursor in `view`;
 * the renderer-versus-CPU colour tests): the ray through the pixel, and where it first meets the
 * ellipsoid (raised by a height). GL-free, double precision.
 *
 * Pixels are given as offsets from the image's centre in pixels (x right, y up), so the caller
 * says where its image's centre lies (a window's cursor at (cx, cy) from the top-left corner of a
 * W x H image: dx = cx - W / 2, dy = H / 2 - cy; a pixel's centre is at +0.5). A perspective
 * camera: the ray through the image plane at that offset (the vertical field of view over the
 * viewport's height). A fisheye (a domemaster, Camera.hpp): the direction at angle r /
 * pixelsPerRadian from the axis, turned by the offset's angle around it; none outside the cone.
 *
 * The ellipsoid raised by h: semi-axes a + h and b + h (h = 0: the Geodesy's own surface; a
 * sphere's a = b). The intersection scales z by (a + h) / (b + h) to meet a sphere, then solves
 * the quadratic with the numerically stable root (no cancellation from a camera 1e9 m away).
 */

#include <tellus/planet/Camera.hpp>
#include <tellus/planet/Geodesy.hpp>

#include <glm/vec3.hpp>

#include <optional>

namespace tellus::planet {

/** The unit direction (ECEF) of the ray through the pixel at (dxPx, dyPx) from the image's centre
 * (x right, y up); nullopt outside a fisheye's circle. */
std::optional<glm::dvec3> pixelRay(const Camera& camera, double dxPx, double dyPx) noexcept;

/** The first point in front of `origin` along the unit `direction` where it meets the ellipsoid
 * raised by heightM (the distance along the ray, metres); nullopt when it misses or the surface
 * lies behind. An origin inside the surface gives the way out. */
std::optional<double> rayEllipsoidDistance(const Geodesy& geodesy,
                                           const glm::dvec3& origin,
                                           const glm::dvec3& direction,
                                           double heightM = 0.0) noexcept;

/** The geodetic point (heightM = heightM) seen through the pixel at (dxPx, dyPx) from the image's
 * centre; nullopt when the ray misses the globe (sky) or leaves a fisheye's circle. */
std::optional<Geodetic> pickGlobe(const Camera& camera,
                                  const Geodesy& geodesy,
                                  double dxPx,
                                  double dyPx,
                                  double heightM = 0.0) noexcept;

} // namespace tellus::planet
