#include <tellus/planet/Patch.hpp>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <tuple>
#include <vector>

namespace tellus::planet {

namespace {

constexpr double kDegToRad = std::numbers::pi / 180.0;
constexpr int kBoundSamples = 17; // per side, for the bounding sphere

glm::dvec3 toVec(const Ecef& e) {
  return {e.x, e.y, e.z};
}

void validate(const Sector& s) {
  const bool finite = std::isfinite(s.west) && std::isfinite(s.east) && std::isfinite(s.south) &&
                      std::isfinite(s.north);
  if (!finite || !(s.south >= -90.0 && s.south < s.north && s.north <= 90.0) ||
      !(s.west >= -180.0 && s.west < s.east && s.east <= 180.0))
    throw std::invalid_argument("planet: sector must satisfy -90 <= south < north <= 90 and "
                                "-180 <= west < east <= 180");
}

/** Surface point; a pole is one point whatever the longitude. */
glm::dvec3 surfacePoint(const Geodesy& g, double lat, double lon, double h) {
  if (lat == 90.0 || lat == -90.0) lon = 0.0;
  return toVec(g.toEcef(lat, lon, h));
}

glm::dvec3 normalAt(const Geodesy& g, double lat, double lon) {
  if (lat == 90.0 || lat == -90.0) lon = 0.0;
  return toVec(g.surfaceNormal(lat, lon));
}

double angleBetween(const glm::dvec3& a, const glm::dvec3& b) {
  return std::atan2(glm::length(glm::cross(a, b)), glm::dot(a, b));
}

} // namespace

double edgeLerp(double a, double b, int i, int count) noexcept {
  if (i == 0) return a;
  if (i == count - 1) return b;
  return a + (b - a) * (static_cast<double>(i) / static_cast<double>(count - 1));
}

SurfaceFrame surfaceFrame(double a, double b, double latDeg, double lonDeg) noexcept {
  const double phi = latDeg * kDegToRad, lam = lonDeg * kDegToRad;
  const double sp = std::sin(phi), cp = latDeg == 90.0 || latDeg == -90.0 ? 0.0 : std::cos(phi);
  const double sl = std::sin(lam), cl = std::cos(lam);
  // N: prime vertical radius of curvature, M: meridional; both a on a sphere.
  const double w2 = a * a * cp * cp + b * b * sp * sp;
  const double w = std::sqrt(w2);
  const double N = a * a / w;
  const double M = a * a * b * b / (w2 * w);
  SurfaceFrame f;
  f.position = {N * cp * cl, N * cp * sl, b * b / (a * a) * N * sp};
  f.perDegLat = M * kDegToRad * glm::dvec3(-sp * cl, -sp * sl, cp);
  f.perDegLon = N * cp * kDegToRad * glm::dvec3(-sl, cl, 0.0);
  return f;
}

bool BoundingSphere::contains(const glm::dvec3& p) const noexcept {
  return glm::length(p - centre) <= radius;
}

bool OrientedBox::contains(const glm::dvec3& p) const noexcept {
  const glm::dvec3 d = p - centre;
  for (std::size_t i = 0; i < 3; ++i)
    if (!(std::abs(glm::dot(d, axes[i])) <= halfExtents[static_cast<glm::length_t>(i)]))
      return false;
  return true;
}

namespace {

/** How many of the four corners are distinct points (a pole's corners are one). */
int distinctCount(const std::array<glm::dvec3, 4>& corners) {
  int count = 0;
  for (std::size_t i = 0; i < 4; ++i) {
    bool seen = false;
    for (std::size_t j = 0; j < i; ++j)
      seen = seen || corners[j] == corners[i];
    if (!seen) ++count;
  }
  return count;
}

/** The half-angle of a cone around the centre's normal holding the node's normals: the angular
 * distance from the middle grows monotonically towards the corners along each edge of a lat/long
 * rectangle, so the corners bound it. */
double normalConeOf(const glm::dvec3& centreNormal,
                    const std::array<glm::dvec3, 4>& cornerNormals) {
  double cone = 0.0;
  for (const auto& n : cornerNormals)
    cone = std::max(cone, angleBetween(centreNormal, n));
  return cone * (1.0 + 1e-12) + 1e-12;
}

/** The node's surface sampled for its bounds: a kBoundSamples x kBoundSamples grid at both
 * heights, in (row, col, height) order, and the samples' box. */
struct BoundSamples {
  std::vector<glm::dvec3> points;
  glm::dvec3 lo{std::numeric_limits<double>::infinity()};
  glm::dvec3 hi{-std::numeric_limits<double>::infinity()};
};

BoundSamples sampleBounds(const Geodesy& geodesy, const Sector& s, double minH, double maxH) {
  BoundSamples b;
  b.points.reserve(2 * kBoundSamples * kBoundSamples);
  for (int r = 0; r < kBoundSamples; ++r) {
    const double lat = edgeLerp(s.south, s.north, r, kBoundSamples);
    for (int c = 0; c < kBoundSamples; ++c) {
      const double lon = edgeLerp(s.west, s.east, c, kBoundSamples);
      for (const double h : {minH, maxH}) {
        const glm::dvec3 p = surfacePoint(geodesy, lat, lon, h);
        b.points.push_back(p);
        b.lo = glm::min(b.lo, p);
        b.hi = glm::max(b.hi, p);
      }
    }
  }
  return b;
}

// Between samples: on a cell of the 17 x 17 grid, the patch p(lat, lon) (at a fixed height)
// is within e = (dLat^2 max|p_lat,lat| + dLon^2 max|p_lon,lon|) / 8 of the bilinear
// interpolant of the cell's four samples (the tensor-product linear interpolation error; the
// interpolant is a convex combination of the samples). |p_lon,lon| is the parallel's radius,
// (N + h) cos(lat) <= (a^2/b + |h|) cos(smallest |latitude|); |p_lat,lat| is at most
// sqrt(M^2 + M'^2) + |h| <= 1.01 a^2/b + |h| (M the meridional radius of curvature, at most
// a^2/b, M' below 1 % of it on WGS84). A convex volume holding the samples then holds every
// patch point once grown by e; heights in between lie on the segment between the two sampled
// heights. The cosine matters for wide polar nodes (36 degrees of longitude a few km from the
// pole); e is metres where the old half-cell bound was kilometres (263 km at level zero).
double interpolationMargin(const Geodesy& geodesy, const Sector& s, double minH, double maxH) {
  const double a = geodesy.equatorialRadius();
  const double b = geodesy.polarRadius();
  const double maxAbsH = std::max(std::abs(minH), std::abs(maxH));
  const double cells = static_cast<double>(kBoundSamples - 1);
  const double minAbsLat =
      (s.south <= 0.0 && s.north >= 0.0) ? 0.0 : std::min(std::abs(s.south), std::abs(s.north));
  // cos rounded up a little (and never below 0) so the bound stays conservative.
  const double parallelScale = std::min(1.0, std::cos(minAbsLat * kDegToRad) + 1e-15);
  const double cellLatRad = (s.north - s.south) / cells * kDegToRad;
  const double cellLonRad = (s.east - s.west) / cells * kDegToRad;
  const double kLat = 1.01 * a * a / b + maxAbsH;
  const double kLon = (a * a / b + maxAbsH) * parallelScale;
  return (cellLatRad * cellLatRad * kLat + cellLonRad * cellLonRad * kLon) / 8.0;
}

/** Bounding sphere: the samples' box's middle as the centre, grown by the margin. */
BoundingSphere sphereAround(const BoundSamples& samples, double margin) {
  BoundingSphere sphere;
  sphere.centre = 0.5 * (samples.lo + samples.hi);
  double r2 = 0.0;
  for (const auto& p : samples.points) {
    const glm::dvec3 d = p - sphere.centre;
    r2 = std::max(r2, glm::dot(d, d));
  }
  sphere.radius = (std::sqrt(r2) + margin) * (1.0 + 1e-12) + 1e-6;
  return sphere;
}

// The boxes: the samples' extent along east, north and up at a middle longitude and the middle
// latitude (an orthonormal frame built from the angles, defined at the poles too), grown by the
// same margin (a projection on a unit axis is 1-Lipschitz). The whole node's, and one per half
// of the columns (each patch point lies in a cell of one half, within the margin of the hull of
// that cell's samples): for a wide polar wedge, whose arc a single box fits loosely.
OrientedBox boxAround(const BoundSamples& samples,
                      const glm::dvec3& centre,
                      double midLat,
                      double lonDeg,
                      int firstCol,
                      int lastCol,
                      double margin) {
  const double sLat = std::sin(midLat * kDegToRad), cLat = std::cos(midLat * kDegToRad);
  const double sLon = std::sin(lonDeg * kDegToRad), cLon = std::cos(lonDeg * kDegToRad);
  const std::array<glm::dvec3, 3> axes{glm::dvec3(-sLon, cLon, 0.0),
                                       glm::dvec3(-sLat * cLon, -sLat * sLon, cLat),
                                       glm::dvec3(cLat * cLon, cLat * sLon, sLat)};
  glm::dvec3 minA(std::numeric_limits<double>::infinity());
  glm::dvec3 maxA(-std::numeric_limits<double>::infinity());
  for (std::size_t i = 0; i < samples.points.size(); ++i) {
    const int col = static_cast<int>(i / 2) % kBoundSamples; // (row, col, height) order
    if (col < firstCol || col > lastCol) continue;
    const glm::dvec3 d = samples.points[i] - centre;
    const glm::dvec3 t(glm::dot(d, axes[0]), glm::dot(d, axes[1]), glm::dot(d, axes[2]));
    minA = glm::min(minA, t);
    maxA = glm::max(maxA, t);
  }
  OrientedBox box;
  box.axes = axes;
  const glm::dvec3 mid = 0.5 * (minA + maxA);
  box.centre = centre + mid.x * axes[0] + mid.y * axes[1] + mid.z * axes[2];
  const glm::dvec3 half = 0.5 * (maxA - minA) + glm::dvec3(margin);
  box.halfExtents = half * (1.0 + 1e-12) + glm::dvec3(1e-6);
  return box;
}

} // namespace

NodeGeometry::NodeGeometry(const Geodesy& geodesy,
                           const Sector& sector,
                           double minHeightM,
                           double maxHeightM)
    : sector_(sector), minHeight_(minHeightM), maxHeight_(maxHeightM) {
  validate(sector);
  if (!(std::isfinite(minHeightM) && std::isfinite(maxHeightM) && minHeightM <= maxHeightM))
    throw std::invalid_argument("planet: node heights must be finite with min <= max");

  a_ = geodesy.equatorialRadius();
  b_ = geodesy.polarRadius();
  const Sector& s = sector_;
  const std::array<std::array<double, 2>, 4> latLon{
      {{s.south, s.west}, {s.south, s.east}, {s.north, s.east}, {s.north, s.west}}};
  for (std::size_t i = 0; i < 4; ++i) {
    corners_[i] = surfacePoint(geodesy, latLon[i][0], latLon[i][1], 0.0);
    cornerNormals_[i] = normalAt(geodesy, latLon[i][0], latLon[i][1]);
    cornerFrames_[i] =
        surfaceFrame(geodesy.equatorialRadius(), geodesy.polarRadius(), latLon[i][0], latLon[i][1]);
    cornerFrames_[i].position = corners_[i]; // GeographicLib's, bit-identical to the corners
  }
  distinctCorners_ = distinctCount(corners_);

  const double midLat = 0.5 * (s.south + s.north);
  const double midLon = 0.5 * (s.west + s.east);
  centre_ = surfacePoint(geodesy, midLat, midLon, 0.0);
  centreNormal_ = normalAt(geodesy, midLat, midLon);
  normalCone_ = normalConeOf(centreNormal_, cornerNormals_);

  const BoundSamples samples = sampleBounds(geodesy, s, minHeightM, maxHeightM);
  const double margin = interpolationMargin(geodesy, s, minHeightM, maxHeightM);
  bounds_ = sphereAround(samples, margin);
  constexpr int middleCol = kBoundSamples / 2;
  box_ = boxAround(samples, centre_, midLat, midLon, 0, kBoundSamples - 1, margin);
  halfBoxes_[0] =
      boxAround(samples, centre_, midLat, 0.5 * (s.west + midLon), 0, middleCol, margin);
  halfBoxes_[1] = boxAround(
      samples, centre_, midLat, 0.5 * (midLon + s.east), middleCol, kBoundSamples - 1, margin);
}

PatchMesh buildPatchMesh(const Geodesy& geodesy, const Sector& sector, int n) {
  validate(sector);
  if (n < 3 || n > 1025 || ((n - 1) & (n - 2)) != 0)
    throw std::invalid_argument("planet: patch grid size must be 2^k + 1, 3 <= n <= 1025");
  PatchMesh mesh;
  mesh.n = n;
  mesh.centre = surfacePoint(
      geodesy, 0.5 * (sector.south + sector.north), 0.5 * (sector.west + sector.east), 0.0);
  mesh.vertices.resize(static_cast<std::size_t>(n) * static_cast<std::size_t>(n));
  for (int r = 0; r < n; ++r) {
    const double lat = edgeLerp(sector.south, sector.north, r, n);
    const double v = static_cast<double>(r) / static_cast<double>(n - 1);
    for (int c = 0; c < n; ++c) {
      const double lon = edgeLerp(sector.west, sector.east, c, n);
      PatchVertex& vx = mesh.vertices[static_cast<std::size_t>(r * n + c)];
      vx.position = surfacePoint(geodesy, lat, lon, 0.0) - mesh.centre;
      vx.normal = normalAt(geodesy, lat, lon);
      vx.uvNode = {static_cast<double>(c) / static_cast<double>(n - 1), v};
      vx.uvGlobal = {(lon + 180.0) / 360.0, (lat + 90.0) / 180.0};
      // No NaN or inf in what reaches the GPU (issue #8; debug builds).
      assert(std::isfinite(vx.position.x) && std::isfinite(vx.position.y) &&
             std::isfinite(vx.position.z));
      assert(std::isfinite(vx.normal.x) && std::isfinite(vx.normal.y) &&
             std::isfinite(vx.normal.z));
      assert(vx.uvNode.x >= 0.0 && vx.uvNode.x <= 1.0 && vx.uvNode.y >= 0.0 && vx.uvNode.y <= 1.0);
      assert(vx.uvGlobal.x >= 0.0 && vx.uvGlobal.x <= 1.0 && vx.uvGlobal.y >= 0.0 &&
             vx.uvGlobal.y <= 1.0);
    }
  }
  return mesh;
}

namespace {

// The distance from the origin to segment [a, b] (a point when a == b).
double segmentNorm(const glm::dvec3& a, const glm::dvec3& b) {
  const glm::dvec3 d = b - a;
  const double dd = glm::dot(d, d);
  const double t = dd > 0.0 ? std::clamp(-glm::dot(a, d) / dd, 0.0, 1.0) : 0.0;
  return glm::length(a + t * d);
}

// The distance from the origin to triangle (a, b, c): its edges, and the foot of the perpendicular
// from the origin onto its plane when that falls inside. A degenerate triangle (a polar cell with
// two corners at the pole) is its edges.
double triangleNorm(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
  double best = std::min({segmentNorm(a, b), segmentNorm(b, c), segmentNorm(c, a)});
  const glm::dvec3 n = glm::cross(b - a, c - a);
  const double nn = glm::dot(n, n);
  if (nn > 0.0) {
    const glm::dvec3 p = n * (glm::dot(n, a) / nn);
    if (glm::dot(glm::cross(b - a, p - a), n) >= 0.0 &&
        glm::dot(glm::cross(c - b, p - b), n) >= 0.0 &&
        glm::dot(glm::cross(a - c, p - c), n) >= 0.0)
      best = std::min(best, glm::length(p));
  }
  return best;
}

} // namespace

double gridChordDepthM(const Geodesy& geodesy, const Sector& sector, int cols, int rows) {
  validate(sector);
  if (cols < 2 || rows < 2) throw std::invalid_argument("planet: a grid has at least 2 x 2 points");
  const double a = geodesy.equatorialRadius(), b = geodesy.polarRadius();
  // Grid points in the space where the ellipsoid is the unit sphere.
  std::vector<glm::dvec3> p(static_cast<std::size_t>(cols) * static_cast<std::size_t>(rows));
  for (int r = 0; r < rows; ++r) {
    const double lat = edgeLerp(sector.south, sector.north, r, rows);
    for (int c = 0; c < cols; ++c) {
      const glm::dvec3 q =
          surfacePoint(geodesy, lat, edgeLerp(sector.west, sector.east, c, cols), 0.0);
      p[static_cast<std::size_t>(r * cols + c)] = {q.x / a, q.y / a, q.z / b};
    }
  }
  const auto at = [&](int r, int c) -> const glm::dvec3& {
    return p[static_cast<std::size_t>(r * cols + c)];
  };
  double smallest = 1.0;
  for (int r = 0; r + 1 < rows; ++r)
    for (int c = 0; c + 1 < cols; ++c) {
      const glm::dvec3 &sw = at(r, c), &se = at(r, c + 1), &nw = at(r + 1, c),
                       &ne = at(r + 1, c + 1);
      for (const auto& [x, y, z] :
           {std::tie(sw, se, ne), std::tie(sw, ne, nw), std::tie(sw, se, nw), std::tie(se, ne, nw)})
        smallest = std::min(smallest, triangleNorm(x, y, z));
    }
  return (1.0 - smallest) * a;
}

} // namespace tellus::planet
