// Time that plays, rendered (issue 24, label gl): a layer animated over three times of distinct
// colours from a fake upstream, on an injected frame clock. Each frame shows one time over the
// whole globe, never a mix: while the next time's tiles come (held by the test, answered one at a
// time) the old time holds, then the new one swaps in whole. The next times' tiles are asked for
// ahead at low priority, never more than the bound at once.

#include "../support/FakeTileSource.hpp"
#include "GlTestSupport.hpp"

#include <tellus/planet/TimeAnimation.hpp>
#include <tellus/planet_gl/Renderer.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <thread>
#include <vector>

using namespace tellus;
using namespace tellus::planet;

namespace {

using Rgb = std::array<int, 3>;

constexpr GridSpec kGrid{Sector{}, 36.0, 32, 32, 6};
const std::map<std::string, Rgb> kColours{
    {"", {200, 40, 40}}, {"t0", {20, 60, 220}}, {"t1", {250, 250, 20}}, {"t2", {30, 200, 30}}};
const CameraPose kView{10.0, 20.0, 8.0e6, 0.0, 0.0};

std::vector<std::byte> solidPng(Rgb c) {
  std::vector<std::uint8_t> px(static_cast<std::size_t>(kGrid.tileWidth * kGrid.tileHeight * 4));
  for (std::size_t i = 0; i < px.size(); i += 4) {
    px[i] = static_cast<std::uint8_t>(c[0]);
    px[i + 1] = static_cast<std::uint8_t>(c[1]);
    px[i + 2] = static_cast<std::uint8_t>(c[2]);
    px[i + 3] = 255;
  }
  return encodePngRgba(kGrid.tileWidth, kGrid.tileHeight, px);
}

/** "base" one colour, "sst" a colour per time; requests of the times in `held` wait for
 * release(). */
struct World {
  World() {
    for (const char* name : {"base", "sst"})
      source.addLayer({name, kGrid, "image/png", [](const TileAddress& a) {
                         const Rgb c = kColours.at(a.layer == "base" ? "" : a.time);
                         return test::FakeTileSource::result(
                             TileStatus::Ok, solidPng(c), "image/png");
                       }});
    source.holdIf([this](const TileAddress& a) { return held.contains(a.time); });
  }
  std::set<std::string> held;
  test::FakeTileSource source;
};

/** The time whose colour every pixel of the middle 24 x 24 shows (within 2), or "" when they do
 * not all show one time's colour (a frame that mixes times, or something else). */
std::string shownTime(const Renderer& r, const std::vector<std::uint8_t>& px) {
  for (const char* t : {"t0", "t1", "t2"}) {
    const Rgb& want = kColours.at(t);
    bool all = true;
    for (int y = r.height() / 2 - 12; y < r.height() / 2 + 12 && all; ++y)
      for (int x = r.width() / 2 - 12; x < r.width() / 2 + 12 && all; ++x)
        for (std::size_t c = 0; c < 3; ++c)
          if (std::abs(px[static_cast<std::size_t>((y * r.width() + x) * 4) + c] - want[c]) > 2)
            all = false;
    if (all) return t;
  }
  return "";
}

struct Animated {
  std::shared_ptr<double> clock = std::make_shared<double>(0.0);
  RendererOptions options() const {
    RendererOptions o;
    o.layer = "base";
    o.width = 96;
    o.height = 96;
    o.overlays = {{"sst", "t0", 1.0, true, -1}}; // as --animate starts a layer: its first time
    o.frameClock = [c = clock] { return *c; };
    return o;
  }
  static TimeAnimation animation() {
    TimeAnimationOptions ao;
    ao.instantsPerSecond = 1.0;
    ao.fetchAhead = 2;
    ao.aheadInFlight = 3;
    auto a = TimeAnimation::create({"t0", "t1", "t2"}, ao);
    EXPECT_TRUE(a.has_value());
    return std::move(*a);
  }
};

} // namespace

TEST(AnimationGl, FramesShowOneTimeWholeHoldWhileTheNextComesAndThenSwap) {
  World w;
  Animated anim;
  const Geodesy wgs;
  w.held = {"t1"};
  OPEN_RENDERER(r, w.source, wgs, anim.options());
  r.animateLayer(1, Animated::animation());
  auto done = gltest::renderComplete(r, kView);
  ASSERT_TRUE(done.complete);
  EXPECT_EQ(shownTime(r, done.pixels), "t0");
  const auto& a0 = *done.stats.layers[1].animation;
  EXPECT_EQ(a0.state, "playing");
  EXPECT_EQ(a0.target, "t0");
  // t0 shows: t1's and t2's tiles for the view are asked for ahead, at a priority below every
  // visible tile's, never more than three at once.
  for (int i = 0; i < 20; ++i)
    r.frame(kView);
  EXPECT_GT(w.source.requestsFor("sst", "t1"), 0u);
  bool low = true;
  for (const auto& q : w.source.requests())
    if (q.address.time == "t1") low = low && q.priority < 0.0;
  EXPECT_TRUE(low);
  EXPECT_LE(r.stats().layers[1].animation->aheadMaxInFlight, 3u);
  EXPECT_EQ(r.stats().layers[1].animation->aheadInFlight, 3u); // t1's held requests
  // One second later t1 is due; its tiles come one a frame. Until the last, every frame shows
  // t0 whole and says it holds; then t1 whole.
  *anim.clock = 1.0;
  int holding = 0;
  std::string last = "t0";
  for (int frame = 0; frame < 400; ++frame) {
    *anim.clock += 0.01;
    r.frame(kView);
    const std::string shown = shownTime(r, r.readPixels());
    ASSERT_TRUE(shown == "t0" || shown == "t1") << "frame " << frame << " mixes times";
    ASSERT_FALSE(last == "t1" && shown == "t0") << "went back";
    last = shown;
    if (shown == "t1" && r.complete()) break;
    if (r.stats().layers[1].time == "t0") {
      ASSERT_EQ(shown, "t0");
      EXPECT_EQ(r.stats().layers[1].pendingTime, "t1");
      if (r.stats().layers[1].animation->state == "holding") ++holding;
    }
    w.source.release(1);
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  EXPECT_EQ(last, "t1");
  EXPECT_GT(holding, 3) << "t1's tiles came over several frames, t0 held meanwhile";
  const auto& a1 = *r.stats().layers[1].animation;
  EXPECT_EQ(a1.target, "t1");
  EXPECT_GE(a1.heldSteps, 1u);
  EXPECT_LE(a1.aheadMaxInFlight, 3u);
  EXPECT_EQ(r.stats().layers[1].swaps, 1u);
  // t1 was due at 1.0: arrived within its step the schedule holds (t2 due at 2.0), later t1 gets
  // its whole second from its arrival. Then t2, whose tiles are not held, and round to t0.
  w.held.clear();
  w.source.release();
  const double arrived = *anim.clock;
  const double t1Start = arrived - 1.0 <= 1.0 ? 1.0 : arrived;
  *anim.clock = t1Start + 0.99;
  done = gltest::renderComplete(r, kView);
  EXPECT_EQ(shownTime(r, done.pixels), "t1");
  *anim.clock = t1Start + 1.0;
  done = gltest::renderComplete(r, kView);
  EXPECT_EQ(shownTime(r, done.pixels), "t2");
  EXPECT_EQ(done.stats.layers[1].time, "t2");
  *anim.clock = t1Start + 2.0;
  done = gltest::renderComplete(r, kView);
  EXPECT_EQ(shownTime(r, done.pixels), "t0");
  EXPECT_EQ(done.stats.layers[1].swaps, 3u);
}

TEST(AnimationGl, PausedItHoldsItsTimeAndStepsByHand) {
  World w;
  Animated anim;
  const Geodesy wgs;
  OPEN_RENDERER(r, w.source, wgs, anim.options());
  r.animateLayer(1, Animated::animation());
  ASSERT_TRUE(gltest::renderComplete(r, kView).complete);
  r.toggleLayerAnimation(1);
  ASSERT_EQ(r.layerAnimation(1)->state(), PlayState::Paused);
  *anim.clock = 5.0;
  auto done = gltest::renderComplete(r, kView);
  EXPECT_EQ(shownTime(r, done.pixels), "t0");
  EXPECT_EQ(done.stats.layers[1].animation->state, "paused");
  r.stepLayerAnimation(1, -1); // round to t2
  done = gltest::renderComplete(r, kView);
  EXPECT_EQ(shownTime(r, done.pixels), "t2");
  r.animateLayer(1, std::nullopt); // stopped: the layer keeps its time
  *anim.clock = 50.0;
  done = gltest::renderComplete(r, kView);
  EXPECT_EQ(shownTime(r, done.pixels), "t2");
  EXPECT_FALSE(done.stats.layers[1].animation.has_value());
  EXPECT_THROW(r.animateLayer(7, Animated::animation()), std::invalid_argument);
}
