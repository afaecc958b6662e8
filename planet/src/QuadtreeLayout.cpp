#include <tellus/cache/TileSource.hpp>
#include <tellus/planet/Quadtree.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace tellus::planet {

namespace {

constexpr double kDegToRad = std::numbers::pi / 180.0;

} // namespace

bool Quadtree::isCapKey(const NodeKey& key) const noexcept {
  if (!caps_ || key.col != 0 || key.level < 0 || key.level >= grid_.numLevels() ||
      key.span != grid_.colCount(key.level))
    return false;
  const Sector& s = grid_.spec().sector;
  return (key.row == 0 && s.south == -90.0) ||
         (key.row == grid_.rowCount(key.level) - 1 && s.north == 90.0);
}

LodParams Quadtree::lodFor(const NodeKey& key) const noexcept {
  LodParams p = params_.lod;
  if (isCapKey(key)) {
    p.tileWidthPx *= kCapTextureWidthFactor;
  } else if (key.span > 1) {
    // A merged node's image may hold only the texels east-west its parallels need (a WMS gives
    // them so, TileSource.hpp): its texels are measured at that width, whatever its source.
    p.tileWidthPx = wholeSpanTexelWidth(sectorOf(key), p.tileWidthPx, p.tileHeightPx);
  }
  return p;
}

std::int64_t Quadtree::spanFor(std::int32_t level,
                               std::int64_t row,
                               std::int64_t parentSpanInChildCols) const noexcept {
  const std::int64_t lo = parentSpanInChildCols / 2; // the parent's span: a plain quadtree split
  if (!params_.polarMerge || !globalLongitudes_) return lo;
  const Sector s = grid_.sectorOf({level, row, 0});
  // The widest east-west edge is the equatorward one; one column there is cos(lat) times the
  // north-south extent. The largest power of two not above 1/cos keeps the node's east-west
  // extent at or below its north-south extent everywhere, so a merged node never splits for its
  // east-west edge before a square node of its level would.
  const double equatorward = std::min(std::abs(s.south), std::abs(s.north));
  const double c = std::cos(equatorward * kDegToRad);
  double ideal = c > 0.0 ? 1.0 / c : 0x1p62;
  ideal = std::min(ideal, 0x1p62);
  int exponent = 0;
  std::frexp(ideal, &exponent); // ideal = f * 2^exponent, f in [0.5, 1)
  const std::int64_t want = std::int64_t{1} << std::clamp(exponent - 1, 0, 62);
  return std::clamp(want, lo, parentSpanInChildCols);
}

Quadtree::ChildKeys Quadtree::childKeys(const NodeKey& key) const noexcept {
  return childKeysFor(key, nullptr);
}

EastWestEdges Quadtree::eastWestEdges(const NodeKey& key) const noexcept {
  const Sector s = sectorOf(key);
  const double lons[3] = {s.west, 0.5 * (s.west + s.east), s.east};
  EastWestEdges out;
  const double lats[2] = {s.south, s.north};
  for (std::size_t e = 0; e < 2; ++e) {
    out.present[e] = lats[e] != 90.0 && lats[e] != -90.0; // the pole: an edge of length 0
    if (!out.present[e]) continue;
    for (std::size_t i = 0; i < 3; ++i) {
      const Ecef p = geodesy_.toEcef(lats[e], lons[i], 0.0);
      const Ecef n = geodesy_.surfaceNormal(lats[e], lons[i]);
      out.points[e * 3 + i] = {p.x, p.y, p.z};
      out.normals[e * 3 + i] = {n.x, n.y, n.z};
    }
  }
  return out;
}

bool Quadtree::fitsEastWest(const EastWestEdges& edges,
                            const Camera& camera,
                            double liftM) const noexcept {
  // Each half of each east-west edge within half the limit: the wide node's texels are twice as
  // wide as its halves', so this is the test the two halves would pass, at their granularity
  // (perspective across a wide node enlarges the near texels more than the whole edge shows).
  const double limit = 0.5 * static_cast<double>(params_.lod.tileWidthPx) * params_.lod.threshold;
  for (std::size_t e = 0; e < 2; ++e) {
    if (!edges.present[e]) continue;
    glm::dvec2 px[3]{};
    for (std::size_t i = 0; i < 3; ++i)
      if (!camera.projectPx(edges.points[e * 3 + i] + edges.normals[e * 3 + i] * liftM, px[i]))
        return false;
    for (std::size_t i = 0; i < 2; ++i) {
      const glm::dvec2 d = px[i + 1] - px[i];
      if (!(d.x * d.x + d.y * d.y <= limit * limit)) return false; // NaN: does not fit
    }
  }
  return true;
}

bool Quadtree::fitsEastWest(const NodeKey& key, const Camera& camera) const {
  double lift = 0.0;
  if (heightRange_) {
    const auto [lo, hi] = heightRange_(sectorOf(key));
    lift = std::clamp(camera.pose().altitudeM, lo, hi);
  }
  return fitsEastWest(eastWestEdges(key), camera, lift);
}

bool Quadtree::visibleNow(const NodeKey& key, const Camera& camera) const {
  if (!grid_.isValid(key.firstTile()) ||
      !grid_.isValid({key.level, key.row, key.col + key.span - 1}))
    return false;
  return cullNode(camera, NodeGeometry(geodesy_, sectorOf(key)), occluder_).visible;
}

bool Quadtree::widerPaysOff(const NodeKey& wide, std::int64_t span, const Camera& camera) const {
  // The wide node is too wide to draw from here: the LOD test will split it (its whole east-west
  // edge is over the limit). Worth it when what it splits into, one level down with the same
  // choice made there, costs fewer visible nodes than the row's static nodes now: near the pole
  // a ring's static nodes can be twice as many as the texel test needs, and the ring one level
  // down, closer to the pole, may fit wide (the least-node cover of the pole view does this).
  if (wide.level + 1 >= grid_.numLevels()) return false;
  const LodResult lod =
      evaluateLod(camera, NodeGeometry(geodesy_, sectorOf(wide)), params_.lod, true);
  if (!lod.split || lod.cornerBehindCamera) return false;
  int statics = 0;
  for (std::int64_t c = wide.col; c < wide.col + wide.span; c += span)
    statics += visibleNow({wide.level, wide.row, c, span}, camera) ? 1 : 0;
  if (statics < 2) return false;
  const std::int32_t L = wide.level + 1;
  const std::int64_t width = wide.span * 2;
  int below = 0;
  for (int half = 0; half < 2 && below < statics; ++half) {
    const std::int64_t row = wide.row * 2 + half;
    const std::int64_t s = spanFor(L, row, width);
    const NodeKey whole{L, row, wide.col * 2, width};
    if (s < width && !fitsEastWest(whole, camera)) {
      for (std::int64_t c = whole.col; c < whole.col + width; c += s)
        below += visibleNow({L, row, c, s}, camera) ? 1 : 0;
    } else {
      below += visibleNow(whole, camera) ? 1 : 0;
    }
  }
  return below < statics;
}

std::int64_t Quadtree::staticSpanOf(const Node& node) const noexcept {
  const NodeKey& k = node.key_;
  if (node.parent_ == nullptr) return k.span;
  const std::int64_t width =
      node.parent_->cap_ ? std::int64_t{1} << k.level : node.parent_->key_.span * 2;
  return spanFor(k.level, k.row, width);
}

Quadtree::ChildKeys
Quadtree::childKeysFor(const NodeKey& key, const Camera* camera, bool narrow) const {
  ChildKeys out;
  if (key.level + 1 >= grid_.numLevels()) return out;
  const std::int32_t L = key.level + 1;
  if (isCapKey(key)) {
    // The next cap, then the ring: per root column, the half of that column's merged row (its
    // wedge at this cap's level) that the next cap does not cover.
    const bool north = key.row != 0;
    out.keys.assign(1, NodeKey{L, north ? key.row * 2 + 1 : 0, 0, grid_.colCount(L)});
    out.present.assign(1, 1);
    const std::int64_t rootWidth = std::int64_t{1} << key.level;
    for (std::int64_t rc = 0; rc < rootCols_; ++rc) {
      const ChildKeys w = childKeysFor({key.level, key.row, rc * rootWidth, rootWidth}, camera);
      for (std::size_t i = 0; i < 2; ++i) {
        const std::size_t slot = (north ? 0 : 2) + i;
        if (!w.present[slot]) continue;
        out.keys.push_back(w.keys[slot]);
        out.present.push_back(1);
      }
    }
    return out;
  }
  const std::int64_t width = key.span * 2; // the parent's columns at the child level
  for (int half = 0; half < 2; ++half) {   // 0: south row, 1: north row
    const std::int64_t row = key.row * 2 + half;
    std::int64_t span = spanFor(L, row, width);
    // The LOD test found east-west texels over the limit: children as wide as the parent would
    // have the same ones (a split that never helps); a plain quadtree split halves them.
    if (narrow) span = width / 2;
    // A merged row may be as wide as the parent when the camera sees its east-west edges within
    // the texel limit (it would otherwise be two nodes no wider than tall).
    if (!narrow && camera != nullptr && params_.adaptivePolarSpans && span > 1 && span < width &&
        (fitsEastWest({L, row, key.col * 2, width}, *camera) ||
         widerPaysOff({L, row, key.col * 2, width}, span, *camera)))
      span = width;
    for (std::int64_t i = 0; i * span < width; ++i) {
      const NodeKey k{L, row, key.col * 2 + i * span, span};
      bool valid = grid_.isValid(k.firstTile());
      if (valid && span > 1) valid = grid_.isValid({L, row, k.col + span - 1});
      const auto slot = static_cast<std::size_t>(half * 2 + i);
      out.keys[slot] = k;
      out.present[slot] = valid ? 1 : 0;
    }
  }
  return out;
}

} // namespace tellus::planet
