// The renderer's layer set (planet/gl/src/LayerSet.hpp), GL-free: the base and the overlays, the
// users' changes (times, level limits, order, opacity, visibility), swaps once a pending time is
// ready, evictions back to the pool, and the per-layer statistics.

#include "../../planet/gl/src/FrameUpdate.hpp"
#include "LayerTestSupport.hpp"

#include <gtest/gtest.h>

#include <set>
#include <stdexcept>

using namespace tellus;
using namespace tellus::planet;
using namespace tellus::planet::layertest;

namespace {

void threeLayers(FakeTileSource& s) {
  addLayer(s, "base", grid36(3));
  addLayer(s, "clouds", grid36(2));
  addLayer(s, "sst", grid36(4));
  GridSpec other = grid36(3);
  other.levelZeroDeltaDeg = 45.0;
  addLayer(s, "other-grid", other);
}

/** Frames until the set swaps a pending time in (at most 20): the number of frames taken. */
int framesUntilSwapped(LayerSet& set, const Camera& cam, std::size_t layer) {
  const std::size_t before = set[layer].swaps;
  for (int frame = 1; frame <= 20; ++frame) {
    updateLayers(set, cam, frame * 0.1);
    set.swapReady();
    if (set[layer].swaps > before) return frame;
  }
  return -1;
}

} // namespace

TEST(LayerSet, OpensTheBaseAndTheOverlaysInDrawingOrderEachWithItsOwnTag) {
  FakeTileSource source;
  threeLayers(source);
  Layers l(source, layerOptions("base", {"clouds", "sst"}));
  LayerSet& set = *l.set;
  ASSERT_EQ(set.size(), 3u);
  EXPECT_EQ(set[0].opt.layer, "base");
  EXPECT_FALSE(set[0].current->overlay);
  EXPECT_EQ(set[1].current->layer, "clouds");
  EXPECT_TRUE(set[1].current->overlay);
  EXPECT_EQ(set[2].current->grid.numLevels(), 4);
  EXPECT_EQ(&set.geo(), set.base().tree.get());
  std::set<int> tags;
  for (std::size_t i = 0; i < set.size(); ++i) {
    tags.insert(set[i].current->tag);
    EXPECT_EQ(set.byTag(set[i].current->tag), set[i].current.get());
    EXPECT_FALSE(set[i].pending);
  }
  EXPECT_EQ(tags.size(), 3u);
  EXPECT_EQ(set.byTag(999), nullptr);
  // Each layer's share of the texture budget.
  EXPECT_EQ(set[1].current->lru.budget(), l.opt.textureBudgetBytes / 3);
  // The texture size and mip levels of the grid's tiles.
  EXPECT_EQ(set[0].current->texWidth, 256);
  EXPECT_EQ(set[0].current->texLevels, 9);
}

TEST(LayerSet, RefusesAnUnknownLayerAndAnOverlayOnAnotherGrid) {
  FakeTileSource source;
  threeLayers(source);
  const Geodesy geodesy;
  RendererOptions o = layerOptions("base", {"nowhere"});
  LayerSet unknown(source, geodesy, o, *TileGrid::create(grid36(3)));
  const auto a = unknown.open();
  ASSERT_FALSE(a.has_value());
  EXPECT_EQ(a.error(), "unknown layer 'nowhere'");
  RendererOptions p = layerOptions("base", {"other-grid"});
  LayerSet mismatched(source, geodesy, p, *TileGrid::create(grid36(3)));
  const auto b = mismatched.open();
  ASSERT_FALSE(b.has_value());
  EXPECT_NE(b.error().find("must share the base layer's grid"), std::string::npos) << b.error();
}

TEST(LayerSet, ATimeChangeWaitsAsPendingAndGoingBackToTheCurrentTimeCancelsIt) {
  FakeTileSource source;
  threeLayers(source);
  Layers l(source, layerOptions("base", {"clouds"}));
  LayerSet& set = *l.set;
  set.setTime(1, "2024-01-01");
  ASSERT_TRUE(set[1].pending);
  EXPECT_EQ(set[1].pending->time, "2024-01-01");
  EXPECT_EQ(set[1].current->time, "");
  const int pendingTag = set[1].pending->tag;
  set.setTime(1, "2024-01-01"); // the same pending time: nothing new
  EXPECT_EQ(set[1].pending->tag, pendingTag);
  set.setTime(1, "2024-01-02"); // replaced
  EXPECT_NE(set[1].pending->tag, pendingTag);
  EXPECT_EQ(set.byTag(pendingTag), nullptr);
  set.setTime(1, ""); // back to the current time: cancelled
  EXPECT_FALSE(set[1].pending);
  EXPECT_EQ(set[1].opt.time, "");
  EXPECT_THROW(set.setTime(7, "x"), std::invalid_argument);
}

TEST(LayerSet, APendingTimeSwapsInWhenEveryNodeItDrawsIsSettled) {
  FakeTileSource source; // every tile absent: settled once the answers are in
  threeLayers(source);
  Layers l(source, layerOptions("base", {"clouds"}));
  LayerSet& set = *l.set;
  const Camera cam = cameraAt(l.geodesy, 45.0, 7.0, 2e7);
  updateLayers(set, cam, 0.0);
  set.setTime(1, "2024-01-01");
  const std::size_t currentBefore = source.requestsFor("clouds", "");
  EXPECT_GT(framesUntilSwapped(set, cam, 1), 0);
  EXPECT_EQ(set[1].current->time, "2024-01-01");
  EXPECT_FALSE(set[1].pending);
  EXPECT_EQ(set[1].swaps, 1u);
  // While pending, only the new time streamed; the old time's requests are kept as retired.
  EXPECT_EQ(source.requestsFor("clouds", ""), currentBefore);
  EXPECT_GT(source.requestsFor("clouds", "2024-01-01"), 0u);
  EXPECT_EQ(set[1].retiredRequested, currentBefore);
  RenderStats stats;
  const LayerTotals totals = set.collectStats(stats);
  ASSERT_EQ(stats.layers.size(), 2u);
  EXPECT_EQ(stats.layers[1].time, "2024-01-01");
  EXPECT_EQ(stats.layers[1].pendingTime, "");
  EXPECT_EQ(stats.layers[1].swaps, 1u);
  EXPECT_EQ(stats.layers[1].tilesRequested,
            source.requestsFor("clouds", "") + source.requestsFor("clouds", "2024-01-01"));
  EXPECT_EQ(totals.stream.requested, source.requestCount());
  EXPECT_TRUE(totals.idle);
}

TEST(LayerSet, ALevelLimitIsSwappedInLikeATimeAndOnePastTheLayersOwnChangesNothing) {
  FakeTileSource source;
  threeLayers(source);
  Layers l(source, layerOptions("base", {"sst"}));
  LayerSet& set = *l.set;
  set.setMaxLevel(1, 10); // sst has 4 levels: the same layer
  EXPECT_FALSE(set[1].pending);
  EXPECT_EQ(set[1].opt.maxLevel, 10);
  set.setMaxLevel(1, 1);
  ASSERT_TRUE(set[1].pending);
  EXPECT_EQ(set[1].pending->grid.numLevels(), 2);
  EXPECT_EQ(set[1].current->grid.numLevels(), 4);
  set.setMaxLevel(1, -1); // back to all of them: the current layer already is
  EXPECT_FALSE(set[1].pending);
  EXPECT_THROW(set.setMaxLevel(1, -2), std::invalid_argument);
  EXPECT_THROW(set.setMaxLevel(1, 41), std::invalid_argument);
  EXPECT_THROW(set.setMaxLevel(2, 1), std::invalid_argument);
}

TEST(LayerSet, OnlyOverlaysMoveHaveAnOpacityOrHide) {
  FakeTileSource source;
  threeLayers(source);
  Layers l(source, layerOptions("base", {"clouds", "sst", "clouds"}));
  LayerSet& set = *l.set;
  set.move(1, 3);
  EXPECT_EQ(set[1].opt.layer, "sst");
  EXPECT_EQ(set[2].opt.layer, "clouds");
  EXPECT_EQ(set[3].opt.layer, "clouds");
  set.move(3, 1);
  EXPECT_EQ(set[1].opt.layer, "clouds");
  EXPECT_EQ(set[2].opt.layer, "sst");
  EXPECT_THROW(set.move(0, 1), std::invalid_argument);
  EXPECT_THROW(set.move(1, 4), std::invalid_argument);
  set.setOpacity(2, 0.25);
  EXPECT_EQ(set[2].opt.opacity, 0.25);
  EXPECT_THROW(set.setOpacity(0, 0.5), std::invalid_argument);
  EXPECT_THROW(set.setOpacity(2, 1.5), std::invalid_argument);
  set.setVisible(2, false);
  EXPECT_FALSE(set[2].opt.visible);
  EXPECT_THROW(set.setVisible(0, false), std::invalid_argument);
}

TEST(LayerSet, EvictedTexturesGoBackToThePoolAndTheirNodesFallBack) {
  FakeTileSource source;
  threeLayers(source);
  RendererOptions o = layerOptions("base");
  o.textureBudgetBytes = 100;
  Layers l(source, o);
  LayerTextures& base = l.set->base();
  Node& first = *plainRoots(*base.tree)[0];
  Node& second = *plainRoots(*base.tree)[1];
  first.texture = TextureState::Finished;
  base.uploading.insert(first.key());
  base.install(first.key(), NodeTexture{}, 80);
  EXPECT_FALSE(base.uploading.contains(first.key()));
  EXPECT_TRUE(base.textures.contains(first.key()));
  EXPECT_EQ(base.evict(), 0u);
  base.lru.beginFrame(); // a later frame: the first texture is no longer drawn
  base.install(second.key(), NodeTexture{}, 80);
  EXPECT_EQ(base.evict(), 1u);
  EXPECT_FALSE(base.textures.contains(first.key()));
  EXPECT_TRUE(base.textures.contains(second.key()));
  EXPECT_EQ(base.pool.size(), 1u);
  EXPECT_EQ(first.texture, TextureState::NoTexture);
  // A wide (polar cap) texture is never pooled.
  base.pool.release(NodeTexture{GlTexture(NoCreate), true});
  EXPECT_EQ(base.pool.size(), 1u);
}

TEST(LayerSet, ANodeIsDoneWithItsOwnTextureOrWhenNoneExists) {
  FakeTileSource source;
  threeLayers(source);
  Layers l(source, layerOptions("base"));
  LayerTextures& base = l.set->base();
  Quadtree& tree = *base.tree;
  Node* found = nullptr;
  for (const auto& r : tree.roots())
    if (r && !r->isCap() && found == nullptr) found = r.get();
  ASSERT_NE(found, nullptr);
  Node& root = *found;
  ASSERT_TRUE(tree.split(root));
  Node& child = *root.child(0);
  EXPECT_FALSE(base.done(child));
  child.texture = TextureState::Finished;
  EXPECT_TRUE(base.done(child));
  child.texture = TextureState::Absent; // shows its parent's, which is not there yet
  EXPECT_FALSE(base.done(child));
  root.texture = TextureState::Finished;
  EXPECT_TRUE(base.done(child));
  root.texture = TextureState::Decoding;
  base.undecodable.insert(root.key()); // an undecodable texture counts as done
  EXPECT_TRUE(base.done(child));
  EXPECT_TRUE(base.idle());
  base.decoding.insert(child.key());
  EXPECT_FALSE(base.idle());
  EXPECT_FALSE(l.set->idle());
}
