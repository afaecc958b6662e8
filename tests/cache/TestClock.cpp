// The injected clock: the system's two clocks, and a manual one that moves only when told.

#include <tellus/cache/Clock.hpp>

#include <gtest/gtest.h>

#include <chrono>
#include <thread>
#include <vector>

using namespace tellus;
using namespace std::chrono_literals;

TEST(Clock, SystemClockIsTheStandardLibrarysClocks) {
  const auto before = std::chrono::duration_cast<std::chrono::milliseconds>(
                          std::chrono::system_clock::now().time_since_epoch())
                          .count();
  const auto steadyBefore = std::chrono::steady_clock::now();
  const Clock& c = Clock::system();
  const UnixMillis now = c.now();
  const auto steady = c.steady();
  EXPECT_GE(now, before);
  EXPECT_LE(now, unixMillisNow());
  EXPECT_GE(steady, steadyBefore);
  EXPECT_LE(steady, std::chrono::steady_clock::now());
  EXPECT_EQ(systemClock().get(), &Clock::system());
}

TEST(Clock, ManualClockStandsStillUntilMoved) {
  ManualClock c(1'704'067'200'000); // 2024-01-01T00:00:00Z
  const auto steady = c.steady();
  EXPECT_EQ(c.now(), 1'704'067'200'000);
  EXPECT_EQ(c.steady(), steady);
  c.advance(1500ms);
  EXPECT_EQ(c.now(), 1'704'067'201'500);
  EXPECT_EQ(c.steady() - steady, 1500ms);
  EXPECT_EQ(c.wallNow().time_since_epoch(), std::chrono::milliseconds(1'704'067'201'500));
  c.advance(-1s); // time does not go back
  EXPECT_EQ(c.now(), 1'704'067'201'500);
  c.setNow(1'000); // a wall clock stepped back moves wall time alone
  EXPECT_EQ(c.now(), 1'000);
  EXPECT_EQ(c.steady() - steady, 1500ms);
  c.advance(999us); // below a millisecond: kept, not yet shown in now()
  EXPECT_EQ(c.now(), 1'000);
  c.advance(1us);
  EXPECT_EQ(c.now(), 1'001);
}

TEST(Clock, ManualClockStartsAtThePresentOrWhereItIsTold) {
  const UnixMillis before = unixMillisNow();
  ManualClock present;
  EXPECT_GE(present.now(), before);
  EXPECT_LE(present.now(), unixMillisNow());
  const auto steadyStart = std::chrono::steady_clock::time_point(5h);
  const auto wallStart = std::chrono::system_clock::time_point(std::chrono::milliseconds(42));
  ManualClock given(steadyStart, wallStart);
  EXPECT_EQ(given.steady(), steadyStart);
  EXPECT_EQ(given.now(), 42);
}

TEST(Clock, ManualClockIsReadWhileAnotherThreadMovesIt) {
  ManualClock c(0);
  std::vector<std::thread> readers;
  for (int t = 0; t < 3; ++t) {
    readers.emplace_back([&] {
      UnixMillis last = 0;
      for (int i = 0; i < 10000; ++i) {
        const UnixMillis n = c.now();
        EXPECT_GE(n, last);
        last = n;
      }
    });
  }
  for (int i = 0; i < 10000; ++i)
    c.advance(1ms);
  for (auto& r : readers)
    r.join();
  EXPECT_EQ(c.now(), 10000);
}
