#include <tellus/planet/ScreenArea.hpp>

#include <algorithm>
#include <array>
#include <cmath>

namespace tellus::planet {

namespace {

constexpr int kMaxVerts = 16; // 4 corners + one vertex per clipping plane (5) and margin

struct Poly {
  std::array<glm::dvec4, kMaxVerts> v{};
  int n = 0;
};

/** Sutherland-Hodgman against dist(p) >= 0, with dist linear in clip space. */
template <class Dist> void clip(const Poly& in, Poly& out, Dist dist) noexcept {
  out.n = 0;
  for (int i = 0; i < in.n; ++i) {
    const glm::dvec4& a = in.v[static_cast<std::size_t>(i)];
    const glm::dvec4& b = in.v[static_cast<std::size_t>((i + 1) % in.n)];
    const double da = dist(a), db = dist(b);
    if (da >= 0.0 && out.n < kMaxVerts) out.v[static_cast<std::size_t>(out.n++)] = a;
    if ((da >= 0.0) != (db >= 0.0) && out.n < kMaxVerts) {
      const double t = da / (da - db);
      out.v[static_cast<std::size_t>(out.n++)] = a + (b - a) * t;
    }
  }
}

} // namespace

double clippedScreenArea(const Camera& camera, const std::array<glm::dvec3, 4>& corners) noexcept {
  if (camera.isFisheye()) {
    // The fisheye-projected quad (not clipped to the circle), at most the whole image: a priority.
    std::array<glm::dvec2, 4> px{};
    for (std::size_t i = 0; i < 4; ++i)
      if (!camera.projectPx(corners[i], px[i])) return 0.0;
    double twice = 0.0;
    for (std::size_t i = 0; i < 4; ++i)
      twice += px[i].x * px[(i + 1) % 4].y - px[(i + 1) % 4].x * px[i].y;
    const double full = static_cast<double>(camera.viewport().width) * camera.viewport().height;
    const double area = std::min(0.5 * std::abs(twice), full);
    return std::isfinite(area) ? area : 0.0;
  }
  Poly a, b;
  for (const glm::dvec3& c : corners) {
    const glm::dvec4 p = camera.toClip(c);
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.w)) return 0.0;
    a.v[static_cast<std::size_t>(a.n++)] = p;
  }
  const double near = camera.nearM();
  clip(a, b, [near](const glm::dvec4& p) { return p.w - near; });
  clip(b, a, [](const glm::dvec4& p) { return p.w - p.x; });
  clip(a, b, [](const glm::dvec4& p) { return p.w + p.x; });
  clip(b, a, [](const glm::dvec4& p) { return p.w - p.y; });
  clip(a, b, [](const glm::dvec4& p) { return p.w + p.y; });
  if (b.n < 3) return 0.0;
  const double hw = 0.5 * camera.viewport().width, hh = 0.5 * camera.viewport().height;
  double twice = 0.0;
  for (int i = 0; i < b.n; ++i) {
    const glm::dvec4& p = b.v[static_cast<std::size_t>(i)];
    const glm::dvec4& q = b.v[static_cast<std::size_t>((i + 1) % b.n)];
    const double px = p.x / p.w * hw, py = p.y / p.w * hh;
    const double qx = q.x / q.w * hw, qy = q.y / q.w * hh;
    twice += px * qy - qx * py;
  }
  const double area = 0.5 * std::abs(twice);
  return std::isfinite(area) ? area : 0.0;
}

double nodeScreenArea(const Camera& camera, const NodeGeometry& node) noexcept {
  const Sector& s = node.sector();
  const bool north = s.north == 90.0, south = s.south == -90.0;
  if (!(s.west == -180.0 && s.east == 180.0) || north == south)
    return clippedScreenArea(camera, node.corners());
  // The corners are the rim's point at 180 degrees (twice) and the pole (twice).
  const glm::dvec3 pole = node.corners()[north ? NE : SW];
  const double rimLat = north ? s.south : s.north;
  const double a = node.equatorialRadiusM(), b = node.polarRadiusM();
  constexpr int kWedges = 16;
  double total = 0.0;
  glm::dvec3 west = surfaceFrame(a, b, rimLat, -180.0).position;
  for (int i = 1; i <= kWedges; ++i) {
    const glm::dvec3 east =
        surfaceFrame(a, b, rimLat, -180.0 + 360.0 * static_cast<double>(i) / kWedges).position;
    total += north ? clippedScreenArea(camera, {west, east, pole, pole})
                   : clippedScreenArea(camera, {pole, pole, east, west});
    west = east;
  }
  return total;
}

} // namespace tellus::planet
