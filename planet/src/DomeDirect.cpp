#include <tellus/planet/DomeDirect.hpp>
#include <tellus/planet/Quadtree.hpp>

#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>

namespace tellus::planet {

FisheyeMapped fisheyeMap(const glm::dvec3& q, double halfAngleRad) noexcept {
  FisheyeMapped m;
  const double lateral = std::hypot(q.x, q.y);
  m.dist = glm::length(q);
  m.theta = std::atan2(lateral, -q.z);
  // theta / lateral, with its limit 1 / |q| at the axis (there |q| = -q.z to 1e-12).
  // Nearly straight behind, the direction fades out instead (clipped there in any case).
  const double d = std::max(m.dist, 1e-300);
  const double k = lateral > 1e-6 * d ? m.theta / lateral
                   : q.z < 0.0        ? 1.0 / d
                                      : m.theta / (1e-6 * d);
  m.xy = glm::dvec2(q.x, q.y) * (k / halfAngleRad);
  return m;
}

glm::dvec3 toDomeFrame(const Camera& fisheye, const glm::dvec3& world) noexcept {
  const glm::dvec3 d = world - fisheye.position();
  return {glm::dot(d, fisheye.right()), glm::dot(d, fisheye.up()), -glm::dot(d, fisheye.forward())};
}

namespace {

/** directEdgeErrorPx with the ends already mapped (a cell's vertices are mapped once). */
double edgeError(const Camera& fisheye,
                 const glm::dvec3& a,
                 const FisheyeMapped& ma,
                 const glm::dvec3& b,
                 const FisheyeMapped& mb) noexcept {
  const double alpha = fisheye.fisheyeHalfAngleRad();
  const double clip = alpha + kDirectClipMarginPx / fisheye.pixelsPerRadian();
  const double behind = std::numbers::pi * (1.0 - 0.1 / 180.0);
  constexpr double kInf = std::numeric_limits<double>::infinity();
  if (!(ma.theta <= clip) && !(mb.theta <= clip)) {
    // Both ends clipped: nothing drawn, right unless the edge's middle is in the cone (the clip,
    // linear between the ends, would drop what should show).
    const FisheyeMapped mm = fisheyeMap(toDomeFrame(fisheye, 0.5 * (a + b)), alpha);
    return mm.theta <= clip ? kInf : 0.0;
  }
  const double nearM = fisheye.nearM();
  if (!(ma.dist >= nearM) || !(mb.dist >= nearM) || !(ma.theta < behind) || !(mb.theta < behind))
    return kInf;
  const double t = ma.dist / (ma.dist + mb.dist);
  const FisheyeMapped mt = fisheyeMap(toDomeFrame(fisheye, a + t * (b - a)), alpha);
  if (!(mt.dist >= nearM) || !(mt.theta < behind)) return kInf;
  const glm::dvec2 drawn = 0.5 * (ma.xy + mb.xy);
  const double e = glm::length(mt.xy - drawn) * alpha * fisheye.pixelsPerRadian();
  return std::isfinite(e) ? e : kInf;
}

} // namespace

double directEdgeErrorPx(const Camera& fisheye, const glm::dvec3& a, const glm::dvec3& b) noexcept {
  const double alpha = fisheye.fisheyeHalfAngleRad();
  return edgeError(fisheye,
                   a,
                   fisheyeMap(toDomeFrame(fisheye, a), alpha),
                   b,
                   fisheyeMap(toDomeFrame(fisheye, b), alpha));
}

namespace {

/** A longitude moved into [west, east] by the shorter way round (as the LOD does). */
double clampLongitude(double lon, double west, double east) noexcept {
  lon = std::remainder(lon, 360.0);
  if (lon >= west && lon <= east) return lon;
  const double toWest = std::remainder(west - lon, 360.0),
               toEast = std::remainder(lon - east, 360.0);
  return std::abs(toWest) <= std::abs(toEast) ? west : east;
}

} // namespace

double directChordErrorPx(const Camera& fisheye,
                          const NodeGeometry& node,
                          int meshSize,
                          double groundBelowM,
                          int meshRows) noexcept {
  if (meshRows == 0) meshRows = meshSize;
  if (!fisheye.isFisheye() || meshSize < 2 || meshRows < 2) return 0.0;
  const Sector& s = node.sector();
  const double a = node.equatorialRadiusM(), b = node.polarRadiusM();
  const double ground = std::isfinite(groundBelowM) ? groundBelowM : 0.0;
  const double lift =
      std::clamp(std::min(ground, fisheye.pose().altitudeM), node.minHeightM(), node.maxHeightM());
  const int n = meshSize, cells = n - 1, rowCells = meshRows - 1;
  auto vertex = [&](int row, int col) {
    const glm::dvec3 p =
        surfaceFrame(
            a, b, edgeLerp(s.south, s.north, row, meshRows), edgeLerp(s.west, s.east, col, n))
            .position;
    if (lift == 0.0) return p;
    return p + lift * glm::normalize(glm::dvec3(p.x / (a * a), p.y / (a * a), p.z / (b * b)));
  };
  double worst = 0.0;
  auto cell = [&](int r, int c) {
    r = std::clamp(r, 0, rowCells - 1);
    c = std::clamp(c, 0, cells - 1);
    const std::array<glm::dvec3, 4> p{
        vertex(r, c), vertex(r, c + 1), vertex(r + 1, c), vertex(r + 1, c + 1)};
    std::array<FisheyeMapped, 4> m{};
    for (std::size_t i = 0; i < 4; ++i)
      m[i] = fisheyeMap(toDomeFrame(fisheye, p[i]), fisheye.fisheyeHalfAngleRad());
    // The cell's south and west sides (the others are a neighbour's) and both diagonals.
    for (const auto& [u, v] : {std::pair<std::size_t, std::size_t>{0, 1}, {0, 2}, {0, 3}, {1, 2}})
      worst = std::max(worst, edgeError(fisheye, p[u], m[u], p[v], m[v]));
  };
  for (const int r : {0, rowCells / 4, rowCells / 2, 3 * rowCells / 4, rowCells - 1})
    for (const int c : {0, cells / 4, cells / 2, 3 * cells / 4, cells - 1})
      cell(r, c);
  const CameraPose& pose = fisheye.pose();
  const double nearLat = std::clamp(pose.latDeg, s.south, s.north);
  const double nearLon = clampLongitude(pose.lonDeg, s.west, s.east);
  const int nr = static_cast<int>(std::floor((nearLat - s.south) / (s.north - s.south) * rowCells));
  const int nc = static_cast<int>(std::floor((nearLon - s.west) / (s.east - s.west) * cells));
  for (int dr = -1; dr <= 1; ++dr)
    for (int dc = -1; dc <= 1; ++dc)
      cell(nr + dr, nc + dc);
  return worst;
}

double directChordErrorPx(const Camera& fisheye,
                          std::span<Node* const> nodes,
                          int meshSize,
                          double groundBelowM) noexcept {
  double worst = 0.0;
  for (const Node* n : nodes)
    if (n != nullptr)
      worst = std::max(worst,
                       directChordErrorPx(
                           fisheye, n->geometry(), n->meshSize(meshSize), groundBelowM, meshSize));
  return worst;
}

} // namespace tellus::planet
