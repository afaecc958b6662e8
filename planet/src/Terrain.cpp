#include <tellus/codec/Bil16.hpp>
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

constexpr std::size_t kHistoryLimit = 4096;

glm::dvec3 toVec(const Ecef& e) {
  return {e.x, e.y, e.z};
}

Sector grown(const Sector& s, double byLat, double byLon) {
  return {s.west - byLon, s.south - byLat, s.east + byLon, s.north + byLat};
}

bool intersects(const Sector& a, const Sector& b) {
  // Closed intervals: a tile that only touches a node's edge still changes its edge heights.
  return a.west <= b.east && b.west <= a.east && a.south <= b.north && b.south <= a.north;
}

/** Wrapped copies of a sector (growing a tile past +-180 reaches the other side). */
bool intersectsWrapped(const Sector& changed, const Sector& s) {
  if (intersects(changed, s)) return true;
  if (changed.west < -180.0 &&
      intersects({changed.west + 360.0, changed.south, 180.0, changed.north}, s))
    return true;
  if (changed.east > 180.0 &&
      intersects({-180.0, changed.south, changed.east - 360.0, changed.north}, s))
    return true;
  return false;
}

} // namespace

std::expected<HeightTile, std::string> heightTileFromSamples(const TileKey& key,
                                                             int width,
                                                             int height,
                                                             std::span<const double> raw,
                                                             const HeightEncoding& encoding) {
  if (width <= 0 || height <= 0 ||
      raw.size() != static_cast<std::size_t>(width) * static_cast<std::size_t>(height))
    return std::unexpected("the elevation tile has " + std::to_string(raw.size()) +
                           " samples, not " + std::to_string(width) + " x " +
                           std::to_string(height));
  HeightTile t;
  t.key = key;
  t.width = width;
  t.height = height;
  t.metres.resize(raw.size());
  float lo = std::numeric_limits<float>::infinity(), hi = -lo;
  for (std::size_t i = 0; i < raw.size(); ++i) {
    double m = raw[i];
    if (encoding.noData && m == *encoding.noData)
      m = 0.0;
    else
      m = m * encoding.scale + encoding.offset;
    if (!std::isfinite(m))
      return std::unexpected(std::string("the elevation tile has a non-finite sample"));
    const auto f = static_cast<float>(m);
    t.metres[i] = f;
    lo = std::min(lo, f);
    hi = std::max(hi, f);
  }
  t.minM = lo;
  t.maxM = hi;
  return t;
}

std::expected<HeightTile, std::string> decodeBil16(const TileKey& key,
                                                   int width,
                                                   int height,
                                                   std::span<const std::byte> bytes,
                                                   const HeightEncoding& encoding) {
  // A negative width or height is an empty tile here: heightTileFromSamples says what is wrong.
  const auto samples = codec::decodeBil16(bytes, std::max(width, 0), std::max(height, 0));
  if (!samples) return std::unexpected(samples.error());
  const std::vector<double> raw(samples->begin(), samples->end());
  return heightTileFromSamples(key, width, height, raw, encoding);
}

void applyVerticalDatum(HeightTile& tile, const Sector& sector, const VerticalDatum& datum) {
  if (!datum.usesGeoid() || tile.width <= 0 || tile.height <= 0) return;
  const double dLat = (sector.north - sector.south) / tile.height;
  const double dLon = (sector.east - sector.west) / tile.width;
  float lo = std::numeric_limits<float>::infinity(), hi = -lo;
  std::vector<double> n(static_cast<std::size_t>(tile.width));
  for (int r = 0; r < tile.height; ++r) {
    const double lat = sector.north - (r + 0.5) * dLat;
    // A row of samples is a parallel: N at the geoid grid's meridians it crosses, linear between
    // (exactly the bilinear interpolation; 40x fewer lookups for a 150-sample row in one cell).
    datum.geoid()->undulationsAlongParallel(lat, sector.west + 0.5 * dLon, dLon, n);
    for (int c = 0; c < tile.width; ++c) {
      float& m = tile.metres[static_cast<std::size_t>(r) * static_cast<std::size_t>(tile.width) +
                             static_cast<std::size_t>(c)];
      const double h = static_cast<double>(m) + n[static_cast<std::size_t>(c)];
      // Sample centres lie inside [-90, 90] x finite longitudes, where the geoid is finite; a
      // non-finite result (a broken grid) keeps the height the tile gave.
      if (std::isfinite(h)) m = static_cast<float>(h);
      lo = std::min(lo, m);
      hi = std::max(hi, m);
    }
  }
  tile.minM = lo;
  tile.maxM = hi;
}

HeightField::HeightField(const TileGrid& grid) : grid_(grid) {
  const Sector& s = grid_.spec().sector;
  globalLongitudes_ = s.west == -180.0 && s.east == 180.0;
  perLevel_.assign(static_cast<std::size_t>(grid_.numLevels()), 0);
}

bool HeightField::insert(HeightTile tile) {
  if (!grid_.isValid(tile.key) || tile.width != grid_.spec().tileWidth ||
      tile.height != grid_.spec().tileHeight ||
      tile.metres.size() !=
          static_cast<std::size_t>(tile.width) * static_cast<std::size_t>(tile.height))
    return false;
  const TileKey key = tile.key;
  lowest_ = std::min(lowest_, static_cast<double>(tile.minM));
  const auto [it, inserted] = tiles_.insert_or_assign(key, std::move(tile));
  (void)it;
  if (inserted) {
    ++perLevel_[static_cast<std::size_t>(key.level)];
    deepest_ = std::max(deepest_, key.level);
  }
  ++generation_;
  const double d = grid_.deltaDeg(key.level);
  const Sector s = grid_.sectorOf(key);
  history_.push_back(
      {generation_, grown(s, d / grid_.spec().tileHeight, d / grid_.spec().tileWidth)});
  if (history_.size() > kHistoryLimit) {
    const std::size_t drop = history_.size() / 2;
    historyFloor_ = history_[drop - 1].generation;
    history_.erase(history_.begin(), history_.begin() + static_cast<std::ptrdiff_t>(drop));
  }
  return true;
}

bool HeightField::changedSince(std::uint64_t g, const Sector& sector) const noexcept {
  if (g >= generation_) return false;
  if (g < historyFloor_) return true;
  for (auto it = history_.rbegin(); it != history_.rend() && it->generation > g; ++it)
    if (intersectsWrapped(it->sector, sector)) return true;
  return false;
}

int HeightField::levelForSpacing(double spacingDeg) const noexcept {
  const int last = grid_.numLevels() - 1;
  for (int l = 0; l < last; ++l) {
    const double sampleDeg =
        grid_.deltaDeg(l) / std::min(grid_.spec().tileWidth, grid_.spec().tileHeight);
    if (sampleDeg <= spacingDeg) return l;
  }
  return last;
}

// The one reading of a point both queries share: latitude clamped, a pole one point, longitude
// wrapped with -180 and 180 one meridian and -0.0 as 0; then the deepest level holding a tile
// there.
const HeightTile* HeightField::deepestAt(double& latDeg, double& lonDeg) const noexcept {
  latDeg = std::clamp(latDeg, -90.0, 90.0);
  if (latDeg == 90.0 || latDeg == -90.0) lonDeg = 0.0;
  lonDeg = std::remainder(lonDeg, 360.0); // [-180, 180]
  if (globalLongitudes_ && lonDeg == 180.0) lonDeg = -180.0;
  if (lonDeg == 0.0) lonDeg = 0.0; // -0.0
  for (int l = deepest_; l >= 0; --l) {
    if (perLevel_[static_cast<std::size_t>(l)] == 0) continue;
    const auto key = grid_.keyAt(latDeg, lonDeg, l);
    if (!key) continue;
    if (const auto it = tiles_.find(*key); it != tiles_.end()) return &it->second;
  }
  return nullptr;
}

int HeightField::levelAt(double latDeg, double lonDeg) const noexcept {
  if (!std::isfinite(latDeg) || !std::isfinite(lonDeg)) return -1;
  const HeightTile* t = deepestAt(latDeg, lonDeg);
  return t != nullptr ? t->key.level : -1;
}

double HeightField::heightAt(double latDeg, double lonDeg) const noexcept {
  if (!std::isfinite(latDeg) || !std::isfinite(lonDeg))
    return std::numeric_limits<double>::quiet_NaN();
  const HeightTile* t = deepestAt(latDeg, lonDeg);
  return t != nullptr ? sample(*t, latDeg, lonDeg) : 0.0;
}

// Bilinear over the level's mosaic: texel centres at half-texel offsets; a tap outside the tile
// reads the neighbour tile of the same level when it is held (wrapping east-west on a global grid)
// and is clamped into the tile otherwise. Depends only on the point and the tiles held.
double HeightField::sample(const HeightTile& t, double latDeg, double lonDeg) const noexcept {
  const Sector s = grid_.sectorOf(t.key);
  const int w = t.width, h = t.height;
  const double fx = (lonDeg - s.west) / (s.east - s.west) * w - 0.5;
  const double fy = (s.north - latDeg) / (s.north - s.south) * h - 0.5;
  const double x0 = std::floor(fx), y0 = std::floor(fy);
  const double tx = fx - x0, ty = fy - y0;
  const std::int64_t rows = grid_.rowCount(t.key.level), cols = grid_.colCount(t.key.level);
  auto tap = [&](std::int64_t ix, std::int64_t iy) -> double {
    if (ix >= 0 && ix < w && iy >= 0 && iy < h)
      return t.metres[static_cast<std::size_t>(iy * w + ix)];
    const std::int64_t dc = ix < 0 ? -1 : ix >= w ? 1 : 0;
    const std::int64_t dr = iy < 0 ? 1 : iy >= h ? -1 : 0; // image rows go south, tile rows north
    std::int64_t col = t.key.col + dc;
    const std::int64_t row = t.key.row + dr;
    if (globalLongitudes_) col = (col % cols + cols) % cols;
    const HeightTile* other = nullptr;
    if (row >= 0 && row < rows && col >= 0 && col < cols) {
      const TileKey k{t.key.level, row, col};
      if (grid_.isValid(k))
        if (const auto it = tiles_.find(k); it != tiles_.end()) other = &it->second;
    }
    if (other == nullptr) {
      const std::int64_t cx = std::clamp<std::int64_t>(ix, 0, w - 1),
                         cy = std::clamp<std::int64_t>(iy, 0, h - 1);
      return t.metres[static_cast<std::size_t>(cy * w + cx)];
    }
    const std::int64_t ox = ix - dc * w, oy = iy + dr * h;
    return other->metres[static_cast<std::size_t>(oy * w + ox)];
  };
  const auto ix = static_cast<std::int64_t>(x0), iy = static_cast<std::int64_t>(y0);
  const double top = tap(ix, iy) * (1.0 - tx) + tap(ix + 1, iy) * tx;
  const double bottom = tap(ix, iy + 1) * (1.0 - tx) + tap(ix + 1, iy + 1) * tx;
  return top * (1.0 - ty) + bottom * ty;
}

// heightAt reads, at each point, the deepest level holding a tile there (its bilinear taps
// reaching one sample into the neighbours). Below the deepest level whose tiles cover the whole
// sector nothing is read, so the range comes from that level and the deeper ones only: tight for
// deep nodes, where the coarse tiles' mountain ranges would make every node as tall as a continent.
std::pair<double, double> HeightField::rangeOver(const Sector& sector) const {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  int fullLevel = -1;
  struct Level {
    double lo, hi;
    bool any;
  };
  std::vector<Level> levels(static_cast<std::size_t>(deepest_ + 1), {lo, hi, false});
  for (int l = deepest_; l >= 0; --l) {
    if (perLevel_[static_cast<std::size_t>(l)] == 0) continue;
    const double d = grid_.deltaDeg(l);
    const Sector g = grown(sector, d / grid_.spec().tileHeight, d / grid_.spec().tileWidth);
    const Sector clipped{std::max(g.west, -180.0),
                         std::max(g.south, -90.0),
                         std::min(g.east, 180.0),
                         std::min(g.north, 90.0)};
    const auto keys = grid_.keysCovering(clipped, l, 256);
    Level& lv = levels[static_cast<std::size_t>(l)];
    if (!keys) { // too many tiles to look at: every tile of the level
      for (const auto& [k, t] : tiles_)
        if (k.level == l) {
          lv.lo = std::min(lv.lo, static_cast<double>(t.minM));
          lv.hi = std::max(lv.hi, static_cast<double>(t.maxM));
          lv.any = true;
        }
      continue;
    }
    bool all = !keys->empty();
    for (const TileKey& k : *keys) {
      const auto it = tiles_.find(k);
      if (it == tiles_.end()) {
        // A tile of the sector itself missing (touching counts: a point on the sector's edge may
        // belong to it; a neighbour only the taps reach does not) means this level does not
        // cover the sector.
        if (intersects(grid_.sectorOf(k), sector)) all = false;
        continue;
      }
      lv.lo = std::min(lv.lo, static_cast<double>(it->second.minM));
      lv.hi = std::max(lv.hi, static_cast<double>(it->second.maxM));
      lv.any = true;
    }
    if (all) {
      fullLevel = l;
      break;
    }
  }
  for (int l = std::max(fullLevel, 0); l <= deepest_; ++l) {
    const Level& lv = levels[static_cast<std::size_t>(l)];
    if (!lv.any) continue;
    lo = std::min(lo, lv.lo);
    hi = std::max(hi, lv.hi);
  }
  if (fullLevel < 0) { // some point may have no tile at all: height 0 there
    lo = std::min(lo, 0.0);
    hi = std::max(hi, 0.0);
  }
  return {lo, hi};
}

namespace {

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

} // namespace

namespace {

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
 * vertices strictly inside it, then its last vertex), into the quadrant range given. */
void addFan(TerrainMesh& mesh,
            std::vector<std::uint32_t>& quadrant,
            std::uint32_t apex,
            const std::vector<std::uint32_t>& chain) {
  for (std::size_t a = 0; a + 1 < chain.size(); ++a) {
    quadrant.insert(quadrant.end(), {apex, chain[a], chain[a + 1]});
    ++mesh.zeroAreaTriangles;
  }
}

/** Edge fixing onto a coarser neighbour whose edge is not a power of two times ours (a polar
 * cap's rim): our side's vertices go onto its chords by their coordinate along the edge (t, in
 * coarse segments; a vertex within 1e-9 of a coarse vertex takes that vertex's position), and
 * each coarse segment with our vertices strictly inside gets the zero-area fan from its first
 * vertex over them to its last (an extra vertex where a coarse vertex lies beyond our edge), as
 * in the power-of-two case. */
void fixOntoPolyline(TerrainMesh& mesh,
                     std::array<std::vector<std::uint32_t>, 4>& quad,
                     int n,
                     Direction d,
                     double ma,
                     double mb,
                     double ca,
                     double cb,
                     const std::vector<glm::dvec3>& cpos) {
  const auto nc = static_cast<std::int64_t>(cpos.size());
  const double segments = static_cast<double>(nc - 1);
  auto fineIndex = [&](int i) { return sideVertex(n, d, i); };
  auto quadrantOf = [&](int i) { return sideQuadrant(n, d, i); };
  std::vector<double> t(static_cast<std::size_t>(n));
  std::vector<std::int64_t> on(static_cast<std::size_t>(n), -1); // the coarse vertex it is
  for (int i = 0; i < n; ++i) {
    const double x = (edgeLerp(ma, mb, i, n) - ca) / (cb - ca) * segments;
    const double r = std::round(x);
    const auto k = static_cast<std::size_t>(i);
    t[k] = x;
    if (std::abs(x - r) < 1e-9 && r >= 0.0 && r <= segments) on[k] = static_cast<std::int64_t>(r);
    TerrainVertex& v = mesh.vertices[fineIndex(i)];
    if (on[k] >= 0) {
      v.position = cpos[static_cast<std::size_t>(on[k])];
    } else {
      const double j = std::clamp(std::floor(x), 0.0, segments - 1.0);
      const auto jj = static_cast<std::size_t>(j);
      v.position = cpos[jj] + (cpos[jj + 1] - cpos[jj]) * (x - j);
    }
  }
  std::vector<std::uint32_t> extra(cpos.size(), UINT32_MAX);
  auto coarseIndex = [&](std::int64_t j, int nearFine) {
    for (int i = 0; i < n; ++i)
      if (on[static_cast<std::size_t>(i)] == j) return fineIndex(i);
    auto& slot = extra[static_cast<std::size_t>(j)];
    if (slot == UINT32_MAX) {
      TerrainVertex v = mesh.vertices[fineIndex(nearFine)];
      v.position = cpos[static_cast<std::size_t>(j)];
      slot = static_cast<std::uint32_t>(mesh.vertices.size());
      mesh.vertices.push_back(v);
    }
    return slot;
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
        chain.push_back(fineIndex(i));
      }
    }
    if (firstInner < 0) continue;
    const int lastInner = firstInner + static_cast<int>(chain.size()) - 1;
    const std::uint32_t apex = coarseIndex(j, firstInner);
    chain.push_back(coarseIndex(j + 1, lastInner));
    addFan(mesh, quad[static_cast<std::size_t>(quadrantOf(firstInner))], apex, chain);
  }
  // A coarse vertex strictly between two of ours (never so in the power-of-two case) is a kink
  // of the coarse edge that our straight segment cuts across: the triangle between them is not
  // degenerate (a height step with relief), and without it a pixel falls through. Wound like the
  // cells (counter-clockwise seen from outside) when the kink bends outwards.
  const bool reversed = d == Direction::North || d == Direction::West;
  for (int i = 0; i + 1 < n; ++i) {
    const double a = t[static_cast<std::size_t>(i)], b = t[static_cast<std::size_t>(i) + 1];
    for (auto j = static_cast<std::int64_t>(std::floor(a)) + 1; static_cast<double>(j) < b; ++j) {
      if (j > static_cast<std::int64_t>(segments)) continue;
      if (on[static_cast<std::size_t>(i)] == j || on[static_cast<std::size_t>(i) + 1] == j)
        continue;
      const std::uint32_t c = coarseIndex(j, i), p = fineIndex(i), q = fineIndex(i + 1);
      auto& target = quad[static_cast<std::size_t>(quadrantOf(i))];
      if (reversed)
        target.insert(target.end(), {q, c, p});
      else
        target.insert(target.end(), {p, c, q});
      ++mesh.kinkTriangles;
    }
  }
}

} // namespace

TerrainMesh buildTerrainMesh(const Geodesy& geodesy,
                             const Sector& sector,
                             int n,
                             const HeightFunction& height,
                             const std::array<EdgeAdapt, 4>& edges,
                             int rows) {
  if (rows == 0) rows = n;
  for (const int k : {n, rows})
    if (k < 3 || k > 1025 || ((k - 1) & (k - 2)) != 0)
      throw std::invalid_argument("planet: patch grid size must be 2^k + 1, 3 <= n <= 1025");
  if (rows != n &&
      std::any_of(edges.begin(), edges.end(), [](const EdgeAdapt& e) { return e.active; }))
    throw std::invalid_argument("planet: edge fixing needs a square patch grid");
  const Sector& s = sector;
  if (!(std::isfinite(s.west) && std::isfinite(s.east) && std::isfinite(s.south) &&
        std::isfinite(s.north)) ||
      !(s.south >= -90.0 && s.south < s.north && s.north <= 90.0) ||
      !(s.west >= -180.0 && s.west < s.east && s.east <= 180.0))
    throw std::invalid_argument("planet: sector must satisfy -90 <= south < north <= 90 and "
                                "-180 <= west < east <= 180");
  // A height that is not a finite number (a broken height function; the field itself never gives
  // one for finite input) is the ellipsoid's: NaN or inf never reaches a vertex, a normal or the
  // node's height range (issue #8; asserted below in debug builds).
  auto heightOf = [&](double lat, double lon) {
    const double h = height(lat, lon);
    return std::isfinite(h) ? h : 0.0;
  };
  auto position = [&](double lat, double lon) {
    if (lat == 90.0 || lat == -90.0) lon = 0.0; // a pole is one point
    return toVec(geodesy.toEcef(lat, lon, heightOf(lat, lon)));
  };

  TerrainMesh mesh;
  mesh.n = n;
  mesh.rows = rows;
  // Positions on an (rows + 2) x (n + 2) ring: the grid plus one step outside for the normals.
  const int m = n + 2, mr = rows + 2;
  const double dLat = (s.north - s.south) / (rows - 1), dLon = (s.east - s.west) / (n - 1);
  std::vector<glm::dvec3> ring(static_cast<std::size_t>(mr) * static_cast<std::size_t>(m));
  std::vector<double> lats(static_cast<std::size_t>(mr)), lons(static_cast<std::size_t>(m));
  for (int i = 0; i < mr; ++i)
    lats[static_cast<std::size_t>(i)] = i == 0        ? std::max(-90.0, s.south - dLat)
                                        : i == mr - 1 ? std::min(90.0, s.north + dLat)
                                                      : edgeLerp(s.south, s.north, i - 1, rows);
  for (int i = 0; i < m; ++i)
    lons[static_cast<std::size_t>(i)] = i == 0       ? s.west - dLon
                                        : i == m - 1 ? s.east + dLon
                                                     : edgeLerp(s.west, s.east, i - 1, n);
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (int r = 0; r < mr; ++r)
    for (int c = 0; c < m; ++c) {
      const double lat = lats[static_cast<std::size_t>(r)], lon = lons[static_cast<std::size_t>(c)];
      const double hgt = heightOf(lat, lat == 90.0 || lat == -90.0 ? 0.0 : lon);
      if (r > 0 && r < mr - 1 && c > 0 && c < m - 1) {
        lo = std::min(lo, hgt);
        hi = std::max(hi, hgt);
      }
      ring[static_cast<std::size_t>(r * m + c)] =
          toVec(geodesy.toEcef(lat, lat == 90.0 || lat == -90.0 ? 0.0 : lon, hgt));
    }
  mesh.minHeightM = lo;
  mesh.maxHeightM = hi;

  mesh.vertices.resize(static_cast<std::size_t>(rows) * static_cast<std::size_t>(n));
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < n; ++c) {
      TerrainVertex& v = mesh.vertices[static_cast<std::size_t>(r * n + c)];
      const auto at = [&](int rr, int cc) { return ring[static_cast<std::size_t>(rr * m + cc)]; };
      v.position = at(r + 1, c + 1);
      const glm::dvec3 east = at(r + 1, c + 2) - at(r + 1, c);
      const glm::dvec3 north = at(r + 2, c + 1) - at(r, c + 1);
      glm::dvec3 nrm = glm::cross(east, north);
      const double len = glm::length(nrm);
      if (!(len > 0.0) || !std::isfinite(len)) { // the pole row: east-west differences vanish
        const double lat = lats[static_cast<std::size_t>(r + 1)],
                     lon = lons[static_cast<std::size_t>(c + 1)];
        nrm = toVec(geodesy.surfaceNormal(lat, lat == 90.0 || lat == -90.0 ? 0.0 : lon));
      } else {
        nrm /= len;
      }
      v.normal = glm::vec3(nrm);
      v.uvNode = {static_cast<double>(c) / (n - 1), static_cast<double>(r) / (rows - 1)};
    }

  // Triangles per quadrant: cells, then (below) the zero-area fans of its outer edges.
  const int half = (n - 1) / 2, halfRows = (rows - 1) / 2;
  std::array<std::vector<std::uint32_t>, 4> quad;
  auto vid = [n](int r, int c) { return static_cast<std::uint32_t>(r * n + c); };
  for (int r = 0; r + 1 < rows; ++r)
    for (int c = 0; c + 1 < n; ++c) {
      auto& q = quad[static_cast<std::size_t>((r >= halfRows ? 2 : 0) + (c >= half ? 1 : 0))];
      const std::uint32_t a = vid(r, c), b = vid(r, c + 1), d = vid(r + 1, c),
                          e = vid(r + 1, c + 1);
      q.insert(q.end(), {a, b, e, a, e, d});
    }

  // Edge fixing: each adapted side's vertices onto the coarse neighbour's chords, then fans.
  for (int side = 0; side < 4; ++side) {
    const EdgeAdapt& ad = edges[static_cast<std::size_t>(side)];
    if (!ad.active) continue;
    const auto d = static_cast<Direction>(side);
    const bool alongLon = d == Direction::North || d == Direction::South;
    const Sector& c = ad.coarse;
    const double ca = alongLon ? c.west : c.south, cb = alongLon ? c.east : c.north;
    const double ma = alongLon ? s.west : s.south, mb = alongLon ? s.east : s.north;
    if (!(ca <= ma && mb <= cb)) continue;
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
        fixOntoPolyline(mesh, quad, n, d, ma, mb, ca, cb, ad.coarseVertices);
      continue;
    }
    const auto q = static_cast<std::int64_t>(std::llround((ma - ca) / (mb - ma)));
    if (q < 0 || q >= bigR) continue;
    auto fineIndex = [&](int i) { return sideVertex(n, d, i); };
    auto quadrantOf = [&](int i) { return sideQuadrant(n, d, i); };
    // The coarse vertices: the neighbour's own grid points along the shared line, computed with
    // the neighbour's parameters, so they are the very points it draws.
    std::vector<glm::dvec3> cpos(static_cast<std::size_t>(n));
    if (ad.coarseVertices.size() == static_cast<std::size_t>(n)) {
      cpos = ad.coarseVertices;
    } else {
      for (int j = 0; j < n; ++j) {
        const GridPoint g = onSide(s, d, edgeLerp(ca, cb, j, n));
        cpos[static_cast<std::size_t>(j)] = position(g.lat, g.lon);
      }
    }
    const std::int64_t u0 = q * (n - 1);
    for (int i = 0; i < n; ++i) {
      const std::int64_t u = u0 + i;
      const std::int64_t j = u / bigR, r = u % bigR;
      TerrainVertex& v = mesh.vertices[fineIndex(i)];
      if (r == 0) {
        v.position = cpos[static_cast<std::size_t>(j)];
      } else {
        const double t = static_cast<double>(r) / static_cast<double>(bigR);
        const glm::dvec3& a = cpos[static_cast<std::size_t>(j)];
        v.position = a + (cpos[static_cast<std::size_t>(j + 1)] - a) * t;
      }
    }
    // Fans (thesis figure 21): for each coarse segment j our edge touches, the triangles from its
    // first vertex over the fine vertices inside it and its last vertex. Each has zero area; their
    // outer edge is the coarse node's edge, shared exactly, so no pixel falls between.
    std::vector<std::uint32_t> extra(static_cast<std::size_t>(n), UINT32_MAX);
    auto coarseIndex = [&](std::int64_t j, int nearFine) {
      const std::int64_t u = j * bigR - u0;
      if (u >= 0 && u < n) return fineIndex(static_cast<int>(u));
      auto& slot = extra[static_cast<std::size_t>(j)];
      if (slot == UINT32_MAX) { // beyond this node's edge: an extra vertex
        TerrainVertex v = mesh.vertices[fineIndex(nearFine)];
        v.position = cpos[static_cast<std::size_t>(j)];
        slot = static_cast<std::uint32_t>(mesh.vertices.size());
        mesh.vertices.push_back(v);
      }
      return slot;
    };
    const std::int64_t jFirst = u0 / bigR, jLast = (u0 + n - 2) / bigR;
    for (std::int64_t j = jFirst; j <= jLast; ++j) {
      std::vector<std::uint32_t> chain;
      int firstInner = -1;
      for (int i = 0; i < n; ++i) {
        const std::int64_t u = u0 + i;
        if (u > j * bigR && u < (j + 1) * bigR) {
          if (firstInner < 0) firstInner = i;
          chain.push_back(fineIndex(i));
        }
      }
      if (firstInner < 0) continue; // R == 1 cannot happen; nothing strictly inside
      const int lastInner = firstInner + static_cast<int>(chain.size()) - 1;
      const std::uint32_t apex = coarseIndex(j, firstInner);
      chain.push_back(coarseIndex(j + 1, lastInner));
      addFan(mesh, quad[static_cast<std::size_t>(quadrantOf(firstInner))], apex, chain);
    }
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
  for (const TerrainVertex& v : mesh.vertices) {
    assert(std::isfinite(v.position.x) && std::isfinite(v.position.y) &&
           std::isfinite(v.position.z));
    assert(std::isfinite(v.normal.x) && std::isfinite(v.normal.y) && std::isfinite(v.normal.z));
    assert(std::abs(glm::length(glm::dvec3(v.normal)) - 1.0) < 1e-3);
    assert(v.uvNode.x >= 0.0 && v.uvNode.x <= 1.0 && v.uvNode.y >= 0.0 && v.uvNode.y <= 1.0);
  }
  assert(std::isfinite(mesh.minHeightM) && std::isfinite(mesh.maxHeightM));
#endif
  return mesh;
}

} // namespace tellus::planet
