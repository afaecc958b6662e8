// The per-client budget of upstream fetches: a token bucket per address on an injected clock.

#include <tellus/cache/Clock.hpp>
#include <tellus/proxy/FetchBudget.hpp>

#include <gtest/gtest.h>

#include <atomic>
#include <memory>
#include <string>
#include <thread>
#include <vector>

using namespace tellus;
using namespace std::chrono_literals;

TEST(FetchBudget, AMinutesWorthAtOnceThenRefilledEvenly) {
  ManualClock t;
  FetchBudget b(60, t); // one a second, sixty at once
  for (int i = 0; i < 60; ++i)
    ASSERT_FALSE(b.take("10.0.0.1")) << i;
  const auto wait = b.take("10.0.0.1");
  ASSERT_TRUE(wait);
  EXPECT_EQ(*wait, 1000ms);
  EXPECT_EQ(b.refused(), 1u);
  // Another client has its own budget.
  EXPECT_FALSE(b.take("10.0.0.2"));
  t.advance(500ms);
  ASSERT_TRUE(b.take("10.0.0.1"));
  EXPECT_EQ(*b.take("10.0.0.1"), 500ms);
  t.advance(500ms);
  EXPECT_FALSE(b.take("10.0.0.1"));
  EXPECT_TRUE(b.take("10.0.0.1"));
  // Never more than a minute's worth, however long it was idle.
  t.advance(std::chrono::hours(24));
  for (int i = 0; i < 60; ++i)
    ASSERT_FALSE(b.take("10.0.0.1")) << i;
  EXPECT_TRUE(b.take("10.0.0.1"));
  EXPECT_EQ(b.clients(), 2u);
}

TEST(FetchBudget, ZeroIsUnlimited) {
  FetchBudget b(0);
  EXPECT_TRUE(b.unlimited());
  for (int i = 0; i < 10000; ++i)
    ASSERT_FALSE(b.take("x"));
  EXPECT_EQ(b.clients(), 0u);
  EXPECT_TRUE(FetchBudget(-1).unlimited());
  EXPECT_TRUE(FetchBudget(std::numeric_limits<double>::quiet_NaN()).unlimited());
}

TEST(FetchBudget, ConcurrentClientsNeverTakeMoreThanTheirBudget) {
  ManualClock t;
  FetchBudget b(100, t);
  std::atomic<int> granted{0};
  std::vector<std::thread> threads;
  for (int k = 0; k < 4; ++k) {
    threads.emplace_back([&] {
      for (int i = 0; i < 100; ++i)
        if (!b.take("same")) ++granted;
    });
  }
  for (auto& th : threads)
    th.join();
  EXPECT_EQ(granted.load(), 100);
  EXPECT_EQ(b.refused(), 300u);
}
