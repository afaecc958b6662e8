#include <tellus/planet/Lod.hpp>

#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <span>

namespace tellus::planet {

namespace {

/** Points of a polar cap's rim the local test samples besides the one at the camera's longitude:
 * a tilted view sees the rim's largest texels off the camera's meridian too. */
constexpr int kCapRimSamples = 15;

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

/** Terrain: the points are measured at the height of the node's relief nearest the camera's (its
 * altitude clamped to the node's height range), not on the ellipsoid: 1 m above a 1,000 m plateau
 * the texels are as large as 1 m above the sea, not 1,000 m (issue #6/#8). */
class Lift {
public:
  Lift(const Camera& camera, const NodeGeometry& node) noexcept
      : a0_(node.equatorialRadiusM()), b0_(node.polarRadiusM()),
        liftM_(std::clamp(camera.pose().altitudeM, node.minHeightM(), node.maxHeightM())) {}

  glm::dvec3 operator()(const glm::dvec3& p) const noexcept {
    if (liftM_ == 0.0) return p;
    const glm::dvec3 n =
        glm::normalize(glm::dvec3(p.x / (a0_ * a0_), p.y / (a0_ * a0_), p.z / (b0_ * b0_)));
    return p + n * liftM_;
  }
  SurfaceFrame operator()(SurfaceFrame f) const noexcept {
    f.position = (*this)(f.position);
    return f;
  }

private:
  double a0_, b0_, liftM_;
};

/** How an edge is found over its limit: by its squared length (the perspective's test) or by its
 * ratio to the limit (the fisheye's). They can differ in the last bit of the division's rounding;
 * each projection keeps the test it has always had. */
enum class EdgeSplit { LengthOverLimit, RatioOverOne };

/** A node's four edges by their corners: SW-SE and NW-NE run east-west, SE-NE and NW-SW
 * north-south. */
struct CornerEdge {
  std::size_t a, b;
  bool eastWest;
};
constexpr std::array<CornerEdge, 4> kCornerEdges{
    {{SW, SE, true}, {NW, NE, true}, {SE, NE, false}, {SW, NW, false}}};

/** The most pixels an edge may cover: its texels times the threshold (east-west, north-south). */
glm::dvec2 edgeLimits(const LodParams& params) noexcept {
  return {static_cast<double>(params.tileWidthPx) * params.threshold,
          static_cast<double>(params.tileHeightPx) * params.threshold};
}

/** The thesis's test on the corners' pixels (kCornerEdges); a pole edge has length 0. */
void testWholeEdges(const std::array<glm::dvec2, 4>& px,
                    const LodParams& params,
                    EdgeSplit rule,
                    LodResult& r) noexcept {
  const glm::dvec2 limit = edgeLimits(params);
  const double limitW2 = limit.x * limit.x;
  const double limitH2 = limit.y * limit.y;
  for (const CornerEdge& e : kCornerEdges) {
    const glm::dvec2 d = px[e.b] - px[e.a];
    const double len2 = d.x * d.x + d.y * d.y;
    const double lim2 = e.eastWest ? limitW2 : limitH2;
    const double ratio = len2 / lim2;
    if (ratio > r.worstRatioSquared) r.worstRatioSquared = ratio;
    if (rule == EdgeSplit::LengthOverLimit ? len2 > lim2 : !(ratio <= 1.0)) r.split = true;
  }
}

/** Which sample point of the local texel test a projection is asked about. Border: where an edge
 * of the node crosses the viewport's border (the on-screen test's clipped edges). */
enum class Point { Corner, Midpoint, Nearest, Rim, Ground, Border };

/** A point of an edge where it crosses the viewport's border, by the edge's parameter (0 at the
 * edge's first corner, 1 at its second), found on the chord between the corners (testTexels
 * moves it onto the edge's own crossing). */
struct BorderPoint {
  std::size_t a, b;
  double t;
  int plane; ///< the frustum plane crossed (clipSegment's order)
};

/** The signed distance of a clip-space point inside frustum plane k: the near plane, then the
 * right, left, top and bottom sides (>= 0 inside). */
double planeDistance(const glm::dvec4& c, int k, double near) noexcept {
  switch (k) {
  case 0:
    return c.w - near;
  case 1:
    return c.w - c.x;
  case 2:
    return c.w + c.x;
  case 3:
    return c.w - c.y;
  default:
    return c.w + c.y;
  }
}

/** The part of the clip-space segment a-b inside the view frustum (near plane and the four
 * sides), as parameters [t0, t1]; false when none of it is. */
bool clipSegment(const glm::dvec4& a,
                 const glm::dvec4& b,
                 double near,
                 double& t0,
                 double& t1,
                 int* plane0 = nullptr,
                 int* plane1 = nullptr) {
  t0 = 0.0;
  t1 = 1.0;
  const std::array<glm::dvec2, 5> d{{{a.w - near, b.w - near},
                                     {a.w - a.x, b.w - b.x},
                                     {a.w + a.x, b.w + b.x},
                                     {a.w - a.y, b.w - b.y},
                                     {a.w + a.y, b.w + b.y}}};
  for (int k = 0; k < 5; ++k) {
    const glm::dvec2& p = d[static_cast<std::size_t>(k)];
    if (p.x < 0.0 && p.y < 0.0) return false;
    if (p.x < 0.0 && p.x / (p.x - p.y) > t0) {
      t0 = p.x / (p.x - p.y);
      if (plane0) *plane0 = k;
    }
    if (p.y < 0.0 && p.x / (p.x - p.y) < t1) {
      t1 = p.x / (p.x - p.y);
      if (plane1) *plane1 = k;
    }
  }
  return t1 > t0;
}

/** The perspective's pixels: the corners through the view-projection and the perspective
 * division; a texel through the division's derivative at its point (projectedLength2). */
class PerspectiveProbe {
public:
  static constexpr bool kMidpoints = false;
  static constexpr EdgeSplit kEdgeSplit = EdgeSplit::LengthOverLimit;

  /** onScreen: only what the viewport shows counts (LodParams::onScreenOnly). */
  PerspectiveProbe(const Camera& camera, bool onScreen, double a = 1.0, double b = 1.0) noexcept
      : camera_(camera), halfW_(0.5 * static_cast<double>(camera.viewport().width)),
        halfH_(0.5 * static_cast<double>(camera.viewport().height)), rows_(camera.viewProjection()),
        onScreen_(onScreen), invA2_(1.0 / (a * a)), invB2_(1.0 / (b * b)) {}

  /** With onScreen: whether an admitted sample faces the camera (its ellipsoid normal towards
   * the eye). A node whose on-screen samples all lie on the globe's far side is hidden (the
   * culling's bounds are conservative for large nodes); it keeps the whole-node test, which
   * splits it so that culling can drop its children, instead of being drawn and fetched. */
  bool sawFacing() const noexcept { return facing_; }

  /** The edges: with onScreen, each edge's part inside the frustum against its share of the tile's
   * texels (an edge wholly off screen does not count), and where an edge crosses the border the
   * crossing becomes a sample of the local test; else the thesis's whole edges. */
  void testEdges(const std::array<glm::dvec2, 4>& px, const LodParams& params, LodResult& r) {
    if (!onScreen_) {
      testWholeEdges(px, params, kEdgeSplit, r);
      return;
    }
    const glm::dvec2 limit = edgeLimits(params);
    for (const CornerEdge& e : kCornerEdges) {
      double t0 = 0.0, t1 = 1.0;
      int k0 = 0, k1 = 0;
      if (!clipSegment(clip_[e.a], clip_[e.b], camera_.nearM(), t0, t1, &k0, &k1)) continue;
      const glm::dvec4 p0 = clip_[e.a] + (clip_[e.b] - clip_[e.a]) * t0;
      const glm::dvec4 p1 = clip_[e.a] + (clip_[e.b] - clip_[e.a]) * t1;
      const glm::dvec2 d{(p1.x / p1.w - p0.x / p0.w) * halfW_,
                         (p1.y / p1.w - p0.y / p0.w) * halfH_};
      const double len2 = d.x * d.x + d.y * d.y;
      const double lim = (e.eastWest ? limit.x : limit.y) * (t1 - t0);
      const double ratio = len2 / (lim * lim);
      if (ratio > r.worstRatioSquared) r.worstRatioSquared = ratio;
      if (len2 > lim * lim) r.split = true;
      if (t0 > 0.0) border_[borderCount_++] = {e.a, e.b, t0, k0};
      if (t1 < 1.0) border_[borderCount_++] = {e.a, e.b, t1, k1};
    }
  }
  std::span<const BorderPoint> border() const noexcept {
    return std::span<const BorderPoint>(border_.data(), borderCount_);
  }

  bool projectCorner(std::size_t i, const glm::dvec3& p, glm::dvec2& px) noexcept {
    clip_[i] = camera_.toClip(p);
    const glm::dvec4& c = clip_[i];
    // w is the distance in front of the eye; at or in front of the near plane means projectable.
    if (!(c.w >= camera_.nearM()) || !std::isfinite(c.x) || !std::isfinite(c.y)) return false;
    px = {c.x / c.w * halfW_, c.y / c.w * halfH_};
    return true;
  }
  /** The ground seen through the viewport's border: the nearest visible points of a tilted view. */
  std::span<const Camera::GroundPoint> ground() const noexcept { return camera_.viewportGround(); }
  /** Whether the point counts (in front of the near plane; the point below the camera and a cap's
   * rim point only on screen: a tilted view's nadir is out of sight, the ground points stand for
   * what is in sight), and it becomes the point length2 measures at. */
  bool admit(const SurfaceFrame& f, Point kind, std::size_t corner) noexcept {
    bool in = true;
    if (kind == Point::Corner) {
      c_ = clip_[corner];
      in = !onScreen_ || (std::abs(c_.x) <= c_.w && std::abs(c_.y) <= c_.w);
    } else {
      c_ = camera_.toClip(f.position);
      if (!(c_.w >= camera_.nearM())) return false;
      in = kind == Point::Ground || kind == Point::Border ||
           (std::abs(c_.x) <= c_.w && std::abs(c_.y) <= c_.w);
    }
    if (in && onScreen_ && !facing_) {
      const glm::dvec3& p = f.position;
      const glm::dvec3 n(p.x * invA2_, p.y * invA2_, p.z * invB2_);
      facing_ = glm::dot(camera_.position() - p, n) > 0.0;
    }
    return in;
  }
  double length2(const glm::dvec3& v) const noexcept {
    return projectedLength2(rows_, c_, v, halfW_, halfH_);
  }

private:
  const Camera& camera_;
  double halfW_, halfH_;
  ClipRows rows_;
  std::array<glm::dvec4, 4> clip_{};
  glm::dvec4 c_{0.0};
  bool onScreen_;
  double invA2_, invB2_;
  bool facing_ = false;
  std::array<BorderPoint, 8> border_{};
  std::size_t borderCount_ = 0;
};

/** A fisheye's pixels: the same corner edges and local texels, measured in the fisheye's pixels
 * (Camera::projectPx and fisheyeLength2) instead of the perspective's. */
class FisheyeProbe {
public:
  /** The fisheye map is not a projective one: a node's largest texel can lie inside an edge (a
   * grazing view near the horizon, the stretch around the axis). The edges' midpoints and the
   * centre count too. */
  static constexpr bool kMidpoints = true;
  static constexpr EdgeSplit kEdgeSplit = EdgeSplit::RatioOverOne;

  explicit FisheyeProbe(const Camera& camera) noexcept : camera_(camera) {}

  void testEdges(const std::array<glm::dvec2, 4>& px, const LodParams& params, LodResult& r) const {
    testWholeEdges(px, params, kEdgeSplit, r);
  }
  std::span<const BorderPoint> border() const noexcept { return {}; }

  bool projectCorner(std::size_t, const glm::dvec3& p, glm::dvec2& px) const noexcept {
    return camera_.projectPx(p, px);
  }
  std::span<const Camera::GroundPoint> ground() const noexcept { return camera_.domeGround(); }
  /** Whether the point counts (beyond the near distance; the point below the camera and a cap's
   * rim point only inside the fisheye's cone), and it becomes the point length2 measures at. */
  bool admit(const SurfaceFrame& f, Point kind, std::size_t) noexcept {
    p_ = f.position;
    if (kind == Point::Corner) return true;
    if (!(glm::length(p_ - camera_.position()) >= camera_.nearM())) return false;
    return (kind != Point::Nearest && kind != Point::Rim) || inCone(p_);
  }
  double length2(const glm::dvec3& v) const noexcept { return fisheyeLength2(camera_, p_, v); }

private:
  bool inCone(const glm::dvec3& p) const noexcept {
    const glm::dvec3 d = glm::normalize(p - camera_.position());
    return std::acos(std::clamp(glm::dot(d, camera_.forward()), -1.0, 1.0)) <=
           camera_.fisheyeHalfAngleRad();
  }
  const Camera& camera_;
  glm::dvec3 p_{0.0};
};

/** The local texel test (Lod.hpp): one texel's step east and north along the surface (metres per
 * degree times degrees per texel) in the probe's pixels at the node's sample points, in this
 * order: the corners, the edges' midpoints and the centre (where the probe asks for them), the
 * node's point nearest below the camera, a polar cap's rim point, the ground points. */
template <class Probe>
void testTexels(const Camera& camera,
                const NodeGeometry& node,
                const LodParams& params,
                const Lift& lift,
                Probe& probe,
                LodResult& r) noexcept {
  const Sector& s = node.sector();
  const double texLon = (s.east - s.west) / static_cast<double>(params.tileWidthPx);
  const double texLat = (s.north - s.south) / static_cast<double>(params.tileHeightPx);
  const double t2 = params.threshold * params.threshold;
  const double a = node.equatorialRadiusM(), b = node.polarRadiusM();
  auto at = [&](double lat, double lon) { return lift(surfaceFrame(a, b, lat, lon)); };
  // A polar cap (a whole top or bottom row) may be drawn from bands of its row each only as wide
  // as its parallels need (proxy/src/tiles/CapBands.hpp): its texels are as long east-west on
  // every parallel as on its rim. Its step east is that length everywhere; at the pole, where
  // east is every horizontal direction, the longer of two.
  const bool cap = s.east - s.west >= 360.0;
  const double rimLat = s.north == 90.0 ? s.south : s.north;
  const double capEastM = cap ? glm::length(at(rimLat, 0.0).perDegLon) * texLon : 0.0;
  auto eastStep2 = [&](const SurfaceFrame& f) {
    if (!cap) return probe.length2(f.perDegLon * texLon);
    const double len = glm::length(f.perDegLon);
    if (len > 0.0) return probe.length2(f.perDegLon * (capEastM / len));
    return std::max(probe.length2(glm::dvec3(capEastM, 0.0, 0.0)),
                    probe.length2(glm::dvec3(0.0, capEastM, 0.0)));
  };
  double worst = 0.0;
  auto sample = [&](const SurfaceFrame& f, Point kind, std::size_t corner = 0) {
    if (!probe.admit(f, kind, corner)) return;
    const double e = eastStep2(f);
    const double n = probe.length2(f.perDegLat * texLat);
    if (!(e <= t2)) r.eastWestOver = true; // NaN (not projectable) too: refine
    if (!(n <= t2)) r.northSouthOver = true;
    const double m = std::max(e, n) / t2;
    if (std::isnan(m))
      worst = 1e300;
    else if (m > worst)
      worst = m;
  };
  for (std::size_t i = 0; i < 4; ++i)
    sample(lift(node.cornerFrames()[i]), Point::Corner, i);
  if constexpr (Probe::kMidpoints) {
    const double mLat = 0.5 * (s.south + s.north), mLon = 0.5 * (s.west + s.east);
    const std::array<std::array<double, 2>, 5> mids{
        {{s.south, mLon}, {s.north, mLon}, {mLat, s.west}, {mLat, s.east}, {mLat, mLon}}};
    for (const auto& m : mids)
      sample(at(m[0], m[1]), Point::Midpoint);
  }
  // The node's point below the camera: where a camera above a large node's interior sees its
  // largest texels (its corners may all be far away).
  const CameraPose& pose = camera.pose();
  const double nearLat = std::clamp(pose.latDeg, s.south, s.north);
  const double nearLon = clampLongitude(pose.lonDeg, s.west, s.east);
  const bool interior =
      (nearLat != s.south && nearLat != s.north) || (nearLon != s.west && nearLon != s.east);
  if (interior) sample(at(nearLat, nearLon), Point::Nearest); // else it is a corner, sampled above
  // A polar cap (a whole top or bottom row) has its largest east-west texels along its rim, which
  // has no corner but one: its point at the camera's longitude, the nearest, counts as well.
  if (cap) {
    sample(at(rimLat, nearLon), Point::Rim);
    for (int i = 0; i < kCapRimSamples; ++i)
      sample(at(rimLat, nearLon + 360.0 * (i + 1) / (kCapRimSamples + 1)), Point::Rim);
  }
  // Where an edge crosses the viewport's border (onScreenOnly): the visible part's corners.
  const std::array<std::array<double, 2>, 4> cornerLatLon{
      {{s.south, s.west}, {s.south, s.east}, {s.north, s.east}, {s.north, s.west}}};
  // The crossing was found on the chord between the corners; the surface above it bulges
  // toward the camera (a 1,000 km edge by 20 km) and may lie off screen: a few secant steps on
  // the crossed plane's distance move it onto the border along the edge itself.
  for (const BorderPoint& bp : probe.border()) {
    const auto& p = cornerLatLon[bp.a];
    const auto& q = cornerLatLon[bp.b];
    auto pointAt = [&](double t) { return at(p[0] + (q[0] - p[0]) * t, p[1] + (q[1] - p[1]) * t); };
    auto dist = [&](double t) {
      return planeDistance(camera.toClip(pointAt(t).position), bp.plane, camera.nearM());
    };
    double ta = bp.t, tb = std::clamp(bp.t + (bp.t < 0.5 ? 1e-3 : -1e-3), 0.0, 1.0);
    double fa = dist(ta), fb = dist(tb);
    for (int i = 0; i < 4 && std::abs(fa) > 1e-9 * glm::length(pointAt(ta).position) && fa != fb;
         ++i) {
      const double tc = std::clamp(ta - fa * (ta - tb) / (fa - fb), 0.0, 1.0);
      tb = ta;
      fb = fa;
      ta = tc;
      fa = dist(ta);
    }
    if (std::isfinite(ta)) sample(pointAt(ta), Point::Border);
  }
  for (const Camera::GroundPoint& gp : probe.ground()) {
    if (!gp.hit || gp.latDeg < s.south || gp.latDeg > s.north || gp.lonDeg < s.west ||
        gp.lonDeg > s.east)
      continue;
    sample(at(gp.latDeg, gp.lonDeg), Point::Ground);
  }
  r.worstTexelRatioSquared = worst;
  if (!(worst <= 1.0)) r.split = true;
}

/** The test in one projection's pixels: the corners (a corner that cannot be projected splits),
 * the edges, then, where they fit and the params ask for it, the local texels. */
template <class Probe>
LodResult evaluateWith(const Camera& camera,
                       const NodeGeometry& node,
                       const LodParams& params,
                       Probe& probe) noexcept {
  const Lift lift(camera, node);
  LodResult r;
  std::array<glm::dvec2, 4> px{};
  for (std::size_t i = 0; i < 4; ++i)
    if (!probe.projectCorner(i, lift(node.corners()[i]), px[i])) {
      r.cornerBehindCamera = true;
      r.split = true;
      return r;
    }
  probe.testEdges(px, params, r);
  if (r.split || !params.perspectiveAware) return r;
  testTexels(camera, node, params, lift, probe, r);
  return r;
}

} // namespace

LodResult evaluateLod(const Camera& camera,
                      const NodeGeometry& node,
                      const LodParams& params,
                      bool merged) noexcept {
  if (params.tileWidthPx < 1 || params.tileHeightPx < 1 || !(params.threshold > 0.0) ||
      !std::isfinite(params.threshold))
    return LodResult{};
  if (camera.isFisheye()) {
    FisheyeProbe fisheye(camera);
    return evaluateWith(camera, node, params, fisheye);
  }
  // A merged polar row or cap keeps the whole-node test: a cap's corner quad is a line (its rim's
  // point at 180 degrees and the pole), and the rows' widening (Quadtree's fitsEastWest) measures
  // whole half edges; the two must agree, or a row made wide by one is split by the other.
  if (params.onScreenOnly && params.perspectiveAware && !merged) {
    PerspectiveProbe visible(camera, true, node.equatorialRadiusM(), node.polarRadiusM());
    const LodResult r = evaluateWith(camera, node, params, visible);
    if (r.split || visible.sawFacing()) return r;
  }
  PerspectiveProbe whole(camera, false);
  return evaluateWith(camera, node, params, whole);
}

} // namespace tellus::planet
