// Polar caps from one whole row and merged nodes from one image of their box (NodeTiles, issue 29,
// docs/design/poles.md): what the stream scheduler and the time prefetcher ask for where the
// source gives them whole, and their fallback (GL-free).
#include "../support/FakeTileSource.hpp"
#include "PlanetTestSupport.hpp"

#include <tellus/planet/Quadtree.hpp>
#include <tellus/planet/TextureLru.hpp>
#include <tellus/planet/TextureStreamer.hpp>
#include <tellus/planet/TimePrefetch.hpp>

#include <gtest/gtest.h>

#include <set>
#include <string>
#include <vector>

using namespace tellus;
using namespace tellus::planet;

namespace {

QuadtreeParams capTreeParams() {
  QuadtreeParams p;
  p.lod = {512, 512, 1.0};
  p.maxSplitsPerFrame = 100000;
  return p;
}

void settleCaps(Quadtree& tree, const Camera& cam) {
  for (int i = 0; i < 100; ++i)
    if (tree.update(cam).created == 0) break;
}

using tellus::test::FakeTileSource;

TileResult capTile(TileStatus status) {
  return FakeTileSource::result(
      status, status == TileStatus::Ok ? std::vector<std::byte>(16) : std::vector<std::byte>{});
}

void answerAllCaps(FakeTileSource& src, TileStatus status) {
  src.setFallbackAnswer([status](const TileAddress&) { return capTile(status); });
}

} // namespace

// Where the source gives polar rows whole (NodeTiles, issue 29), a drawn cap asks for ONE tile,
// `<layer>@caps` at (level, row, 0), instead of its row's tiles; it is kept under the reserved
// column (one past the row's last) and makes the cap's texture once received. Both poles.
TEST(TextureStreamer, AWholeRowCapAsksForOneTileOfTheCapsLayer) {
  const Geodesy g;
  for (const double lat : {90.0, -90.0}) {
    SCOPED_TRACE(lat);
    Quadtree tree(g, planet::test::globalGrid(), capTreeParams());
    ASSERT_TRUE(tree.capsEnabled());
    FakeTileSource src;
    answerAllCaps(src, TileStatus::Ok);
    TextureStreamer streamer(src, {"l", "", 1000000, 1.0, 120.0});
    streamer.setNodeTiles(NodeTiles::whole(planet::test::globalGrid().colCount(0), true));
    TextureStreamer composed(src, {"l", "", 1000000, 1.0, 120.0});
    TextureLru lru(std::size_t{1} << 40);
    const Camera cam(g, {lat, 0.0, 3.0e6, 0.0, 0.0}, {1024, 768});
    settleCaps(tree, cam);
    std::vector<Node*> caps;
    for (Node* n : tree.drawList())
      if (n->isCap()) caps.push_back(n);
    ASSERT_FALSE(caps.empty());
    streamer.update(tree, cam, 0.0, &lru);
    std::size_t capRequests = 0;
    for (const auto& r : src.requests()) {
      if (r.address.layer.starts_with("l@span")) continue; // merged nodes: below
      if (r.address.layer == "l@caps") {
        ++capRequests;
        EXPECT_EQ(r.address.key.col, 0);
        continue;
      }
      for (const Node* c : caps) // no tile of a drawn cap's row
        EXPECT_FALSE(r.address.key.level == c->level() && r.address.key.row == c->key().row);
    }
    EXPECT_EQ(capRequests, caps.size());
    streamer.update(tree, cam, 1.0, &lru);
    for (Node* c : caps) {
      const TileKey whole{c->level(), c->key().row, c->key().span};
      EXPECT_EQ(streamer.state(whole), TileFetch::Received);
      EXPECT_EQ(c->texture, TextureState::Decoding);
    }
    // The same view composed asks for each cap's row tiles, min(span, 80) of them.
    src.forgetRequests();
    composed.update(tree, cam, 0.0, &lru);
    std::size_t rowTiles = 0;
    for (const auto& r : src.requests())
      for (const Node* c : caps)
        rowTiles += r.address.layer == "l" && r.address.key.level == c->level() &&
                    r.address.key.row == c->key().row;
    std::size_t expected = 0;
    for (const Node* c : caps)
      expected += static_cast<std::size_t>(textureTileCount(c->key()));
    EXPECT_EQ(rowTiles, expected);
  }
}

// A whole row the source fails (a WMS's size limit, an error page) turns whole rows off: the cap
// is then composed of its row's tiles, as where the source cannot give rows whole. One it does
// not have (offline, not cached) has that cap composed alone.
TEST(TextureStreamer, AFailedWholeRowFallsBackToComposingTheCap) {
  for (const TileStatus refused : {TileStatus::Failed, TileStatus::Absent}) {
    SCOPED_TRACE(static_cast<int>(refused));
    const Geodesy g;
    Quadtree tree(g, planet::test::globalGrid(), capTreeParams());
    FakeTileSource src;
    src.setFallbackAnswer([refused](const TileAddress& a) {
      return capTile(a.layer == "l@caps" ? refused : TileStatus::Ok);
    });
    TextureStreamer streamer(src, {"l", "", 1000000, 1.0, 120.0});
    streamer.setNodeTiles(NodeTiles::whole(planet::test::globalGrid().colCount(0), true));
    TextureLru lru(std::size_t{1} << 40);
    const Camera cam(g, {90.0, 0.0, 3.0e5, 0.0, 0.0}, {1024, 768});
    settleCaps(tree, cam);
    const Node* cap = nullptr;
    for (const Node* n : tree.drawList())
      if (n->isCap()) cap = n;
    ASSERT_NE(cap, nullptr);
    streamer.update(tree, cam, 0.0, &lru);
    EXPECT_EQ(src.requestsFor("l@caps"), 1u);
    streamer.update(tree, cam, 1.0, &lru); // the failure arrives: the row's tiles are asked for
    const bool failed = refused == TileStatus::Failed;
    EXPECT_EQ(streamer.stats().wholeRowsRefused, failed ? 1u : 0u);
    EXPECT_EQ(streamer.nodeTiles().caps, !failed);
    EXPECT_FALSE(streamer.nodeTiles().wholeCap(cap->key()));
    EXPECT_TRUE(streamer.nodeTiles().spans); // a refused row says nothing of spans
    std::size_t rowTiles = 0;
    for (const auto& r : src.requests())
      rowTiles += r.address.layer == "l" && r.address.key.level == cap->level() &&
                  r.address.key.row == cap->key().row;
    EXPECT_EQ(rowTiles, static_cast<std::size_t>(textureTileCount(cap->key())));
    streamer.update(tree, cam, 2.0, &lru);
    EXPECT_EQ(src.requestsFor("l@caps"), 1u); // never again
    EXPECT_EQ(cap->texture, TextureState::Decoding);
  }
}

// Every aligned run of k columns (k a power of two, 2 up to below the row's columns) of a row has
// a reserved column of its own, past the cap's, that names it back; at level 0 and the deepest
// level of a 36-degree grid (10 x 2^24 columns), at the row's ends.
TEST(NodeTiles, EveryAlignedRunHasAColumnOfItsOwn) {
  const NodeTiles t = NodeTiles::whole(10, true);
  for (const std::int32_t level : {0, 1, 3, 24}) {
    SCOPED_TRACE(level);
    const std::int64_t cols = t.cols(level);
    std::set<std::int64_t> seen;
    for (std::int64_t k = 2; k < cols; k *= 2) {
      std::vector<std::int64_t> firsts;
      if (cols / k <= 64) {
        for (std::int64_t c = 0; c + k <= cols; c += k)
          firsts.push_back(c);
      } else {
        firsts = {0, k, cols / 2 - k, cols - 2 * k, cols - k};
      }
      for (const std::int64_t c : firsts) {
        const NodeKey n{level, 7, c, k};
        ASSERT_TRUE(t.wholeSpan(n));
        ASSERT_EQ(t.count(n), 1);
        const TileKey reserved = t.tile(n, 0);
        EXPECT_GT(reserved.col, cols);
        EXPECT_TRUE(t.isWholeSpan(reserved));
        EXPECT_FALSE(t.isWholeRow(reserved));
        EXPECT_EQ(t.spanNode(reserved), n);
        EXPECT_TRUE(seen.insert(reserved.col).second);
        const TileAddress a = t.address("bm", "2020", reserved);
        EXPECT_EQ(a.layer, "bm@span" + std::to_string(k));
        EXPECT_EQ(a.time, "2020");
        EXPECT_EQ(a.key, (TileKey{level, 7, c}));
      }
    }
    // Not whole: one tile, an unaligned run, the cap (its own kind), spans turned off.
    EXPECT_FALSE(t.wholeSpan({level, 7, 0, 1}));
    if (cols > 4) {
      EXPECT_FALSE(t.wholeSpan({level, 7, 2, 4}));
    }
    EXPECT_FALSE(t.wholeSpan({level, 7, 0, cols}));
    EXPECT_TRUE(t.wholeCap({level, 7, 0, cols}));
    NodeTiles off = t;
    off.spans = false;
    EXPECT_FALSE(off.wholeSpan({level, 7, 0, 2}));
    EXPECT_EQ(off.count({level, 7, 0, 2}), 2);
  }
  // A grid of 45-degree roots: eight columns, so a cap's span is a power of two too; it stays
  // a cap, never a span.
  const NodeTiles eight = NodeTiles::whole(8, true);
  EXPECT_TRUE(eight.wholeCap({2, 0, 0, 32}));
  EXPECT_FALSE(eight.wholeSpan({2, 0, 0, 32}));
  EXPECT_EQ(eight.tile({2, 0, 0, 32}, 0), (TileKey{2, 0, 32}));
}

// A failure turns the layer's caps or spans off; an absence that one node's whole tile only.
TEST(NodeTiles, AnAbsenceComposesOneNodeAFailureTheLayers) {
  NodeTiles t = NodeTiles::whole(10, true);
  const NodeKey a{3, 79, 0, 16}, b{3, 79, 16, 16}, cap{3, 79, 0, 80};
  EXPECT_FALSE(t.refused(t.tile(a, 0), false));
  EXPECT_FALSE(t.wholeSpan(a));
  EXPECT_EQ(t.count(a), 16);
  EXPECT_TRUE(t.wholeSpan(b));
  EXPECT_TRUE(t.spans);
  EXPECT_FALSE(t.refused(t.tile(cap, 0), false));
  EXPECT_FALSE(t.wholeCap(cap));
  EXPECT_TRUE(t.caps);
  EXPECT_TRUE(t.wholeCap({4, 159, 0, 160})); // the next level's cap
  EXPECT_TRUE(t.refused(t.tile(b, 0), true));
  EXPECT_FALSE(t.spans);
  EXPECT_FALSE(t.wholeSpan(b));
  EXPECT_FALSE(t.refused(t.tile(b, 0), true)); // already off
  EXPECT_FALSE(t.refused({3, 79, 5}, true));   // a grid tile: nothing to turn off
  EXPECT_TRUE(t.caps);
}

// The layer names of whole spans read back only in their one spelling.
TEST(NodeTiles, WholeSpanLayerNamesReadBackExactly) {
  for (const std::int64_t k : {std::int64_t{2}, std::int64_t{16}, kMaxWholeSpan}) {
    const std::string name = wholeSpanLayer("blue_marble", k); // the view points into it
    const auto p = parseWholeSpanLayer(name);
    ASSERT_TRUE(p.has_value());
    EXPECT_EQ(p->layer, "blue_marble");
    EXPECT_EQ(p->span, k);
  }
  for (const char* bad : {"l@span",
                          "l@span1",
                          "l@span3",
                          "l@span0",
                          "l@span02",
                          "l@span-2",
                          "l@span+2",
                          "l@span2x",
                          "@span2",
                          "l@caps",
                          "l",
                          "l@span99999999999999",
                          "l@span2199023255553"})
    EXPECT_FALSE(parseWholeSpanLayer(bad).has_value()) << bad;
  EXPECT_EQ(parseWholeSpanLayer("a@span2@span4")->layer, "a@span2");
}

namespace {

/** The drawn merged nodes (span 2 or more, not caps) of a view. */
std::vector<const Node*> drawnMerged(const Quadtree& tree) {
  std::vector<const Node*> merged;
  for (const Node* n : tree.drawList())
    if (!n->isCap() && n->key().span >= 2) merged.push_back(n);
  return merged;
}

} // namespace

// Where the source gives merged nodes whole, each drawn one asks for ONE tile,
// `<layer>@span<k>` at its first column, and none of its row's tiles; composed, the same view
// asks for textureTileCount(key) tiles each (up to 16). Both poles, the ring at 300 km.
TEST(TextureStreamer, AWholeSpanAsksForOneImageOfTheMergedNodesBox) {
  const Geodesy g;
  for (const double lat : {89.0, -89.0}) {
    SCOPED_TRACE(lat);
    Quadtree tree(g, planet::test::globalGrid(), capTreeParams());
    FakeTileSource src;
    answerAllCaps(src, TileStatus::Ok);
    TextureStreamer streamer(src, {"l", "", 1000000, 1.0, 120.0});
    streamer.setNodeTiles(NodeTiles::whole(planet::test::globalGrid().colCount(0), true));
    TextureLru lru(std::size_t{1} << 40);
    const Camera cam(g, {lat, 0.0, 3.0e5, 0.0, 0.0}, {1024, 768});
    settleCaps(tree, cam);
    const auto merged = drawnMerged(tree);
    ASSERT_GE(merged.size(), 4u);
    streamer.update(tree, cam, 0.0, &lru);
    std::size_t spanRequests = 0;
    for (const auto& r : src.requests()) {
      if (const auto s = parseWholeSpanLayer(r.address.layer)) {
        EXPECT_EQ(s->layer, "l");
        const NodeKey n{r.address.key.level, r.address.key.row, r.address.key.col, s->span};
        EXPECT_NE(std::find_if(
                      merged.begin(), merged.end(), [&](const Node* m) { return m->key() == n; }),
                  merged.end());
        ++spanRequests;
        continue;
      }
      for (const Node* m : merged) // no tile of a drawn merged node
        EXPECT_FALSE(r.address.layer == "l" && r.address.key.level == m->level() &&
                     r.address.key.row == m->key().row && r.address.key.col >= m->key().col &&
                     r.address.key.col < m->key().col + m->key().span);
    }
    EXPECT_EQ(spanRequests, merged.size());
    streamer.update(tree, cam, 1.0, &lru);
    std::size_t composedTiles = 0;
    for (const Node* m : merged) {
      EXPECT_EQ(streamer.state(streamer.nodeTiles().tile(m->key(), 0)), TileFetch::Received);
      EXPECT_EQ(m->texture, TextureState::Decoding);
      composedTiles += static_cast<std::size_t>(textureTileCount(m->key()));
    }
    EXPECT_GE(composedTiles, 4 * merged.size()); // what composing them would have cost
  }
}

// A span the source fails turns spans off (merged nodes composed of their tiles from then on)
// and leaves caps whole; one it lacks has that node composed alone. The time prefetcher follows
// its own failures and its streamer's.
TEST(TextureStreamer, AFailedWholeSpanFallsBackToComposingTheMergedNode) {
  for (const TileStatus refused : {TileStatus::Failed, TileStatus::Absent}) {
    SCOPED_TRACE(static_cast<int>(refused));
    const Geodesy g;
    Quadtree tree(g, planet::test::globalGrid(), capTreeParams());
    FakeTileSource src;
    src.setFallbackAnswer([refused](const TileAddress& a) {
      return capTile(parseWholeSpanLayer(a.layer) ? refused : TileStatus::Ok);
    });
    TextureStreamer streamer(src, {"l", "", 1000000, 1.0, 120.0});
    streamer.setNodeTiles(NodeTiles::whole(planet::test::globalGrid().colCount(0), true));
    TextureLru lru(std::size_t{1} << 40);
    const Camera cam(g, {89.0, 0.0, 3.0e5, 0.0, 0.0}, {1024, 768});
    settleCaps(tree, cam);
    const auto merged = drawnMerged(tree);
    ASSERT_FALSE(merged.empty());
    streamer.update(tree, cam, 0.0, &lru);
    const std::size_t asked = src.requestCount();
    streamer.update(tree, cam, 1.0, &lru); // the refusals arrive: the merged nodes' tiles asked
    const bool failed = refused == TileStatus::Failed;
    EXPECT_EQ(streamer.stats().wholeSpansRefused, failed ? 1u : 0u);
    EXPECT_EQ(streamer.stats().wholeRowsRefused, 0u);
    EXPECT_EQ(streamer.nodeTiles().spans, !failed);
    EXPECT_TRUE(streamer.nodeTiles().caps);
    for (const Node* m : merged)
      EXPECT_FALSE(streamer.nodeTiles().wholeSpan(m->key()));
    std::set<TileKey> tiles;
    for (const auto& r : src.requests())
      if (r.address.layer == "l") tiles.insert(r.address.key);
    for (const Node* m : merged)
      for (std::int64_t i = 0; i < textureTileCount(m->key()); ++i)
        EXPECT_TRUE(tiles.contains(textureTile(m->key(), i)));
    streamer.update(tree, cam, 2.0, &lru);
    std::size_t spansAfter = 0;
    const auto all = src.requests();
    for (std::size_t i = asked; i < all.size(); ++i)
      spansAfter += parseWholeSpanLayer(all[i].address.layer).has_value();
    EXPECT_EQ(spansAfter, 0u); // never again

    // The prefetcher: asks whole spans while its streamer does, stops on a refusal of its own.
    FakeTileSource ahead;
    ahead.setFallbackAnswer([refused](const TileAddress& a) {
      return capTile(parseWholeSpanLayer(a.layer) ? refused : TileStatus::Ok);
    });
    TimePrefetcher p(ahead, {"l", 1000000, -1.0});
    p.setNodeTiles(NodeTiles::whole(planet::test::globalGrid().colCount(0), true));
    const std::vector<std::string> times{"t1"};
    p.update(tree, times);
    EXPECT_EQ(ahead.requestsFor("l@span" + std::to_string(merged.front()->key().span), "t1") > 0,
              true);
    p.update(tree, std::vector<std::string>{}); // the answers taken in, t1 forgotten
    EXPECT_EQ(p.nodeTiles().spans, !failed);    // an absence at one time says nothing of others
    EXPECT_TRUE(p.nodeTiles().caps);
    if (!failed) continue;
    // ... and follows its streamer's: a fresh one told the streamer has turned spans off.
    TimePrefetcher q(ahead, {"l", 1000000, -1.0});
    q.setNodeTiles(NodeTiles::whole(planet::test::globalGrid().colCount(0), true));
    q.followNodeTiles(streamer.nodeTiles());
    ahead.forgetRequests();
    q.update(tree, times);
    for (const auto& r : ahead.requests())
      EXPECT_FALSE(parseWholeSpanLayer(r.address.layer).has_value()) << r.address.layer;
  }
}
