#include <tellus/planet/Culling.hpp>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace tellus::planet {

FrustumResult classify(const Frustum& frustum, const BoundingSphere& sphere) noexcept {
  bool intersects = false;
  for (const Plane& p : frustum.planes) {
    const double d = p.signedDistance(sphere.centre);
    if (d < -sphere.radius) return FrustumResult::Outside;
    if (d < sphere.radius) intersects = true;
  }
  return intersects ? FrustumResult::Intersecting : FrustumResult::Inside;
}

bool isBackFacing(const Camera& camera, const NodeGeometry& node) noexcept {
  // Only a relief-free node on the ellipsoid itself: there the solid body behind each point is the
  // convex ellipsoid. Anything with heights is left to the horizon test.
  if (node.minHeightM() != 0.0 || node.maxHeightM() != 0.0) return false;
  // For a point p with unit normal n on a convex body, n.p is the body's support value h(n); on the
  // ellipsoid h(n) = sqrt(a^2 (nx^2 + ny^2) + b^2 nz^2), smallest where |nz| = sin|lat| is largest.
  // So over the patch n.(C - p) <= max over the normal cone of n.C - min h, and the camera is below
  // every tangent plane of the patch when that bound is negative.
  const Sector& s = node.sector();
  const double a = node.equatorialRadiusM();
  const double b = node.polarRadiusM();
  const double maxAbsLat =
      std::max(std::abs(s.south), std::abs(s.north)) * std::numbers::pi / 180.0;
  const double sz = std::sin(maxAbsLat), cz = std::cos(maxAbsLat);
  const double minSupport = std::sqrt(a * a * cz * cz + b * b * sz * sz);
  const glm::dvec3& c = camera.position();
  const double len = glm::length(c);
  const glm::dvec3& axis = node.centreNormal();
  const double gamma = std::atan2(glm::length(glm::cross(axis, c)), glm::dot(axis, c));
  const double closest = std::max(0.0, gamma - node.normalConeHalfAngleRad());
  return len * std::cos(closest) < minSupport * (1.0 - 1e-12);
}

HorizonOccluder::HorizonOccluder(const Geodesy& geodesy, double occluderHeightM) noexcept
    : equatorialRadiusM(geodesy.equatorialRadius() + occluderHeightM),
      polarRadiusM(geodesy.polarRadius() + occluderHeightM) {}

namespace {
glm::dvec3 scaled(const HorizonOccluder& o, const glm::dvec3& p) {
  return {p.x / o.equatorialRadiusM, p.y / o.equatorialRadiusM, p.z / o.polarRadiusM};
}
} // namespace

bool HorizonOccluder::isOccluded(const glm::dvec3& cameraEcef,
                                 const BoundingSphere& sphere) const noexcept {
  if (!(equatorialRadiusM > 0.0 && polarRadiusM > 0.0)) return false;
  const glm::dvec3 c = scaled(*this, cameraEcef);
  const double d = glm::length(c);
  if (!(d > 1.0)) return false; // on or inside the occluder: it hides nothing for sure
  const glm::dvec3 q0 = scaled(*this, sphere.centre);
  // A world sphere becomes an ellipsoid inside a sphere of radius r / (smallest semi-axis).
  const double rho = sphere.radius / std::min(equatorialRadiusM, polarRadiusM);
  const glm::dvec3 v = q0 - c;
  const double dist = glm::length(v);
  if (!(dist > rho)) return false; // the camera is inside the node's sphere
  const glm::dvec3 chat = c / d;
  // Strictly beyond the plane of the tangent circle (x.chat = 1/d) ...
  const double margin = 1e-12;
  if (!(glm::dot(q0, chat) + rho < 1.0 / d - margin)) return false;
  // ... and strictly inside the shadow cone (axis -chat, half-angle asin(1/d)).
  const double theta = std::asin(std::min(1.0, 1.0 / d));
  const double phi = std::atan2(glm::length(glm::cross(v, -chat)), glm::dot(v, -chat));
  const double beta = std::asin(std::min(1.0, rho / dist));
  return phi + beta < theta - margin;
}

bool HorizonOccluder::segmentHitsOccluder(const glm::dvec3& cameraEcef,
                                          const glm::dvec3& point) const noexcept {
  const glm::dvec3 c = scaled(*this, cameraEcef);
  const glm::dvec3 u = scaled(*this, point) - c;
  const double uu = glm::dot(u, u);
  const double t = uu > 0.0 ? std::clamp(-glm::dot(c, u) / uu, 0.0, 1.0) : 0.0;
  const glm::dvec3 x = c + t * u;
  return glm::dot(x, x) < 1.0;
}

CullResult
cullNode(const Camera& camera, const NodeGeometry& node, const HorizonOccluder& occluder) noexcept {
  CullResult r;
  if (isBackFacing(camera, node)) return r;
  r.frustum = classify(camera.frustum(), node.bounds());
  if (r.frustum == FrustumResult::Outside) return r;
  if (occluder.isOccluded(camera.position(), node.bounds())) return r;
  r.visible = true;
  return r;
}

} // namespace tellus::planet
