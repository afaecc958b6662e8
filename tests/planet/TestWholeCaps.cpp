// Polar caps from one whole row (NodeTiles, issue 29, docs/design/poles.md): what the stream
// scheduler asks for where the source gives polar rows whole, and its fallback (GL-free).
#include "../support/FakeTileSource.hpp"
#include "PlanetTestSupport.hpp"

#include <tellus/planet/Quadtree.hpp>
#include <tellus/planet/TextureLru.hpp>
#include <tellus/planet/TextureStreamer.hpp>

#include <gtest/gtest.h>

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
    streamer.setNodeTiles({planet::test::globalGrid().colCount(0)});
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

// A whole row the source fails (a WMS's size limit, an error page) or does not have (offline,
// not cached) turns whole rows off: the cap is then composed of its row's tiles, as where the
// source cannot give rows whole.
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
    streamer.setNodeTiles({planet::test::globalGrid().colCount(0)});
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
    EXPECT_EQ(streamer.stats().wholeRowsRefused, 1u);
    EXPECT_EQ(streamer.nodeTiles().wholeRowRootCols, 0);
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
