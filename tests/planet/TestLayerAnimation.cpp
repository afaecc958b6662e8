// Time that plays in the frame (planet/gl/src/LayerAnimation.hpp), GL-free: the animated layer is
// asked for each time when it is due and swaps it in through the layer set's pending time, the
// next times' tiles are fetched ahead for the drawn nodes within the bound, and stopping the
// animation leaves the layer at its time.

#include "../../planet/gl/src/FrameUpdate.hpp"
#include "../../planet/gl/src/LayerAnimation.hpp"
#include "LayerTestSupport.hpp"

#include <gtest/gtest.h>

#include <stdexcept>

using namespace tellus;
using namespace tellus::planet;
using namespace tellus::planet::layertest;

namespace {

TimeAnimation threeTimes() {
  TimeAnimationOptions o;
  o.instantsPerSecond = 1.0;
  o.fetchAhead = 2;
  o.aheadInFlight = 2;
  return *TimeAnimation::create({"t0", "t1", "t2"}, o);
}

/** One frame's animation points in Renderer::frame's order. */
void frame(LayerSet& set, const Camera& cam, double nowS) {
  stepAnimations(set, nowS);
  updateLayers(set, cam, nowS);
  fetchAhead(set);
  set.swapReady();
  observeAnimations(set, nowS);
}

} // namespace

TEST(LayerAnimation, AsksForEachTimeWhenDueAndFetchesTheNextOnesAhead) {
  FakeTileSource source;
  addLayer(source, "base", grid36(3));
  addLayer(source, "sst", grid36(3)); // every tile absent: a time is ready once asked
  Layers l(source, layerOptions("base", {"sst"}));
  LayerSet& set = *l.set;
  const Camera cam = cameraAt(l.geodesy, 20.0, 10.0, 1.0e7);
  set.animate(1, threeTimes());
  // Answers come at once but are taken in at the next frame: two a frame (the bound).
  for (int i = 0; i < 100; ++i)
    frame(set, cam, 0.0);
  EXPECT_EQ(set[1].current->time, "t0");
  EXPECT_FALSE(set[1].pending);
  EXPECT_EQ(set[1].animation->state(), PlayState::Playing);
  // t1 and t2 were asked for ahead, never more than two at once.
  EXPECT_GT(source.requestsFor("sst", "t1"), 0u);
  EXPECT_GT(source.requestsFor("sst", "t2"), 0u);
  EXPECT_LE(set[1].prefetch->stats().maxInFlightSeen, 2u);
  EXPECT_EQ(set[1].prefetch->stats().settled, set[1].prefetch->stats().wanted);
  for (int i = 0; i < 10; ++i)
    frame(set, cam, 0.9);
  EXPECT_EQ(set[1].current->time, "t0"); // not due yet
  frame(set, cam, 1.0);
  EXPECT_TRUE(set[1].pending || set[1].current->time == "t1");
  for (int i = 0; i < 10; ++i)
    frame(set, cam, 1.0);
  EXPECT_EQ(set[1].current->time, "t1");
  EXPECT_EQ(set[1].swaps, 2u); // default -> t0 -> t1
  set.animate(1, std::nullopt);
  for (int i = 0; i < 5; ++i)
    frame(set, cam, 9.0);
  EXPECT_EQ(set[1].current->time, "t1");
  EXPECT_FALSE(set[1].prefetch);
  EXPECT_THROW(set.animate(5, threeTimes()), std::invalid_argument);
}
