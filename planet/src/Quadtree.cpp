#include <tellus/planet/Quadtree.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <queue>
#include <utility>

namespace tellus::planet {

namespace {

constexpr double kDegToRad = std::numbers::pi / 180.0;

/** A key's extent in rows and columns of a finer (or equal) level. */
struct Extent {
  std::int64_t r0, r1, c0, c1;
};

Extent extentAt(const NodeKey& k, std::int32_t level) noexcept {
  const int shift = level - k.level;
  return {k.row << shift, (k.row + 1) << shift, k.col << shift, (k.col + k.span) << shift};
}

Direction opposite(Direction d) noexcept {
  switch (d) {
  case Direction::North:
    return Direction::South;
  case Direction::South:
    return Direction::North;
  case Direction::East:
    return Direction::West;
  case Direction::West:
    return Direction::East;
  }
  return Direction::North;
}

constexpr std::array<Direction, 4> kDirections{
    Direction::North, Direction::East, Direction::South, Direction::West};

} // namespace

Node::Node(const Geodesy& geodesy,
           const NodeKey& key,
           const Sector& sector,
           Node* parent,
           double minHeightM,
           double maxHeightM)
    : key_(key), geometry_(geodesy, sector, minHeightM, maxHeightM), parent_(parent) {}

std::unique_ptr<Node> Quadtree::makeNode(const NodeKey& key, Node* parent) {
  const Sector s = sectorOf(key);
  std::unique_ptr<Node> n;
  if (!heightRange_) {
    n = std::make_unique<Node>(geodesy_, key, s, parent);
  } else {
    const auto [lo, hi] = heightRange_(s);
    n = std::make_unique<Node>(geodesy_, key, s, parent, lo, hi);
  }
  n->cap_ = isCapKey(key);
  if (parent != nullptr && !n->cap_ && key.span > staticSpanOf(*n))
    n->widened_ = std::make_unique<const EastWestEdges>(eastWestEdges(key));
  return n;
}

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
  if (isCapKey(key)) p.tileWidthPx *= kCapTextureWidthFactor;
  return p;
}

void Quadtree::setTerrain(HeightRange range, double occluderHeightM) {
  heightRange_ = std::move(range);
  params_.occluderHeightM = occluderHeightM;
  occluder_ = HorizonOccluder(geodesy_, occluderHeightM);
}

double Quadtree::chordDepthM(int meshSize) const {
  double depth = 0.0;
  for (const auto& r : roots_)
    if (r)
      depth =
          std::max(depth, gridChordDepthM(geodesy_, r->sector(), r->meshSize(meshSize), meshSize));
  return depth;
}

std::size_t Quadtree::refreshHeights(const std::function<bool(const Sector&)>& changed) {
  if (!heightRange_) return 0;
  std::size_t count = 0;
  forEach([&](Node& n) {
    const Sector& s = n.sector();
    if (!changed(s)) return;
    const auto [lo, hi] = heightRange_(s);
    if (lo == n.geometry_.minHeightM() && hi == n.geometry_.maxHeightM()) return;
    n.geometry_ = NodeGeometry(geodesy_, s, lo, hi);
    ++count;
  });
  return count;
}

Node::~Node() = default;

Quadtree::Quadtree(const Geodesy& geodesy, const TileGrid& grid, QuadtreeParams params)
    : geodesy_(geodesy), grid_(grid), params_(params), occluder_(geodesy, params.occluderHeightM) {
  const Sector& s = grid_.spec().sector;
  globalLongitudes_ = s.west == -180.0 && s.east == 180.0;
  rootCols_ = grid_.colCount(0);
  const std::int64_t rows = grid_.rowCount(0);
  // Caps need every column of the polar rows, and a column count that doubles per level.
  caps_ = params_.polarCaps && params_.polarMerge && globalLongitudes_ && rows >= 2 &&
          (s.north == 90.0 || s.south == -90.0);
  for (std::int32_t L = 1; caps_ && L < grid_.numLevels(); ++L)
    caps_ = grid_.colCount(L) == (rootCols_ << L) && grid_.rowCount(L) == (rows << L);
  roots_.resize(static_cast<std::size_t>(rows * rootCols_));
  for (std::int64_t r = 0; r < rows; ++r)
    for (std::int64_t c = 0; c < rootCols_; ++c) {
      if (isCapKey({0, r, 0, rootCols_})) {
        bool all = true;
        for (std::int64_t i = 0; i < rootCols_; ++i)
          all = all && grid_.isValid({0, r, i});
        if (c == 0 && all) {
          roots_[static_cast<std::size_t>(r * rootCols_)] = makeNode({0, r, 0, rootCols_}, nullptr);
          ++nodeCount_;
        }
        continue;
      }
      const NodeKey k{0, r, c, 1};
      if (!grid_.isValid(k.firstTile())) continue;
      roots_[static_cast<std::size_t>(r * rootCols_ + c)] = makeNode(k, nullptr);
      ++nodeCount_;
    }
  for (auto& r : roots_)
    if (r) linkNeighbours(*r);
}

Quadtree::~Quadtree() = default;

Sector Quadtree::sectorOf(const NodeKey& key) const noexcept {
  Sector s = grid_.sectorOf(key.firstTile());
  if (key.span > 1) s.east = grid_.sectorOf({key.level, key.row, key.col + key.span - 1}).east;
  return s;
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
  const LodResult lod = evaluateLod(camera, NodeGeometry(geodesy_, sectorOf(wide)), params_.lod);
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

Node* Quadtree::rootContaining(std::int32_t level,
                               std::int64_t row,
                               std::int64_t col) const noexcept {
  const std::int64_t r = row >> level, c = col >> level;
  if (r < 0 || c < 0 || c >= rootCols_ || r >= grid_.rowCount(0)) return nullptr;
  if (isCapKey({0, r, 0, rootCols_})) return roots_[static_cast<std::size_t>(r * rootCols_)].get();
  return roots_[static_cast<std::size_t>(r * rootCols_ + c)].get();
}

Node* Quadtree::findNeighbour(const Node& node, Direction d) const noexcept {
  const NodeKey& k = node.key_;
  const std::int32_t L = k.level;
  const std::int64_t cols = grid_.colCount(L);
  std::int64_t row = k.row, c0 = k.col, c1 = k.col + k.span;
  switch (d) {
  case Direction::North:
    if (k.row + 1 >= grid_.rowCount(L)) return nullptr; // across the pole: none
    row = k.row + 1;
    break;
  case Direction::South:
    if (k.row == 0) return nullptr;
    row = k.row - 1;
    break;
  case Direction::East:
    c0 = (k.col + k.span) % cols;
    c1 = c0 + 1;
    break;
  case Direction::West:
    c0 = (k.col - 1 + cols) % cols;
    c1 = c0 + 1;
    break;
  }
  auto covers = [&](const Node& n) {
    const Extent e = extentAt(n.key_, L);
    return e.r0 <= row && row < e.r1 && e.c0 <= c0 && c1 <= e.c1;
  };
  Node* n = rootContaining(L, row, c0);
  if (n == nullptr || !covers(*n)) return nullptr;
  for (;;) {
    Node* next = nullptr;
    for (const auto& ch : n->children_)
      if (ch && ch->key_.level <= L && covers(*ch)) {
        next = ch.get();
        break;
      }
    if (next == nullptr) break;
    n = next;
  }
  // Covering the edge from inside an ancestor means the nodes across are narrower than this one
  // (equatorward of a merged polar row): no single neighbour.
  const Extent self = extentAt(k, L);
  const Extent e = extentAt(n->key_, L);
  if (e.r0 <= self.r0 && self.r1 <= e.r1 && e.c0 <= self.c0 && self.c1 <= e.c1) return nullptr;
  return n;
}

void Quadtree::linkNeighbours(Node& node) noexcept {
  for (Direction d : kDirections)
    node.neighbours_[static_cast<std::size_t>(d)] = findNeighbour(node, d);
}

bool Quadtree::borders(const Node& q, const Node& p, Direction side) const noexcept {
  const std::int32_t M = std::max(q.key_.level, p.key_.level);
  const Extent a = extentAt(p.key_, M), b = extentAt(q.key_, M);
  const std::int64_t cols = grid_.colCount(M);
  const bool colsOverlap = std::max(a.c0, b.c0) < std::min(a.c1, b.c1);
  const bool rowsOverlap = std::max(a.r0, b.r0) < std::min(a.r1, b.r1);
  switch (side) {
  case Direction::North:
    return b.r0 == a.r1 && colsOverlap;
  case Direction::South:
    return b.r1 == a.r0 && colsOverlap;
  case Direction::East:
    return b.c0 == a.c1 % cols && rowsOverlap;
  case Direction::West:
    return b.c1 % cols == a.c0 && rowsOverlap;
  }
  return false;
}

void Quadtree::relinkBorderingIn(Node& n, const Node& around, Direction side) noexcept {
  // n intersects the one-cell-wide strip (at the deepest level) just across around's edge?
  const std::int32_t M = grid_.numLevels() - 1;
  const Extent a = extentAt(around.key_, M), b = extentAt(n.key_, M);
  const std::int64_t cols = grid_.colCount(M);
  bool hit = false;
  switch (side) {
  case Direction::North:
    hit = b.r0 <= a.r1 && a.r1 < b.r1 && std::max(a.c0, b.c0) < std::min(a.c1, b.c1);
    break;
  case Direction::South:
    hit = b.r0 <= a.r0 - 1 && a.r0 - 1 < b.r1 && std::max(a.c0, b.c0) < std::min(a.c1, b.c1);
    break;
  case Direction::East: {
    const std::int64_t c = a.c1 % cols;
    hit = b.c0 <= c && c < b.c1 && std::max(a.r0, b.r0) < std::min(a.r1, b.r1);
    break;
  }
  case Direction::West: {
    const std::int64_t c = (a.c0 - 1 + cols) % cols;
    hit = b.c0 <= c && c < b.c1 && std::max(a.r0, b.r0) < std::min(a.r1, b.r1);
    break;
  }
  }
  if (!hit) return;
  if (n.key_.level >= around.key_.level && borders(n, around, side)) {
    const Direction back = opposite(side);
    n.neighbours_[static_cast<std::size_t>(back)] = findNeighbour(n, back);
  }
  for (auto& ch : n.children_)
    if (ch) relinkBorderingIn(*ch, around, side);
}

void Quadtree::relinkAround(const Node& node) noexcept {
  for (Direction d : kDirections)
    for (auto& r : roots_)
      if (r) relinkBorderingIn(*r, node, d);
}

bool Quadtree::split(Node& node) {
  return splitWith(node, false);
}

bool Quadtree::childrenAsWide(const Node& node) const noexcept {
  for (const auto& ch : node.children_)
    if (ch && ch->key_.span == node.key_.span * 2) return true;
  return false;
}

bool Quadtree::splitWith(Node& node, bool narrow) {
  if (node.hasChildren()) return true;
  const ChildKeys ck = childKeysFor(node.key_, splitCamera_, narrow && !node.cap_);
  int made = 0;
  node.children_.resize(ck.keys.size());
  for (std::size_t i = 0; i < ck.keys.size(); ++i) {
    if (!ck.present[i]) continue;
    node.children_[i] = makeNode(ck.keys[i], &node);
    ++made;
  }
  if (made == 0) {
    node.children_.clear();
    return false;
  }
  node.childCount_ = made;
  nodeCount_ += static_cast<std::size_t>(made);
  stats_.created += static_cast<std::size_t>(made);
  for (auto& ch : node.children_)
    if (ch) linkNeighbours(*ch);
  relinkAround(node);
  return true;
}

void Quadtree::removeChildren(Node& node) {
  if (!node.hasChildren()) return;
  std::size_t count = 0;
  auto counter = [&count](Node&) { ++count; };
  for (auto& ch : node.children_)
    if (ch) forEachIn(*ch, counter);
  node.children_.clear();
  node.childCount_ = 0;
  nodeCount_ -= count;
  stats_.removed += count;
  relinkAround(node);
}

const FrameStats& Quadtree::update(const Camera& camera) {
  ++frame_;
  stats_ = FrameStats{};
  drawList_.clear();
  splitsThisFrame_ = 0;
  splitCamera_ = &camera;
  for (auto& r : roots_)
    if (r) visit(*r, false, camera);
  splitCamera_ = nullptr;
  enforceNodeLimit();
  stats_.drawn = drawList_.size();
  stats_.nodes = nodeCount_;
  return stats_;
}

void Quadtree::visit(Node& node, bool insideFrustum, const Camera& camera) {
  ++stats_.visited;
  const NodeGeometry& g = node.geometry_;
  if (isBackFacing(camera, g)) {
    ++stats_.culledBackFace;
    return;
  }
  if (!insideFrustum) {
    const FrustumResult f = params_.tightFrustumCulling ? classifyNode(camera, g)
                                                        : classify(camera.frustum(), g.bounds());
    if (f == FrustumResult::Outside) {
      ++stats_.culledFrustum;
      return;
    }
    insideFrustum = f == FrustumResult::Inside;
  }
  if (occluder_.isOccluded(camera.position(), g.bounds()) ||
      (node.cap_ && occluder_.isCapOccluded(camera.position(), g))) {
    ++stats_.culledHorizon;
    return;
  }
  ++stats_.visible;
  node.lastVisible_ = frame_;
  const LodResult lod = evaluateLod(camera, g, node.cap_ ? lodFor(node.key_) : params_.lod);
  bool refine = lod.split;
  // A row widened for another camera (wider than the static rule) keeps the test it was made
  // with, each half of each east-west edge within half the limit: the whole-edge test alone
  // would let perspective enlarge its near texels further than a static node's.
  if (!refine && node.widened_ &&
      !fitsEastWest(*node.widened_,
                    camera,
                    std::clamp(camera.pose().altitudeM, g.minHeightM(), g.maxHeightM())))
    refine = true;
  bool descend = refine && node.key_.level + 1 < grid_.numLevels();
  // East-west texels over the limit while the north-south ones fit: children as wide as the node
  // would keep the same east-west texels (its equatorward edge is theirs), so a merged row then
  // splits east-west; children made as wide as the node earlier (for another camera) are made
  // again, narrower. Where both are over, the layout of spanFor() (the row's shape) stands: a
  // north-south split halves the children's height, and a child row that becomes wider than
  // tall is narrowed by spanFor() itself.
  // A cap has no narrower form: its split halves the east-west texels of both its parts.
  const bool narrow = !node.cap_ && lod.eastWestOver && !lod.northSouthOver && node.key_.span > 1;
  if (descend && narrow && node.hasChildren() && childrenAsWide(node)) {
    if (splitsThisFrame_ >= params_.maxSplitsPerFrame) {
      ++stats_.splitsDeferred;
      descend = false;
    } else {
      removeChildren(node);
    }
  }
  if (descend && !node.hasChildren()) {
    if (splitsThisFrame_ >= params_.maxSplitsPerFrame) {
      ++stats_.splitsDeferred;
      descend = false;
    } else {
      ++splitsThisFrame_;
      descend = splitWith(node, narrow);
    }
  }
  if (descend) {
    for (auto& ch : node.children_)
      if (ch) visit(*ch, insideFrustum, camera);
    return;
  }
  node.lastDrawn_ = frame_;
  drawList_.push_back(&node);
  stats_.maxLevel = std::max(stats_.maxLevel, node.key_.level);
}

void Quadtree::enforceNodeLimit() {
  if (nodeCount_ <= params_.maxNodes) return;
  // Candidates (thesis 4.7.2): nodes whose children are all leaves, none drawn this frame; the
  // one whose children were visible longest ago goes first. Removing children can make the
  // parent a candidate, so it is pushed back.
  // Ties (nodes last visible in the same frame) go deepest first, then by key: deterministic,
  // never by address.
  struct Entry {
    std::uint64_t lastUse;
    Node* node;
    bool operator>(const Entry& o) const noexcept {
      if (lastUse != o.lastUse) return lastUse > o.lastUse;
      if (node->key_.level != o.node->key_.level) return node->key_.level < o.node->key_.level;
      return node->key_ > o.node->key_;
    }
  };
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> heap;
  auto lastUse = [this](const Node& n) -> std::optional<std::uint64_t> {
    if (!n.hasChildren()) return std::nullopt;
    std::uint64_t newest = 0;
    for (const auto& ch : n.children_) {
      if (!ch) continue;
      if (ch->hasChildren() || ch->lastDrawn_ == frame_) return std::nullopt;
      newest = std::max(newest, ch->lastVisible_);
    }
    return newest;
  };
  auto collect = [&](Node& n) {
    if (auto t = lastUse(n)) heap.push({*t, &n});
  };
  forEach(collect);
  while (nodeCount_ > params_.maxNodes && !heap.empty()) {
    Node* n = heap.top().node;
    heap.pop();
    removeChildren(*n);
    if (Node* p = n->parent_)
      if (auto t = lastUse(*p)) heap.push({*t, p});
  }
}

} // namespace tellus::planet
