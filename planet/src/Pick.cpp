#include <tellus/planet/Pick.hpp>

#include <glm/geometric.hpp>

#include <cmath>
#include <numbers>
#include <utility>

namespace tellus::planet {

std::optional<glm::dvec3> pixelRay(const Camera& camera, double dxPx, double dyPx) noexcept {
  if (camera.isFisheye()) {
    const double r = std::hypot(dxPx, dyPx);
    const double theta = r / camera.pixelsPerRadian();
    if (!(theta <= camera.fisheyeHalfAngleRad())) return std::nullopt;
    if (r == 0.0) return camera.forward();
    const double s = std::sin(theta) / r;
    return glm::normalize(std::cos(theta) * camera.forward() +
                          s * (dxPx * camera.right() + dyPx * camera.up()));
  }
  const double h = camera.viewport().height;
  // The image plane at distance f (pixels) from the eye: tan(vfov / 2) = (h / 2) / f.
  const double f = 0.5 * h / std::tan(0.5 * camera.verticalFovDeg() * std::numbers::pi / 180.0);
  return glm::normalize(f * camera.forward() + dxPx * camera.right() + dyPx * camera.up());
}

std::optional<double> rayEllipsoidDistance(const Geodesy& geodesy,
                                           const glm::dvec3& origin,
                                           const glm::dvec3& direction,
                                           double heightM) noexcept {
  const double a = geodesy.equatorialRadius() + heightM;
  const double b = geodesy.polarRadius() + heightM;
  if (!(a > 0.0 && b > 0.0)) return std::nullopt;
  // Scaled so that the ellipsoid is the sphere of radius a; distances along the ray keep t.
  const double k = a / b;
  const glm::dvec3 o{origin.x, origin.y, origin.z * k};
  const glm::dvec3 d{direction.x, direction.y, direction.z * k};
  const double qa = glm::dot(d, d);
  const double qb = 2.0 * glm::dot(o, d);
  const double qc = glm::dot(o, o) - a * a;
  const double disc = qb * qb - 4.0 * qa * qc;
  if (!(disc >= 0.0)) return std::nullopt;
  // Stable roots: q = -(b + sign(b) sqrt(disc)) / 2, t1 = q / a, t2 = c / q.
  const double q = -0.5 * (qb + std::copysign(std::sqrt(disc), qb));
  double t1 = q / qa;
  double t2 = q != 0.0 ? qc / q : t1;
  if (t1 > t2) std::swap(t1, t2);
  if (t1 >= 0.0) return t1;
  if (t2 >= 0.0) return t2; // inside: the way out
  return std::nullopt;
}

std::optional<Geodetic> pickGlobe(const Camera& camera,
                                  const Geodesy& geodesy,
                                  double dxPx,
                                  double dyPx,
                                  double heightM) noexcept {
  const auto dir = pixelRay(camera, dxPx, dyPx);
  if (!dir) return std::nullopt;
  const auto t = rayEllipsoidDistance(geodesy, camera.position(), *dir, heightM);
  if (!t) return std::nullopt;
  const glm::dvec3 p = camera.position() + *t * *dir;
  Geodetic g = geodesy.fromEcef({p.x, p.y, p.z});
  g.heightM = heightM;
  return g;
}

} // namespace tellus::planet
