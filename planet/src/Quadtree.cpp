#include <tellus/planet/Quadtree.hpp>

#include <algorithm>
#include <queue>
#include <utility>

namespace tellus::planet {

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

bool Quadtree::passesCulling(const Node& node, bool& insideFrustum, const Camera& camera) {
  const NodeGeometry& g = node.geometry_;
  if (isBackFacing(camera, g)) {
    ++stats_.culledBackFace;
    return false;
  }
  if (!insideFrustum) {
    const FrustumResult f = params_.tightFrustumCulling ? classifyNode(camera, g)
                                                        : classify(camera.frustum(), g.bounds());
    if (f == FrustumResult::Outside) {
      ++stats_.culledFrustum;
      return false;
    }
    insideFrustum = f == FrustumResult::Inside;
  }
  if (occluder_.isOccluded(camera.position(), g.bounds()) ||
      (node.cap_ && occluder_.isCapOccluded(camera.position(), g))) {
    ++stats_.culledHorizon;
    return false;
  }
  return true;
}

bool Quadtree::refines(const Node& node, const LodResult& lod, const Camera& camera) const {
  if (lod.split) return true;
  // A row widened for another camera (wider than the static rule) keeps the test it was made
  // with, each half of each east-west edge within half the limit: the whole-edge test alone
  // would let perspective enlarge its near texels further than a static node's.
  const NodeGeometry& g = node.geometry_;
  return node.widened_ &&
         !fitsEastWest(*node.widened_,
                       camera,
                       std::clamp(camera.pose().altitudeM, g.minHeightM(), g.maxHeightM()));
}

bool Quadtree::descends(Node& node, const LodResult& lod, bool refine) {
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
  return descend;
}

void Quadtree::visit(Node& node, bool insideFrustum, const Camera& camera) {
  ++stats_.visited;
  if (!passesCulling(node, insideFrustum, camera)) return;
  ++stats_.visible;
  node.lastVisible_ = frame_;
  const LodResult lod = evaluateLod(camera,
                                    node.geometry_,
                                    node.key_.span > 1 ? lodFor(node.key_) : params_.lod,
                                    node.key_.span > 1);
  if (descends(node, lod, refines(node, lod, camera))) {
    for (auto& ch : node.children_)
      if (ch) visit(*ch, insideFrustum, camera);
    return;
  }
  node.lastDrawn_ = frame_;
  node.drawnTexelRatioSquared_ = std::max(lod.worstRatioSquared, lod.worstTexelRatioSquared);
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
