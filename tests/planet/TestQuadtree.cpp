#include "PlanetTestSupport.hpp"

#include <tellus/planet/Quadtree.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <numbers>
#include <random>
#include <set>
#include <stdexcept>

using namespace tellus;
using namespace tellus::planet;

namespace {

QuadtreeParams params(int splits = 100000, std::size_t maxNodes = 1000000) {
  QuadtreeParams p;
  p.lod = {512, 512, 1.0};
  p.maxSplitsPerFrame = splits;
  p.maxNodes = maxNodes;
  return p;
}

/** Updates until nothing more is created or deferred (at most `frames` updates). */
const FrameStats& converge(Quadtree& tree, const Camera& cam, int frames = 200) {
  for (int i = 0; i < frames; ++i) {
    const FrameStats& s = tree.update(cam);
    if (s.created == 0 && s.splitsDeferred == 0) break;
  }
  return tree.stats();
}

std::set<const Node*> liveNodes(const Quadtree& tree) {
  std::set<const Node*> live;
  tree.forEach([&](const Node& n) { live.insert(&n); });
  return live;
}

/** Every pointer in the tree targets a live node; neighbours are what the tree would link now
 * and are the same level or coarser. */
void expectConsistent(const Quadtree& tree) {
  const auto live = liveNodes(tree);
  EXPECT_EQ(live.size(), tree.nodeCount());
  for (const Node* n : live) {
    if (n->parent()) {
      EXPECT_TRUE(live.contains(n->parent()));
    }
    for (int s = 0; s < n->childSlots(); ++s)
      if (Node* c = n->child(s)) {
        EXPECT_TRUE(live.contains(c));
        EXPECT_EQ(c->parent(), n);
      }
    for (Direction d : {Direction::North, Direction::East, Direction::South, Direction::West}) {
      Node* nb = n->neighbour(d);
      EXPECT_EQ(nb, tree.findNeighbour(*n, d))
          << "level " << n->level() << " dir " << static_cast<int>(d);
      if (nb) {
        EXPECT_TRUE(live.contains(nb));
        EXPECT_LE(nb->level(), n->level());
      }
    }
  }
  for (const Node* n : tree.drawList())
    EXPECT_TRUE(live.contains(n));
}

std::size_t drawnTopDown(const Geodesy& g, double lat, double altitude, bool polarMerge) {
  QuadtreeParams p = params();
  p.polarMerge = polarMerge;
  Quadtree tree(g, test::globalGrid(), p);
  const Camera cam(g, {lat, 10.0, altitude, 0.0, 0.0}, {1024, 768}, 45.0);
  return converge(tree, cam).drawn;
}

} // namespace

TEST(Quadtree, RootsAreTheLevelZeroTilesWithNeighbours) {
  const Geodesy g;
  QuadtreeParams p = params();
  p.polarCaps = false;
  Quadtree tree(g, test::globalGrid(), p);
  EXPECT_EQ(tree.nodeCount(), 50u);
  expectConsistent(tree);
  const auto& roots = tree.roots();
  // Row 0 column 0 is the south-west tile: its west neighbour wraps to column 9.
  const Node& sw = *roots[0];
  EXPECT_EQ(sw.key(), (NodeKey{0, 0, 0, 1}));
  ASSERT_NE(sw.neighbour(Direction::West), nullptr);
  EXPECT_EQ(sw.neighbour(Direction::West)->key(), (NodeKey{0, 0, 9, 1}));
  EXPECT_EQ(sw.neighbour(Direction::South), nullptr); // across the south pole
  EXPECT_EQ(sw.neighbour(Direction::North)->key(), (NodeKey{0, 1, 0, 1}));
  const Node& top = *roots[4 * 10 + 3];
  EXPECT_EQ(top.neighbour(Direction::North), nullptr); // across the north pole
}

// With polar caps the polar rows of level zero are one root each: 30 tiles and two caps.
TEST(Quadtree, PolarCapsAreTheRootsOfThePolarRows) {
  const Geodesy g;
  Quadtree tree(g, test::globalGrid(), params());
  ASSERT_TRUE(tree.capsEnabled());
  EXPECT_EQ(tree.nodeCount(), 32u);
  expectConsistent(tree);
  const auto& roots = tree.roots();
  const Node& south = *roots[0];
  const Node& north = *roots[4 * 10];
  EXPECT_TRUE(south.isCap());
  EXPECT_TRUE(north.isCap());
  EXPECT_EQ(south.key(), (NodeKey{0, 0, 0, 10}));
  EXPECT_EQ(north.key(), (NodeKey{0, 4, 0, 10}));
  EXPECT_EQ(north.sector().west, -180.0);
  EXPECT_EQ(north.sector().east, 180.0);
  EXPECT_EQ(north.sector().south, 54.0);
  EXPECT_EQ(roots[4 * 10 + 3], nullptr);
  for (Direction d : {Direction::North, Direction::East, Direction::West})
    EXPECT_EQ(north.neighbour(d), nullptr);              // the pole; itself east and west
  EXPECT_EQ(north.neighbour(Direction::South), nullptr); // ten tiles: no single node
  const Node& below = *roots[3 * 10 + 7];
  EXPECT_EQ(below.neighbour(Direction::North), &north); // a tile's edge lies on the cap's rim
  EXPECT_EQ(tree.lodFor(north.key()).tileWidthPx, 512 * kCapTextureWidthFactor);
  EXPECT_EQ(tree.lodFor(below.key()).tileWidthPx, 512);
  // Its children: the next cap, then its ring west to east (one or two nodes per root column).
  Quadtree::ChildKeys ck = tree.childKeys(north.key());
  ASSERT_GE(ck.keys.size(), 11u);
  EXPECT_EQ(ck.keys[0], (NodeKey{1, 9, 0, 20}));
  std::int64_t col = 0;
  for (std::size_t i = 1; i < ck.keys.size(); ++i) {
    EXPECT_TRUE(ck.present[i]);
    EXPECT_EQ(ck.keys[i].level, 1);
    EXPECT_EQ(ck.keys[i].row, 8);
    EXPECT_EQ(ck.keys[i].col, col);
    col += ck.keys[i].span;
  }
  EXPECT_EQ(col, 20); // the whole ring
  ck = tree.childKeys(south.key());
  EXPECT_EQ(ck.keys[0], (NodeKey{1, 0, 0, 20}));
  EXPECT_EQ(ck.keys[1].row, 1);
  // A split cap: the ring's nodes and the next cap are neighbours across the next cap's rim.
  Node& cap = const_cast<Node&>(north);
  ASSERT_TRUE(tree.split(cap));
  EXPECT_EQ(cap.childCount(), static_cast<int>(ck.keys.size()));
  ASSERT_TRUE(tree.split(*cap.child(0)));
  expectConsistent(tree);
  for (int s = 1; s < cap.childSlots(); ++s) {
    EXPECT_EQ(cap.child(s)->neighbour(Direction::North), cap.child(0));
    EXPECT_FALSE(cap.child(s)->isCap());
  }
  EXPECT_TRUE(cap.child(0)->isCap());
  EXPECT_TRUE(cap.child(0)->child(0)->isCap());
  tree.removeChildren(cap);
  expectConsistent(tree);
  EXPECT_EQ(tree.nodeCount(), 32u);
  // Caps need the poles and every longitude: a regional dataset has none.
  QuadtreeParams off = params();
  off.polarMerge = false;
  EXPECT_FALSE(Quadtree(g, test::globalGrid(), off).capsEnabled());
}

TEST(Quadtree, GlobeFrom20000KmDrawsLevelZero) {
  const Geodesy g;
  Quadtree tree(g, test::globalGrid(), params());
  const Camera cam(g, {0.0, 0.0, 2e7, 0.0, 0.0}, {1024, 768}, 45.0);
  const FrameStats& s = tree.update(cam);
  EXPECT_EQ(s.created, 0u);
  EXPECT_GE(s.drawn, 8u);
  EXPECT_EQ(s.visited, 32u); // 30 tiles and two polar caps
  EXPECT_EQ(s.visited, s.visible + s.culledBackFace + s.culledFrustum + s.culledHorizon);
  EXPECT_GT(s.culledBackFace + s.culledHorizon, 0u);
  for (const Node* n : tree.drawList())
    EXPECT_EQ(n->level(), 0);
}

TEST(Quadtree, SplitLimitDrawsTheLowerLod) {
  const Geodesy g;
  Quadtree tree(g, test::globalGrid(), params(2));
  const Camera cam(g, {46.5, 8.0, 1000.0, 0.0, 0.0}, {1024, 768}, 45.0);
  const FrameStats& first = tree.update(cam);
  EXPECT_LE(first.created, 8u); // two splits of up to four children
  EXPECT_GT(first.splitsDeferred, 0u);
  EXPECT_GT(first.drawn, 0u); // something is drawn although the LOD is not reached
  int frames = 1;
  while (tree.update(cam).splitsDeferred > 0 && frames < 500)
    ++frames;
  EXPECT_LT(frames, 500);
  EXPECT_GE(tree.stats().maxLevel, 11);
  expectConsistent(tree);
}

TEST(Quadtree, DrawListCoversTheViewWithoutOverlap) {
  const Geodesy g;
  Quadtree tree(g, test::globalGrid(), params());
  const Camera cam(g, {30.0, 100.0, 3e5, 20.0, 50.0}, {1024, 768}, 45.0);
  converge(tree, cam);
  // Drawn nodes are leaves of the drawn part and never an ancestor of another drawn node.
  std::set<const Node*> drawn(tree.drawList().begin(), tree.drawList().end());
  for (const Node* n : tree.drawList())
    for (const Node* a = n->parent(); a; a = a->parent())
      EXPECT_FALSE(drawn.contains(a));
  expectConsistent(tree);
}

TEST(Quadtree, RemovalNullsEveryPointerToRemovedNodes) {
  const Geodesy g;
  Quadtree tree(g, test::globalGrid(), params(200));
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> lat(-90.0, 90.0), lon(-180.0, 180.0), alt(3.0, 7.0);
  for (int round = 0; round < 12; ++round) {
    const Camera cam(g, {lat(rng), lon(rng), std::pow(10.0, alt(rng)), 0.0, 30.0}, {800, 600});
    for (int f = 0; f < 3; ++f)
      tree.update(cam);
    expectConsistent(tree);
    // Remove a few random subtrees (including ones holding drawn nodes: the caller may).
    std::vector<Node*> inner;
    tree.forEach([&](const Node& n) {
      if (n.hasChildren()) inner.push_back(const_cast<Node*>(&n));
    });
    std::shuffle(inner.begin(), inner.end(), rng);
    for (std::size_t i = 0; i < std::min<std::size_t>(3, inner.size()); ++i) {
      // A shuffled candidate may have been removed with an earlier one: look it up again.
      const auto live = liveNodes(tree);
      if (!live.contains(inner[i])) continue;
      tree.removeChildren(*inner[i]);
      EXPECT_FALSE(inner[i]->hasChildren());
    }
    // The draw list may now hold removed nodes; the next update rebuilds it.
    tree.update(cam);
    expectConsistent(tree);
  }
}

TEST(Quadtree, NodeLimitRemovesLeastRecentlyVisibleFirst) {
  const Geodesy g;
  Quadtree tree(g, test::globalGrid(), params());
  auto deepAt = [&](double lat, double lon) {
    int count = 0;
    tree.forEach([&](const Node& n) {
      const Sector& s = n.sector();
      if (n.level() >= 8 && s.west <= lon && lon <= s.east && s.south <= lat && lat <= s.north)
        ++count;
    });
    return count;
  };
  const Camera alps(g, {46.5, 8.0, 2000.0, 0.0, 0.0}, {1024, 768}, 45.0);
  converge(tree, alps);
  const std::size_t alpsNodes = tree.nodeCount();
  const int deepAlpsBefore = deepAt(46.5, 8.0);
  ASSERT_GT(deepAlpsBefore, 3);
  const Camera andes(g, {-33.0, -70.0, 2000.0, 0.0, 0.0}, {1024, 768}, 45.0);
  Quadtree andesAlone(g, test::globalGrid(), params());
  converge(andesAlone, andes);
  // The Andes need about as many nodes again: under a limit that holds either view, the Alps
  // must go.
  const std::size_t limit = std::max(alpsNodes, andesAlone.nodeCount());
  ASSERT_LT(limit, alpsNodes + andesAlone.nodeCount() - 50);
  QuadtreeParams limited = tree.params();
  limited.maxNodes = limit;
  tree.setParams(limited);
  converge(tree, andes);
  EXPECT_LE(tree.nodeCount(), limit);
  EXPECT_GT(tree.stats().drawn, 0u);
  EXPECT_LT(deepAt(46.5, 8.0), deepAlpsBefore / 2);    // least recently visible: removed
  EXPECT_GE(deepAt(-33.0, -70.0), deepAlpsBefore - 1); // drawn now: complete
  EXPECT_GE(tree.stats().maxLevel, 10);
  for (const Node* n : tree.drawList())
    EXPECT_EQ(n->lastDrawnFrame(), tree.frame());
  expectConsistent(tree);
  // A limit below what one frame draws: drawn nodes are kept, the rest goes.
  QuadtreeParams tight = tree.params();
  tight.maxNodes = 10;
  tree.setParams(tight);
  tree.update(andes);
  EXPECT_GT(tree.nodeCount(), 10u);
  const auto live = liveNodes(tree);
  for (const Node* n : tree.drawList())
    EXPECT_TRUE(live.contains(n));
  expectConsistent(tree);
}

// ---- the poles ----

/** The texel-to-pixel guarantee checked on the surface itself (not the corner plane): at 9 x 9
 * points of every drawn node (9 x 129 of a cap) that lie in the viewport, one texel step east and
 * one north project to at most threshold pixels (2 % slack for the plane approximation of the LOD
 * test). */
double worstTexelPixels(const Camera& cam, const Geodesy& g, const Node& n, const LodParams& lod) {
  const Sector& s = n.sector();
  const double du = (s.east - s.west) / lod.tileWidthPx;
  const double dv = (s.north - s.south) / lod.tileHeightPx;
  // A cap's image may be made of bands of its row, each only as wide as its equatorward parallel
  // needs (proxy/src/tiles/CapBands.hpp): east-west, a texel may be as long in metres on every
  // parallel as on the rim. Its step is that length, due east (any horizontal way at the pole).
  const bool cap = s.east - s.west >= 360.0;
  const double rimLat = s.north == 90.0 ? s.south : s.north;
  const double rimStepM =
      glm::length(test::vec(g.toEcef(rimLat, 0.0, 0.0)) - test::vec(g.toEcef(rimLat, du, 0.0)));
  auto clipToPx = [&](const glm::dvec3& e, glm::dvec2& out) {
    const glm::dvec4 c = cam.toClip(e);
    if (!(c.w > cam.nearM())) return false;
    out = {c.x / c.w * 0.5 * cam.viewport().width, c.y / c.w * 0.5 * cam.viewport().height};
    return std::abs(c.x / c.w) <= 1.0 && std::abs(c.y / c.w) <= 1.0;
  };
  auto toPx = [&](double lat, double lon, glm::dvec2& out) {
    return clipToPx(test::vec(g.toEcef(lat, lon, 0.0)), out);
  };
  double worst = 0.0;
  const int cols = cap ? 128 : 8; // a cap's whole parallels: a view may see a few degrees of them
  for (int i = 0; i <= 8; ++i)
    for (int j = 0; j <= cols; ++j) {
      const double lat = std::min(s.north - dv, s.south + (s.north - s.south) * i / 8.0);
      const double lon = std::min(s.east - du, s.west + (s.east - s.west) * j / cols);
      glm::dvec2 p, pe, pn;
      if (!toPx(lat, lon, p)) continue;
      if (cap) {
        const double l = lon * std::numbers::pi / 180.0;
        const glm::dvec3 at = test::vec(g.toEcef(lat, lon, 0.0));
        for (const glm::dvec3 east : {glm::dvec3(-std::sin(l), std::cos(l), 0.0),
                                      glm::dvec3(std::cos(l), std::sin(l), 0.0)}) {
          if (clipToPx(at + east * rimStepM, pe)) worst = std::max(worst, glm::length(pe - p));
          if (std::abs(lat) != 90.0) break; // east is one way off the pole
        }
      } else if (toPx(lat, lon + du, pe)) {
        worst = std::max(worst, glm::length(pe - p));
      }
      if (toPx(lat + dv, lon, pn)) worst = std::max(worst, glm::length(pn - p));
    }
  return worst;
}

/** A point of the surface the camera sees: in the frustum and not behind the globe. */
bool seesPoint(const Camera& cam, const Geodesy& g, double lat, double lon) {
  const glm::dvec3 p = test::vec(g.toEcef(lat, lon, 0.0));
  return test::inFrustum(cam, p) && !HorizonOccluder(g).segmentHitsOccluder(cam.position(), p);
}

bool seesSector(const Camera& cam, const Geodesy& g, const Sector& s) {
  constexpr int n = 24;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j)
      if (seesPoint(
              cam, g, s.south + (s.north - s.south) * i / n, s.west + (s.east - s.west) * j / n))
        return true;
  return false;
}

/** The fewest nodes any tree over this tiling could draw for the view: nodes with a visible
 * surface point (sampled; the culling tests, which never cull a visible node, prune the search),
 * refined while the LOD test asks, where each child row may take the
 * static layout (childKeys) or, where a polar row is merged, the parent's whole width; the least
 * total. A lower bound up to the sampling (a sliver with a visible part between samples is left
 * out, which only lowers it). */
std::size_t
minimumNodes(const Quadtree& tree, const Camera& cam, const Geodesy& g, const NodeKey& key) {
  const Sector s = tree.sectorOf(key);
  const NodeGeometry geometry(g, s);
  if (!cullNode(cam, geometry, HorizonOccluder(g)).visible) return 0; // conservative
  if (!evaluateLod(cam, geometry, tree.params().lod).split) return seesSector(cam, g, s) ? 1 : 0;
  const Quadtree::ChildKeys ck = tree.childKeys(key);
  if (!ck.present[0] && !ck.present[2]) return 1; // the deepest level
  std::size_t total = 0;
  for (int half = 0; half < 2; ++half) {
    std::size_t statics = 0;
    for (int i = 0; i < 2; ++i)
      if (ck.present[static_cast<std::size_t>(half * 2 + i)])
        statics += minimumNodes(tree, cam, g, ck.keys[static_cast<std::size_t>(half * 2 + i)]);
    const NodeKey& first = ck.keys[static_cast<std::size_t>(half * 2)];
    const std::int64_t width = key.span * 2;
    std::size_t best = statics;
    if (first.span > 1 && first.span < width) {
      const NodeKey wide{first.level, first.row, key.col * 2, width};
      best = std::min(best, minimumNodes(tree, cam, g, wide));
    }
    total += best;
  }
  return total;
}

std::size_t minimumNodes(const Quadtree& tree, const Camera& cam, const Geodesy& g) {
  std::size_t total = 0;
  for (const auto& r : tree.roots())
    if (r) total += minimumNodes(tree, cam, g, r->key());
  return total;
}

// Merged rows without caps (the tiling of level-zero roots): see PolarCapsKeepThePole... below.
TEST(QuadtreeExtremes, PoleTopDownCostsAtMostOneAndAHalfTheEquator) {
  const Geodesy g;
  QuadtreeParams p = params();
  p.polarCaps = false;
  for (double alt : {2e7, 6e6, 2e6, 1e6, 6e5, 2e5, 1e5, 6e4, 2e4, 1e4}) {
    Quadtree eq(g, test::globalGrid(), p), np(g, test::globalGrid(), p),
        sp(g, test::globalGrid(), p);
    const Camera eqCam(g, {0.0, 10.0, alt, 0.0, 0.0}, {1024, 768}, 45.0);
    const Camera npCam(g, {90.0, 10.0, alt, 0.0, 0.0}, {1024, 768}, 45.0);
    const Camera spCam(g, {-90.0, 10.0, alt, 0.0, 0.0}, {1024, 768}, 45.0);
    const std::size_t equator = converge(eq, eqCam).drawn;
    const std::size_t pole = converge(np, npCam).drawn;
    const std::size_t southPole = converge(sp, spCam).drawn;
    const std::size_t eqMin = minimumNodes(eq, eqCam, g), poleMin = minimumNodes(np, npCam, g);
    const double ratio = static_cast<double>(pole) / static_cast<double>(equator);
    std::printf("altitude %8.0f m: equator %2zu (least %2zu), north pole %2zu (least %2zu), "
                "south pole %2zu; ratio %.2f, least possible %.2f\n",
                alt,
                equator,
                eqMin,
                pole,
                poleMin,
                southPole,
                ratio,
                static_cast<double>(poleMin) / static_cast<double>(eqMin));
    EXPECT_EQ(southPole, pole) << alt; // the tiling is symmetric about the equator
    EXPECT_EQ(drawnTopDown(g, 0.0, alt, false), equator) << alt; // nothing changes off the poles
    EXPECT_FALSE(np.capsEnabled());
    // The goal, wherever any tree over this tiling could reach it: 1.5x the equator view.
    const double leastRatio = static_cast<double>(poleMin) / static_cast<double>(eqMin);
    if (leastRatio <= 1.5) {
      EXPECT_LE(ratio, 1.5) << alt;
    }
    // Elsewhere (2,000 km: 2.25x, 1,000 km: 3x, 200 km: 1.62x at least) the geometry forbids it:
    // the ten wedges that meet at the pole are ten nodes whatever the altitude, and the equator
    // view there needs only 6 to 16. The tree then stays within 1.25x of the least possible.
    EXPECT_LE(static_cast<double>(pole), 1.25 * static_cast<double>(poleMin)) << alt;
  }
}

QuadtreeParams capParams() {
  QuadtreeParams p = params();
  p.polarCaps = true;
  return p;
}

// Polar caps: the whole top row of a level is one node, so the ten wedges that meet at the pole
// become one node and the goal holds at every altitude.
TEST(QuadtreeExtremes, PolarCapsKeepThePoleWithinOneAndAHalfTheEquator) {
  const Geodesy g;
  double worstRatio = 0.0;
  for (double alt : {2e7, 6e6, 2e6, 1e6, 6e5, 2e5, 1e5, 6e4, 2e4, 1e4, 1e3, 1e2}) {
    Quadtree eq(g, test::globalGrid(), capParams()), np(g, test::globalGrid(), capParams()),
        sp(g, test::globalGrid(), capParams());
    const Camera eqCam(g, {0.0, 10.0, alt, 0.0, 0.0}, {1024, 768}, 45.0);
    const Camera npCam(g, {90.0, 10.0, alt, 0.0, 0.0}, {1024, 768}, 45.0);
    const Camera spCam(g, {-90.0, 10.0, alt, 0.0, 0.0}, {1024, 768}, 45.0);
    const std::size_t equator = converge(eq, eqCam).drawn;
    const std::size_t pole = converge(np, npCam).drawn;
    const std::size_t southPole = converge(sp, spCam).drawn;
    expectConsistent(np);
    const double ratio = static_cast<double>(pole) / static_cast<double>(equator);
    worstRatio = std::max(worstRatio, ratio);
    double worstTexel = 0.0;
    for (const Node* n : np.drawList())
      worstTexel = std::max(worstTexel, worstTexelPixels(npCam, g, *n, np.lodFor(n->key())));
    std::printf("caps, altitude %9.0f m: equator %2zu, north pole %2zu, south pole %2zu; ratio "
                "%.2f; largest texel at the pole %.3f px\n",
                alt,
                equator,
                pole,
                southPole,
                ratio,
                worstTexel);
    EXPECT_EQ(southPole, pole) << alt;
    EXPECT_LE(ratio, 1.5) << alt;
    EXPECT_LE(worstTexel, 1.03) << alt;
  }
  std::printf("caps: worst pole/equator ratio %.2f\n", worstRatio);
}

// The same with terrain (the renderer makes caps with an elevation layer too): every node's
// heights span -500 to 4,000 m (an ice sheet's range), which grows the bounding volumes the culling
// tests and moves the occluder down, and lifts the points the LOD test measures to 4,000 m; the
// camera is above the highest terrain. The merged rows' east-west test once measured at height 0
// while the LOD measured at 4,000 m: from 20 km and 10 km the pole view refined rows as wide as
// their parents down to the deepest level (692 and 51,004 nodes, caps or not).
TEST(QuadtreeExtremes, PolarCapsKeepThePoleWithinOneAndAHalfTheEquatorWithTerrain) {
  const Geodesy g;
  for (double alt : {2e7, 2e6, 6e5, 1e5, 2e4, 1e4}) {
    auto make = [&](bool caps = true) {
      QuadtreeParams p = capParams();
      p.polarCaps = caps;
      auto t = std::make_unique<Quadtree>(g, test::globalGrid(), p);
      t->setTerrain([](const Sector&) { return std::pair{-500.0, 4000.0}; }, -500.0);
      t->refreshHeights([](const Sector&) { return true; });
      return t;
    };
    const auto eq = make(), np = make(), sp = make();
    const Camera eqCam(g, {0.0, 10.0, alt, 0.0, 0.0}, {1024, 768}, 45.0);
    const Camera npCam(g, {90.0, 10.0, alt, 0.0, 0.0}, {1024, 768}, 45.0);
    const Camera spCam(g, {-90.0, 10.0, alt, 0.0, 0.0}, {1024, 768}, 45.0);
    const std::size_t equator = converge(*eq, eqCam).drawn;
    const std::size_t pole = converge(*np, npCam).drawn;
    const std::size_t southPole = converge(*sp, spCam).drawn;
    expectConsistent(*np);
    const double ratio = static_cast<double>(pole) / static_cast<double>(equator);
    std::printf("caps with terrain, altitude %9.0f m: equator %2zu, north pole %2zu, south pole "
                "%2zu; ratio %.2f\n",
                alt,
                equator,
                pole,
                southPole,
                ratio);
    EXPECT_EQ(southPole, pole) << alt;
    EXPECT_LE(ratio, 1.5) << alt;
    const auto rows = make(false); // merged rows alone: 2.5x at worst, as without terrain
    EXPECT_LE(converge(*rows, npCam).drawn, 3 * equator) << alt;
  }
}

// Over the drawn nodes of the pole views (merged rows, adaptive spans, the wedges) and the equator.
TEST(QuadtreeExtremes, TexelToPixelHoldsAtThePole) {
  const Geodesy g;
  for (double lat : {90.0, 89.9, -90.0, 0.0})
    for (double alt : {2e7, 2e6, 1e6, 2e5, 1e5, 2e4, 1e3}) {
      for (double tilt : {0.0, 60.0}) {
        // Tilted from 2,000 km and below (from 20,000 km a tilted view misses the globe).
        if (tilt > 0.0 && alt > 2e6) continue;
        Quadtree tree(g, test::globalGrid(), params());
        const Camera cam(g, {lat, 10.0, alt, 30.0, tilt}, {1024, 768}, 45.0);
        converge(tree, cam);
        double worst = 0.0;
        for (const Node* n : tree.drawList())
          worst = std::max(worst, worstTexelPixels(cam, g, *n, tree.lodFor(n->key())));
        // Top down and tilted, the local texels keep the largest within 3 % (the corner test alone
        // let tilted views reach ~1.45 px: TexelToPixelHoldsTiltedEverywhere).
        EXPECT_LE(worst, 1.03) << lat << " " << alt << " " << tilt;
        EXPECT_GT(worst, 0.25) << lat << " " << alt << " " << tilt; // and not absurdly fine
      }
    }
}

// Over the caps, tilted: a cap drawn from bands of its row (proxy/src/tiles/CapBands.hpp) has
// east-west texels as long on every parallel as on its rim, and a view along a meridian shows them
// unshortened where the north-south ones are foreshortened. The LOD measures a cap's east-west
// step at the rim's length everywhere, and samples the rim at 16 longitudes (at the camera's alone,
// a cap's texels reached 1.057 px tilted 60 degrees from 88 S): the largest stays within 3 %.
TEST(QuadtreeExtremes, TexelToPixelHoldsOverCapsInBandsTilted) {
  const Geodesy g;
  double worstAll = 0.0;
  for (double lat : {90.0, 89.0, 86.0, -90.0, -88.0})
    for (double alt : {2e6, 2e5, 2e4, 1e3})
      for (double tilt : {30.0, 60.0, 75.0})
        for (double heading : {0.0, 90.0, 180.0}) {
          const Camera cam(g, {lat, 10.0, alt, heading, tilt}, {1024, 768}, 45.0);
          Quadtree tree(g, test::globalGrid(), capParams());
          converge(tree, cam);
          double worst = 0.0;
          for (const Node* n : tree.drawList())
            worst = std::max(worst, worstTexelPixels(cam, g, *n, tree.lodFor(n->key())));
          EXPECT_LE(worst, 1.03) << lat << " " << alt << " " << tilt << " " << heading;
          worstAll = std::max(worstAll, worst);
        }
  std::printf("over the caps, tilted: largest texel %.3f px\n", worstAll);
}

// The texel-to-pixel guarantee under tilted views, anywhere: the equator, mid-latitudes, near and
// at the poles, from 2,000 km down to 1 km, top down and tilted 30 and 60 degrees. The corner test
// alone (perspectiveAware off) lets near texels reach 1.6 px tilted and 3.5 px over the interior
// of a large polar wedge; with the local texels at the corners, the point below the camera and the
// viewport's ground points, the largest texel of a drawn node stays within 3 % of the threshold
// (the tolerance: the surface's curvature between the sample points and the one-texel finite
// difference of worstTexelPixels against the derivative the test uses).
TEST(QuadtreeExtremes, TexelToPixelHoldsTiltedEverywhere) {
  const Geodesy g;
  double worstAll = 0.0, worstCorners = 0.0;
  for (double threshold : {1.0, 2.0})
    for (double lat : {0.0, 45.0, -60.0, 84.0, 89.9, 90.0})
      for (double alt : {2e6, 2.4e5, 2e4, 1e3})
        for (double tilt : {0.0, 30.0, 60.0}) {
          if (threshold != 1.0 && (tilt != 60.0 || lat != 45.0)) continue;
          QuadtreeParams p = params();
          p.lod.threshold = threshold;
          const Camera cam(g, {lat, 10.0, alt, 30.0, tilt}, {1024, 768}, 45.0);
          Quadtree tree(g, test::globalGrid(), p);
          converge(tree, cam);
          double worst = 0.0;
          for (const Node* n : tree.drawList())
            worst = std::max(worst, worstTexelPixels(cam, g, *n, tree.lodFor(n->key())));
          EXPECT_LE(worst, 1.03 * threshold)
              << "lat " << lat << " alt " << alt << " tilt " << tilt << " threshold " << threshold;
          EXPECT_GT(worst, 0.25 * threshold) << lat << " " << alt << " " << tilt;
          worstAll = std::max(worstAll, worst / threshold);
          if (threshold == 1.0 && (tilt == 60.0 || lat == 90.0)) {
            // The thesis's corner test alone, for comparison (and so that this test can fail).
            p.lod.perspectiveAware = false;
            Quadtree corners(g, test::globalGrid(), p);
            converge(corners, cam);
            double w = 0.0;
            for (const Node* n : corners.drawList())
              w = std::max(w, worstTexelPixels(cam, g, *n, corners.lodFor(n->key())));
            worstCorners = std::max(worstCorners, w);
          }
        }
  std::printf("largest texel: %.3f px per threshold (corner test alone: %.3f px)\n",
              worstAll,
              worstCorners);
  EXPECT_GT(worstCorners, 1.3); // the checker sees what the corner test misses
}

// Near the poles a merged row's children are as wide as itself (north-south splits only). Where
// the local texel test finds only east-west texels over the limit, such children would have the
// same east-west texels at the sample: the tree refined them down to level 24 (17,044 nodes drawn
// tilted 30 degrees at 84 N from 20 km, 77,980 at 89.9 N from 240 km) before the row was made to
// split east-west. Now the views converge to the levels their texels ask for.
TEST(QuadtreeExtremes, EastWestTexelsAloneSplitAMergedRowEastWest) {
  const Geodesy g;
  for (const CameraPose pose : {CameraPose{84.0, 10.0, 2e4, 30.0, 30.0},
                                CameraPose{89.9, 10.0, 2.4e5, 30.0, 30.0},
                                CameraPose{89.9, 10.0, 2e4, 30.0, 60.0},
                                CameraPose{90.0, 10.0, 1e3, 30.0, 30.0}}) {
    Quadtree tree(g, test::globalGrid(), params());
    const Camera cam(g, pose, {1024, 768}, 45.0);
    const FrameStats& s = converge(tree, cam);
    EXPECT_EQ(s.created, 0u) << pose.latDeg << " " << pose.altitudeM;
    EXPECT_LE(s.maxLevel, 16) << pose.latDeg << " " << pose.altitudeM;
    EXPECT_LE(s.drawn, 60u) << pose.latDeg << " " << pose.altitudeM;
    expectConsistent(tree);
  }
  // A tree whose wide children were made for another camera: they are made again, narrower.
  Quadtree tree(g, test::globalGrid(), params());
  converge(tree, Camera(g, {89.9, 10.0, 2e4, 30.0, 0.0}, {1024, 768}, 45.0));
  const Camera tilted(g, {89.9, 10.0, 2e4, 30.0, 60.0}, {1024, 768}, 45.0);
  const FrameStats& s = converge(tree, tilted);
  EXPECT_EQ(s.created, 0u);
  EXPECT_LE(s.maxLevel, 16);
  double worst = 0.0;
  for (const Node* n : tree.drawList())
    worst = std::max(worst, worstTexelPixels(tilted, g, *n, tree.lodFor(n->key())));
  EXPECT_LE(worst, 1.03);
  expectConsistent(tree);
}

// Widened polar rows are made for the camera of the moment; after a path over the pole (zooming
// in and out, tilting, turning) the nodes made for earlier cameras must keep the guarantee: no
// texel larger than the threshold (3 % for the sampling, as in TexelToPixelHoldsTiltedEverywhere),
// like a fresh static tree (adaptivePolarSpans off) for the same camera. The corner-plane test
// alone let texels reach 3.5 px tilted 60 degrees over a level-2 polar wedge from 240 km (the
// camera above the wedge's interior, its corners far away) and 1.04 px top down over one from
// 1,750 km; the local texels at the point below the camera and the viewport's ground points
// catch both.
TEST(QuadtreeExtremes, TexelToPixelHoldsAfterAPathOverThePole) {
  const Geodesy g;
  Quadtree tree(g, test::globalGrid(), params());
  QuadtreeParams staticRows = params();
  staticRows.adaptivePolarSpans = false;
  std::mt19937_64 rng(90);
  std::uniform_real_distribution<double> lat(86.0, 90.0), lon(-180.0, 180.0), heading(0.0, 360.0);
  std::uniform_real_distribution<double> logAlt(3.0, 6.3);
  int drawnChecked = 0;
  for (int step = 0; step < 16; ++step) {
    const double alt = std::pow(10.0, logAlt(rng));
    const double tilt = (step % 3 == 0 || alt > 1e6) ? 0.0 : 60.0;
    const double sign = step % 4 == 3 ? -1.0 : 1.0; // now and then the south pole
    const double la = sign * lat(rng), lo = lon(rng), hd = heading(rng);
    const Camera cam(g, {la, lo, alt, hd, tilt}, {1024, 768}, 45.0);
    converge(tree, cam);
    double worst = 0.0;
    for (const Node* n : tree.drawList()) {
      worst = std::max(worst, worstTexelPixels(cam, g, *n, tree.lodFor(n->key())));
      ++drawnChecked;
    }
    Quadtree fresh(g, test::globalGrid(), staticRows);
    converge(fresh, cam);
    double worstStatic = 0.0;
    for (const Node* n : fresh.drawList())
      worstStatic = std::max(worstStatic, worstTexelPixels(cam, g, *n, fresh.lodFor(n->key())));
    EXPECT_LE(worst, 1.03) << step << ": lat " << la << " alt " << alt << " tilt " << tilt;
    EXPECT_LE(worstStatic, 1.03) << step << ": lat " << la << " alt " << alt << " tilt " << tilt;
  }
  EXPECT_GT(drawnChecked, 200);
  expectConsistent(tree);
}

TEST(QuadtreeExtremes, NeighboursAcrossTheAntimeridianAndAtThePoles) {
  const Geodesy g;
  Quadtree tree(g, test::globalGrid(), params());
  // Looking at the antimeridian near the pole and on the equator: deep trees on both sides.
  for (const CameraPose pose : {CameraPose{0.0, 180.0, 5e4, 0.0, 0.0},
                                CameraPose{89.5, 179.9, 5e4, 0.0, 40.0},
                                CameraPose{-90.0, -180.0, 1e4, 0.0, 0.0}})
    converge(tree, Camera(g, pose, {1024, 768}));
  expectConsistent(tree);
  int wrapped = 0, poleNone = 0;
  const TileGrid grid = test::globalGrid();
  tree.forEach([&](const Node& n) {
    const NodeKey& k = n.key();
    if (n.isCap()) { // a whole polar row: no east, west or poleward neighbour
      for (Direction d : {Direction::North, Direction::East, Direction::South, Direction::West})
        EXPECT_EQ(n.neighbour(d), nullptr);
      ++poleNone;
      return;
    }
    if (k.col + k.span == grid.colCount(k.level)) { // the easternmost column
      const Node* e = n.neighbour(Direction::East);
      ASSERT_NE(e, nullptr);
      EXPECT_EQ(e->sector().west, -180.0);
      ++wrapped;
    }
    if (k.row + 1 == grid.rowCount(k.level)) {
      EXPECT_EQ(n.neighbour(Direction::North), nullptr);
      ++poleNone;
    }
    if (k.row == 0) {
      EXPECT_EQ(n.neighbour(Direction::South), nullptr);
    }
  });
  EXPECT_GT(wrapped, 10);
  EXPECT_GT(poleNone, 10);
}

TEST(QuadtreeExtremes, OneMetreAndOneBillionMetres) {
  const Geodesy g;
  QuadtreeParams p = params();
  Quadtree tree(g, test::globalGrid(), p);
  // 1e9 m: the globe is a few pixels; level zero only, nothing created.
  const FrameStats& far = tree.update(Camera(g, {0.0, 0.0, 1e9, 0.0, 0.0}, {1024, 768}));
  EXPECT_EQ(far.created, 0u);
  EXPECT_GT(far.drawn, 0u);
  // 1 m above the ground at the pole, looking at the horizon: the nodes under the camera reach
  // the deepest levels and the tree stays consistent; nothing non-finite.
  for (double lat : {90.0, 0.0}) {
    const Camera cam(g, {lat, 0.0, 1.0, 0.0, 85.0}, {1024, 768});
    converge(tree, cam, 400);
    EXPECT_GE(tree.stats().maxLevel, 22) << lat; // ~1 m tiles underfoot
    EXPECT_GT(tree.stats().drawn, 0u);
    expectConsistent(tree);
  }
}

TEST(QuadtreeExtremes, NonFiniteCameraIsRejectedAndTheTreeUntouched) {
  const Geodesy g;
  Quadtree tree(g, test::globalGrid(), params());
  const double nan = std::nan("");
  EXPECT_THROW(Camera(g, {nan, 0.0, 1e6, 0.0, 0.0}, {1024, 768}), std::invalid_argument);
  EXPECT_THROW(Camera(g, {0.0, 0.0, nan, 0.0, 0.0}, {1024, 768}), std::invalid_argument);
  EXPECT_THROW(Camera(g, {0.0, 0.0, 1e6, nan, 0.0}, {1024, 768}), std::invalid_argument);
  EXPECT_EQ(tree.nodeCount(), 32u);
  EXPECT_EQ(tree.frame(), 0u);
}

TEST(QuadtreeExtremes, DeepestLevelDoesNotSplitAndPartialDatasets) {
  const Geodesy g;
  // A 3-level dataset over Europe: only its tiles exist, no merged rows (not global).
  GridSpec spec;
  spec.sector = {-10.0, 30.0, 40.0, 72.0};
  spec.numLevels = 3;
  const auto grid = TileGrid::create(spec);
  ASSERT_TRUE(grid);
  Quadtree tree(g, *grid, params());
  const Camera cam(g, {46.5, 8.0, 1000.0, 0.0, 0.0}, {1024, 768});
  converge(tree, cam);
  EXPECT_EQ(tree.stats().maxLevel, 2);
  tree.forEach([&](const Node& n) {
    EXPECT_EQ(n.key().span, 1);
    EXPECT_TRUE(grid->isValid(n.key().firstTile()));
  });
  expectConsistent(tree);
}

// The horizon occluder's margin for the meshes' chords: the deepest of the roots' grids, a polar
// cap's rim cells (2.8 degrees of longitude round the pole) deeper than a 36-degree tile's.
TEST(Quadtree, ChordDepthIsTheDeepestRootGrid) {
  const Geodesy g;
  for (const bool caps : {false, true}) {
    QuadtreeParams p = params();
    p.polarCaps = caps;
    const Quadtree tree(g, test::globalGrid(), p);
    const double depth = tree.chordDepthM(33);
    double deepest = 0.0;
    for (const auto& r : tree.roots()) {
      if (!r) continue;
      const double d = gridChordDepthM(g, r->sector(), r->meshSize(33), 33);
      EXPECT_LE(d, depth);
      deepest = std::max(deepest, d);
    }
    EXPECT_EQ(depth, deepest);
    std::printf("caps %d: chord depth %.1f m (33 points), %.2f m (65)\n",
                caps ? 1 : 0,
                depth,
                tree.chordDepthM(65));
    EXPECT_GT(depth, 600.0) << caps; // ~614 m: a level-zero tile's 1.125-degree cells
    EXPECT_LT(depth, 2000.0) << caps;
    // A finer mesh sags less: twice the points a side, a quarter.
    EXPECT_LT(tree.chordDepthM(65), depth / 3.0) << caps;
  }
}
