#include <tellus/planet/Morph.hpp>
#include <tellus/planet/Terrain.hpp>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

namespace tellus::planet {

namespace {

glm::dvec3 toVec(const Ecef& e) {
  return {e.x, e.y, e.z};
}

/** The point of a grid line: latitude/longitude for (row, col) of an n-grid over s. */
struct GridPoint {
  double lat;
  double lon;
};

/** The point at parameter p of side d of sector s: p is a longitude along north/south sides, a
 * latitude along east/west ones. */
GridPoint onSide(const Sector& s, Direction d, double p) {
  switch (d) {
  case Direction::North:
    return {s.north, p};
  case Direction::South:
    return {s.south, p};
  case Direction::East:
    return {p, s.east};
  case Direction::West:
    return {p, s.west};
  }
  return {0.0, 0.0};
}

/** The index of the i-th vertex (west to east, south to north) of side d of an n x n grid. */
std::uint32_t sideVertex(int n, Direction d, int i) noexcept {
  auto vid = [n](int r, int c) { return static_cast<std::uint32_t>(r * n + c); };
  switch (d) {
  case Direction::North:
    return vid(n - 1, i);
  case Direction::South:
    return vid(0, i);
  case Direction::East:
    return vid(i, n - 1);
  case Direction::West:
    return vid(i, 0);
  }
  return vid(0, 0);
}

/** The quadrant range (SW, SE, NW, NE) whose cells hold the i-th vertex of side d. */
int sideQuadrant(int n, Direction d, int i) noexcept {
  const int upper = i < (n - 1) / 2 ? 0 : 1;
  switch (d) {
  case Direction::North:
    return 2 + upper;
  case Direction::South:
    return upper;
  case Direction::East:
    return 2 * upper + 1;
  case Direction::West:
    return 2 * upper;
  }
  return 0;
}

/** The zero-area fan of one coarse segment: from its first vertex (apex) over the chain (our
 * vertices strictly inside it, then its last vertex), into the quadrant range given. Wound as
 * the grid's cells (counter-clockwise seen from outside) over the sliver it closes, the gap
 * between our side and the coarse chord beyond it: the chain runs west to east or south to north,
 * so a south or an east side's fan is reversed. Wound backwards (as before), a draw with back
 * faces culled (Renderer::redrawLast) dropped the slivers and showed one-pixel cracks. */
void addFan(TerrainMesh& mesh,
            std::vector<std::uint32_t>& quadrant,
            Direction side,
            std::uint32_t apex,
            const std::vector<std::uint32_t>& chain) {
  const bool reversed = side == Direction::South || side == Direction::East;
  for (std::size_t a = 0; a + 1 < chain.size(); ++a) {
    if (reversed)
      quadrant.insert(quadrant.end(), {apex, chain[a + 1], chain[a]});
    else
      quadrant.insert(quadrant.end(), {apex, chain[a], chain[a + 1]});
    ++mesh.zeroAreaTriangles;
  }
}

using Quadrants = std::array<std::vector<std::uint32_t>, 4>;

/** One side of an n x n grid: its vertices (west to east, south to north) and their quadrants. */
struct Side {
  int n;
  Direction d;
  std::uint32_t vertex(int i) const noexcept { return sideVertex(n, d, i); }
  int quadrant(int i) const noexcept { return sideQuadrant(n, d, i); }
};

/** The vertices a side's fans need beyond the grid's: a coarse vertex past our edge, made once as
 * a copy of our vertex next to it moved onto it. */
class ExtraVertices {
public:
  explicit ExtraVertices(std::size_t coarseCount) : slots_(coarseCount, UINT32_MAX) {}

  std::uint32_t at(TerrainMesh& mesh,
                   std::int64_t j,
                   std::uint32_t nearFine,
                   const glm::dvec3& position,
                   const glm::dvec4& morph = glm::dvec4(0.0)) {
    auto& slot = slots_[static_cast<std::size_t>(j)];
    if (slot == UINT32_MAX) {
      TerrainVertex v = mesh.vertices[nearFine];
      v.position = position;
      v.morphDelta = glm::dvec3(morph);
      v.morphExtentM = morph.w;
      slot = static_cast<std::uint32_t>(mesh.vertices.size());
      mesh.vertices.push_back(v);
    }
    return slot;
  }

private:
  std::vector<std::uint32_t> slots_;
};

/** Where a side's vertices lie along a polyline edge: t, in coarse segments from its start, and
 * the coarse vertex each one is (-1: none). */
struct PolylineParams {
  std::vector<double> t;
  std::vector<std::int64_t> on;
};

/** Our side's vertices onto the polyline's chords by their coordinate along the edge; a vertex
 * within 1e-9 of a coarse vertex takes that vertex's position. */
PolylineParams snapOntoPolyline(TerrainMesh& mesh,
                                const Side& side,
                                double ma,
                                double mb,
                                double ca,
                                double cb,
                                const std::vector<glm::dvec3>& cpos) {
  const int n = side.n;
  const auto nc = static_cast<std::int64_t>(cpos.size());
  const double segments = static_cast<double>(nc - 1);
  PolylineParams p{std::vector<double>(static_cast<std::size_t>(n)),
                   std::vector<std::int64_t>(static_cast<std::size_t>(n), -1)};
  for (int i = 0; i < n; ++i) {
    const double x = (edgeLerp(ma, mb, i, n) - ca) / (cb - ca) * segments;
    const double r = std::round(x);
    const auto k = static_cast<std::size_t>(i);
    p.t[k] = x;
    if (std::abs(x - r) < 1e-9 && r >= 0.0 && r <= segments) p.on[k] = static_cast<std::int64_t>(r);
    TerrainVertex& v = mesh.vertices[side.vertex(i)];
    if (p.on[k] >= 0) {
      v.position = cpos[static_cast<std::size_t>(p.on[k])];
    } else {
      const double j = std::clamp(std::floor(x), 0.0, segments - 1.0);
      const auto jj = static_cast<std::size_t>(j);
      v.position = cpos[jj] + (cpos[jj + 1] - cpos[jj]) * (x - j);
    }
  }
  return p;
}

/** Edge fixing onto a coarser neighbour whose edge is not a power of two times ours (a polar
 * cap's rim): our side's vertices go onto its chords (snapOntoPolyline), and each coarse segment
 * with our vertices strictly inside gets the zero-area fan from its first vertex over them to its
 * last (an extra vertex where a coarse vertex lies beyond our edge), as in the power-of-two
 * case. */
void fixOntoPolyline(TerrainMesh& mesh,
                     Quadrants& quad,
                     const Side& side,
                     double ma,
                     double mb,
                     double ca,
                     double cb,
                     const std::vector<glm::dvec3>& cpos) {
  const int n = side.n;
  const double segments = static_cast<double>(static_cast<std::int64_t>(cpos.size()) - 1);
  const auto [t, on] = snapOntoPolyline(mesh, side, ma, mb, ca, cb, cpos);
  for (int i = 0; i < n; ++i) // a cap's rim does not morph: neither do our vertices on it
    mesh.vertices[side.vertex(i)].morphDelta = glm::dvec3(0.0);
  ExtraVertices extra(cpos.size());
  auto coarseIndex = [&](std::int64_t j, int nearFine) {
    for (int i = 0; i < n; ++i)
      if (on[static_cast<std::size_t>(i)] == j) return side.vertex(i);
    return extra.at(mesh, j, side.vertex(nearFine), cpos[static_cast<std::size_t>(j)]);
  };
  const auto jFirst = static_cast<std::int64_t>(std::clamp(std::floor(t.front()), 0.0, segments));
  const auto jLast = static_cast<std::int64_t>(std::clamp(std::ceil(t.back()), 0.0, segments));
  for (std::int64_t j = jFirst; j < jLast; ++j) {
    std::vector<std::uint32_t> chain;
    int firstInner = -1;
    for (int i = 0; i < n; ++i) {
      const auto k = static_cast<std::size_t>(i);
      if (on[k] < 0 && t[k] > static_cast<double>(j) && t[k] < static_cast<double>(j + 1)) {
        if (firstInner < 0) firstInner = i;
        chain.push_back(side.vertex(i));
      }
    }
    if (firstInner < 0) continue;
    const int lastInner = firstInner + static_cast<int>(chain.size()) - 1;
    const std::uint32_t apex = coarseIndex(j, firstInner);
    chain.push_back(coarseIndex(j + 1, lastInner));
    addFan(mesh, quad[static_cast<std::size_t>(side.quadrant(firstInner))], side.d, apex, chain);
  }
  // A coarse vertex strictly between two of ours (never so in the power-of-two case) is a kink
  // of the coarse edge that our straight segment cuts across: the triangle between them is not
  // degenerate (a height step with relief), and without it a pixel falls through. Wound like the
  // cells (counter-clockwise seen from outside) when the kink bends outwards.
  const bool reversed = side.d == Direction::North || side.d == Direction::West;
  for (int i = 0; i + 1 < n; ++i) {
    const double a = t[static_cast<std::size_t>(i)], b = t[static_cast<std::size_t>(i) + 1];
    for (auto j = static_cast<std::int64_t>(std::floor(a)) + 1; static_cast<double>(j) < b; ++j) {
      if (j > static_cast<std::int64_t>(segments)) continue;
      if (on[static_cast<std::size_t>(i)] == j || on[static_cast<std::size_t>(i) + 1] == j)
        continue;
      const std::uint32_t c = coarseIndex(j, i), p = side.vertex(i), q = side.vertex(i + 1);
      auto& target = quad[static_cast<std::size_t>(side.quadrant(i))];
      if (reversed)
        target.insert(target.end(), {q, c, p});
      else
        target.insert(target.end(), {p, c, q});
      ++mesh.kinkTriangles;
    }
  }
}

/** The displaced surface. A height that is not a finite number (a broken height function; the
 * field itself never gives one for finite input) is the ellipsoid's: NaN or inf never reaches a
 * vertex, a normal or the node's height range (issue #8; asserted in debug builds). */
struct Surface {
  const Geodesy& geodesy;
  const HeightFunction& height;

  double heightOf(double lat, double lon) const {
    const double h = height(lat, lon);
    return std::isfinite(h) ? h : 0.0;
  }
  glm::dvec3 position(double lat, double lon) const {
    if (lat == 90.0 || lat == -90.0) lon = 0.0; // a pole is one point
    return toVec(geodesy.toEcef(lat, lon, heightOf(lat, lon)));
  }
};

/** The coarse vertices of a side: the neighbour's own grid points along the shared line (given,
 * or computed with the neighbour's parameters), so they are the very points it draws. */
std::vector<glm::dvec3> coarseSideVertices(const EdgeAdapt& ad,
                                           const Sector& s,
                                           const Side& side,
                                           double ca,
                                           double cb,
                                           const Surface& surface) {
  const int n = side.n;
  std::vector<glm::dvec3> cpos(static_cast<std::size_t>(n));
  if (ad.coarseVertices.size() == static_cast<std::size_t>(n)) {
    cpos = ad.coarseVertices;
  } else {
    for (int j = 0; j < n; ++j) {
      const GridPoint g = onSide(s, side.d, edgeLerp(ca, cb, j, n));
      cpos[static_cast<std::size_t>(j)] = surface.position(g.lat, g.lon);
    }
  }
  return cpos;
}

/** Our side's vertices onto the coarse edge's chords: fine vertex i sits u = u0 + i fine steps
 * from the coarse edge's start, coarse vertex j at j R. */
void snapOntoChords(TerrainMesh& mesh,
                    const Side& side,
                    std::int64_t u0,
                    std::int64_t bigR,
                    const std::vector<glm::dvec3>& cpos,
                    const std::vector<glm::dvec4>& cmorph) {
  for (int i = 0; i < side.n; ++i) {
    const std::int64_t u = u0 + i;
    const std::int64_t j = u / bigR, r = u % bigR;
    TerrainVertex& v = mesh.vertices[side.vertex(i)];
    const auto jj = static_cast<std::size_t>(j);
    if (r == 0) {
      v.position = cpos[jj];
      v.morphDelta = glm::dvec3(cmorph[jj]);
      v.morphExtentM = cmorph[jj].w;
    } else {
      const double t = static_cast<double>(r) / static_cast<double>(bigR);
      const glm::dvec3& a = cpos[jj];
      v.position = a + (cpos[jj + 1] - a) * t;
      // On the coarse chord as it morphs: the ends' offsets interpolated alike.
      const glm::dvec3 ma(cmorph[jj]), mb(cmorph[jj + 1]);
      v.morphDelta = ma + (mb - ma) * t;
      v.morphExtentM = std::max(cmorph[jj].w, cmorph[jj + 1].w);
    }
  }
}

/** The coarse side's morph (EdgeAdapt::coarseMorph): given, or from its vertices (even ones
 * stay, odd ones onto their neighbours' chord) with extentM; zeros when extentM is 0. */
std::vector<glm::dvec4>
coarseSideMorph(const EdgeAdapt& ad, const std::vector<glm::dvec3>& cpos, double extentM) {
  if (ad.coarseMorph.size() == cpos.size()) return ad.coarseMorph;
  std::vector<glm::dvec4> m(cpos.size(), glm::dvec4(0.0));
  if (!(extentM > 0.0)) return m;
  for (std::size_t j = 0; j < cpos.size(); ++j) {
    const glm::dvec3 d = (j & 1U) != 0 && j + 1 < cpos.size()
                             ? 0.5 * (cpos[j - 1] + cpos[j + 1]) - cpos[j]
                             : glm::dvec3(0.0);
    m[j] = glm::dvec4(d, extentM);
  }
  return m;
}

/** Fans (thesis figure 21): for each coarse segment j our edge touches, the triangles from its
 * first vertex over the fine vertices inside it and its last vertex. Each has zero area; their
 * outer edge is the coarse node's edge, shared exactly, so no pixel falls between. */
void addChordFans(TerrainMesh& mesh,
                  Quadrants& quad,
                  const Side& side,
                  std::int64_t u0,
                  std::int64_t bigR,
                  const std::vector<glm::dvec3>& cpos,
                  const std::vector<glm::dvec4>& cmorph) {
  const int n = side.n;
  ExtraVertices extra(static_cast<std::size_t>(n));
  auto coarseIndex = [&](std::int64_t j, int nearFine) {
    const std::int64_t u = j * bigR - u0;
    if (u >= 0 && u < n) return side.vertex(static_cast<int>(u));
    // beyond this node's edge: an extra vertex
    return extra.at(mesh,
                    j,
                    side.vertex(nearFine),
                    cpos[static_cast<std::size_t>(j)],
                    cmorph[static_cast<std::size_t>(j)]);
  };
  const std::int64_t jFirst = u0 / bigR, jLast = (u0 + n - 2) / bigR;
  for (std::int64_t j = jFirst; j <= jLast; ++j) {
    std::vector<std::uint32_t> chain;
    int firstInner = -1;
    for (int i = 0; i < n; ++i) {
      const std::int64_t u = u0 + i;
      if (u > j * bigR && u < (j + 1) * bigR) {
        if (firstInner < 0) firstInner = i;
        chain.push_back(side.vertex(i));
      }
    }
    if (firstInner < 0) continue; // R == 1 cannot happen; nothing strictly inside
    const int lastInner = firstInner + static_cast<int>(chain.size()) - 1;
    const std::uint32_t apex = coarseIndex(j, firstInner);
    chain.push_back(coarseIndex(j + 1, lastInner));
    addFan(mesh, quad[static_cast<std::size_t>(side.quadrant(firstInner))], side.d, apex, chain);
  }
}

/** Edge fixing of one adapted side: its vertices onto the coarse neighbour's chords, then fans. */
void fixSide(TerrainMesh& mesh,
             Quadrants& quad,
             const Sector& s,
             const Side& side,
             const EdgeAdapt& ad,
             const Surface& surface,
             double morphExtentM) {
  const bool alongLon = side.d == Direction::North || side.d == Direction::South;
  const Sector& c = ad.coarse;
  const double ca = alongLon ? c.west : c.south, cb = alongLon ? c.east : c.north;
  const double ma = alongLon ? s.west : s.south, mb = alongLon ? s.east : s.north;
  if (!(ca <= ma && mb <= cb)) return;
  // The coarse edge is R = 2^m times ours and we are its q-th part: fine vertex i sits at
  // u = q (n - 1) + i fine steps from its start, coarse vertex j at j R. Integers, so which
  // fine vertices are coarse vertices never depends on rounding.
  const double ratio = (cb - ca) / (mb - ma);
  const auto bigR = static_cast<std::int64_t>(std::llround(ratio));
  if (bigR < 2 || (bigR & (bigR - 1)) != 0 ||
      std::abs(ratio - static_cast<double>(bigR)) > 1e-9 * ratio) {
    // Not a quadtree neighbour: a polar cap, whose rim is a whole parallel (10 or 20 times our
    // edge) drawn with its own vertex count (nc, given). The same fix in real coordinates.
    if (ratio > 1.0 && ad.coarseVertices.size() >= 2)
      fixOntoPolyline(mesh, quad, side, ma, mb, ca, cb, ad.coarseVertices);
    return;
  }
  const auto q = static_cast<std::int64_t>(std::llround((ma - ca) / (mb - ma)));
  if (q < 0 || q >= bigR) return;
  const std::vector<glm::dvec3> cpos = coarseSideVertices(ad, s, side, ca, cb, surface);
  const std::int64_t u0 = q * (side.n - 1);
  // The coarse side's extent (morphEdgeExtent): ours times its span along the side over our
  // latitude span.
  const std::vector<glm::dvec4> cmorph =
      coarseSideMorph(ad, cpos, morphExtentM * ((cb - ca) / (s.north - s.south)));
  snapOntoChords(mesh, side, u0, bigR, cpos, cmorph);
  addChordFans(mesh, quad, side, u0, bigR, cpos, cmorph);
}

void checkMeshArguments(const Sector& s, int n, int rows, const std::array<EdgeAdapt, 4>& edges) {
  for (const int k : {n, rows})
    if (k < 3 || k > 1025 || ((k - 1) & (k - 2)) != 0)
      throw std::invalid_argument("planet: patch grid size must be 2^k + 1, 3 <= n <= 1025");
  if (rows != n &&
      std::any_of(edges.begin(), edges.end(), [](const EdgeAdapt& e) { return e.active; }))
    throw std::invalid_argument("planet: edge fixing needs a square patch grid");
  if (!(std::isfinite(s.west) && std::isfinite(s.east) && std::isfinite(s.south) &&
        std::isfinite(s.north)) ||
      !(s.south >= -90.0 && s.south < s.north && s.north <= 90.0) ||
      !(s.west >= -180.0 && s.west < s.east && s.east <= 180.0))
    throw std::invalid_argument("planet: sector must satisfy -90 <= south < north <= 90 and "
                                "-180 <= west < east <= 180");
}

/** Positions on an (rows + 2) x (n + 2) ring: the grid plus one step outside for the normals,
 * and the height range over the grid's points. */
struct Ring {
  int m = 0;
  std::vector<double> lats, lons;
  std::vector<glm::dvec3> points;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  const glm::dvec3& at(int r, int c) const { return points[static_cast<std::size_t>(r * m + c)]; }
};

Ring sampleRing(const Surface& surface, const Sector& s, int n, int rows) {
  Ring ring;
  const int m = n + 2, mr = rows + 2;
  ring.m = m;
  const double dLat = (s.north - s.south) / (rows - 1), dLon = (s.east - s.west) / (n - 1);
  ring.points.resize(static_cast<std::size_t>(mr) * static_cast<std::size_t>(m));
  ring.lats.resize(static_cast<std::size_t>(mr));
  ring.lons.resize(static_cast<std::size_t>(m));
  for (int i = 0; i < mr; ++i)
    ring.lats[static_cast<std::size_t>(i)] = i == 0 ? std::max(-90.0, s.south - dLat)
                                             : i == mr - 1
                                                 ? std::min(90.0, s.north + dLat)
                                                 : edgeLerp(s.south, s.north, i - 1, rows);
  for (int i = 0; i < m; ++i)
    ring.lons[static_cast<std::size_t>(i)] = i == 0       ? s.west - dLon
                                             : i == m - 1 ? s.east + dLon
                                                          : edgeLerp(s.west, s.east, i - 1, n);
  for (int r = 0; r < mr; ++r)
    for (int c = 0; c < m; ++c) {
      const double lat = ring.lats[static_cast<std::size_t>(r)],
                   lon = ring.lons[static_cast<std::size_t>(c)];
      const double hgt = surface.heightOf(lat, lat == 90.0 || lat == -90.0 ? 0.0 : lon);
      if (r > 0 && r < mr - 1 && c > 0 && c < m - 1) {
        ring.lo = std::min(ring.lo, hgt);
        ring.hi = std::max(ring.hi, hgt);
      }
      ring.points[static_cast<std::size_t>(r * m + c)] =
          toVec(surface.geodesy.toEcef(lat, lat == 90.0 || lat == -90.0 ? 0.0 : lon, hgt));
    }
  return ring;
}

/** The grid's vertices: positions from the ring, normals from its central differences. */
void setGridVertices(TerrainMesh& mesh, const Ring& ring, const Geodesy& geodesy) {
  const int n = mesh.n, rows = mesh.rows;
  mesh.vertices.resize(static_cast<std::size_t>(rows) * static_cast<std::size_t>(n));
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < n; ++c) {
      TerrainVertex& v = mesh.vertices[static_cast<std::size_t>(r * n + c)];
      v.position = ring.at(r + 1, c + 1);
      const glm::dvec3 east = ring.at(r + 1, c + 2) - ring.at(r + 1, c);
      const glm::dvec3 north = ring.at(r + 2, c + 1) - ring.at(r, c + 1);
      glm::dvec3 nrm = glm::cross(east, north);
      const double len = glm::length(nrm);
      if (!(len > 0.0) || !std::isfinite(len)) { // the pole row: east-west differences vanish
        const double lat = ring.lats[static_cast<std::size_t>(r + 1)],
                     lon = ring.lons[static_cast<std::size_t>(c + 1)];
        nrm = toVec(geodesy.surfaceNormal(lat, lat == 90.0 || lat == -90.0 ? 0.0 : lon));
      } else {
        nrm /= len;
      }
      v.normal = glm::vec3(nrm);
      v.uvNode = {static_cast<double>(c) / (n - 1), static_cast<double>(r) / (rows - 1)};
    }
}

/** The grid's cells, two triangles each, per quadrant (SW, SE, NW, NE). */
Quadrants gridCells(int n, int rows) {
  const int half = (n - 1) / 2, halfRows = (rows - 1) / 2;
  Quadrants quad;
  auto vid = [n](int r, int c) { return static_cast<std::uint32_t>(r * n + c); };
  for (int r = 0; r + 1 < rows; ++r)
    for (int c = 0; c + 1 < n; ++c) {
      auto& q = quad[static_cast<std::size_t>((r >= halfRows ? 2 : 0) + (c >= half ? 1 : 0))];
      const std::uint32_t a = vid(r, c), b = vid(r, c + 1), d = vid(r + 1, c),
                          e = vid(r + 1, c + 1);
      q.insert(q.end(), {a, b, e, a, e, d});
    }
  return quad;
}

#ifndef NDEBUG
void assertFinite(const TerrainMesh& mesh) {
  for (const TerrainVertex& v : mesh.vertices) {
    assert(std::isfinite(v.position.x) && std::isfinite(v.position.y) &&
           std::isfinite(v.position.z));
    assert(std::isfinite(v.normal.x) && std::isfinite(v.normal.y) && std::isfinite(v.normal.z));
    assert(std::abs(glm::length(glm::dvec3(v.normal)) - 1.0) < 1e-3);
    assert(v.uvNode.x >= 0.0 && v.uvNode.x <= 1.0 && v.uvNode.y >= 0.0 && v.uvNode.y <= 1.0);
  }
  assert(std::isfinite(mesh.minHeightM) && std::isfinite(mesh.maxHeightM));
}
#endif

} // namespace

TerrainMesh buildTerrainMesh(const Geodesy& geodesy,
                             const Sector& sector,
                             int n,
                             const HeightFunction& height,
                             const std::array<EdgeAdapt, 4>& edges,
                             int rows,
                             double morphExtentM) {
  if (rows == 0) rows = n;
  checkMeshArguments(sector, n, rows, edges);
  const Surface surface{geodesy, height};
  TerrainMesh mesh;
  mesh.n = n;
  mesh.rows = rows;
  const Ring ring = sampleRing(surface, sector, n, rows);
  mesh.minHeightM = ring.lo;
  mesh.maxHeightM = ring.hi;
  setGridVertices(mesh, ring, geodesy);
  if (morphExtentM > 0.0 && rows == n)
    setGridMorph(mesh, morphExtentM, morphEdgeExtent(morphExtentM, sector, true));
  // Triangles per quadrant: cells, then the zero-area fans of its adapted outer edges.
  Quadrants quad = gridCells(n, rows);
  for (int side = 0; side < 4; ++side) {
    const EdgeAdapt& ad = edges[static_cast<std::size_t>(side)];
    if (ad.active)
      fixSide(mesh, quad, sector, Side{n, static_cast<Direction>(side)}, ad, surface, morphExtentM);
  }
  for (int qd = 0; qd < 4; ++qd) {
    mesh.quadrantStart[static_cast<std::size_t>(qd)] =
        static_cast<std::uint32_t>(mesh.indices.size());
    mesh.indices.insert(mesh.indices.end(),
                        quad[static_cast<std::size_t>(qd)].begin(),
                        quad[static_cast<std::size_t>(qd)].end());
  }
  mesh.quadrantStart[4] = static_cast<std::uint32_t>(mesh.indices.size());
#ifndef NDEBUG
  assertFinite(mesh);
#endif
  return mesh;
}

} // namespace tellus::planet
