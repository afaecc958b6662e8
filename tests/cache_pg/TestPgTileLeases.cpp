// Single-flight leases in PostgreSQL between "instances" (each PgTileLeases has its own sessions,
// as two processes would): one holder, waiters woken by its NOTIFY, a dead holder's lease taken
// over. The proxy's use of them is in tests/cli/test_scale_out.sh.

#include "PgServer.hpp"

#include <tellus/cache_pg/PgTileLeases.hpp>

#include <gtest/gtest.h>

#include <chrono>
#include <future>

using namespace tellus;
using namespace std::chrono_literals;

namespace {

// Each test's leases live in a database of its own: ctest runs tests side by side, and advisory
// locks and notifications are per database (a shared one let a test find its tile leased by
// another).
std::shared_ptr<ITileLeases> openLeases(const std::string& uri) {
  PgConnectOptions o;
  o.conninfo = uri;
  auto l = openPgTileLeases(o);
  EXPECT_TRUE(l) << (l ? "" : l.error().message);
  return l ? *l : nullptr;
}

const LeaseKey kTile{"gibs/bluemarble", TileKey{5, 17, 40}};

} // namespace

TEST(PgTileLeases, OneHolderAtATimeAndItsReleaseWakesTheWaitersAtOnce) {
  const std::string db = test::pgCreateDatabase();
  auto a = openLeases(db);
  auto b = openLeases(db);
  auto c = openLeases(db);
  ASSERT_TRUE(a && b && c);
  EXPECT_TRUE(a->healthy());
  ASSERT_EQ(a->acquireOrWait(kTile, 60s, [] { FAIL() << "the holder is never woken"; }),
            LeaseOutcome::Acquired);
  std::promise<void> wokeB, wokeC;
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(b->acquireOrWait(kTile, 60s, [&] { wokeB.set_value(); }), LeaseOutcome::Waiting);
  EXPECT_EQ(c->acquireOrWait(kTile, 60s, [&] { wokeC.set_value(); }), LeaseOutcome::Waiting);
  // Another tile is free meanwhile.
  const LeaseKey other{"gibs/bluemarble", TileKey{5, 17, 41}};
  EXPECT_EQ(b->acquireOrWait(other, 60s, [] {}), LeaseOutcome::Acquired);
  b->release(other);
  a->release(kTile);
  // Woken by the NOTIFY, long before the 60 s recheck.
  ASSERT_EQ(wokeB.get_future().wait_for(30s), std::future_status::ready);
  ASSERT_EQ(wokeC.get_future().wait_for(30s), std::future_status::ready);
  EXPECT_LT(std::chrono::steady_clock::now() - start, 30s);
  // One of the woken takes it; the other waits again.
  EXPECT_EQ(b->acquireOrWait(kTile, 60s, [] {}), LeaseOutcome::Acquired);
  EXPECT_EQ(c->acquireOrWait(kTile, 60s, [] {}), LeaseOutcome::Waiting);
  b->release(kTile);
}

TEST(PgTileLeases, ProgressWakesTheWaitersAtOnceAndTheLeaseStaysHeld) {
  const std::string db = test::pgCreateDatabase();
  // A metatile's holder announces each tile stored: the other instances look again at once.
  auto a = openLeases(db);
  auto b = openLeases(db);
  ASSERT_TRUE(a && b);
  ASSERT_EQ(a->acquireOrWait(kTile, 60s, [] {}), LeaseOutcome::Acquired);
  std::promise<void> woke, again;
  ASSERT_EQ(b->acquireOrWait(kTile, 60s, [&] { woke.set_value(); }), LeaseOutcome::Waiting);
  a->progress(kTile);
  ASSERT_EQ(woke.get_future().wait_for(30s), std::future_status::ready) << "long before 60 s";
  // Still a's: b waits again, until a's release.
  ASSERT_EQ(b->acquireOrWait(kTile, 60s, [&] { again.set_value(); }), LeaseOutcome::Waiting);
  a->release(kTile);
  ASSERT_EQ(again.get_future().wait_for(30s), std::future_status::ready);
  EXPECT_EQ(b->acquireOrWait(kTile, 60s, [] {}), LeaseOutcome::Acquired);
  b->release(kTile);
}

TEST(PgTileLeases, ALeaseOfAProcessThatDiesIsFreeAtOnceAndItsWaitersTakeItAtTheirRecheck) {
  const std::string db = test::pgCreateDatabase();
  auto a = openLeases(db);
  auto b = openLeases(db);
  ASSERT_TRUE(a && b);
  ASSERT_EQ(a->acquireOrWait(kTile, 60s, [] {}), LeaseOutcome::Acquired);
  std::promise<void> woke;
  ASSERT_EQ(b->acquireOrWait(kTile, 200ms, [&] { woke.set_value(); }), LeaseOutcome::Waiting);
  a.reset(); // its sessions end without a release or a NOTIFY, as when it is killed
  ASSERT_EQ(woke.get_future().wait_for(30s), std::future_status::ready);
  EXPECT_EQ(b->acquireOrWait(kTile, 60s, [] {}), LeaseOutcome::Acquired);
  b->release(kTile);
}

TEST(PgTileLeases, OneProcessAskingTwiceForItsOwnLeaseWaitsLikeTheOthers) {
  const std::string db = test::pgCreateDatabase();
  auto a = openLeases(db);
  ASSERT_TRUE(a);
  ASSERT_EQ(a->acquireOrWait(kTile, 60s, [] {}), LeaseOutcome::Acquired);
  std::promise<void> woke;
  EXPECT_EQ(a->acquireOrWait(kTile, 60s, [&] { woke.set_value(); }), LeaseOutcome::Waiting);
  a->release(kTile);
  ASSERT_EQ(woke.get_future().wait_for(30s), std::future_status::ready);
  EXPECT_EQ(a->acquireOrWait(kTile, 60s, [] {}), LeaseOutcome::Acquired);
  a->release(kTile);
}

TEST(PgTileLeases, LocalLeasesAreAlwaysGranted) {
  auto l = localTileLeases();
  EXPECT_EQ(l->acquireOrWait(kTile, 1s, [] {}), LeaseOutcome::Acquired);
  EXPECT_EQ(l->acquireOrWait(kTile, 1s, [] {}), LeaseOutcome::Acquired);
  l->release(kTile);
  EXPECT_EQ(leaseNumber(kTile), leaseNumber(LeaseKey{"gibs/bluemarble", TileKey{5, 17, 40}}));
  EXPECT_NE(leaseNumber(kTile), leaseNumber(LeaseKey{"gibs/other", TileKey{5, 17, 40}}));
}
