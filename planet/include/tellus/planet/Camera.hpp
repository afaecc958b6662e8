#pragma once
/**
 * @file Camera.hpp
 * @brief The planet renderer's camera over a Geodesy model, all in double precision.
 *
 * Pose: geodetic latitude/longitude (degrees), altitude above the model's surface (metres, may be
 * negative), heading (degrees clockwise from north) and tilt (degrees from straight down: 0 looks
 * at the nadir, 90 at the horizon). Matrices are GLM double matrices (column-major, GL
 * conventions: the eye looks down -z). The projection is reversed-Z with an infinite far plane for
 * a 32-bit float depth buffer with glClipControl(GL_LOWER_LEFT, GL_ZERO_TO_ONE): depth is 1 at the
 * near plane and tends to 0 at infinity, so one frustum serves 1 m to 1e9 m. Floats come later,
 * camera-relative, in the GL layer.
 */

#include <tellus/planet/Geodesy.hpp>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <array>

namespace tellus::planet {

struct CameraPose {
  double latDeg = 0.0;     ///< [-90, 90]
  double lonDeg = 0.0;     ///< any finite value (wraps)
  double altitudeM = 1e7;  ///< above the model's surface; finite
  double headingDeg = 0.0; ///< clockwise from north; finite
  double tiltDeg = 0.0;    ///< 0 = nadir, 90 = horizon; [0, 180]
};

struct Viewport {
  int width = 1024; ///< pixels, > 0
  int height = 768; ///< pixels, > 0
};

/** A plane n.x + d = 0 with unit n; n.x + d >= 0 is the inner (visible) side. */
struct Plane {
  glm::dvec3 n{0.0};
  double d = 0.0;
  double signedDistance(const glm::dvec3& p) const noexcept { return glm::dot(n, p) + d; }
};

/** The five planes of an infinite-far frustum in world (ECEF) space: left, right, bottom, top,
 * near. */
struct Frustum {
  enum Index { Left = 0, Right, Bottom, Top, Near };
  std::array<Plane, 5> planes{};
};

/** Immutable once built; cheap to copy. Throws std::invalid_argument for a pose, viewport, field
 * of view or near distance that is out of range or not finite. */
class Camera {
public:
  Camera(const Geodesy& geodesy,
         const CameraPose& pose,
         Viewport viewport,
         double verticalFovDeg = 45.0,
         double nearM = 0.1);

  const CameraPose& pose() const noexcept { return pose_; }
  Viewport viewport() const noexcept { return viewport_; }
  double verticalFovDeg() const noexcept { return vfovDeg_; }
  double nearM() const noexcept { return near_; }

  /** ECEF position (metres) and unit vectors of the eye frame in ECEF. */
  const glm::dvec3& position() const noexcept { return position_; }
  const glm::dvec3& forward() const noexcept { return forward_; }
  const glm::dvec3& up() const noexcept { return up_; }
  const glm::dvec3& right() const noexcept { return right_; }

  const glm::dmat4& view() const noexcept { return view_; }
  const glm::dmat4& projection() const noexcept { return projection_; }
  const glm::dmat4& viewProjection() const noexcept { return viewProjection_; }

  /** Planes extracted from viewProjection() (Gribb/Hartmann), normalised. */
  const Frustum& frustum() const noexcept { return frustum_; }

  /** Clip coordinates of a world point (w = distance in front of the eye along forward()). */
  glm::dvec4 toClip(const glm::dvec3& world) const noexcept;

  /** The surface point (height 0 on the model) seen through a point of the viewport's border or
   * its centre, where the ray meets the model. The texel-to-pixel test samples the ones inside a
   * node: the nearest visible ground of a tilted view lies on the viewport's bottom edge, inside a
   * large node whose corners are all far away. */
  struct GroundPoint {
    bool hit = false;
    double latDeg = 0.0;
    double lonDeg = 0.0;
  };
  /** Corners (bottom-left, bottom-right, top-right, top-left), the midpoints of the bottom, right,
   * top and left edges, and the centre. */
  const std::array<GroundPoint, 9>& viewportGround() const noexcept { return ground_; }

private:
  CameraPose pose_;
  Viewport viewport_;
  double vfovDeg_;
  double near_;
  glm::dvec3 position_{0.0}, forward_{0.0}, up_{0.0}, right_{0.0};
  glm::dmat4 view_{1.0}, projection_{1.0}, viewProjection_{1.0};
  Frustum frustum_;
  std::array<GroundPoint, 9> ground_{};
};

/** The near plane distance for a camera at this altitude above the ground: 0.1 m, but less for a
 * low camera (never under 1 mm): half the smallest eye distance (w) at which any ray of the view
 * can meet flat ground that far below, whatever the tilt (altitude / sqrt(1 + tan^2(fov / 2) (1 +
 * aspect^2)), halved). Otherwise the ground under a camera 0.1 m up is at or in front of the near
 * plane: clipped (holes) and taken by the LOD for corners behind the eye (split to the deepest
 * level). Reversed-Z float depth keeps its relative precision whatever the near distance.
 * Altitudes at or below 0 (inside the model: no ground below) and NaN give 0.1 m. */
double
nearDistanceFor(double altitudeM, double verticalFovDeg = 45.0, double aspect = 1.0) noexcept;

/** Reversed-Z, infinite far, depth in [0, 1] (glClipControl ZERO_TO_ONE): clip z = near, clip w =
 * -z_eye, so NDC depth = near / distance. */
glm::dmat4
reversedZInfinitePerspective(double verticalFovRad, double aspect, double nearM) noexcept;

} // namespace tellus::planet
