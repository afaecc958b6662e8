// The update phase for the layers (planet/gl/src/FrameUpdate.hpp), GL-free: which trees update and
// which streamers ask for tiles.

#include "../../planet/gl/src/FrameUpdate.hpp"
#include "LayerTestSupport.hpp"

#include <gtest/gtest.h>

using namespace tellus;
using namespace tellus::planet;
using namespace tellus::planet::layertest;

TEST(FrameUpdate, TheBaseAndVisibleOverlaysStreamAndAHiddenOverlayAsksForNothing) {
  FakeTileSource source;
  addLayer(source, "base", grid36(3));
  addLayer(source, "clouds", grid36(3));
  addLayer(source, "sst", grid36(3));
  Layers l(source, layerOptions("base", {"clouds", "sst"}));
  LayerSet& set = *l.set;
  set.setVisible(2, false);
  const Camera cam = cameraAt(l.geodesy, 0.0, 0.0, 2e7);
  const FrameStats fs = updateLayers(set, cam, 0.0);
  EXPECT_GT(fs.drawn, 0u);
  EXPECT_EQ(fs.drawn, set.geo().drawList().size());
  EXPECT_TRUE(set[0].current->updated);
  EXPECT_TRUE(set[1].current->updated);
  EXPECT_FALSE(set[2].current->updated);
  EXPECT_GT(source.requestsFor("base"), 0u);
  EXPECT_GT(source.requestsFor("clouds"), 0u);
  EXPECT_EQ(source.requestsFor("sst"), 0u);
  EXPECT_TRUE(set[2].current->tree->drawList().empty()) << "a hidden overlay's tree is not updated";
  set.setVisible(2, true);
  updateLayers(set, cam, 0.1);
  EXPECT_TRUE(set[2].current->updated);
  EXPECT_GT(source.requestsFor("sst"), 0u);
}

TEST(FrameUpdate, ALayerSwitchingTimeStreamsOnlyTheNewTime) {
  FakeTileSource source;
  addLayer(source, "base", grid36(3));
  addLayer(source, "clouds", grid36(3));
  Layers l(source, layerOptions("base", {"clouds"}));
  LayerSet& set = *l.set;
  const Camera cam = cameraAt(l.geodesy, 30.0, 60.0, 1e7);
  updateLayers(set, cam, 0.0);
  const std::size_t before = source.requestsFor("clouds", "");
  set.setTime(1, "t1");
  set.setTime(0, "t1"); // the base too: its old tree is still what is drawn
  source.forgetRequests();
  updateLayers(set, cam, 0.1);
  EXPECT_FALSE(set[1].current->updated);
  EXPECT_TRUE(set[1].pending->updated);
  EXPECT_FALSE(set[0].current->updated);
  EXPECT_TRUE(set[0].pending->updated);
  EXPECT_FALSE(set.geo().drawList().empty()) << "the drawn tree is updated while its time waits";
  EXPECT_EQ(source.requestsFor("clouds", ""), 0u);
  EXPECT_EQ(source.requestsFor("base", ""), 0u);
  EXPECT_GT(source.requestsFor("clouds", "t1"), 0u);
  EXPECT_GT(source.requestsFor("base", "t1"), 0u);
  EXPECT_GT(before, 0u);
}
