#include <tellus/planet/Culling.hpp>

#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
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

FrustumResult classify(const Frustum& frustum, const OrientedBox& box) noexcept {
  bool intersects = false;
  for (const Plane& p : frustum.planes) {
    const double d = p.signedDistance(box.centre);
    const double r = std::abs(glm::dot(p.n, box.axes[0])) * box.halfExtents.x +
                     std::abs(glm::dot(p.n, box.axes[1])) * box.halfExtents.y +
                     std::abs(glm::dot(p.n, box.axes[2])) * box.halfExtents.z;
    if (d < -r) return FrustumResult::Outside;
    if (d < r) intersects = true;
  }
  return intersects ? FrustumResult::Intersecting : FrustumResult::Inside;
}

bool projectsOutsideViewport(const Camera& camera, const OrientedBox& box) noexcept {
  const double halfW = 0.5 * static_cast<double>(camera.viewport().width);
  const double halfH = 0.5 * static_cast<double>(camera.viewport().height);
  std::array<glm::dvec2, 8> px{};
  for (std::size_t i = 0; i < 8; ++i) {
    const glm::dvec3 p = box.centre + ((i & 1u) ? 1.0 : -1.0) * box.halfExtents.x * box.axes[0] +
                         ((i & 2u) ? 1.0 : -1.0) * box.halfExtents.y * box.axes[1] +
                         ((i & 4u) ? 1.0 : -1.0) * box.halfExtents.z * box.axes[2];
    const glm::dvec4 c = camera.toClip(p);
    if (!(c.w > camera.nearM()) || !std::isfinite(c.x) || !std::isfinite(c.y)) return false;
    px[i] = {c.x / c.w * halfW, c.y / c.w * halfH};
  }
  const std::array<glm::dvec2, 4> view{
      {{-halfW, -halfH}, {halfW, -halfH}, {halfW, halfH}, {-halfW, halfH}}};
  auto separates = [&](const glm::dvec2& axis) {
    double bMin = std::numeric_limits<double>::infinity(), bMax = -bMin;
    for (const glm::dvec2& p : px) {
      const double t = glm::dot(p, axis);
      bMin = std::min(bMin, t);
      bMax = std::max(bMax, t);
    }
    double vMin = std::numeric_limits<double>::infinity(), vMax = -vMin;
    for (const glm::dvec2& p : view) {
      const double t = glm::dot(p, axis);
      vMin = std::min(vMin, t);
      vMax = std::max(vMax, t);
    }
    return bMax < vMin || vMax < bMin;
  };
  if (separates({1.0, 0.0}) || separates({0.0, 1.0})) return true;
  // The twelve edges: corners differing in one bit.
  for (std::size_t i = 0; i < 8; ++i)
    for (std::size_t bit = 1; bit < 8; bit <<= 1) {
      if (i & bit) continue;
      const glm::dvec2 e = px[i | bit] - px[i];
      if (e.x == 0.0 && e.y == 0.0) continue;
      if (separates({-e.y, e.x})) return true;
    }
  return false;
}

FrustumResult classifyCone(const Camera& camera, const BoundingSphere& sphere) noexcept {
  const glm::dvec3 d = sphere.centre - camera.position();
  const double dist = glm::length(d);
  if (!(dist > sphere.radius)) return FrustumResult::Intersecting; // the eye is inside it
  const double rho = std::asin(std::min(1.0, sphere.radius / dist));
  const double theta = std::acos(std::clamp(glm::dot(d / dist, camera.forward()), -1.0, 1.0));
  const double alpha = camera.fisheyeHalfAngleRad();
  if (theta - rho > alpha) return FrustumResult::Outside;
  if (theta + rho <= alpha) return FrustumResult::Inside;
  return FrustumResult::Intersecting;
}

FrustumResult classifyNode(const Camera& camera, const NodeGeometry& node) noexcept {
  if (camera.isFisheye()) return classifyCone(camera, node.bounds());
  const FrustumResult sphere = classify(camera.frustum(), node.bounds());
  if (sphere != FrustumResult::Intersecting) return sphere;
  const FrustumResult box = classify(camera.frustum(), node.box());
  if (box != FrustumResult::Intersecting) return box;
  if (projectsOutsideViewport(camera, node.box())) return FrustumResult::Outside;
  // The two half boxes together contain the patch too: outside when each half is.
  for (const OrientedBox& half : node.halfBoxes())
    if (classify(camera.frustum(), half) != FrustumResult::Outside &&
        !projectsOutsideViewport(camera, half))
      return FrustumResult::Intersecting;
  return FrustumResult::Outside;
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
    : equatorialRadiusM(geodesy.minEquatorialRadius() + occluderHeightM),
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

bool HorizonOccluder::isCapOccluded(const glm::dvec3& cameraEcef,
                                    const NodeGeometry& node) const noexcept {
  const Sector& s = node.sector();
  const bool north = s.north == 90.0, south = s.south == -90.0;
  if (!(s.west == -180.0 && s.east == 180.0) || north == south) return false;
  if (!(equatorialRadiusM > 0.0 && polarRadiusM > 0.0)) return false;
  const glm::dvec3 c = scaled(*this, cameraEcef);
  const double d = glm::length(c);
  if (!(d > 1.0)) return false;
  // The cap's points at the largest height, from the rim to the pole: their largest scaled
  // distance (the surface bulges between samples by far less than the margin below) and the rim's
  // angle from the pole (latitude is monotonic in the scaled z, so the rim bounds the cap).
  const double a = node.equatorialRadiusM(), b = node.polarRadiusM();
  const double h = std::max(node.maxHeightM(), 0.0);
  const double rimLat = north ? s.south : s.north;
  const double poleLat = north ? 90.0 : -90.0;
  double r = 0.0, rho = 0.0;
  constexpr int kSamples = 9;
  for (int i = 0; i < kSamples; ++i) {
    const double lat = rimLat + (poleLat - rimLat) * i / (kSamples - 1);
    const double phi = lat * std::numbers::pi / 180.0;
    const double cp = std::cos(phi), sp = std::sin(phi);
    const double w = std::sqrt(a * a * cp * cp + b * b * sp * sp);
    const double n = a * a / w;
    const glm::dvec3 p{(n + h) * cp, 0.0, (b * b / (a * a) * n + h) * sp};
    const glm::dvec3 q = scaled(*this, p);
    r = std::max(r, glm::length(q));
    if (i == 0) rho = std::atan2(std::abs(q.x), std::abs(q.z));
  }
  r = std::max(r * (1.0 + 1e-9), 1.0);
  const glm::dvec3 pole{0.0, 0.0, north ? 1.0 : -1.0};
  const double gamma = std::atan2(glm::length(glm::cross(c, pole)), glm::dot(c, pole));
  const double reach = std::acos(1.0 / d) + std::acos(1.0 / r);
  return gamma - rho > reach + 1e-9;
}

CullResult
cullNode(const Camera& camera, const NodeGeometry& node, const HorizonOccluder& occluder) noexcept {
  CullResult r;
  if (isBackFacing(camera, node)) return r;
  r.frustum = classifyNode(camera, node);
  if (r.frustum == FrustumResult::Outside) return r;
  if (occluder.isOccluded(camera.position(), node.bounds()) ||
      occluder.isCapOccluded(camera.position(), node))
    return r;
  r.visible = true;
  return r;
}

} // namespace tellus::planet
