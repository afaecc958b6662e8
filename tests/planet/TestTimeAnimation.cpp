// Time that plays (planet/TimeAnimation.hpp, planet/TimePrefetch.hpp), GL-free: the clock mapped
// onto instants at a rate, holding while the asked instant's tiles are missing (never skipping),
// the schedule kept when the swaps keep up, loop and once, pause and steps by hand; and fetching
// ahead: the next instants' tiles for the drawn nodes at low priority, never more in flight than
// the bound, cancelled when no longer ahead.
#include "../support/FakeTileSource.hpp"
#include "PlanetTestSupport.hpp"

#include <tellus/planet/Quadtree.hpp>
#include <tellus/planet/TimeAnimation.hpp>
#include <tellus/planet/TimePrefetch.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

using namespace tellus;
using namespace tellus::planet;

namespace {

using Strings = std::vector<std::string>;

TimeAnimation make(Strings instants, double rate = 1.0, bool loop = true) {
  TimeAnimationOptions o;
  o.instantsPerSecond = rate;
  o.loop = loop;
  auto a = TimeAnimation::create(std::move(instants), o);
  EXPECT_TRUE(a.has_value()) << (a ? "" : a.error());
  return std::move(*a);
}

/** A layer that shows whatever it is asked for by the next frame (the swaps keep up): the
 * instant shown at each clock time of `clock`. */
Strings playInstantly(TimeAnimation& a, const std::vector<double>& clock) {
  Strings shown;
  std::string layer = "default";
  for (double t : clock) {
    a.update(t, layer);
    layer = a.target(); // the frame swaps it in
    a.observe(t, layer);
    shown.push_back(layer);
  }
  return shown;
}

} // namespace

TEST(TimeAnimation, RefusesNothingToPlayDuplicatesAndRatesOutOfRange) {
  EXPECT_FALSE(TimeAnimation::create({}, {}).has_value());
  EXPECT_FALSE(TimeAnimation::create({"a", ""}, {}).has_value());
  const auto dup = TimeAnimation::create({"a", "b", "a"}, {});
  ASSERT_FALSE(dup.has_value());
  EXPECT_NE(dup.error().find("a twice"), std::string::npos);
  for (double r : {0.0, -1.0, 1001.0, std::nan("")}) {
    TimeAnimationOptions o;
    o.instantsPerSecond = r;
    EXPECT_FALSE(TimeAnimation::create({"a"}, o).has_value()) << r;
  }
  TimeAnimationOptions o;
  o.fetchAhead = 17;
  EXPECT_FALSE(TimeAnimation::create({"a"}, o).has_value());
  o.fetchAhead = 2;
  o.aheadInFlight = 0;
  EXPECT_FALSE(TimeAnimation::create({"a"}, o).has_value());
}

TEST(TimeAnimation, TheClockAtARateGivesTheInstantAndLoops) {
  TimeAnimation a = make({"t0", "t1", "t2"}, 2.0); // half a second each
  const Strings shown = playInstantly(a, {0.0, 0.25, 0.49, 0.5, 0.99, 1.0, 1.49, 1.5, 2.0});
  EXPECT_EQ(shown, (Strings{"t0", "t0", "t0", "t1", "t1", "t2", "t2", "t0", "t1"}));
  EXPECT_EQ(a.state(), PlayState::Playing);
  EXPECT_EQ(a.heldSteps(), 0u);
}

TEST(TimeAnimation, AFrameRateThatIsNoMultipleOfTheRateKeepsTheSchedule) {
  // 7 instants a second drawn at 25 frames a second: instant k from frame time k / 7 on.
  TimeAnimation a = make({"a", "b", "c", "d", "e", "f", "g"}, 7.0, false);
  std::vector<double> clock;
  for (int n = 0; n < 50; ++n)
    clock.push_back(n / 25.0);
  const Strings shown = playInstantly(a, clock);
  for (int n = 0; n < 50; ++n) {
    const auto k = std::min<std::size_t>(6, static_cast<std::size_t>(n * 7 / 25));
    EXPECT_EQ(shown[static_cast<std::size_t>(n)], a.instants()[k]) << "frame " << n;
  }
}

TEST(TimeAnimation, OnceEndsOnTheLastInstant) {
  TimeAnimation a = make({"t0", "t1"}, 1.0, false);
  const Strings shown = playInstantly(a, {0.0, 1.0, 2.0, 3.0, 10.0});
  EXPECT_EQ(shown, (Strings{"t0", "t1", "t1", "t1", "t1"}));
  EXPECT_EQ(a.state(), PlayState::Ended);
  EXPECT_TRUE(a.ahead(3).empty());
  a.play(11.0); // starts over
  EXPECT_EQ(a.update(11.0, "t1"), "t0");
}

TEST(TimeAnimation, OneInstantIsShownAndNothingIsAhead) {
  TimeAnimation a = make({"only"}, 10.0, true);
  EXPECT_EQ(playInstantly(a, {0.0, 0.5, 1.0}), (Strings{"only", "only", "only"}));
  EXPECT_TRUE(a.ahead(2).empty());
}

TEST(TimeAnimation, HoldsUntilTheAskedInstantIsShownAndNeverSkipsOne) {
  TimeAnimation a = make({"t0", "t1", "t2"}, 1.0);
  EXPECT_EQ(a.update(0.0, "default"), "t0");
  a.observe(0.0, "default");
  EXPECT_EQ(a.state(), PlayState::Playing); // asked this instant: not late yet
  // t0's tiles take 3.5 s: the clock runs on, the animation still asks for t0.
  for (double t : {1.0, 2.0, 3.0}) {
    EXPECT_EQ(a.update(t, "default"), "t0");
    EXPECT_EQ(a.state(), PlayState::Holding);
  }
  a.update(3.5, "t0"); // arrived more than a step late: t0 gets its whole second from 3.5
  EXPECT_EQ(a.state(), PlayState::Playing);
  EXPECT_EQ(a.heldSteps(), 1u);
  EXPECT_DOUBLE_EQ(a.heldSeconds(), 3.5);
  EXPECT_EQ(a.update(4.4, "t0"), "t0");
  EXPECT_EQ(a.update(4.5, "t0"), "t1");
  // t1 is slow too, long enough for t2 to be due: t2 is not asked for before t1 was shown.
  EXPECT_EQ(a.update(6.0, "t0"), "t1");
  EXPECT_EQ(a.update(6.2, "t1"), "t1");
  EXPECT_EQ(a.update(7.2, "t1"), "t2");
}

TEST(TimeAnimation, ALittleLateKeepsTheScheduleSoTheRateHolds) {
  TimeAnimation a = make({"t0", "t1", "t2", "t3"}, 1.0);
  a.update(0.0, "default");
  a.update(0.05, "t0"); // 50 ms late: t1 still due at 1.0
  EXPECT_EQ(a.update(1.0, "t0"), "t1");
  a.update(1.2, "t1");
  EXPECT_EQ(a.update(1.99, "t1"), "t1");
  EXPECT_EQ(a.update(2.0, "t1"), "t2");
  EXPECT_EQ(a.heldSteps(), 2u);
  EXPECT_NEAR(a.heldSeconds(), 0.25, 1e-12);
}

TEST(TimeAnimation, PausesResumesAndStepsByHand) {
  TimeAnimation a = make({"t0", "t1", "t2"}, 1.0);
  playInstantly(a, {0.0, 0.5});
  a.togglePause(0.6);
  EXPECT_EQ(a.state(), PlayState::Paused);
  EXPECT_EQ(a.update(5.0, "t0"), "t0"); // paused: no step however long
  a.togglePause(5.0);                   // t0 gets a whole step from now
  EXPECT_EQ(a.update(5.9, "t0"), "t0");
  EXPECT_EQ(a.update(6.0, "t0"), "t1");
  a.step(-1); // by hand: back to t0, paused
  EXPECT_EQ(a.state(), PlayState::Paused);
  EXPECT_EQ(a.target(), "t0");
  a.step(-1); // wraps round
  EXPECT_EQ(a.target(), "t2");
  a.step(+2);
  EXPECT_EQ(a.target(), "t1");
  EXPECT_EQ(a.update(20.0, "t0"), "t1"); // asked, shown once its tiles are there
}

TEST(TimeAnimation, AheadNamesTheNextInstantsInPlayingOrder) {
  TimeAnimation loop = make({"a", "b", "c", "d"}, 1.0, true);
  loop.update(0.0, "a");
  EXPECT_EQ(loop.ahead(2), (Strings{"b", "c"}));
  EXPECT_EQ(loop.ahead(9), (Strings{"b", "c", "d"})); // never the target itself
  loop.step(3);
  EXPECT_EQ(loop.ahead(2), (Strings{"a", "b"})); // round the loop
  TimeAnimation once = make({"a", "b", "c", "d"}, 1.0, false);
  once.step(3);
  EXPECT_TRUE(once.ahead(2).empty());
  once.step(-1);
  EXPECT_EQ(once.ahead(2), Strings{"d"});
}

namespace {

QuadtreeParams treeParams() {
  QuadtreeParams p;
  p.lod = {256, 256, 1.0};
  p.maxSplitsPerFrame = 100000;
  return p;
}

/** A tree converged on a view of the Alps from 2,000 km. */
struct View {
  Geodesy g;
  Quadtree tree{g, planet::test::globalGrid(), treeParams()};
  View() {
    const Camera cam(g, {46.0, 8.0, 2e6, 0.0, 0.0}, {800, 600}, 45.0);
    for (int i = 0; i < 50; ++i)
      if (tree.update(cam).created == 0) break;
  }
  std::size_t tiles() const {
    std::size_t n = 0;
    for (const Node* node : tree.drawList())
      n += static_cast<std::size_t>(textureTileCount(node->key()));
    return n;
  }
};

} // namespace

TEST(TimePrefetch, AsksForTheNextTimesTilesAtLowPriorityWithinTheBound) {
  View v;
  ASSERT_GT(v.tiles(), 8u);
  tellus::test::FakeTileSource src;
  src.setDelivery(tellus::test::FakeTileSource::Delivery::Held);
  TimePrefetcher p(src, {"sst", 3, -1.0});
  const Strings ahead{"t1", "t2"};
  p.update(v.tree, ahead);
  EXPECT_EQ(src.openCount(), 3u); // the bound
  for (const auto& r : src.requests()) {
    EXPECT_EQ(r.address.layer, "sst");
    EXPECT_EQ(r.address.time, "t1"); // the nearer time first
    EXPECT_LT(r.priority, 0.0);
  }
  // As answers come, more are asked, never more than three out at once, every tile once.
  for (int frame = 0; frame < 200 && p.stats().settled < p.stats().wanted; ++frame) {
    src.release(2);
    p.update(v.tree, ahead);
    EXPECT_LE(src.openCount(), 3u);
  }
  EXPECT_EQ(p.stats().wanted, 2 * v.tiles());
  EXPECT_EQ(p.stats().settled, p.stats().wanted);
  EXPECT_EQ(p.stats().requested, 2 * v.tiles());
  EXPECT_EQ(p.stats().maxInFlightSeen, 3u);
  EXPECT_EQ(src.requestsFor("sst", "t1"), v.tiles());
  EXPECT_EQ(src.requestsFor("sst", "t2"), v.tiles());
  p.update(v.tree, ahead); // nothing new to ask
  EXPECT_EQ(src.requestCount(), 2 * v.tiles());
}

TEST(TimePrefetch, CancelsTheTimesNoLongerAheadAndForgetsThem) {
  View v;
  tellus::test::FakeTileSource src;
  src.setDelivery(tellus::test::FakeTileSource::Delivery::Held);
  TimePrefetcher p(src, {"sst", 4, -1.0});
  p.update(v.tree, Strings{"t1"});
  EXPECT_EQ(src.openCount(), 4u);
  p.update(v.tree, Strings{"t2"}); // the animation moved on: t1's requests go
  EXPECT_EQ(src.cancelled().size(), 4u);
  EXPECT_EQ(src.openCount(), 4u);
  for (const auto& r : src.openRequests())
    EXPECT_EQ(r.address.time, "t2");
  p.update(v.tree, Strings{});
  EXPECT_EQ(src.openCount(), 0u);
  EXPECT_EQ(p.stats().inFlight, 0u);
  EXPECT_EQ(p.stats().wanted, 0u);
}
