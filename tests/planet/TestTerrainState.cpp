// The renderer's heights (planet/gl/src/TerrainState.hpp), GL-free: whether relief could show
// from a camera, the elevation layer opened or refused, the level a node's mesh needs, and what a
// frame asks for with the relief on and off.

#include "../../planet/gl/src/FrameUpdate.hpp"
#include "../../planet/gl/src/TerrainState.hpp"
#include "LayerTestSupport.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

using namespace tellus;
using namespace tellus::planet;
using namespace tellus::planet::layertest;

namespace {

GridSpec elevationGrid() {
  GridSpec g;
  g.levelZeroDeltaDeg = 20.0;
  g.tileWidth = g.tileHeight = 150;
  g.numLevels = 5;
  return g;
}

} // namespace

TEST(TerrainState, ReliefShowsWhenItCouldMoveAPointByTheGivenPixels) {
  const Geodesy g;
  const Camera cam = cameraAt(g, 0.0, 0.0, 1e6); // 480 px high, 45 degrees
  const double f = 240.0 / std::tan(22.5 * std::numbers::pi / 180.0);
  // 11 km of relief seen from 1,000 km moves a point by 11000 f / 989000 = 6.4 px.
  EXPECT_TRUE(reliefCouldShow(cam, 1e6, 11000.0, 0.5));
  EXPECT_TRUE(reliefCouldShow(cam, 1e6, 11000.0, 11000.0 * f / 989000.0 - 1e-9));
  EXPECT_FALSE(reliefCouldShow(cam, 1e6, 11000.0, 11000.0 * f / 989000.0 + 1e-9));
  EXPECT_FALSE(reliefCouldShow(cam, 1e9, 11000.0, 0.5));
  EXPECT_TRUE(reliefCouldShow(cam, 5000.0, 11000.0, 100.0)) << "within the relief: always";
  const Camera dome(g, CameraPose{0.0, 0.0, 1e7}, 1000, Fisheye{180.0, 0.0});
  EXPECT_EQ(reliefCouldShow(dome, 1e7, 11000.0, 0.5),
            11000.0 * dome.pixelsPerRadian() / (1e7 - 11000.0) >= 0.5);
}

TEST(TerrainState, WithoutAnElevationLayerHeightsAreZeroAndEveryNodeComplete) {
  RendererOptions o;
  TerrainState t(o);
  EXPECT_FALSE(t.enabled());
  EXPECT_EQ(t.heightAt(46.0, 8.0), 0.0);
  EXPECT_FALSE(t.busy());
  FakeTileSource source;
  addLayer(source, "base", grid36(3));
  Layers l(source, layerOptions("base"));
  updateLayers(*l.set, cameraAt(l.geodesy, 0.0, 0.0, 2e7), 0.0);
  RenderStats stats;
  t.want(l.set->geo(), 0.0, stats);
  EXPECT_EQ(stats.heightTilesRequested, 0u);
  EXPECT_TRUE(t.complete(*l.set->geo().drawList().front()));
}

TEST(TerrainState, RefusesAnUnknownElevationLayerAndABadExaggeration) {
  FakeTileSource source;
  addLayer(source, "heights", elevationGrid());
  RendererOptions o;
  o.elevationLayer = "nowhere";
  TerrainState unknown(o);
  const auto a = unknown.open(source);
  ASSERT_FALSE(a.has_value());
  EXPECT_EQ(a.error(), "unknown elevation layer 'nowhere'");
  RendererOptions p;
  p.elevationLayer = "heights";
  p.verticalExaggeration = 0.0;
  TerrainState flat(p);
  ASSERT_FALSE(flat.open(source).has_value());
  p.verticalExaggeration = 2.0;
  TerrainState ok(p);
  ASSERT_TRUE(ok.open(source).has_value());
  EXPECT_TRUE(ok.enabled());
}

TEST(TerrainState, FarAwayTheReliefIsOffAndNoHeightsAreAskedFor) {
  FakeTileSource source;
  addLayer(source, "base", grid36(6));
  addLayer(source, "heights", elevationGrid());
  RendererOptions o = layerOptions("base");
  o.elevationLayer = "heights";
  Layers l(source, o);
  TerrainState t(l.opt);
  ASSERT_TRUE(t.open(source).has_value());
  LayerSet& set = *l.set;

  const Camera far = cameraAt(l.geodesy, 46.0, 8.0, 3e7);
  t.chooseRelief(far, 3e7, set);
  EXPECT_TRUE(t.reliefOff());
  updateLayers(set, far, 0.0);
  RenderStats stats;
  t.want(set.geo(), 0.0, stats);
  EXPECT_EQ(stats.nodesWithoutHeights, set.geo().drawList().size());
  EXPECT_EQ(source.requestsFor("heights"), 0u);
  EXPECT_TRUE(t.complete(*set.geo().drawList().front()));

  const Camera near = cameraAt(l.geodesy, 46.0, 8.0, 2e5);
  t.chooseRelief(near, 2e5, set);
  EXPECT_FALSE(t.reliefOff());
  for (int frame = 1; frame <= 3; ++frame)
    updateLayers(set, near, frame * 0.1);
  t.want(set.geo(), 0.3, stats);
  EXPECT_EQ(stats.nodesWithoutHeights, 0u);
  EXPECT_GT(source.requestsFor("heights"), 0u);
  EXPECT_EQ(stats.heightTilesRequested, source.requestsFor("heights"));
  // Coarse levels first: no request of a level follows one of a deeper level.
  int deepest = 0;
  for (const auto& r : source.requests())
    if (r.address.layer == "heights") {
      EXPECT_GE(r.address.key.level, deepest);
      deepest = std::max(deepest, r.address.key.level);
    }
}

TEST(TerrainState, ANodesMeshNeedsTheElevationLevelAsFineAsItsGrid) {
  FakeTileSource source;
  addLayer(source, "base", grid36(12));
  addLayer(source, "heights", elevationGrid());
  RendererOptions o = layerOptions("base");
  o.elevationLayer = "heights";
  Layers l(source, o);
  TerrainState t(l.opt);
  ASSERT_TRUE(t.open(source).has_value());
  Quadtree& tree = l.set->geo();
  Node* node = nullptr;
  for (const auto& r : tree.roots())
    if (r && !r->isCap() && node == nullptr) node = r.get();
  ASSERT_NE(node, nullptr);
  int previous = -1;
  for (int level = 0; level < 10 && node != nullptr; ++level) {
    const int needed = t.heightLevelFor(*node);
    EXPECT_GE(needed, previous) << "level " << level;
    EXPECT_LT(needed, 5);
    previous = needed;
    ASSERT_TRUE(tree.split(*node));
    node = node->child(0);
  }
  EXPECT_EQ(previous, 4) << "the deepest nodes need the deepest elevation level";
}
