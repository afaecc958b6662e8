#include <tellus/planet/Lod.hpp>

#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <cmath>

namespace tellus::planet {

namespace {

/** The rows of the view-projection matrix's linear part that give clip x, y and w. */
struct ClipRows {
  glm::dvec3 x, y, w;
  explicit ClipRows(const glm::dmat4& m) noexcept
      : x(m[0][0], m[1][0], m[2][0]), y(m[0][1], m[1][1], m[2][1]), w(m[0][3], m[1][3], m[2][3]) {}
};

/** Squared pixel length of the projection of displacement v at the point whose clip coordinates
 * are c: the derivative of (x / w, y / w) scaled to pixels. */
double projectedLength2(const ClipRows& rows,
                        const glm::dvec4& c,
                        const glm::dvec3& v,
                        double halfW,
                        double halfH) noexcept {
  const double dx = glm::dot(rows.x, v), dy = glm::dot(rows.y, v), dw = glm::dot(rows.w, v);
  const double inv = 1.0 / (c.w * c.w);
  const double px = halfW * (dx * c.w - c.x * dw) * inv;
  const double py = halfH * (dy * c.w - c.y * dw) * inv;
  return px * px + py * py;
}

/** A longitude moved into [west, east] by the shorter way round. */
double clampLongitude(double lon, double west, double east) noexcept {
  lon = std::remainder(lon, 360.0); // [-180, 180]
  if (lon >= west && lon <= east) return lon;
  const double toWest = std::remainder(west - lon, 360.0),
               toEast = std::remainder(lon - east, 360.0);
  return std::abs(toWest) <= std::abs(toEast) ? west : east;
}

/** Squared fisheye pixel length of a small displacement v at world point p: the angular step
 * seen from the eye, radial part (along increasing theta) at pixelsPerRadian, the part around the
 * axis stretched by theta / sin(theta), theta capped at the rim (no pixels lie beyond it). */
double fisheyeLength2(const Camera& camera, const glm::dvec3& p, const glm::dvec3& v) noexcept {
  const glm::dvec3 d = p - camera.position();
  const double dist = glm::length(d);
  const glm::dvec3 dh = d / dist;
  const glm::dvec3 w = (v - glm::dot(v, dh) * dh) / dist; // radians, tangent to the unit sphere
  const double k = camera.pixelsPerRadian();
  const glm::dvec3& axis = camera.forward();
  const double c = std::clamp(glm::dot(dh, axis), -1.0, 1.0);
  const glm::dvec3 towardAxis = axis - c * dh; // |.| = sin(theta)
  const double sinT = glm::length(towardAxis);
  if (!(sinT > 1e-9)) return k * k * glm::dot(w, w);
  const double radial = -glm::dot(w, towardAxis) / sinT; // along increasing theta
  const double around2 = std::max(0.0, glm::dot(w, w) - radial * radial);
  const double theta = std::min(std::atan2(sinT, c), camera.fisheyeHalfAngleRad());
  const double stretch = theta / std::sin(theta);
  return k * k * (radial * radial + stretch * stretch * around2);
}

} // namespace

namespace {

/** evaluateLod for a fisheye camera: the same corner edges and local texels, measured in the
 * fisheye's pixels (Camera::projectPx and fisheyeLength2) instead of the perspective's. */
template <class Lift>
LodResult evaluateLodFisheye(const Camera& camera,
                             const NodeGeometry& node,
                             const LodParams& params,
                             const Lift& lift) noexcept {
  LodResult r;
  std::array<glm::dvec2, 4> px{};
  for (std::size_t i = 0; i < 4; ++i)
    if (!camera.projectPx(lift(node.corners()[i]), px[i])) {
      r.cornerBehindCamera = true;
      r.split = true;
      return r;
    }
  const double limitW = static_cast<double>(params.tileWidthPx) * params.threshold;
  const double limitH = static_cast<double>(params.tileHeightPx) * params.threshold;
  struct Edge {
    std::size_t a, b;
    bool eastWest;
  };
  constexpr std::array<Edge, 4> edges{
      {{SW, SE, true}, {NW, NE, true}, {SE, NE, false}, {SW, NW, false}}};
  for (const Edge& e : edges) {
    const glm::dvec2 d = px[e.b] - px[e.a];
    const double lim = e.eastWest ? limitW : limitH;
    const double ratio = (d.x * d.x + d.y * d.y) / (lim * lim);
    r.worstRatioSquared = std::max(r.worstRatioSquared, ratio);
    if (!(ratio <= 1.0)) r.split = true;
  }
  if (r.split || !params.perspectiveAware) return r;
  const Sector& s = node.sector();
  const double texLon = (s.east - s.west) / static_cast<double>(params.tileWidthPx);
  const double texLat = (s.north - s.south) / static_cast<double>(params.tileHeightPx);
  const double t2 = params.threshold * params.threshold;
  double worst = 0.0;
  auto sample = [&](const SurfaceFrame& f) {
    const double e = fisheyeLength2(camera, f.position, f.perDegLon * texLon);
    const double n = fisheyeLength2(camera, f.position, f.perDegLat * texLat);
    if (!(e <= t2)) r.eastWestOver = true;
    if (!(n <= t2)) r.northSouthOver = true;
    const double m = std::max(e, n) / t2;
    worst = std::isnan(m) ? 1e300 : std::max(worst, m);
  };
  auto lifted = [&](SurfaceFrame f) {
    f.position = lift(f.position);
    return f;
  };
  for (std::size_t i = 0; i < 4; ++i)
    sample(lifted(node.cornerFrames()[i]));
  const double a = node.equatorialRadiusM(), b = node.polarRadiusM();
  // The fisheye map is not a projective one: a node's largest texel can lie inside an edge (a
  // grazing view near the horizon, the stretch around the axis). The edges' midpoints and the
  // centre too.
  {
    const double mLat = 0.5 * (s.south + s.north), mLon = 0.5 * (s.west + s.east);
    const std::array<std::array<double, 2>, 5> mids{
        {{s.south, mLon}, {s.north, mLon}, {mLat, s.west}, {mLat, s.east}, {mLat, mLon}}};
    for (const auto& m : mids) {
      const SurfaceFrame f = lifted(surfaceFrame(a, b, m[0], m[1]));
      if (glm::length(f.position - camera.position()) >= camera.nearM()) sample(f);
    }
  }
  auto inCone = [&](const glm::dvec3& p) {
    const glm::dvec3 d = glm::normalize(p - camera.position());
    return std::acos(std::clamp(glm::dot(d, camera.forward()), -1.0, 1.0)) <=
           camera.fisheyeHalfAngleRad();
  };
  const CameraPose& pose = camera.pose();
  const double nearLat = std::clamp(pose.latDeg, s.south, s.north);
  const double nearLon = clampLongitude(pose.lonDeg, s.west, s.east);
  const bool interior =
      (nearLat != s.south && nearLat != s.north) || (nearLon != s.west && nearLon != s.east);
  if (interior) {
    const SurfaceFrame f = lifted(surfaceFrame(a, b, nearLat, nearLon));
    if (glm::length(f.position - camera.position()) >= camera.nearM() && inCone(f.position))
      sample(f);
  }
  if (s.east - s.west >= 360.0) { // a polar cap: its rim's nearest point (see evaluateLod)
    const SurfaceFrame f = lifted(surfaceFrame(a, b, s.north == 90.0 ? s.south : s.north, nearLon));
    if (glm::length(f.position - camera.position()) >= camera.nearM() && inCone(f.position))
      sample(f);
  }
  for (const Camera::GroundPoint& gp : camera.domeGround()) {
    if (!gp.hit || gp.latDeg < s.south || gp.latDeg > s.north || gp.lonDeg < s.west ||
        gp.lonDeg > s.east)
      continue;
    const SurfaceFrame f = lifted(surfaceFrame(a, b, gp.latDeg, gp.lonDeg));
    if (glm::length(f.position - camera.position()) >= camera.nearM()) sample(f);
  }
  r.worstTexelRatioSquared = worst;
  if (!(worst <= 1.0)) r.split = true;
  return r;
}

} // namespace

LodResult
evaluateLod(const Camera& camera, const NodeGeometry& node, const LodParams& params) noexcept {
  LodResult r;
  if (params.tileWidthPx < 1 || params.tileHeightPx < 1 || !(params.threshold > 0.0) ||
      !std::isfinite(params.threshold))
    return r;
  const double halfW = 0.5 * static_cast<double>(camera.viewport().width);
  const double halfH = 0.5 * static_cast<double>(camera.viewport().height);
  std::array<glm::dvec2, 4> px{};
  std::array<glm::dvec4, 4> clip{};
  // Terrain: the points are measured at the height of the node's relief nearest the camera's
  // (its altitude clamped to the node's height range), not on the ellipsoid: 1 m above a 1,000 m
  // plateau the texels are as large as 1 m above the sea, not 1,000 m (issue #6/#8).
  const double a0 = node.equatorialRadiusM(), b0 = node.polarRadiusM();
  const double liftM = std::clamp(camera.pose().altitudeM, node.minHeightM(), node.maxHeightM());
  auto lift = [&](const glm::dvec3& p) {
    if (liftM == 0.0) return p;
    const glm::dvec3 n =
        glm::normalize(glm::dvec3(p.x / (a0 * a0), p.y / (a0 * a0), p.z / (b0 * b0)));
    return p + n * liftM;
  };
  if (camera.isFisheye()) return evaluateLodFisheye(camera, node, params, lift);
  for (std::size_t i = 0; i < 4; ++i) {
    clip[i] = camera.toClip(lift(node.corners()[i]));
    const glm::dvec4& c = clip[i];
    // w is the distance in front of the eye; at or in front of the near plane means projectable.
    if (!(c.w >= camera.nearM()) || !std::isfinite(c.x) || !std::isfinite(c.y)) {
      r.cornerBehindCamera = true;
      r.split = true;
      r.worstRatioSquared = 0.0;
      return r;
    }
    px[i] = {c.x / c.w * halfW, c.y / c.w * halfH};
  }
  const double limitW = static_cast<double>(params.tileWidthPx) * params.threshold;
  const double limitH = static_cast<double>(params.tileHeightPx) * params.threshold;
  const double limitW2 = limitW * limitW;
  const double limitH2 = limitH * limitH;
  // SW-SE and NW-NE run east-west; SE-NE and NW-SW north-south. A pole edge has length 0.
  struct Edge {
    std::size_t a, b;
    bool eastWest;
  };
  constexpr std::array<Edge, 4> edges{
      {{SW, SE, true}, {NW, NE, true}, {SE, NE, false}, {SW, NW, false}}};
  for (const Edge& e : edges) {
    const glm::dvec2 d = px[e.b] - px[e.a];
    const double len2 = d.x * d.x + d.y * d.y;
    const double ratio = len2 / (e.eastWest ? limitW2 : limitH2);
    if (ratio > r.worstRatioSquared) r.worstRatioSquared = ratio;
    if (len2 > (e.eastWest ? limitW2 : limitH2)) r.split = true;
  }
  if (r.split || !params.perspectiveAware) return r;

  // The local texel at the sample points: one texel's step east and north along the surface
  // (metres per degree times degrees per texel), projected through the derivative of the
  // perspective division.
  const Sector& s = node.sector();
  const double texLon = (s.east - s.west) / static_cast<double>(params.tileWidthPx);
  const double texLat = (s.north - s.south) / static_cast<double>(params.tileHeightPx);
  const double t2 = params.threshold * params.threshold;
  const ClipRows vp(camera.viewProjection());
  double worst = 0.0;
  auto sample = [&](const SurfaceFrame& f, const glm::dvec4& c) {
    const double e = projectedLength2(vp, c, f.perDegLon * texLon, halfW, halfH);
    const double n = projectedLength2(vp, c, f.perDegLat * texLat, halfW, halfH);
    if (!(e <= t2)) r.eastWestOver = true; // NaN (not projectable) too: refine
    if (!(n <= t2)) r.northSouthOver = true;
    const double m = std::max(e, n) / t2;
    if (std::isnan(m))
      worst = 1e300;
    else if (m > worst)
      worst = m;
  };
  auto lifted = [&](SurfaceFrame f) {
    f.position = lift(f.position);
    return f;
  };
  for (std::size_t i = 0; i < 4; ++i)
    sample(lifted(node.cornerFrames()[i]), clip[i]);
  const double a = node.equatorialRadiusM(), b = node.polarRadiusM();
  auto inViewport = [](const glm::dvec4& c) {
    return std::abs(c.x) <= c.w && std::abs(c.y) <= c.w; // ndc within [-1, 1]
  };
  // The node's point below the camera: where a camera above a large node's interior sees its
  // largest texels (its corners may all be far away). Off screen it does not count (a tilted
  // view's nadir is out of sight; the viewport's ground points stand for what is in sight).
  const CameraPose& pose = camera.pose();
  const double nearLat = std::clamp(pose.latDeg, s.south, s.north);
  const double nearLon = clampLongitude(pose.lonDeg, s.west, s.east);
  const bool interior =
      (nearLat != s.south && nearLat != s.north) || (nearLon != s.west && nearLon != s.east);
  if (interior) { // else it is a corner, sampled above
    const SurfaceFrame f = lifted(surfaceFrame(a, b, nearLat, nearLon));
    const glm::dvec4 c = camera.toClip(f.position);
    if (c.w >= camera.nearM() && inViewport(c)) sample(f, c);
  }
  // A polar cap (a whole top or bottom row) has its largest east-west texels along its rim, which
  // has no corner but one: its point at the camera's longitude, the nearest, counts as well.
  if (s.east - s.west >= 360.0) {
    const SurfaceFrame f = lifted(surfaceFrame(a, b, s.north == 90.0 ? s.south : s.north, nearLon));
    const glm::dvec4 c = camera.toClip(f.position);
    if (c.w >= camera.nearM() && inViewport(c)) sample(f, c);
  }
  // The ground seen through the viewport's border: the nearest visible points of a tilted view.
  for (const Camera::GroundPoint& gp : camera.viewportGround()) {
    if (!gp.hit || gp.latDeg < s.south || gp.latDeg > s.north || gp.lonDeg < s.west ||
        gp.lonDeg > s.east)
      continue;
    const SurfaceFrame f = lifted(surfaceFrame(a, b, gp.latDeg, gp.lonDeg));
    const glm::dvec4 c = camera.toClip(f.position);
    if (c.w >= camera.nearM()) sample(f, c);
  }
  r.worstTexelRatioSquared = worst;
  if (!(worst <= 1.0)) r.split = true;
  return r;
}

} // namespace tellus::planet
