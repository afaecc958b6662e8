// What a frame draws (planet/gl/src/DrawList.hpp), GL-free: parts of nodes with their textures
// and uv transforms, overlays over each part, the passes they need, and whether the frame shows
// what its LOD asks for. Textures are handles that own nothing (GlTexture{NoCreate}): the list
// refers to them by address.

#include "../../planet/gl/src/DrawList.hpp"
#include "../../planet/gl/src/FrameUpdate.hpp"
#include "LayerTestSupport.hpp"

#include <gtest/gtest.h>

using namespace tellus;
using namespace tellus::planet;
using namespace tellus::planet::layertest;

namespace {

Node& firstPlainRoot(Quadtree& tree) {
  for (const auto& r : tree.roots())
    if (r && !r->isCap()) return *r;
  throw std::logic_error("no plain root");
}

glm::dvec2 at(const UvTransform& t, double u, double v) {
  return t.apply({u, v});
}

} // namespace

TEST(DrawList, PassesNeededForOverlaysPerPass) {
  DrawList list;
  EXPECT_EQ(list.passes(8), 1u);
  list.parts.push_back({});
  DrawPart many;
  many.overlayEnd = 9;
  list.parts.push_back(many);
  EXPECT_EQ(list.passes(8), 2u);
  EXPECT_EQ(list.passes(1), 9u);
  EXPECT_EQ(list.passes(9), 1u);
}

TEST(DrawList, APartUnderAChildDrawsItsQuadrantThroughTheChildsTransform) {
  FakeTileSource source;
  addLayer(source, "base", grid36(3));
  Layers l(source, layerOptions("base"));
  Quadtree& tree = *l.set->base().tree;
  Node& node = firstPlainRoot(tree);
  ASSERT_TRUE(tree.split(node));
  const GlTexture texture(NoCreate);
  const DrawPart whole = partFor(node, node, texture, UvTransform{});
  EXPECT_EQ(whole.firstQuadrant, 0);
  EXPECT_EQ(whole.lastQuadrant, 4);
  EXPECT_EQ(whole.texture, &texture);
  const Sector& s = node.sector();
  for (int slot = 0; slot < node.childSlots(); ++slot) {
    const Node& child = *node.child(slot);
    const Sector& c = child.sector();
    const DrawPart p = partFor(node, child, texture, UvTransform{});
    const int quadrant = (c.south == s.south ? 0 : 2) + (c.west == s.west ? 0 : 1);
    EXPECT_EQ(p.firstQuadrant, quadrant) << slot;
    EXPECT_EQ(p.lastQuadrant, quadrant + 1) << slot;
    // The node's uv at the child's corners lands on the child's texture's corners.
    const double u0 = (c.west - s.west) / (s.east - s.west),
                 v0 = (c.south - s.south) / (s.north - s.south);
    const double u1 = (c.east - s.west) / (s.east - s.west),
                 v1 = (c.north - s.south) / (s.north - s.south);
    EXPECT_NEAR(at(p.uv, u0, v0).x, 0.0, 1e-12);
    EXPECT_NEAR(at(p.uv, u0, v0).y, 0.0, 1e-12);
    EXPECT_NEAR(at(p.uv, u1, v1).x, 1.0, 1e-12);
    EXPECT_NEAR(at(p.uv, u1, v1).y, 1.0, 1e-12);
  }
}

TEST(DrawList, NodesWithoutTexturesDrawTheGlobalOneAndResidentOnesTheirOwn) {
  FakeTileSource source;
  addLayer(source, "base", grid36(3));
  Layers l(source, layerOptions("base"));
  LayerSet& set = *l.set;
  updateLayers(set, cameraAt(l.geodesy, 20.0, 10.0, 2e7), 0.0);
  const GlTexture global(NoCreate);
  RenderStats stats;
  const DrawList bare = planDraw(set, global, stats);
  const auto& drawn = set.geo().drawList();
  ASSERT_FALSE(drawn.empty());
  ASSERT_EQ(bare.parts.size(), drawn.size());
  for (std::size_t i = 0; i < drawn.size(); ++i) {
    EXPECT_EQ(bare.parts[i].node, drawn[i]);
    EXPECT_EQ(bare.parts[i].texture, &global);
    EXPECT_EQ(bare.parts[i].uv.offset, globalUv(drawn[i]->sector()).offset);
  }
  EXPECT_TRUE(bare.bindings.empty());

  LayerTextures& base = set.base();
  Node& mine = *drawn.front();
  mine.texture = TextureState::Finished;
  base.install(mine.key(), NodeTexture{}, 1000);
  const DrawList own = planDraw(set, global, stats);
  EXPECT_EQ(own.parts.front().texture, &base.textures.at(mine.key()).texture);
  EXPECT_EQ(own.parts.front().uv.scale, glm::dvec2(1.0));
  const auto merged =
      std::count_if(drawn.begin(), drawn.end(), [](const Node* n) { return n->key().span > 1; });
  EXPECT_EQ(stats.mergedNodesDrawn, static_cast<std::size_t>(merged)) << "the polar caps";
}

TEST(DrawList, OverlaysBindTheirNearestTextureInOrderSkippingHiddenOnes) {
  FakeTileSource source;
  addLayer(source, "base", grid36(3));
  addLayer(source, "a", grid36(3));
  addLayer(source, "b", grid36(3));
  addLayer(source, "c", grid36(1));
  Layers l(source, layerOptions("base", {"a", "b", "c"}));
  LayerSet& set = *l.set;
  Quadtree& tree = set.geo();
  Node& node = firstPlainRoot(tree);
  ASSERT_TRUE(tree.split(node));
  ASSERT_TRUE(tree.split(*node.child(0)));
  const Node& grandchild = *node.child(0)->child(3);
  // Overlay a: a texture at the root; b: hidden; c: one level only, a texture at the root.
  for (std::size_t i : {1u, 3u})
    set[i].current->textures[node.key()] = NodeTexture{};
  set[2].current->textures[node.key()] = NodeTexture{};
  set.setVisible(2, false);
  set.setOpacity(3, 0.5);
  const GlTexture baseTexture(NoCreate);
  DrawPart part = partFor(*node.child(0), grandchild, baseTexture, UvTransform{});
  std::vector<OverlayBinding> bindings;
  bindOverlays(set, grandchild, part, bindings);
  ASSERT_EQ(part.overlayEnd - part.overlayBegin, 2u);
  EXPECT_EQ(bindings[0].texture, &set[1].current->textures.at(node.key()).texture);
  EXPECT_EQ(bindings[1].texture, &set[3].current->textures.at(node.key()).texture);
  EXPECT_FLOAT_EQ(bindings[1].opacity, 0.5f);
  // The transform takes the part's node coordinates into the root's texture.
  const UvTransform expected =
      regionToNodeUv(*node.child(0), grandchild, ancestorUv(grandchild.key(), node.key()));
  EXPECT_EQ(bindings[0].uv.scale, expected.scale);
  EXPECT_EQ(bindings[0].uv.offset, expected.offset);
  set.setOpacity(1, 0.0); // nothing to see: skipped
  bindings.clear();
  bindOverlays(set, grandchild, part, bindings);
  EXPECT_EQ(bindings.size(), 1u);
}

TEST(DrawList, TheFrameIsCompleteOnlyWhenItShowsWhatItsLodAsksFor) {
  FakeTileSource source;
  addLayer(source, "base", grid36(2));
  addLayer(source, "a", grid36(2));
  Layers l(source, layerOptions("base", {"a"}));
  LayerSet& set = *l.set;
  const Camera cam = cameraAt(l.geodesy, 0.0, 0.0, 2e7);
  FrameStats fs;
  // Every tile absent: all done once the answers are in (a cap's 10 tiles take a few frames).
  for (int frame = 0; frame < 12; ++frame)
    fs = updateLayers(set, cam, frame * 0.1);
  const auto heights = [](const Node&) { return true; };
  EXPECT_TRUE(drawsWhatLodAsks(set, fs, heights));
  EXPECT_FALSE(drawsWhatLodAsks(set, fs, [](const Node&) { return false; }));
  FrameStats deferred = fs;
  deferred.splitsDeferred = 1;
  EXPECT_FALSE(drawsWhatLodAsks(set, deferred, heights));
  set.setTime(1, "later");
  EXPECT_FALSE(drawsWhatLodAsks(set, fs, heights)) << "a layer is switching time";
}
