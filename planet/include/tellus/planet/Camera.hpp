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
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <array>
#include <span>

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

/** An angular fisheye (azimuthal equidistant) view: the domemaster of a planetarium. A direction
 * at angle theta from the view axis lands at radius theta x pixelsPerRadian from the image centre,
 * pixelsPerRadian = size / fov, so the image's inscribed circle is the cone of half-angle fov / 2.
 * Radially that is size / fov pixels per radian everywhere; along a circle around the axis the
 * map stretches by theta / sin(theta) (pi / 2 at the rim of a 180-degree dome). */
struct Fisheye {
  double fovDeg = 180.0; ///< (0, 360)
  /** The view axis turned up (towards the pose's up) from the pose's forward direction by this
   * many degrees, the image turned with it (a tilted dome). */
  double tiltDeg = 0.0;
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

  /** A fisheye camera (Fisheye): a sizePx x sizePx domemaster. forward() is the dome's axis (the
   * pose's forward turned up by the tilt), up() and right() the image's axes. Its frustum passes
   * everything (culling uses the cone of half-angle fov / 2, see Culling.hpp), its view matrix is
   * the dome's frame and its projection a 90-degree perspective along the axis (for callers that
   * need one; the LOD and culling use the fisheye). verticalFovDeg() is the fisheye's FOV. */
  Camera(const Geodesy& geodesy,
         const CameraPose& pose,
         int sizePx,
         const Fisheye& fisheye,
         double nearM = 0.1);
  /** The same camera position and pose turned to look along forward with this up (orthogonalised;
   * a cube face of a dome, a dome's projector channel), a perspective of this viewport and
   * vertical field of view. With a geodesy it casts viewportGround() as a perspective camera
   * does (a channel's LOD needs it); without, viewportGround() hits nothing. */
  Camera(const Camera& from,
         const glm::dvec3& forward,
         const glm::dvec3& up,
         Viewport viewport,
         double verticalFovDeg,
         const Geodesy* geodesy = nullptr);

  bool isFisheye() const noexcept { return fisheye_; }
  /** Fisheye: half the FOV (the cone of visible directions) and the image's pixels per radian
   * (radially). 0 for a perspective camera. */
  double fisheyeHalfAngleRad() const noexcept { return halfAngle_; }
  double pixelsPerRadian() const noexcept { return pixelsPerRadian_; }
  /** Pixels from the viewport's centre (x right, y up) of a world point: the perspective
   * division, or the fisheye map (radius theta x pixelsPerRadian). False when it cannot be
   * projected: at or behind the near plane, or (fisheye) nearer than the near distance or within
   * a degree of straight behind, where the map's direction is undefined. */
  bool projectPx(const glm::dvec3& world, glm::dvec2& px) const noexcept;

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
   * its centre, where the ray meets the model (fisheye: eight points of the rim, at 45-degree
   * steps from the right, and the centre). The texel-to-pixel test samples the ones inside a
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
  /** Fisheye: the ground seen along 16 directions around the axis at 6 angles from it (a sixth of
   * the half-FOV to the rim): the fisheye's largest texels lie where distance and the stretch
   * around the axis (theta / sin(theta)) combine, which a node's corners alone miss. */
  static constexpr std::size_t kDomeRays = 96;
  const std::array<GroundPoint, kDomeRays>& domeGround() const noexcept { return domeGround_; }

private:
  CameraPose pose_;
  Viewport viewport_;
  double vfovDeg_;
  double near_;
  glm::dvec3 position_{0.0}, forward_{0.0}, up_{0.0}, right_{0.0};
  glm::dmat4 view_{1.0}, projection_{1.0}, viewProjection_{1.0};
  Frustum frustum_;
  std::array<GroundPoint, 9> ground_{};
  std::array<GroundPoint, kDomeRays> domeGround_{};
  bool fisheye_ = false;
  double halfAngle_ = 0.0, pixelsPerRadian_ = 0.0;

  void buildMatrices();
  void castViewportGround(const Geodesy& geodesy);
  void castGroundRays(const Geodesy& geodesy,
                      std::span<const glm::dvec3> directions,
                      std::span<GroundPoint> out);
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
