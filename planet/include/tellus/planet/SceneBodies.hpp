#pragma once
/**
 * @file SceneBodies.hpp
 * @brief Several bodies in one scene (issue 26, "The Earth and the Moon together"): where another
 * body is and how it is turned, in the fixed frame of the body the camera orbits, at the scene's
 * time, and the coarse globe it is drawn as (docs/design/bodies.md, "Several bodies").
 *
 * Frames: the scene's frame is the orbited body's fixed frame (ECEF for the Earth, the IAU frame
 * for the Moon and Mars: astro::celestialToBodyFixed), in metres, origin at its centre; the
 * camera, the quadtree and the lighting live there. Another body B seen from the orbited body A
 * at time t: its centre is M_A (p_B - p_A) and a point q of B's fixed frame is at
 * M_A M_B^T q + centre, with p the geocentric J2000 positions (astro::bodyPositionCelestial) and
 * M the rotations celestial -> fixed. All in double.
 *
 * The distant body is drawn as one globe of its own (DistantGlobe): a latitude-longitude grid of
 * its ellipsoid (planetographic latitudes, as its tiles), with the uv of an equirectangular global
 * image (north up, -180 at the left). Model only what the scene needs: the other body is at least
 * ~350,000 km away whenever the camera is near its own body, where a 128 x 64 grid's chords are
 * under 1.2e-3 of its radius (a 0.05 pixel error for a 40-pixel disc), and a disc a few pixels
 * wide takes a coarser grid of the same vertices (strideFor); flying close to it means
 * orbiting it instead (the camera's body changes: its quadtree, terrain and layers take over).
 * Its vertices are made camera-relative on the CPU in double each frame (centre - eye, plus the
 * rotated body-fixed offset) and only then narrowed to float: nothing Earth-Moon-sized reaches a
 * float.
 *
 * Pure, GL-free; a DistantGlobe is immutable once made.
 */

#include <tellus/planet/Body.hpp>
#include <tellus/planet/Ephemeris.hpp>

#include <glm/mat3x3.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <optional>
#include <string>
#include <vector>

namespace tellus::planet {

/** A body that can share a scene: one with an ephemeris (earth, moon, mars); nullopt for a
 * configured body (no orbit known). */
std::optional<astro::EphemerisBody> sceneBodyOf(const Body& body) noexcept;

/** Another body in the scene's frame at one instant. */
struct BodyPlacement {
  glm::dvec3 centre{0.0};   ///< its centre in the scene's frame, metres
  glm::dmat3 rotation{1.0}; ///< its fixed frame -> the scene's frame
};

/** Where `other` is and how it is turned in `frame`'s fixed frame at a UTC instant (POSIX
 * seconds). The same body gives the identity at the origin. */
BodyPlacement
placeBody(astro::EphemerisBody frame, astro::EphemerisBody other, double unixSeconds) noexcept;

/** A body drawn whole as a coarse globe (see the file comment). */
class DistantGlobe {
public:
  /** slices x stacks quads (slices >= 8, stacks >= 4; the seam column is doubled for its uv). */
  DistantGlobe(const Body& body, int slices = 128, int stacks = 64);
  const Body& body() const noexcept { return body_; }
  /** Vertices (slices + 1) x (stacks + 1), rows from the south pole. */
  std::size_t vertexCount() const noexcept { return fixed_.size(); }
  /** Triangles' vertex indices (the poles' degenerate ones left out) of the grid taken every
   * `stride` vertices each way: 1, 2, 4 or 8 while that leaves at least 8 x 4 quads (a coarser
   * stride gives stride 1's). The vertices are the same for every stride. */
  const std::vector<unsigned>& indices(int stride = 1) const noexcept;
  /** The coarsest stride whose chords stay within 0.1 pixel of the ellipsoid on a disc of
   * `radiusPx` pixels (n slices miss it by R (1 - cos(pi / n)), about R pi^2 / (2 n^2)): a body a
   * few pixels wide is drawn with 16 x 8 quads, not 128 x 64. */
  int strideFor(double radiusPx) const noexcept;
  /** Per vertex 8 floats: the position relative to `eye` (the scene's frame, metres), the
   * ellipsoid's unit normal in the scene's frame, the uv. Written into `out` (resized). The
   * subtraction is in double; only its result is narrowed. Only the vertices indices(stride)
   * draws are written (rows and columns that are multiples of stride); the others keep what
   * `out` held. */
  void cameraRelative(const BodyPlacement& placement,
                      const glm::dvec3& eye,
                      std::vector<float>& out,
                      int stride = 1) const;
  /** Vertices per row (slices + 1): row j starts at vertex j * rowLength(). */
  std::size_t rowLength() const noexcept { return static_cast<std::size_t>(slices_) + 1; }
  /** The body-fixed position (metres) and unit normal of vertex i, and its uv. */
  const glm::dvec3& fixedPosition(std::size_t i) const noexcept { return fixed_[i]; }
  const glm::dvec3& fixedNormal(std::size_t i) const noexcept { return normals_[i]; }
  const glm::vec2& uv(std::size_t i) const noexcept { return uv_[i]; }

private:
  Body body_;
  std::vector<glm::dvec3> fixed_;
  std::vector<glm::dvec3> normals_;
  std::vector<glm::vec2> uv_;
  int slices_ = 0;
  std::vector<std::vector<unsigned>> indices_; ///< [k]: stride 2^k
};

} // namespace tellus::planet
