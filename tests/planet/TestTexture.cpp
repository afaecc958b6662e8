// Texture fallback, screen area, the GPU memory LRU and the stream scheduler (GL-free).
#include "../support/FakeTileSource.hpp"
#include "PlanetTestSupport.hpp"

#include <tellus/planet/Quadtree.hpp>
#include <tellus/planet/ScreenArea.hpp>
#include <tellus/planet/TextureFallback.hpp>
#include <tellus/planet/TextureLru.hpp>
#include <tellus/planet/TextureStreamer.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>
#include <set>

using namespace tellus;
using namespace tellus::planet;

namespace {

QuadtreeParams treeParams() {
  QuadtreeParams p;
  p.lod = {512, 512, 1.0};
  p.maxSplitsPerFrame = 100000;
  return p;
}

void converge(Quadtree& tree, const Camera& cam) {
  for (int i = 0; i < 100; ++i)
    if (tree.update(cam).created == 0) break;
}

/** The deepest drawn node (a chain of ancestors above it). */
Node* deepest(const Quadtree& tree) {
  Node* best = nullptr;
  for (Node* n : tree.drawList())
    if (!best || n->level() > best->level()) best = n;
  return best;
}

using tellus::test::FakeTileSource;

/** The streamer's tiles: 16 bytes when Ok. */
TileResult tile(TileStatus status) {
  return FakeTileSource::result(
      status, status == TileStatus::Ok ? std::vector<std::byte>(16) : std::vector<std::byte>{});
}

/** A source that holds every request until the test answers it. */
void holdAll(FakeTileSource& src) {
  src.setDelivery(FakeTileSource::Delivery::Held);
}

/** A source that answers every request at once with this status. */
void answerAll(FakeTileSource& src, TileStatus status) {
  src.setFallbackAnswer([status](const TileAddress&) { return tile(status); });
}

constexpr std::size_t kTileBytes = 512 * 512 * 4 * 4 / 3; // RGBA8 with mipmaps

} // namespace

// ---- fallback ----

TEST(TextureFallback, AncestorUvMatchesTheThesisExample) {
  // Thesis figure 16: a node two levels down, second column from the west and the second row
  // from the north of its grandparent, spans u 0.5..0.75 and v 0.5..0.75 (v north).
  const UvTransform t = ancestorUv({2, 2, 2, 1}, {0, 0, 0, 1});
  EXPECT_EQ(t.apply({0.0, 0.0}), glm::dvec2(0.5, 0.5));
  EXPECT_EQ(t.apply({1.0, 1.0}), glm::dvec2(0.75, 0.75));
}

TEST(TextureFallback, AncestorUvIsExactManyLevelsUp) {
  const TileGrid grid = planet::test::globalGrid();
  std::mt19937_64 rng(3);
  for (int up : {1, 3, 5, 8, 12, 20, 24})
    for (int level : {up, up + 1, 24}) {
      if (level > 24) continue;
      std::uniform_int_distribution<std::int64_t> row(0, grid.rowCount(level) - 1),
          col(0, grid.colCount(level) - 1);
      for (int i = 0; i < 20; ++i) {
        const NodeKey node{level, row(rng), col(rng), 1};
        const NodeKey anc{level - up, node.row >> up, node.col >> up, 1};
        const UvTransform t = ancestorUv(node, anc);
        // The node's corners, in the ancestor's uv from the sectors' degrees (long double).
        const Sector ns = grid.sectorOf(node.firstTile()), as = grid.sectorOf(anc.firstTile());
        const long double w = static_cast<long double>(as.east) - as.west;
        const long double h = static_cast<long double>(as.north) - as.south;
        const long double u0 = (static_cast<long double>(ns.west) - as.west) / w;
        const long double v1 = (static_cast<long double>(ns.north) - as.south) / h;
        EXPECT_NEAR(static_cast<double>(u0), t.apply({0.0, 0.0}).x, 1e-12) << up << " " << level;
        EXPECT_NEAR(static_cast<double>(v1), t.apply({1.0, 1.0}).y, 1e-12) << up << " " << level;
        // Exact in double: the scale is 2^-up and the offset a multiple of it.
        EXPECT_EQ(t.scale.x, std::ldexp(1.0, -up));
        EXPECT_EQ(std::fmod(t.offset.x, t.scale.x), 0.0);
        EXPECT_GE(t.offset.x, 0.0);
        EXPECT_LE(t.offset.x + t.scale.x, 1.0);
      }
    }
  // A merged polar node inside a merged ancestor.
  const UvTransform p = ancestorUv({6, 319, 64, 32}, {4, 79, 0, 32});
  EXPECT_EQ(p.scale, glm::dvec2(32.0 / 128.0, 1.0 / 4.0));
  EXPECT_EQ(p.offset, glm::dvec2(64.0 / 128.0, 3.0 / 4.0));
}

TEST(TextureFallback, ThesisOrderChildrenAncestorGlobal) {
  const Geodesy g;
  Quadtree tree(g, planet::test::globalGrid(), treeParams());
  converge(tree, Camera(g, {46.5, 8.0, 50000.0, 0.0, 0.0}, {1024, 768}));
  Node* leaf = deepest(tree);
  ASSERT_NE(leaf, nullptr);
  ASSERT_GE(leaf->level(), 5);
  Node* node = leaf->parent();
  // Nothing ready: the global texture, through the node's global uv.
  TexturePlan plan = planTexture(*leaf);
  ASSERT_EQ(plan.partCount, 1);
  EXPECT_EQ(plan.parts[0].source, TextureSource::Global);
  const Sector& s = leaf->sector();
  EXPECT_DOUBLE_EQ(plan.parts[0].uv.apply({0.0, 0.0}).x, (s.west + 180.0) / 360.0);
  EXPECT_DOUBLE_EQ(plan.parts[0].uv.apply({1.0, 1.0}).y, (s.north + 90.0) / 180.0);
  // An ancestor three levels up is ready: it is used, with the recomputed coordinates.
  Node* a3 = node->parent()->parent();
  a3->texture = TextureState::Finished;
  plan = planTexture(*leaf);
  EXPECT_EQ(plan.parts[0].source, TextureSource::Ancestor);
  EXPECT_EQ(plan.parts[0].texture, a3);
  EXPECT_EQ(plan.parts[0].uv.scale.y, 1.0 / 8.0);
  // A nearer one wins.
  node->texture = TextureState::Finished;
  EXPECT_EQ(planTexture(*leaf).parts[0].texture, node);
  node->texture = TextureState::Decoding; // not ready
  // Children first: one ready child gives a mixed plan in parts.
  Node* c0 = nullptr;
  for (int i = 0; i < 4; ++i)
    if (node->child(i)) {
      c0 = node->child(i);
      break;
    }
  ASSERT_NE(c0, nullptr);
  c0->texture = TextureState::Finished;
  plan = planTexture(*node);
  EXPECT_TRUE(plan.drawnInParts);
  EXPECT_EQ(plan.partCount, node->childCount());
  EXPECT_EQ(plan.mixed, node->childCount() > 1);
  for (int i = 0; i < plan.partCount; ++i) {
    const TexturePart& p = plan.parts[static_cast<std::size_t>(i)];
    if (p.region == c0) {
      EXPECT_EQ(p.source, TextureSource::Own);
    } else {
      EXPECT_EQ(p.source, TextureSource::Ancestor);
      EXPECT_EQ(p.texture, a3);
      EXPECT_EQ(p.uv.scale.y, 1.0 / 8.0); // the child's area, three levels below a3
    }
  }
  // All children ready: not mixed. Own ready: itself.
  for (int i = 0; i < 4; ++i)
    if (node->child(i)) node->child(i)->texture = TextureState::Finished;
  EXPECT_FALSE(planTexture(*node).mixed);
  node->texture = TextureState::Finished;
  plan = planTexture(*node);
  EXPECT_EQ(plan.partCount, 1);
  EXPECT_EQ(plan.parts[0].source, TextureSource::Own);
}

// ---- screen area ----

TEST(ScreenArea, ClippedToTheViewportAndTheNearPlane) {
  const Geodesy g;
  const Camera cam(g, {0.0, 0.0, 1e5, 0.0, 0.0}, {1000, 500}, 45.0);
  // A huge node covering the whole view: the area is the viewport's.
  const NodeGeometry big(g, {-5.0, -5.0, 5.0, 5.0});
  EXPECT_NEAR(clippedScreenArea(cam, big.corners()), 1000.0 * 500.0, 1.0);
  // A node in front of the camera but far off to the side: 0.
  const NodeGeometry away(g, {30.0, 0.0, 40.0, 10.0});
  EXPECT_EQ(clippedScreenArea(cam, away.corners()), 0.0);
  // A small node at the nadir: inside the view, roughly its ground area over a pixel's.
  const NodeGeometry small(g, {-0.05, -0.05, 0.05, 0.05});
  const double px = 2.0 * 1e5 * std::tan(22.5 * std::numbers::pi / 180.0) / 500.0; // m per px
  const double side = 0.1 * std::numbers::pi / 180.0 * 6378137.0;
  EXPECT_NEAR(clippedScreenArea(cam, small.corners()),
              side * side / (px * px),
              0.05 * side * side / (px * px));
  // Standing on a node looking at the horizon: corners behind the camera, still finite.
  const Camera ground(g, {0.0, 0.0, 2.0, 0.0, 90.0}, {1000, 500});
  const double a = clippedScreenArea(ground, big.corners());
  EXPECT_TRUE(std::isfinite(a));
  EXPECT_GT(a, 0.0);
  EXPECT_LE(a, 1000.0 * 500.0 + 1.0);
}

// ---- GPU memory ----

TEST(TextureLru, EvictsLeastRecentlyUsedButNeverThisFrame) {
  TextureLru lru(3 * kTileBytes);
  lru.beginFrame();
  lru.insert({1, 0, 0, 1}, kTileBytes);
  lru.insert({1, 0, 1, 1}, kTileBytes);
  lru.beginFrame();
  lru.insert({1, 0, 2, 1}, kTileBytes);
  lru.use({1, 0, 0, 1});
  lru.beginFrame();
  lru.insert({1, 0, 3, 1}, kTileBytes); // over: {1,0,1} is the least recently used
  EXPECT_FALSE(lru.resident({1, 0, 1, 1}));
  EXPECT_TRUE(lru.resident({1, 0, 0, 1}));
  EXPECT_EQ(lru.takeEvicted(), std::vector<NodeKey>{(NodeKey{1, 0, 1, 1})});
  // One frame needing more than the budget: nothing it uses is evicted, and it is reported.
  lru.beginFrame();
  for (std::int64_t c = 0; c < 5; ++c)
    lru.insert({2, 0, c, 1}, kTileBytes);
  EXPECT_TRUE(lru.overBudget());
  EXPECT_EQ(lru.frameBytes(), 5 * kTileBytes);
  for (std::int64_t c = 0; c < 5; ++c)
    EXPECT_TRUE(lru.resident({2, 0, c, 1}));
  lru.beginFrame();
  lru.use({2, 0, 0, 1});
  lru.insert({2, 0, 9, 1}, kTileBytes);
  EXPECT_FALSE(lru.overBudget());
  EXPECT_LE(lru.bytes(), lru.budget());
}

TEST(TextureLru, BudgetHoldsOverRandomCameraPaths) {
  const Geodesy g;
  Quadtree tree(g, planet::test::globalGrid(), treeParams());
  TextureLru lru(300 * kTileBytes);
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> lat(-90.0, 90.0), lon(-180.0, 180.0), alt(2.0, 7.3),
      tilt(0.0, 80.0), step(-1.0, 1.0);
  CameraPose pose{lat(rng), lon(rng), std::pow(10.0, alt(rng)), 0.0, tilt(rng)};
  int overFrames = 0;
  for (int frame = 0; frame < 300; ++frame) {
    if (frame % 60 == 0) pose = {lat(rng), lon(rng), std::pow(10.0, alt(rng)), 0.0, tilt(rng)};
    pose.latDeg = std::clamp(pose.latDeg + step(rng), -90.0, 90.0);
    pose.lonDeg += step(rng);
    pose.altitudeM = std::clamp(pose.altitudeM * (1.0 + 0.1 * step(rng)), 1.0, 2e7);
    const Camera cam(g, pose, {800, 600});
    tree.update(cam);
    lru.beginFrame();
    std::size_t need = 0;
    for (const Node* n : tree.drawList()) {
      const std::size_t bytes = kTileBytes * static_cast<std::size_t>(n->key().span > 1 ? 2 : 1);
      need += bytes;
      if (lru.resident(n->key()))
        lru.use(n->key());
      else
        lru.insert(n->key(), bytes);
    }
    for (const Node* n : tree.drawList())
      ASSERT_TRUE(lru.resident(n->key())); // what this frame draws is never evicted
    if (lru.overBudget()) {
      ++overFrames;
      EXPECT_GT(need, lru.budget()); // only when the frame alone needs more
      EXPECT_EQ(lru.bytes(), lru.frameBytes());
    } else {
      EXPECT_LE(lru.bytes(), lru.budget());
    }
    lru.takeEvicted();
  }
  EXPECT_LT(overFrames, 300);
}

// ---- streaming ----

TEST(TextureStreamer, DrawnRootsFirstThenByScoreWithinTheWindow) {
  const Geodesy g;
  Quadtree tree(g, planet::test::globalGrid(), treeParams());
  FakeTileSource src;
  holdAll(src);
  TextureStreamer streamer(src, {"layer", "", 8, 1.0, 120.0});
  const Camera cam(g, {20.0, 8.0, 6e6, 0.0, 0.0}, {1024, 768}); // roots at the limb
  std::set<TileKey> drawnRoots;
  double now = 0.0;
  for (int frame = 0; frame < 200; ++frame, now += 1.0 / 60.0) {
    tree.update(cam);
    for (const Node* n : tree.drawList())
      if (n->level() == 0)
        for (std::int64_t i = 0; i < textureTileCount(n->key()); ++i)
          drawnRoots.insert(textureTile(n->key(), i));
    streamer.update(tree, cam, now, nullptr);
    EXPECT_LE(src.openCount(), 8u); // the window
    // The source finishes the oldest open request each frame.
    for (const auto& r : src.requests())
      if (r.open) {
        src.answer(r.id, tile(TileStatus::Ok));
        break;
      }
  }
  const auto requests = src.requests();
  ASSERT_GT(requests.size(), drawnRoots.size() + 10);
  ASSERT_FALSE(drawnRoots.empty());
  // The drawn roots first, and only those (issue 29): none of the far side, none above the view.
  EXPECT_LT(drawnRoots.size(), 50u);
  for (std::size_t i = 0; i < drawnRoots.size(); ++i) {
    EXPECT_EQ(requests[i].address.key.level, 0) << i;
    EXPECT_TRUE(drawnRoots.contains(requests[i].address.key)) << i;
  }
  for (std::size_t i = drawnRoots.size(); i < requests.size(); ++i)
    EXPECT_GT(requests[i].address.key.level, 0) << i;
  EXPECT_EQ(requests[0].address.layer, "layer");
  // After the roots, the first requests are the biggest on screen: their scores do not grow
  // within a frame's batch, and each is a drawn node's tile.
  EXPECT_GE(requests[drawnRoots.size()].priority, requests[drawnRoots.size() + 1].priority);
}

// A close view draws no root: it fetches no level-zero tile at all (issue 29), its nodes show the
// global texture until their own arrive; a root under an absent node is asked for all the same.
TEST(TextureStreamer, AViewThatDrawsNoRootFetchesNone) {
  const Geodesy g;
  Quadtree tree(g, planet::test::globalGrid(), treeParams());
  FakeTileSource src;
  answerAll(src, TileStatus::Ok);
  TextureStreamer streamer(src, {"l", "", 1000, 1.0, 120.0});
  TextureLru lru(std::size_t{1} << 40);
  const Camera cam(g, {0.0, 180.0, 2e5, 0.0, 0.0}, {1280, 720});
  converge(tree, cam);
  for (const Node* n : tree.drawList())
    ASSERT_GT(n->level(), 0);
  streamer.update(tree, cam, 0.0, &lru);
  std::size_t wanted = 0;
  for (const Node* n : tree.drawList())
    wanted += static_cast<std::size_t>(textureTileCount(n->key()));
  EXPECT_EQ(src.requestCount(), wanted);
  for (const auto& r : src.requests())
    EXPECT_GT(r.address.key.level, 0);
  const Node* drawn = tree.drawList().front();
  streamer.update(tree, cam, 0.1, &lru);
  EXPECT_EQ(drawn->texture, TextureState::Decoding); // received (answered at once)
  const TexturePlan plan = planTexture(*drawn);
  ASSERT_EQ(plan.partCount, 1);
  EXPECT_EQ(plan.parts[0].source, TextureSource::Global); // no ancestor was fetched

  // Every drawn node absent: the nearest ancestors are asked for, up to the roots.
  Quadtree tree2(g, planet::test::globalGrid(), treeParams());
  FakeTileSource src2;
  src2.setFallbackAnswer([](const TileAddress& a) {
    return tile(a.key.level == 0 ? TileStatus::Ok : TileStatus::Absent);
  });
  TextureStreamer streamer2(src2, {"l", "", 1000, 1.0, 120.0});
  converge(tree2, cam);
  for (int i = 0; i < 40; ++i)
    streamer2.update(tree2, cam, 0.1 * i, &lru);
  bool askedRoot = false;
  for (const auto& r : src2.requests())
    askedRoot = askedRoot || r.address.key.level == 0;
  EXPECT_TRUE(askedRoot);
}

// Issue 29: the global texture as an overview of the layer, k times coarser than level zero,
// shows a drawn root whose texels times k stay within the threshold; then the root is not fetched.
TEST(TextureFallback, AnOverviewShowsTheRootsWhoseTexelsItMatches) {
  const Geodesy g;
  QuadtreeParams p = treeParams();
  p.lod = {512, 512, 1.0};
  Quadtree tree(g, planet::test::globalGrid(), p);
  const Camera globe(g, {0.0, 0.0, 2e7, 0.0, 0.0}, {1280, 720}, 35.98);
  converge(tree, globe);
  ASSERT_FALSE(tree.drawList().empty());
  for (const Node* n : tree.drawList()) {
    ASSERT_EQ(n->level(), 0); // level zero's texels are below half a pixel from 20,000 km
    const double r2 = n->drawnTexelRatioSquared();
    EXPECT_GT(r2, 0.0);
    EXPECT_LT(r2, 0.25);
    EXPECT_TRUE(overviewSuffices(*n, 2.0));
    EXPECT_FALSE(overviewSuffices(*n, 0.0)); // no overview
    EXPECT_EQ(overviewSuffices(*n, 3.0), r2 * 9.0 <= 1.0);
    EXPECT_FALSE(overviewSuffices(*n, 1.0 / std::sqrt(r2) * 1.01)); // one per cent too coarse
  }
  // Closer, the children are drawn: never shown by the overview, however fine it is.
  const Camera close(g, {0.0, 0.0, 3e6, 0.0, 0.0}, {1280, 720}, 35.98);
  converge(tree, close);
  for (const Node* n : tree.drawList()) {
    if (n->level() > 0) {
      EXPECT_FALSE(overviewSuffices(*n, 1e-3));
    }
  }

  // The streamer: with a 2x overview the whole-globe view asks for nothing; without, for the
  // drawn roots.
  for (const double factor : {0.0, 2.0}) {
    Quadtree t(g, planet::test::globalGrid(), p);
    FakeTileSource src;
    holdAll(src);
    TextureStreamer streamer(src, {"l", "", 100, 1.0, 120.0});
    streamer.setOverviewFactor(factor);
    converge(t, globe);
    streamer.update(t, globe, 0.0, nullptr);
    std::size_t drawnTiles = 0;
    for (const Node* n : t.drawList())
      drawnTiles += static_cast<std::size_t>(textureTileCount(n->key()));
    EXPECT_EQ(src.requestCount(), factor > 0.0 ? 0u : drawnTiles) << factor;
  }
}

TEST(TextureStreamer, CancelsWhatTheCameraLeftAndReprioritizes) {
  const Geodesy g;
  Quadtree tree(g, planet::test::globalGrid(), treeParams());
  FakeTileSource src;
  holdAll(src);
  TextureStreamer streamer(src, {"l", "", 6, 1.0, 120.0});
  const Camera alps(g, {46.5, 8.0, 2e4, 0.0, 0.0}, {1024, 768});
  // Roots are fetched first; the source answers those only.
  for (int i = 0; i < 20; ++i) {
    tree.update(alps);
    streamer.update(tree, alps, i * 0.016, nullptr);
    for (const auto& r : src.requests())
      if (r.open && r.address.key.level == 0) src.answer(r.id, tile(TileStatus::Ok));
  }
  for (int i = 0; i < 3; ++i) {
    tree.update(alps);
    streamer.update(tree, alps, 1.0 + i * 0.016, nullptr);
  }
  ASSERT_EQ(src.openCount(), 6u);
  std::set<TileRequestId> alpsOpen;
  for (const auto& r : src.openRequests())
    alpsOpen.insert(r.id);
  // Tilt a little: same tiles, new scores.
  const Camera tilted(g, {46.5, 8.0, 2e4, 0.0, 20.0}, {1024, 768});
  tree.update(tilted);
  streamer.update(tree, tilted, 1.1, nullptr);
  EXPECT_GT(src.reprioritizations(), 0u);
  // Move away: every Alps request is cancelled, the window refills with Andes tiles.
  const Camera andes(g, {-33.0, -70.0, 2e4, 0.0, 0.0}, {1024, 768});
  for (int i = 0; i < 3; ++i) {
    tree.update(andes);
    streamer.update(tree, andes, 1.2 + i * 0.016, nullptr);
  }
  const std::vector<TileRequestId> cancels = src.cancelled();
  for (TileRequestId id : alpsOpen)
    EXPECT_TRUE(std::find(cancels.begin(), cancels.end(), id) != cancels.end());
  EXPECT_EQ(src.openCount(), 6u);
  for (const auto& r : src.requests())
    if (r.open) {
      const Sector s = planet::test::globalGrid().sectorOf(r.address.key);
      EXPECT_LT(s.south, -20.0);
      EXPECT_LT(s.west, -50.0);
    }
  EXPECT_GE(streamer.stats().cancelled, 6u);
}

TEST(TextureStreamer, NoRequestStormWhenEverythingFailsOrIsAbsent) {
  const Geodesy g;
  for (TileStatus status : {TileStatus::Failed, TileStatus::Absent}) {
    Quadtree tree(g, planet::test::globalGrid(), treeParams());
    FakeTileSource src;
    answerAll(src, status);
    TextureStreamer streamer(src, {"l", "", 16, 1.0, 30.0});
    const Camera cam(g, {10.0, 20.0, 1e5, 0.0, 0.0}, {1024, 768});
    // Ten minutes at 10 frames a second, offline: the retry times are whole seconds (1, 2, 4, 8,
    // 16, then 30 s), so a retry starts at most two frames (0.2 s) late, 5 s over the 25 tries:
    // one try fewer at most; a storm (a request every frame) would still be 6,000 per tile. (At
    // 60 frames a second the same counts cost 25 s under the sanitizers.)
    double now = 0.0;
    for (int frame = 0; frame < 6000; ++frame, now += 1.0 / 10.0) {
      tree.update(cam);
      streamer.update(tree, cam, now, nullptr);
    }
    std::map<TileKey, int> perTile;
    for (const auto& r : src.requests())
      ++perTile[r.address.key];
    int worst = 0;
    for (auto& [k, n] : perTile)
      worst = std::max(worst, n);
    if (status == TileStatus::Absent) {
      EXPECT_EQ(worst, 1); // absent: asked once in the session
    } else {
      // Backoff 1, 2, 4, 8, 16, then every 30 s: ~25 tries per tile in 600 s.
      EXPECT_LE(worst, 26);
      EXPECT_GE(worst, 10);
    }
    if (status == TileStatus::Absent) {
      for (const Node* n : tree.drawList()) {
        EXPECT_EQ(n->texture, TextureState::Absent);
      }
    }
  }
}

TEST(TextureStreamer, StatesFollowTheTiles) {
  const Geodesy g;
  QuadtreeParams p = treeParams();
  p.polarCaps = false; // the roots one tile each: the first request is the first root's
  Quadtree tree(g, planet::test::globalGrid(), p);
  FakeTileSource src;
  holdAll(src);
  TextureStreamer streamer(src, {"l", "", 100, 1.0, 120.0});
  TextureLru lru(1000 * kTileBytes);
  const Camera cam(g, {0.0, 0.0, 2e7, 0.0, 0.0}, {1024, 768});
  tree.update(cam);
  streamer.update(tree, cam, 0.0, &lru);
  std::size_t drawnRoots = 0;
  for (const Node* n : tree.drawList())
    drawnRoots += n->level() == 0 ? 1u : 0u;
  ASSERT_GT(drawnRoots, 0u);
  ASSERT_EQ(src.requestCount(), drawnRoots); // the drawn roots (issue 29: not all 50)
  const Node* first = nullptr;
  for (const Node* n : tree.drawList())
    if (n->key().firstTile() == src.requests()[0].address.key) first = n;
  ASSERT_NE(first, nullptr);
  const Node& root = *first;
  tree.update(cam);
  streamer.update(tree, cam, 0.1, &lru);
  EXPECT_EQ(root.texture, TextureState::CheckingCache);
  src.answer(1, tile(TileStatus::Ok));
  tree.update(cam);
  streamer.update(tree, cam, 0.2, &lru);
  EXPECT_EQ(root.texture, TextureState::Decoding);
  auto got = streamer.takeReceived();
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].key, root.key().firstTile());
  lru.insert(root.key(), kTileBytes); // the owner decoded and uploaded it
  tree.update(cam);
  streamer.update(tree, cam, 0.3, &lru);
  EXPECT_EQ(root.texture, TextureState::Finished);
  // Evicted and forgotten: asked for again.
  lru.erase(root.key());
  streamer.forget(root.key());
  const std::size_t before = src.requestCount();
  tree.update(cam);
  streamer.update(tree, cam, 0.4, &lru);
  EXPECT_EQ(src.requestCount(), before + 1);
}

TEST(TextureStreamer, AVeryWidePolarNodeAsksForAtMostSixteenTiles) {
  // The segments: every column for narrow nodes, the middle of 16 equal segments for wide ones.
  const NodeKey narrow{3, 39, 8, 4};
  ASSERT_EQ(textureTileCount(narrow), 4);
  for (std::int64_t i = 0; i < 4; ++i)
    EXPECT_EQ(textureTile(narrow, i), (TileKey{3, 39, 8 + i}));
  const NodeKey wide{24, (5LL << 24) - 1, 3LL << 24, 1LL << 24};
  EXPECT_EQ(textureTileCount(wide), kMaxTextureTiles);
  for (std::int64_t i = 0; i < kMaxTextureTiles; ++i) {
    const TileKey t = textureTile(wide, i);
    EXPECT_EQ(t.col, wide.col + i * (wide.span / 16) + wide.span / 32);
    EXPECT_LT(t.col, wide.col + wide.span);
  }

  // Near the pole at low altitude over a 25-level grid, merged rows get far wider than 16
  // columns; the streamer asks for at most 16 tiles for each, never for all of their columns.
  const Geodesy g;
  Quadtree tree(g, planet::test::globalGrid(), treeParams());
  FakeTileSource src;
  answerAll(src, TileStatus::Ok);
  TextureStreamer streamer(src, {"l", "", 1000000, 1.0, 120.0});
  TextureLru lru(std::size_t{1} << 40);
  const Camera cam(g, {89.99, 0.0, 300.0, 0.0, 0.0}, {1024, 768});
  converge(tree, cam);
  streamer.update(tree, cam, 0.0, &lru);
  std::int64_t widest = 0;
  std::size_t wanted = 0;
  for (const Node* n : tree.drawList()) {
    widest = std::max(widest, n->key().span);
    wanted += static_cast<std::size_t>(textureTileCount(n->key()));
  }
  EXPECT_GT(widest, kMaxTextureTiles) << "the view should draw a merged row wider than 16";
  EXPECT_LE(src.requestCount(), wanted); // the drawn nodes' tiles
  EXPECT_LT(src.requestCount(), 5000u);
}

// A polar cap spans every column of its level (ten root columns times 2^level): its texture is
// made of every tile up to 80 (16 times the odd part, 5), then of the middle tile of each of 80
// equal segments; the segments are exact and cover the row.
TEST(TextureStreamer, PolarCapsAskForTheirRowUpToEightyTiles) {
  for (int level : {0, 1, 2, 3, 4, 10, 24}) {
    const std::int64_t span = std::int64_t{10} << level;
    const NodeKey cap{level, (std::int64_t{5} << level) - 1, 0, span};
    const std::int64_t count = textureTileCount(cap);
    EXPECT_EQ(count, std::min<std::int64_t>(span, 80)) << level;
    std::int64_t previous = -1;
    for (std::int64_t i = 0; i < count; ++i) {
      const TileKey t = textureTile(cap, i);
      EXPECT_GT(t.col, previous);
      EXPECT_LT(t.col, span);
      EXPECT_EQ(t.col, i * (span / count) + (span / count) / 2);
      previous = t.col;
    }
  }
  // Powers of two keep the old rule (16 at most).
  EXPECT_EQ(textureTileCount({5, 0, 0, 64}), kMaxTextureTiles);
}

// A cap's score is the area of its disc: its corner quad is a line (the rim's point at 180
// degrees and the pole), so it is summed over wedges. Top down over the pole, with the whole
// cap on screen, that is the rim's projected circle's area.
TEST(ScreenArea, PolarCapIsItsDisc) {
  const Geodesy g;
  const Camera cam(g, {90.0, 0.0, 2e7, 0.0, 0.0}, {1024, 1024}, 45.0);
  const NodeGeometry cap(g, {-180.0, 72.0, 180.0, 90.0});
  EXPECT_NEAR(clippedScreenArea(cam, cap.corners()), 0.0, 1e-6);
  glm::dvec2 rim, pole;
  ASSERT_TRUE(cam.projectPx(planet::test::vec(g.toEcef(72.0, 0.0, 0.0)), rim));
  ASSERT_TRUE(cam.projectPx(planet::test::vec(g.toEcef(90.0, 0.0, 0.0)), pole));
  const double r = glm::length(rim - pole);
  const double disc = std::numbers::pi * r * r;
  const double area = nodeScreenArea(cam, cap);
  // 16 wedges: a polygon inscribed in the circle, (16 / 2 pi) sin(2 pi / 16) = 97.4 % of it.
  EXPECT_NEAR(area / disc, 8.0 * std::sin(std::numbers::pi / 8.0) / std::numbers::pi, 0.01);
  const NodeGeometry southCap(g, {-180.0, -90.0, 180.0, -72.0});
  const Camera southCam(g, {-90.0, 0.0, 2e7, 0.0, 0.0}, {1024, 1024}, 45.0);
  EXPECT_NEAR(nodeScreenArea(southCam, southCap), area, 1e-6 * area);
  // Any other node: its corner quad.
  const NodeGeometry tile(g, {0.0, 0.0, 36.0, 36.0});
  EXPECT_EQ(nodeScreenArea(cam, tile), clippedScreenArea(cam, tile.corners()));
}

// A cap whose texture is not ready shows its parent cap's (or the global texture), never its
// children's: the next cap and the ring are not the quadrants the GL layer can draw in parts.
TEST(TextureFallback, APolarCapIsNeverDrawnInParts) {
  const Geodesy g;
  Quadtree tree(g, planet::test::globalGrid(), treeParams());
  Node& root = *tree.roots()[4 * 10];
  ASSERT_TRUE(root.isCap());
  ASSERT_TRUE(tree.split(root));
  Node& cap = *root.child(0);
  ASSERT_TRUE(tree.split(cap));
  for (int s = 0; s < cap.childSlots(); ++s)
    cap.child(s)->texture = TextureState::Finished;
  TexturePlan plan = planTexture(cap);
  EXPECT_FALSE(plan.drawnInParts);
  ASSERT_EQ(plan.partCount, 1);
  EXPECT_EQ(plan.parts[0].source, TextureSource::Global);
  root.texture = TextureState::Finished;
  plan = planTexture(cap);
  ASSERT_EQ(plan.partCount, 1);
  EXPECT_EQ(plan.parts[0].source, TextureSource::Ancestor);
  EXPECT_EQ(plan.parts[0].texture, &root);
  // The next cap is the top half of its parent's texture; a ring node a tenth of its width.
  EXPECT_EQ(plan.parts[0].uv.scale, glm::dvec2(1.0, 0.5));
  EXPECT_EQ(plan.parts[0].uv.offset, glm::dvec2(0.0, 0.5));
  const Node& ring = *root.child(1);
  const UvTransform ringUv = ancestorUv(ring.key(), root.key());
  EXPECT_NEAR(ringUv.scale.x, static_cast<double>(ring.key().span) / 20.0, 1e-15);
  EXPECT_EQ(ringUv.scale.y, 0.5);
  EXPECT_EQ(ringUv.offset, glm::dvec2(0.0, 0.0));
}
