/**
 * @file TileGrid.cpp
 * @brief Tile addressing math of the World Wind style lat/long quadtree.
 *
 * Integers are the source of truth: every tile edge comes from edgeAt(origin, index, delta) (or is
 * exactly 90 / 180 for the last row / column), so an edge shared by two tiles is bit-identical and
 * children share their outer edges with the parent (index * 2 and delta / 2 are exact). Positions
 * are mapped to indices with a floor estimate that is then corrected against those very edges, so
 * keyAt() agrees with sectorOf() even where the division rounds across an edge.
 */

#include <tellus/cache/TileGrid.hpp>

#include <algorithm>
#include <cassert>
#include <charconv>
#include <cmath>
#include <limits>
#include <string_view>

namespace tellus {
namespace {

/** Upper bound for row/column counts: indices stay exactly representable as doubles. */
constexpr std::int64_t kMaxIndexCount = std::int64_t{1} << 53;
/** 180/delta and 360/delta count as whole numbers within this relative tolerance. */
constexpr double kWholeTolerance = 1e-9;

/** Shortest round-trip text of a double for error messages. */
std::string num(double v) {
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof buf, v);
  return {buf, res.ptr};
}

std::string num(std::int64_t v) {
  char buf[32];
  const auto res = std::to_chars(buf, buf + sizeof buf, v);
  return {buf, res.ptr};
}

bool isWhole(double q) noexcept {
  if (!std::isfinite(q) || q > static_cast<double>(kMaxIndexCount)) return false;
  return std::abs(q - std::round(q)) <= kWholeTolerance * std::max(1.0, q);
}

/** Level-zero rows of a validated spec (180 / delta, a whole number). */
std::int64_t levelZeroRows(const GridSpec& spec) noexcept {
  return std::llround(180.0 / spec.levelZeroDeltaDeg);
}

std::int64_t levelZeroCols(const GridSpec& spec) noexcept {
  return std::llround(360.0 / spec.levelZeroDeltaDeg);
}

/** The geometry of one level: delta and index counts along one axis. */
struct Axis {
  double origin; ///< -90 (rows) or -180 (columns)
  double delta;
  std::int64_t count;
};

/** The low edge of index i (0 <= i <= count - 1) or the high edge of the last index (i == count),
 * which is exactly -origin (90 or 180). The only place an edge is computed. */
double edgeAt(const Axis& a, std::int64_t i) noexcept {
  if (i >= a.count) return -a.origin;
  const double offset = static_cast<double>(i) * a.delta; // exact index, one rounding
  return a.origin + offset;
}

/** Index whose half-open span [edge(i), edge(i+1)) holds v; v on the final edge gives count - 1.
 * Precondition: v is finite and inside [origin, -origin]. */
std::int64_t indexFloor(const Axis& a, double v) noexcept {
  assert(v >= a.origin && v <= -a.origin); // also rejects NaN
  double f = std::floor((v - a.origin) / a.delta);
  f = std::clamp(f, 0.0, static_cast<double>(a.count - 1));
  auto i = static_cast<std::int64_t>(f);
  // The division may round across an edge; the integer-derived edges decide.
  while (i > 0 && v < edgeAt(a, i))
    --i;
  while (i < a.count - 1 && v >= edgeAt(a, i + 1))
    ++i;
  return i;
}

/** Index whose span (edge(i), edge(i+1)] holds v (closed at the top): a value exactly on an edge
 * belongs to the tile below it. Precondition: v finite, origin < v <= -origin. */
std::int64_t indexCeil(const Axis& a, double v) noexcept {
  std::int64_t i = indexFloor(a, v);
  if (i > 0 && edgeAt(a, i) == v) --i;
  return i;
}

/** Inclusive index range; empty when lo > hi. */
struct Range {
  std::int64_t lo = 0;
  std::int64_t hi = -1;
  bool empty() const noexcept { return lo > hi; }
  std::uint64_t size() const noexcept {
    return empty() ? 0u : static_cast<std::uint64_t>(hi - lo) + 1u;
  }
};

/** Indices whose spans intersect the open interval (lo, hi) with non-zero length. */
Range indicesCovering(const Axis& a, double lo, double hi) noexcept {
  if (!(lo < hi)) return {};
  return {indexFloor(a, lo), indexCeil(a, hi)};
}

bool withinTolerance(double a, double b, double tol) noexcept {
  return std::abs(a - b) <= tol;
}

} // namespace

std::expected<TileGrid, std::string> TileGrid::create(const GridSpec& spec) {
  using std::unexpected;
  const double d = spec.levelZeroDeltaDeg;
  if (!std::isfinite(d) || !(d > 0.0))
    return unexpected("levelZeroDeltaDeg must be finite and > 0, got " + num(d));
  if (!isWhole(180.0 / d))
    return unexpected("levelZeroDeltaDeg must divide 180 into a whole number of rows, got " +
                      num(d));
  if (!isWhole(360.0 / d))
    return unexpected("levelZeroDeltaDeg must divide 360 into a whole number of columns, got " +
                      num(d));
  const std::int64_t rows0 = levelZeroRows(spec);
  const std::int64_t cols0 = levelZeroCols(spec);
  if (rows0 < 1 || cols0 < 2) return unexpected("levelZeroDeltaDeg must be <= 180, got " + num(d));

  if (spec.numLevels < 1 || spec.numLevels > kMaxLevel + 1)
    return unexpected("numLevels must be in [1, " + num(std::int64_t{kMaxLevel} + 1) + "], got " +
                      num(std::int64_t{spec.numLevels}));
  if (cols0 > (kMaxIndexCount >> (spec.numLevels - 1)))
    return unexpected("numLevels " + num(std::int64_t{spec.numLevels}) +
                      " is too deep for levelZeroDeltaDeg " + num(d) +
                      " (more than 2^53 columns at the deepest level)");

  constexpr std::int32_t kMaxTileSize = 65536;
  if (spec.tileWidth < 1 || spec.tileWidth > kMaxTileSize)
    return unexpected("tileWidth must be in [1, 65536], got " + num(std::int64_t{spec.tileWidth}));
  if (spec.tileHeight < 1 || spec.tileHeight > kMaxTileSize)
    return unexpected("tileHeight must be in [1, 65536], got " +
                      num(std::int64_t{spec.tileHeight}));

  const Sector& s = spec.sector;
  const auto checkEdge = [](double v, double limit, std::string_view name) -> std::string {
    if (!std::isfinite(v) || v < -limit || v > limit)
      return "sector." + std::string(name) + " must be finite and in [" + num(-limit) + ", " +
             num(limit) + "], got " + num(v);
    return {};
  };
  for (const auto& msg : {checkEdge(s.west, 180.0, "west"),
                          checkEdge(s.south, 90.0, "south"),
                          checkEdge(s.east, 180.0, "east"),
                          checkEdge(s.north, 90.0, "north")}) {
    if (!msg.empty()) return unexpected(msg);
  }
  if (!(s.south < s.north))
    return unexpected("sector.south (" + num(s.south) + ") must be < sector.north (" +
                      num(s.north) + ")");
  if (!(s.west < s.east))
    return unexpected("sector.west (" + num(s.west) + ") must be < sector.east (" + num(s.east) +
                      "); a dataset sector does not cross the antimeridian");
  return TileGrid(spec);
}

double TileGrid::deltaDeg(std::int32_t level) const noexcept {
  if (level < 0 || level >= spec_.numLevels) return std::numeric_limits<double>::quiet_NaN();
  return std::ldexp(spec_.levelZeroDeltaDeg, -level);
}

std::int64_t TileGrid::rowCount(std::int32_t level) const noexcept {
  if (level < 0 || level >= spec_.numLevels) return 0;
  return levelZeroRows(spec_) << level;
}

std::int64_t TileGrid::colCount(std::int32_t level) const noexcept {
  if (level < 0 || level >= spec_.numLevels) return 0;
  return levelZeroCols(spec_) << level;
}

bool TileGrid::isValid(const TileKey& key) const noexcept {
  if (key.level < 0 || key.level >= spec_.numLevels) return false;
  const double delta = deltaDeg(key.level);
  const Axis rows{-90.0, delta, rowCount(key.level)};
  const Axis cols{-180.0, delta, colCount(key.level)};
  if (key.row < 0 || key.row >= rows.count || key.col < 0 || key.col >= cols.count) return false;
  const Sector& s = spec_.sector;
  return edgeAt(rows, key.row) < s.north && edgeAt(rows, key.row + 1) > s.south &&
         edgeAt(cols, key.col) < s.east && edgeAt(cols, key.col + 1) > s.west;
}

Sector TileGrid::sectorOf(const TileKey& key) const noexcept {
  assert(isValid(key));
  const double delta = deltaDeg(key.level);
  const Axis rows{-90.0, delta, rowCount(key.level)};
  const Axis cols{-180.0, delta, colCount(key.level)};
  return Sector{.west = edgeAt(cols, key.col),
                .south = edgeAt(rows, key.row),
                .east = edgeAt(cols, key.col + 1),
                .north = edgeAt(rows, key.row + 1)};
}

std::optional<TileKey>
TileGrid::keyAt(double latDeg, double lonDeg, std::int32_t level) const noexcept {
  if (level < 0 || level >= spec_.numLevels) return std::nullopt;
  const Sector& s = spec_.sector;
  // NaN fails every comparison; +-inf lies outside the sector (which is inside the globe).
  if (!(latDeg >= s.south && latDeg <= s.north && lonDeg >= s.west && lonDeg <= s.east))
    return std::nullopt;
  const double delta = deltaDeg(level);
  const Axis rows{-90.0, delta, rowCount(level)};
  const Axis cols{-180.0, delta, colCount(level)};
  std::int64_t row = indexFloor(rows, latDeg);
  std::int64_t col = indexFloor(cols, lonDeg);
  // Closed north/east edge of the sector: a point on it that is also a tile edge belongs to the
  // tile below / to the west (the one above lies outside the sector).
  if (latDeg == s.north && row > 0 && edgeAt(rows, row) == latDeg) --row;
  if (lonDeg == s.east && col > 0 && edgeAt(cols, col) == lonDeg) --col;
  return TileKey{level, row, col};
}

std::optional<std::vector<TileKey>>
TileGrid::keysCovering(const Sector& box, std::int32_t level, std::size_t maxKeys) const {
  if (level < 0 || level >= spec_.numLevels) return std::nullopt;
  if (!std::isfinite(box.west) || !std::isfinite(box.south) || !std::isfinite(box.east) ||
      !std::isfinite(box.north))
    return std::vector<TileKey>{};

  const Sector& s = spec_.sector;
  const double delta = deltaDeg(level);
  const Axis rows{-90.0, delta, rowCount(level)};
  const Axis cols{-180.0, delta, colCount(level)};

  // Clipping to the sector also clips to the globe (the sector lies inside it).
  const Range rowRange =
      indicesCovering(rows, std::max(box.south, s.south), std::min(box.north, s.north));
  Range first;  // from the box's west edge eastwards (up to 180 for a crossing box)
  Range second; // a crossing box's part east of -180
  if (box.west <= box.east) {
    first = indicesCovering(cols, std::max(box.west, s.west), std::min(box.east, s.east));
  } else {
    first = indicesCovering(cols, std::max(box.west, s.west), std::min(180.0, s.east));
    second = indicesCovering(cols, std::max(-180.0, s.west), std::min(box.east, s.east));
    // Both parts can hold the same tile (a box spanning almost the whole globe); list it once.
    if (!first.empty() && !second.empty()) second.hi = std::min(second.hi, first.lo - 1);
  }

  const std::uint64_t nRows = rowRange.size();
  const std::uint64_t nCols = first.size() + second.size();
  if (nRows == 0 || nCols == 0) return std::vector<TileKey>{};
  // Count before allocating; nRows * nCols may overflow 64 bits at deep levels.
  const std::uint64_t limit = std::min<std::uint64_t>(maxKeys, std::vector<TileKey>{}.max_size());
  if (nRows > limit / nCols) return std::nullopt;

  std::vector<TileKey> keys;
  keys.reserve(static_cast<std::size_t>(nRows * nCols));
  for (std::int64_t r = rowRange.lo; r <= rowRange.hi; ++r) {
    for (std::int64_t c = first.lo; c <= first.hi; ++c)
      keys.push_back(TileKey{level, r, c});
    for (std::int64_t c = second.lo; c <= second.hi; ++c)
      keys.push_back(TileKey{level, r, c});
  }
  return keys;
}

std::optional<TileKey> TileGrid::parent(const TileKey& key) const noexcept {
  if (key.level == 0 || !isValid(key)) return std::nullopt;
  return TileKey{key.level - 1, key.row / 2, key.col / 2};
}

std::optional<std::array<TileKey, 4>> TileGrid::children(const TileKey& key) const noexcept {
  if (!isValid(key) || key.level + 1 >= spec_.numLevels) return std::nullopt;
  const std::int32_t l = key.level + 1;
  const std::int64_t r = key.row * 2;
  const std::int64_t c = key.col * 2;
  return std::array<TileKey, 4>{
      TileKey{l, r, c}, TileKey{l, r, c + 1}, TileKey{l, r + 1, c}, TileKey{l, r + 1, c + 1}};
}

std::optional<TileKey> TileGrid::neighbour(const TileKey& key, Direction dir) const noexcept {
  if (!isValid(key)) return std::nullopt;
  const std::int64_t rows = rowCount(key.level);
  const std::int64_t cols = colCount(key.level);
  TileKey n = key;
  switch (dir) {
  case Direction::North:
    if (key.row + 1 >= rows) return std::nullopt;
    ++n.row;
    break;
  case Direction::South:
    if (key.row == 0) return std::nullopt;
    --n.row;
    break;
  case Direction::East:
    n.col = key.col + 1 == cols ? 0 : key.col + 1;
    break;
  case Direction::West:
    n.col = key.col == 0 ? cols - 1 : key.col - 1;
    break;
  }
  if (!isValid(n)) return std::nullopt;
  return n;
}

std::optional<TileKey> TileGrid::keyForBbox(const Sector& bbox,
                                            std::int32_t width,
                                            std::int32_t height,
                                            double relTolerance) const noexcept {
  if (width != spec_.tileWidth || height != spec_.tileHeight) return std::nullopt;
  if (!std::isfinite(bbox.west) || !std::isfinite(bbox.south) || !std::isfinite(bbox.east) ||
      !std::isfinite(bbox.north) || !std::isfinite(relTolerance) || relTolerance < 0.0)
    return std::nullopt;
  const double w = bbox.east - bbox.west;
  const double h = bbox.north - bbox.south;
  if (!(w > 0.0) || !(h > 0.0)) return std::nullopt; // also rejects antimeridian-crossing boxes

  // Levels differ by a factor of two, so at most one level has a delta within 25% of the width;
  // the exact comparison against that level's integer-derived edges follows.
  for (std::int32_t level = 0; level < spec_.numLevels; ++level) {
    const double delta = deltaDeg(level);
    if (std::abs(w - delta) > 0.25 * delta) continue;

    const Axis rows{-90.0, delta, rowCount(level)};
    const Axis cols{-180.0, delta, colCount(level)};
    const double fr = std::round((bbox.south + 90.0) / delta);
    const double fc = std::round((bbox.west + 180.0) / delta);
    if (!(fr >= 0.0 && fr < static_cast<double>(rows.count) && fc >= 0.0 &&
          fc < static_cast<double>(cols.count)))
      return std::nullopt;
    const TileKey key{level, static_cast<std::int64_t>(fr), static_cast<std::int64_t>(fc)};

    const double tol = relTolerance * delta;
    const double south = edgeAt(rows, key.row);
    const double north = edgeAt(rows, key.row + 1);
    const double west = edgeAt(cols, key.col);
    const double east = edgeAt(cols, key.col + 1);
    if (!withinTolerance(bbox.south, south, tol) || !withinTolerance(bbox.north, north, tol) ||
        !withinTolerance(bbox.west, west, tol) || !withinTolerance(bbox.east, east, tol) ||
        !withinTolerance(w, east - west, tol) || !withinTolerance(h, north - south, tol))
      return std::nullopt;
    if (!isValid(key)) return std::nullopt;
    return key;
  }
  return std::nullopt;
}

} // namespace tellus
