// The tests' one fake tile source (tests/support/FakeTileSource.hpp) keeps the ITileSource
// contract (tellus/cache/TileSource.hpp) the renderer's and the streamers' tests rely on: one
// answer per request unless cancelled, answers computed when given, held requests answered or
// cancelled in order, failures on demand, and a worker that answers off the caller's thread.

#include "../support/FakeTileSource.hpp"

#include <gtest/gtest.h>

#include <future>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace tellus::test {
namespace {

constexpr GridSpec kGrid{Sector{}, 36.0, 8, 8, 3};

struct Answers {
  std::vector<TileResult> got;
  ITileSource::Callback callback() {
    return [this](TileResult&& r) { got.push_back(std::move(r)); };
  }
};

TEST(FakeTileSource, LayersDescribeThemselvesAndAnswerAtOnce) {
  FakeTileSource src;
  src.addLayer({"a", kGrid, "image/jpeg", FakeTileSource::bytes({std::byte{7}}, "image/jpeg")});
  src.addLayer({"b", kGrid, "image/png", {}});
  const auto a = src.describe("a", "2024-01-01");
  ASSERT_TRUE(a);
  EXPECT_EQ(a->name, "a");
  EXPECT_EQ(a->grid, kGrid);
  EXPECT_EQ(a->mimeType, "image/jpeg");
  EXPECT_EQ(a->time, "2024-01-01");
  EXPECT_FALSE(src.describe("c"));
  Answers got;
  EXPECT_EQ(src.request({"a", "", TileKey{1, 2, 3}}, 5.0, got.callback()), 1u);
  EXPECT_EQ(src.request({"b", "t", TileKey{0, 0, 0}}, 1.0, got.callback()), 2u);
  EXPECT_EQ(src.request({"c", "", TileKey{0, 0, 0}}, 1.0, got.callback()), 3u);
  ASSERT_EQ(got.got.size(), 3u); // inside request()
  EXPECT_EQ(got.got[0].status, TileStatus::Ok);
  EXPECT_EQ(got.got[0].bytes, std::vector<std::byte>{std::byte{7}});
  EXPECT_EQ(got.got[0].contentType, "image/jpeg");
  EXPECT_EQ(got.got[1].status, TileStatus::Absent);
  EXPECT_EQ(got.got[2].status, TileStatus::Absent) << "an unknown layer, no fallback";
  EXPECT_EQ(src.requestCount(), 3u);
  EXPECT_EQ(src.openCount(), 0u);
  EXPECT_EQ(src.requestsFor("b", "t"), 1u);
  EXPECT_EQ(src.requestsFor("b"), 0u);
  EXPECT_EQ(src.deepestLevel("a"), 1);
  EXPECT_EQ(src.deepestLevel("z"), -1);
  const auto r = src.requests();
  EXPECT_EQ(r[0].priority, 5.0);
  EXPECT_FALSE(r[0].open);
  EXPECT_FALSE(src.cancel(1)) << "answered";
  src.forgetRequests();
  EXPECT_EQ(src.requestCount(), 0u);
  EXPECT_EQ(src.requestsFor("b", "t"), 0u);
}

TEST(FakeTileSource, OneLayerForEveryNameAndAFallbackAnswer) {
  FakeTileSource any({"ramp", kGrid, "image/png", FakeTileSource::failed("down")});
  const auto d = any.describe("whatever");
  ASSERT_TRUE(d);
  EXPECT_EQ(d->name, "ramp");
  Answers got;
  any.request({"x", "", TileKey{0, 0, 0}}, 1.0, got.callback());
  ASSERT_EQ(got.got.size(), 1u);
  EXPECT_EQ(got.got[0].status, TileStatus::Failed);
  EXPECT_EQ(got.got[0].message, "down");

  FakeTileSource none;
  none.setFallbackAnswer([](const TileAddress& a) {
    return FakeTileSource::result(
        TileStatus::Ok, std::vector<std::byte>(static_cast<std::size_t>(a.key.level) + 1));
  });
  none.request({"x", "", TileKey{2, 0, 0}}, 1.0, got.callback());
  ASSERT_EQ(got.got.size(), 2u);
  EXPECT_EQ(got.got[1].bytes.size(), 3u);
  EXPECT_FALSE(none.describe("x")) << "a fallback answer describes nothing";
}

TEST(FakeTileSource, HeldRequestsAreAnsweredOrCancelledWhenTheTestSays) {
  int made = 0;
  FakeTileSource src({"l", kGrid, "image/png", [&](const TileAddress&) {
                        ++made;
                        return FakeTileSource::result(TileStatus::Ok, {std::byte{1}});
                      }});
  src.setDelivery(FakeTileSource::Delivery::Held);
  Answers got;
  for (std::int64_t c = 0; c < 5; ++c)
    src.request({"l", "", TileKey{1, 0, c}}, 1.0, got.callback());
  EXPECT_TRUE(got.got.empty());
  EXPECT_EQ(made, 0) << "answers are computed when given";
  EXPECT_EQ(src.openCount(), 5u);
  EXPECT_TRUE(src.cancel(2));
  EXPECT_FALSE(src.cancel(2));
  EXPECT_EQ(src.cancelled(), std::vector<TileRequestId>{2});
  EXPECT_TRUE(src.answer(4, FakeTileSource::result(TileStatus::Absent)));
  EXPECT_FALSE(src.answer(4, FakeTileSource::result(TileStatus::Absent))) << "once";
  EXPECT_TRUE(src.answer(TileKey{1, 0, 4}, FakeTileSource::result(TileStatus::Failed)));
  EXPECT_FALSE(src.answer(TileKey{1, 0, 4}, FakeTileSource::result(TileStatus::Failed)));
  ASSERT_EQ(got.got.size(), 2u);
  EXPECT_EQ(got.got[0].status, TileStatus::Absent);
  EXPECT_EQ(got.got[1].status, TileStatus::Failed);
  // What is left, oldest first: 1 and 3, by the layer's answer.
  const auto open = src.openRequests();
  ASSERT_EQ(open.size(), 2u);
  EXPECT_EQ(open[0].id, 1u);
  EXPECT_EQ(open[1].id, 3u);
  EXPECT_EQ(src.release(1), 1u);
  EXPECT_EQ(src.openRequests()[0].id, 3u);
  EXPECT_EQ(src.release(), 1u);
  EXPECT_EQ(src.release(), 0u);
  EXPECT_EQ(made, 2);
  ASSERT_EQ(got.got.size(), 4u);
  EXPECT_EQ(got.got[3].status, TileStatus::Ok);
  src.reprioritize(1, 9.0);
  EXPECT_EQ(src.reprioritizations(), 1u);
}

TEST(FakeTileSource, SomeRequestsHeldAndTheNthFailed) {
  FakeTileSource src({"l", kGrid, "image/png", FakeTileSource::bytes({std::byte{1}}, "image/png")});
  src.holdIf([](const TileAddress& a) { return a.time == "later"; });
  src.failRequest(2, "the second");
  Answers got;
  src.request({"l", "", TileKey{0, 0, 0}}, 1.0, got.callback());
  src.request({"l", "", TileKey{0, 0, 1}}, 1.0, got.callback());
  src.request({"l", "later", TileKey{0, 0, 2}}, 1.0, got.callback());
  ASSERT_EQ(got.got.size(), 2u);
  EXPECT_EQ(got.got[0].status, TileStatus::Ok);
  EXPECT_EQ(got.got[1].status, TileStatus::Failed);
  EXPECT_EQ(got.got[1].message, "the second");
  EXPECT_EQ(src.openCount(), 1u);
  EXPECT_TRUE(src.answer(3));
  ASSERT_EQ(got.got.size(), 3u);
  EXPECT_EQ(got.got[2].status, TileStatus::Ok);
}

TEST(FakeTileSource, TheWorkerAnswersInOrderOffTheCallersThread) {
  std::promise<void> go;
  std::shared_future<void> started = go.get_future().share();
  FakeTileSource src({"l", kGrid, "image/png", [started](const TileAddress&) {
                        started.wait(); // the first answer waits until the test has asked
                        return FakeTileSource::result(TileStatus::Ok, {std::byte{1}});
                      }});
  src.setDelivery(FakeTileSource::Delivery::Worker);
  std::mutex mutex;
  std::vector<std::pair<TileRequestId, std::thread::id>> order;
  std::promise<void> allDone;
  const auto callback = [&](TileRequestId id) {
    return [&, id](TileResult&& r) {
      EXPECT_EQ(r.status, TileStatus::Ok);
      std::lock_guard lock(mutex);
      order.emplace_back(id, std::this_thread::get_id());
      if (order.size() == 3) allDone.set_value();
    };
  };
  for (TileRequestId id = 1; id <= 4; ++id)
    EXPECT_EQ(
        src.request({"l", "", TileKey{0, 0, static_cast<std::int64_t>(id)}}, 1.0, callback(id)),
        id);
  // The worker waits inside the first answer until `go`: the third is still queued, cancelled.
  EXPECT_TRUE(src.cancel(3));
  go.set_value();
  allDone.get_future().wait();
  std::lock_guard lock(mutex);
  ASSERT_EQ(order.size(), 3u);
  EXPECT_EQ(order[0].first, 1u);
  EXPECT_EQ(order[1].first, 2u);
  EXPECT_EQ(order[2].first, 4u);
  for (const auto& [id, thread] : order)
    EXPECT_NE(thread, std::this_thread::get_id());
}

TEST(FakeTileSource, DestroyedWithRequestsOpenItAnswersNone) {
  Answers got;
  {
    FakeTileSource src;
    src.setDelivery(FakeTileSource::Delivery::Held);
    src.request({"l", "", TileKey{0, 0, 0}}, 1.0, got.callback());
    FakeTileSource worker;
    worker.setDelivery(FakeTileSource::Delivery::Worker);
  }
  EXPECT_TRUE(got.got.empty());
}

} // namespace
} // namespace tellus::test
