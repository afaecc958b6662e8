#include <tellus/planet/Camera.hpp>

#include <GeographicLib/Math.hpp>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace tellus::planet {

namespace {

glm::dvec3 toVec(const Ecef& e) {
  return {e.x, e.y, e.z};
}

Plane normalised(const glm::dvec4& row) {
  const glm::dvec3 n{row.x, row.y, row.z};
  const double len = glm::length(n);
  return Plane{n / len, row.w / len};
}

} // namespace

double nearDistanceFor(double altitudeM, double verticalFovDeg, double aspect) noexcept {
  constexpr double kNear = 0.1, kFloor = 1e-3;
  if (!(altitudeM > 0.0)) return kNear;
  const double t = std::tan(verticalFovDeg * std::numbers::pi / 360.0);
  // The longest ray direction with w = 1 (the view's corner): |d| = sqrt(1 + t^2 (1 + aspect^2)).
  double steepest = std::sqrt(1.0 + t * t * (1.0 + aspect * aspect));
  if (!std::isfinite(steepest) || steepest < 1.0) steepest = 1.0;
  return std::clamp(0.5 * altitudeM / steepest, kFloor, kNear);
}

glm::dmat4
reversedZInfinitePerspective(double verticalFovRad, double aspect, double nearM) noexcept {
  const double f = 1.0 / std::tan(verticalFovRad / 2.0);
  glm::dmat4 p(0.0);
  p[0][0] = f / aspect;
  p[1][1] = f;
  p[2][3] = -1.0;  // clip w = -z_eye
  p[3][2] = nearM; // clip z = near
  return p;
}

Camera::Camera(const Geodesy& geodesy,
               const CameraPose& pose,
               Viewport viewport,
               double verticalFovDeg,
               double nearM)
    : pose_(pose), viewport_(viewport), vfovDeg_(verticalFovDeg), near_(nearM) {
  if (!(std::abs(pose.latDeg) <= 90.0) || !std::isfinite(pose.lonDeg) ||
      !std::isfinite(pose.altitudeM) || !std::isfinite(pose.headingDeg) ||
      !(pose.tiltDeg >= 0.0 && pose.tiltDeg <= 180.0))
    throw std::invalid_argument("Camera: pose out of range or not finite");
  if (viewport.width <= 0 || viewport.height <= 0)
    throw std::invalid_argument("Camera: viewport must be at least 1x1 pixels");
  if (!(verticalFovDeg > 0.0 && verticalFovDeg < 180.0))
    throw std::invalid_argument("Camera: vertical field of view must be in (0, 180) degrees");
  if (!(nearM > 0.0 && std::isfinite(nearM)))
    throw std::invalid_argument("Camera: near distance must be positive and finite");

  position_ = toVec(geodesy.toEcef(pose.latDeg, pose.lonDeg, pose.altitudeM));
  // Local east/north/up; east from the longitude alone stays defined at the poles.
  double sphi = 0, cphi = 0, slam = 0, clam = 0, sh = 0, ch = 0, st = 0, ct = 0;
  GeographicLib::Math::sincosd(pose.latDeg, sphi, cphi);
  GeographicLib::Math::sincosd(pose.lonDeg, slam, clam);
  GeographicLib::Math::sincosd(pose.headingDeg, sh, ch);
  GeographicLib::Math::sincosd(pose.tiltDeg, st, ct);
  const glm::dvec3 upLocal{cphi * clam, cphi * slam, sphi};
  const glm::dvec3 east{-slam, clam, 0.0};
  const glm::dvec3 north = glm::cross(upLocal, east);
  const glm::dvec3 headingDir = ch * north + sh * east;
  forward_ = glm::normalize(ct * -upLocal + st * headingDir);
  up_ = glm::normalize(st * upLocal + ct * headingDir);
  right_ = glm::normalize(glm::cross(forward_, up_));

  buildMatrices();
  castViewportGround(geodesy);
}

void Camera::castViewportGround(const Geodesy& geodesy) {
  const double aspect =
      static_cast<double>(viewport_.width) / static_cast<double>(viewport_.height);
  const double ty = std::tan(0.5 * vfovDeg_ * std::numbers::pi / 180.0), tx = ty * aspect;
  constexpr std::array<std::array<double, 2>, 9> ndc{
      {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}, {0, -1}, {1, 0}, {0, 1}, {-1, 0}, {0, 0}}};
  std::array<glm::dvec3, 9> dirs{};
  for (std::size_t i = 0; i < ndc.size(); ++i)
    dirs[i] = forward_ + ndc[i][0] * tx * right_ + ndc[i][1] * ty * up_;
  castGroundRays(geodesy, dirs, ground_);
}

Camera::Camera(const Geodesy& geodesy,
               const CameraPose& pose,
               int sizePx,
               const Fisheye& fisheye,
               double nearM)
    : Camera(geodesy, pose, Viewport{sizePx, sizePx}, 90.0, nearM) {
  if (!(fisheye.fovDeg > 0.0 && fisheye.fovDeg < 360.0))
    throw std::invalid_argument("Camera: fisheye field of view must be in (0, 360) degrees");
  if (!std::isfinite(fisheye.tiltDeg))
    throw std::invalid_argument("Camera: fisheye tilt must be finite");
  fisheye_ = true;
  vfovDeg_ = fisheye.fovDeg;
  halfAngle_ = 0.5 * fisheye.fovDeg * std::numbers::pi / 180.0;
  pixelsPerRadian_ = static_cast<double>(sizePx) / (2.0 * halfAngle_);
  double st = 0.0, ct = 1.0;
  GeographicLib::Math::sincosd(fisheye.tiltDeg, st, ct);
  const glm::dvec3 f = forward_, u = up_;
  forward_ = glm::normalize(ct * f + st * u);
  up_ = glm::normalize(ct * u - st * f);
  right_ = glm::normalize(glm::cross(forward_, up_));
  buildMatrices();
  // Everything passes the planes: the cone test of Culling.hpp is the fisheye's frustum test.
  for (Plane& p : frustum_.planes)
    p = Plane{glm::dvec3(0.0), 1.0};
  // The rim (theta = half the FOV) at 45-degree steps from the right, then the axis.
  std::array<glm::dvec3, 9> dirs{};
  for (std::size_t i = 0; i < 8; ++i) {
    double sp = 0.0, cp = 1.0, sa = 0.0, ca = 1.0;
    GeographicLib::Math::sincosd(45.0 * static_cast<double>(i), sp, cp);
    GeographicLib::Math::sincosd(0.5 * fisheye.fovDeg, sa, ca);
    dirs[i] = ca * forward_ + sa * (cp * right_ + sp * up_);
  }
  dirs[8] = forward_;
  ground_ = {};
  castGroundRays(geodesy, dirs, ground_);
  std::array<glm::dvec3, kDomeRays> rays{};
  for (std::size_t i = 0; i < kDomeRays; ++i) {
    const double phi = 22.5 * static_cast<double>(i % 16);
    const double theta = 0.5 * fisheye.fovDeg * static_cast<double>(i / 16 + 1) / 6.0;
    double sp = 0.0, cp = 1.0, sa = 0.0, ca = 1.0;
    GeographicLib::Math::sincosd(phi, sp, cp);
    GeographicLib::Math::sincosd(theta, sa, ca);
    rays[i] = ca * forward_ + sa * (cp * right_ + sp * up_);
  }
  castGroundRays(geodesy, rays, domeGround_);
}

Camera::Camera(const Camera& from,
               const glm::dvec3& forward,
               const glm::dvec3& up,
               Viewport viewport,
               double verticalFovDeg,
               const Geodesy* geodesy)
    : pose_(from.pose_), viewport_(viewport), vfovDeg_(verticalFovDeg), near_(from.near_),
      position_(from.position_) {
  if (viewport.width <= 0 || viewport.height <= 0)
    throw std::invalid_argument("Camera: viewport must be at least 1x1 pixels");
  if (!(verticalFovDeg > 0.0 && verticalFovDeg < 180.0))
    throw std::invalid_argument("Camera: vertical field of view must be in (0, 180) degrees");
  forward_ = glm::normalize(forward);
  right_ = glm::normalize(glm::cross(forward_, up));
  up_ = glm::cross(right_, forward_);
  buildMatrices();
  if (geodesy != nullptr) castViewportGround(*geodesy);
}

void Camera::buildMatrices() {
  // View matrix built from the orthonormal frame (no lookAt target point far from the origin).
  view_ = glm::dmat4(1.0);
  for (int i = 0; i < 3; ++i) {
    view_[i][0] = right_[i];
    view_[i][1] = up_[i];
    view_[i][2] = -forward_[i];
  }
  view_[3][0] = -glm::dot(right_, position_);
  view_[3][1] = -glm::dot(up_, position_);
  view_[3][2] = glm::dot(forward_, position_);

  const double aspect =
      static_cast<double>(viewport_.width) / static_cast<double>(viewport_.height);
  projection_ = reversedZInfinitePerspective(vfovDeg_ * std::numbers::pi / 180.0, aspect, near_);
  viewProjection_ = projection_ * view_;

  // Gribb/Hartmann on rows of the view-projection matrix; with depth in [0, 1] reversed, the near
  // plane is w - z >= 0 and the far plane (z >= 0) is at infinity, so it is left out.
  const glm::dmat4 m = glm::transpose(viewProjection_); // m[i] is row i
  frustum_.planes[Frustum::Left] = normalised(m[3] + m[0]);
  frustum_.planes[Frustum::Right] = normalised(m[3] - m[0]);
  frustum_.planes[Frustum::Bottom] = normalised(m[3] + m[1]);
  frustum_.planes[Frustum::Top] = normalised(m[3] - m[1]);
  frustum_.planes[Frustum::Near] = normalised(m[3] - m[2]);
}

void Camera::castGroundRays(const Geodesy& geodesy,
                            std::span<const glm::dvec3> directions,
                            std::span<GroundPoint> out) {
  // Rays against the model's ellipsoid (the unit sphere once x and y are scaled by 1/a and z by
  // 1/b); the geodetic latitude of a surface point from its normal (x / a^2, y / a^2, z / b^2).
  const double a = geodesy.equatorialRadius(), b = geodesy.polarRadius();
  const glm::dvec3 scale(1.0 / a, 1.0 / a, 1.0 / b);
  for (std::size_t i = 0; i < directions.size(); ++i) {
    const glm::dvec3 dir = directions[i];
    const glm::dvec3 o = position_ * scale, d = dir * scale;
    const double A = glm::dot(d, d), B = glm::dot(o, d), C = glm::dot(o, o) - 1.0;
    const double disc = B * B - A * C;
    if (!(disc >= 0.0) || !(C > 0.0)) continue; // misses the model, or the eye is inside it
    const double t = (-B - std::sqrt(disc)) / A;
    if (!(t > 0.0)) continue;
    const glm::dvec3 p = position_ + t * dir;
    GroundPoint& gp = out[i];
    gp.hit = true;
    gp.latDeg =
        std::atan2(p.z / (b * b), std::hypot(p.x, p.y) / (a * a)) * 180.0 / std::numbers::pi;
    gp.lonDeg = std::atan2(p.y, p.x) * 180.0 / std::numbers::pi;
  }
}

bool Camera::projectPx(const glm::dvec3& world, glm::dvec2& px) const noexcept {
  if (!fisheye_) {
    const glm::dvec4 c = toClip(world);
    if (!(c.w >= near_) || !std::isfinite(c.x) || !std::isfinite(c.y)) return false;
    px = {c.x / c.w * 0.5 * static_cast<double>(viewport_.width),
          c.y / c.w * 0.5 * static_cast<double>(viewport_.height)};
    return true;
  }
  const glm::dvec3 d = world - position_;
  const double dist = glm::length(d);
  if (!(dist >= near_) || !std::isfinite(dist)) return false;
  const double x = glm::dot(d, right_), y = glm::dot(d, up_), z = glm::dot(d, forward_);
  const double lateral = std::hypot(x, y);
  const double theta = std::atan2(lateral, z);
  if (theta > std::numbers::pi * (179.0 / 180.0)) return false;
  if (lateral == 0.0) {
    px = {0.0, 0.0};
    return true;
  }
  const double r = theta * pixelsPerRadian_ / lateral;
  px = {x * r, y * r};
  return true;
}

glm::dvec4 Camera::toClip(const glm::dvec3& world) const noexcept {
  return viewProjection_ * glm::dvec4(world, 1.0);
}

} // namespace tellus::planet
