// The composer's decoded-tile cache policy (proxy/src/compose/AdmittingLru.hpp): an LRU within a
// byte budget that keeps a value from its second use on and, when full, only if it was used more
// often than the value it would push out.

#include "../../proxy/src/compose/AdmittingLru.hpp"

#include <gtest/gtest.h>

#include <random>
#include <string>

namespace tellus {
namespace {

using Cache = AdmittingLru<int>;

/** One use of `key` as the composer makes it: a hit, or a miss that keeps the value if admitted.
 * True on a hit. */
bool use(Cache& c, const std::string& key, std::size_t bytes = 10) {
  if (c.get(key)) return true;
  if (c.admits(key, bytes)) c.put(key, std::make_shared<const int>(1), bytes);
  return false;
}

TEST(AdmittingLru, KeepsATileFromItsSecondUseOn) {
  Cache c(100);
  EXPECT_FALSE(use(c, "a")) << "first use: a miss";
  EXPECT_FALSE(c.contains("a")) << "one use does not earn a place";
  EXPECT_FALSE(use(c, "a")) << "second use: still a miss, but now kept";
  EXPECT_TRUE(c.contains("a"));
  EXPECT_TRUE(use(c, "a"));
  EXPECT_EQ(c.bytes(), 10u);
  EXPECT_EQ(c.uses("a"), 3u);
}

TEST(AdmittingLru, NothingLargerThanTheBudgetAndNothingWithABudgetOfZero) {
  Cache c(100);
  use(c, "big", 101);
  use(c, "big", 101);
  EXPECT_FALSE(c.contains("big"));
  c.put("big", std::make_shared<const int>(1), 101);
  EXPECT_EQ(c.size(), 0u);
  Cache none(0);
  for (int i = 0; i < 5; ++i)
    use(none, "a", 1);
  EXPECT_EQ(none.size(), 0u);
}

TEST(AdmittingLru, AFullCacheAdmitsOnlyWhatIsUsedMoreOftenThanItsVictim) {
  Cache c(30); // three values of 10 bytes
  for (const char* k : {"a", "b", "c"})
    for (int i = 0; i < 3; ++i)
      use(c, k);
  ASSERT_EQ(c.size(), 3u);
  // "a" is the least recently used (3 uses): "d" at 2 and 3 uses does not beat it...
  use(c, "d");
  use(c, "d");
  use(c, "d");
  EXPECT_FALSE(c.contains("d"));
  EXPECT_TRUE(c.contains("a"));
  // ... at 4 it does, and "a" goes.
  use(c, "d");
  EXPECT_TRUE(c.contains("d"));
  EXPECT_FALSE(c.contains("a"));
  EXPECT_TRUE(c.contains("b"));
  EXPECT_TRUE(c.contains("c"));
  EXPECT_LE(c.bytes(), 30u);
}

TEST(AdmittingLru, HotTilesSurviveAStreamOfTilesUsedTwice) {
  // What a plain LRU from the second use on got wrong: maps spread over many more tiles than the
  // budget holds pushed the tiles every map needs out before their next use.
  Cache c(40);
  const std::vector<std::string> hot{"L0/0", "L0/1", "L1/0", "L1/1"};
  for (int round = 0; round < 8; ++round)
    for (const auto& k : hot)
      use(c, k);
  for (const auto& k : hot)
    ASSERT_TRUE(c.contains(k));
  int hotHits = 0, hotUses = 0;
  for (int i = 0; i < 5000; ++i) {
    const std::string once = "L3/" + std::to_string(i);
    use(c, once);
    use(c, once);
    if (i % 50 == 0) { // the hot tiles keep being used, far less often than the stream
      for (const auto& k : hot) {
        hotHits += use(c, k) ? 1 : 0;
        ++hotUses;
      }
    }
  }
  EXPECT_EQ(hotHits, hotUses) << "a hot tile was pushed out by tiles used twice";
  EXPECT_LE(c.bytes(), 40u);
}

TEST(AdmittingLru, CountsAgeSoThatYesterdaysHotTilesGiveWay) {
  Cache c(20); // two values
  for (int i = 0; i < 50; ++i) {
    use(c, "old0");
    use(c, "old1");
  }
  const auto before = c.uses("old0");
  // Two new tiles become popular; the old ones are never asked for again. The counts halve every
  // 1,024 uses, so after a few periods the new tiles win the places.
  for (int i = 0; i < 3000; ++i) {
    use(c, "new0");
    use(c, "new1");
  }
  EXPECT_LT(c.uses("old0"), before);
  EXPECT_TRUE(c.contains("new0"));
  EXPECT_TRUE(c.contains("new1"));
  EXPECT_FALSE(c.contains("old0"));
  EXPECT_FALSE(c.contains("old1"));
}

TEST(AdmittingLru, TheCountedKeysAreBounded) {
  Cache c(1000);
  for (std::size_t i = 0; i < Cache::kMaxCountedKeys + 100; ++i)
    c.get("k" + std::to_string(i));
  EXPECT_LE(c.countedKeys(), Cache::kMaxCountedKeys);
}

TEST(AdmittingLru, TheBudgetHoldsForAnyMixOfSizes) {
  Cache c(1000);
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> key(0, 60);
  std::uniform_int_distribution<std::size_t> size(1, 400);
  std::size_t most = 0;
  for (int i = 0; i < 20000; ++i) {
    const std::string k = std::to_string(key(rng));
    if (!c.get(k)) {
      const std::size_t b = size(rng);
      if (c.admits(k, b)) c.put(k, std::make_shared<const int>(i), b);
    }
    ASSERT_LE(c.bytes(), 1000u);
    most = std::max(most, c.bytes());
  }
  EXPECT_GT(most, 500u) << "the cache was used";
}

} // namespace
} // namespace tellus
