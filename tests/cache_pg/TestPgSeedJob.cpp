// A seeding job shared by several seeders (PgSeedJob, issue 27): every band taken by one seeder
// once, a seeder that dies gives its band back, the finished job is forgotten.

#include "PgServer.hpp"

#include <tellus/cache_pg/PgSeedJob.hpp>

#include <gtest/gtest.h>

#include <set>

using namespace tellus;

namespace {

PgConnectOptions connectTo(const std::string& uri) {
  PgConnectOptions o;
  o.conninfo = uri;
  return o;
}

/** A database with the index's schema (which holds seed_bands). */
std::string indexedDatabase() {
  const std::string uri = test::pgCreateDatabase();
  PgTileIndexOptions o;
  o.connect = connectTo(uri);
  EXPECT_TRUE(openPgTileIndex(o));
  return uri;
}

std::vector<SeedBand> bands(int n) {
  std::vector<SeedBand> out;
  for (int i = 0; i < n; ++i)
    out.push_back(SeedBand{i % 3, i});
  return out;
}

} // namespace

TEST(PgSeedJob, TwoSeedersTakeEveryBandOnceBetweenThem) {
  const std::string uri = indexedDatabase();
  auto a = PgSeedJob::open(connectTo(uri), "job", bands(9));
  auto b = PgSeedJob::open(connectTo(uri), "job", bands(9)); // the same command, started later
  ASSERT_TRUE(a && b);
  std::multiset<std::int64_t> taken;
  std::set<std::int64_t> byA, byB;
  for (bool aDone = false, bDone = false; !aDone || !bDone;) {
    if (!aDone) {
      auto n = (*a)->next();
      ASSERT_TRUE(n) << n.error().message;
      if (*n) {
        taken.insert((*n)->row);
        byA.insert((*n)->row);
      } else {
        aDone = true;
      }
    }
    if (!bDone) {
      auto n = (*b)->next();
      ASSERT_TRUE(n) << n.error().message;
      if (*n) {
        taken.insert((*n)->row);
        byB.insert((*n)->row);
      } else {
        bDone = true;
      }
    }
  }
  EXPECT_EQ(taken.size(), 9u);
  EXPECT_EQ(std::set<std::int64_t>(taken.begin(), taken.end()).size(), 9u) << "a band taken twice";
  EXPECT_FALSE(byA.empty());
  EXPECT_FALSE(byB.empty());
  // Finished and forgotten: the same command again is a new job with every band.
  auto c = PgSeedJob::open(connectTo(uri), "job", bands(9));
  ASSERT_TRUE(c);
  int again = 0;
  while (auto n = (*c)->next().value())
    ++again;
  EXPECT_EQ(again, 9);
}

TEST(PgSeedJob, ASeederThatDiesGivesItsBandBack) {
  const std::string uri = indexedDatabase();
  auto a = PgSeedJob::open(connectTo(uri), "job", bands(2));
  auto b = PgSeedJob::open(connectTo(uri), "job", bands(2));
  ASSERT_TRUE(a && b);
  const auto first = (*a)->next().value();
  ASSERT_TRUE(first);
  const auto second = (*b)->next().value();
  ASSERT_TRUE(second);
  EXPECT_NE(first->row, second->row);
  a->reset(); // dies with its band unfinished: its transaction, and lock, go with it
  const auto retaken = (*b)->next().value();
  ASSERT_TRUE(retaken);
  EXPECT_EQ(*retaken, *first);
  EXPECT_FALSE((*b)->next().value());
}
