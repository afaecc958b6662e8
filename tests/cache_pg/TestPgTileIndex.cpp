// What is PostgreSQL's own in the index: connection strings and their passwords, several indexes
// (instances) on one database. The rows' behaviour is the cache contract's (PgBackends.cpp).

#include "../support/CacheFixtures.hpp"
#include "../support/TempDir.hpp"
#include "PgServer.hpp"

#include <tellus/cache_pg/PgTileIndex.hpp>

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <future>
#include <thread>
#include <vector>

using namespace tellus;

namespace {

std::unique_ptr<ITileIndex> openAt(const std::string& uri) {
  PgTileIndexOptions o;
  o.connect.conninfo = uri;
  auto index = openPgTileIndex(o);
  EXPECT_TRUE(index) << (index ? "" : index.error().message);
  return index ? std::move(*index) : nullptr;
}

} // namespace

TEST(PgTileIndex, RedactsPasswordsOfUrisAndKeywordStrings) {
  EXPECT_EQ(redactConninfo("postgresql://tile:s3cret@db.example:5432/tellus?sslmode=require"),
            "postgresql://tile:***@db.example:5432/tellus?sslmode=require");
  EXPECT_EQ(redactConninfo("postgresql://db/tellus?user=u&password=s3cret&x=1"),
            "postgresql://db/tellus?user=u&password=***&x=1");
  EXPECT_EQ(redactConninfo("host=db password=s3cret dbname=t"), "host=db password=*** dbname=t");
  EXPECT_EQ(redactConninfo("postgresql://tile@db/tellus"), "postgresql://tile@db/tellus");
  EXPECT_TRUE(isPostgresUri("postgres://db/t"));
  EXPECT_FALSE(isPostgresUri("/var/cache/tellus"));
}

TEST(PgTileIndex, RefusesAPasswordInTheConnectionStringWithoutRepeatingIt) {
  for (const char* uri : {"postgresql://tile:s3cret@127.0.0.1/tellus",
                          "postgresql://127.0.0.1/tellus?password=s3cret",
                          "host=127.0.0.1 password=s3cret"}) {
    PgTileIndexOptions o;
    o.connect.conninfo = uri;
    auto index = openPgTileIndex(o);
    ASSERT_FALSE(index) << uri;
    EXPECT_EQ(index.error().code, CacheErrc::InvalidArgument);
    EXPECT_NE(index.error().message.find("PGPASSWORD"), std::string::npos);
    EXPECT_EQ(index.error().message.find("s3cret"), std::string::npos) << index.error().message;
  }
  PgTileIndexOptions bad;
  bad.connect.conninfo = "postgresql://[::1";
  EXPECT_FALSE(openPgTileIndex(bad));
}

TEST(PgTileIndex, AFailingConnectionSaysWhereButNeverThePassword) {
  test::TempDir dir{"pgpw"};
  const auto file = dir.path() / "password";
  std::ofstream(file) << "pw-from-file-9d1\n";
  ::setenv("PGPASSWORD", "pw-from-env-7c2", 1);
  PgTileIndexOptions o;
  // Nothing listens on port 1; then a server that knows no such database.
  for (const std::string& uri :
       {std::string("postgresql://tile@127.0.0.1:1/tellus"), test::pgUriOf("no_such_db")}) {
    o.connect.conninfo = uri;
    for (bool withFile : {false, true}) {
      o.connect.passwordFile = withFile ? std::optional(file) : std::nullopt;
      auto index = openPgTileIndex(o);
      ASSERT_FALSE(index);
      const std::string& m = index.error().message;
      EXPECT_NE(m.find("cannot connect to PostgreSQL at"), std::string::npos) << m;
      EXPECT_EQ(m.find("pw-from-file"), std::string::npos) << m;
      EXPECT_EQ(m.find("pw-from-env"), std::string::npos) << m;
    }
  }
  ::unsetenv("PGPASSWORD");
  o.connect.conninfo = test::pgAdminUri();
  o.connect.passwordFile = dir.path() / "missing";
  auto missing = openPgTileIndex(o);
  ASSERT_FALSE(missing);
  EXPECT_NE(missing.error().message.find("password file"), std::string::npos);
}

TEST(PgTileIndex, InstancesOnOneDatabaseShareRowsAndNoticeEachOthersCommits) {
  const std::string uri = test::pgCreateDatabase();
  auto a = openAt(uri);
  auto b = openAt(uri);
  ASSERT_TRUE(a && b);
  EXPECT_FALSE(a->changedByOthers());
  EXPECT_FALSE(b->changedByOthers());
  const auto spec = test::imagerySpec("bluemarble");
  ASSERT_TRUE(a->begin());
  auto da = a->upsertDataset(spec, "local/bluemarble", 1000);
  ASSERT_TRUE(da);
  TileRow row;
  row.bytes = 1234;
  row.meta.contentType = "image/jpeg";
  row.meta.etag = "\"e\"";
  row.meta.fetchedAt = 5000;
  ASSERT_TRUE(a->putRow(da->id, TileKey{3, 4, 5}, row));
  EXPECT_FALSE(b->lookup(da->id, TileKey{3, 4, 5}).value()); // not committed yet
  ASSERT_TRUE(a->commit());
  EXPECT_FALSE(a->changedByOthers()) << "its own commit";
  EXPECT_TRUE(b->changedByOthers());
  EXPECT_FALSE(b->changedByOthers());
  auto seen = b->lookup(da->id, TileKey{3, 4, 5});
  ASSERT_TRUE(seen && *seen);
  EXPECT_EQ((*seen)->bytes, 1234);
  EXPECT_EQ((*seen)->meta.etag, "\"e\"");
  // The same dataset registered by another instance is the same row.
  ASSERT_TRUE(b->begin());
  auto db = b->upsertDataset(spec, "local/bluemarble", 2000);
  ASSERT_TRUE(db && b->commit());
  EXPECT_EQ(db->id, da->id);
  EXPECT_EQ(db->createdAt, 1000);
  EXPECT_EQ(b->totalBytes().value(), 1234);
  EXPECT_EQ(a->integrity(), "ok");
}

// Last-access times are advisory: an instance's touch of a row another instance's transaction
// holds skips it at once. It used to wait for that transaction, and three instances touching the
// same hot tiles in their own orders deadlocked, each writer standing still for PostgreSQL's
// deadlock_timeout (a second) with its tiles' stores behind it.
TEST(PgTileIndex, ATouchNeverWaitsForAnotherInstancesLock) {
  const std::string uri = test::pgCreateDatabase();
  auto a = openAt(uri);
  auto b = openAt(uri);
  ASSERT_TRUE(a && b);
  ASSERT_TRUE(a->begin());
  auto d = a->upsertDataset(test::imagerySpec("bm"), "local/bm", 1);
  ASSERT_TRUE(d);
  TileRow row;
  row.bytes = 10;
  for (std::int64_t c = 0; c < 2; ++c)
    ASSERT_TRUE(a->putRow(d->id, TileKey{0, 0, c}, row));
  ASSERT_TRUE(a->commit());
  ASSERT_TRUE(a->begin());
  a->touch(d->id, TileKey{0, 0, 0}, 100); // holds tile (0, 0, 0) until its commit
  auto other = std::async(std::launch::async, [&] {
    if (!b->begin()) return false;
    b->touch(d->id, TileKey{0, 0, 0}, 200); // held: skipped
    b->touch(d->id, TileKey{0, 0, 1}, 200); // free: touched
    return b->commit().has_value();
  });
  const bool prompt = other.wait_for(std::chrono::seconds(2)) == std::future_status::ready;
  EXPECT_TRUE(prompt) << "the touch waited for the other instance's transaction";
  ASSERT_TRUE(a->commit());
  EXPECT_TRUE(other.get());
}

TEST(PgTileIndex, ARolledBackSavepointUndoesItsOperationOnly) {
  auto a = openAt(test::pgCreateDatabase());
  ASSERT_TRUE(a);
  ASSERT_TRUE(a->begin());
  auto d = a->upsertDataset(test::imagerySpec("bm"), "local/bm", 1);
  ASSERT_TRUE(d);
  TileRow row;
  row.bytes = 10;
  a->savepoint();
  ASSERT_TRUE(a->putRow(d->id, TileKey{0, 0, 0}, row));
  a->releaseSavepoint();
  a->savepoint();
  ASSERT_TRUE(a->putRow(d->id, TileKey{0, 0, 1}, row));
  a->rollbackToSavepoint();
  a->releaseSavepoint();
  ASSERT_TRUE(a->commit());
  EXPECT_TRUE(a->lookup(d->id, TileKey{0, 0, 0}).value());
  EXPECT_FALSE(a->lookup(d->id, TileKey{0, 0, 1}).value());
  EXPECT_EQ(a->totalBytes().value(), 10);
}

TEST(PgTileIndex, InstancesStartedAtOnceOnAnEmptyDatabaseCreateTheSchemaOnce) {
  // Three `tellus serve` started together: each saw no schema, the first created it under the
  // lock, and the others, woken, must see it (a backend's catalog cache of "no such table" from
  // before it waited used to make them create it again: "relation already exists").
  for (int attempt = 0; attempt < 3; ++attempt) {
    const std::string uri = test::pgCreateDatabase();
    constexpr std::size_t kInstances = 8;
    std::vector<std::string> errors(kInstances);
    std::vector<std::thread> threads;
    for (std::size_t i = 0; i < kInstances; ++i) {
      threads.emplace_back([&, i] {
        PgTileIndexOptions o;
        o.connect.conninfo = uri;
        auto index = openPgTileIndex(o);
        if (!index) errors[i] = index.error().message;
      });
    }
    for (auto& t : threads)
      t.join();
    for (const auto& e : errors)
      EXPECT_EQ(e, "");
  }
}

TEST(PgTileIndex, PutRowsWritesWhatPutRowWritesInOneStatement) {
  // A metatile's rows in one INSERT (putRows) against the same rows one by one: the same rows
  // back, the usage triggers counting each, a replaced row replaced, a key given twice the last.
  const std::string uri = test::pgCreateDatabase();
  auto a = openAt(uri);
  ASSERT_TRUE(a);
  ASSERT_TRUE(a->begin());
  const auto many = a->upsertDataset(test::imagerySpec("many"), "local/many", 1000).value();
  const auto single = a->upsertDataset(test::imagerySpec("single"), "local/single", 1000).value();
  ASSERT_TRUE(a->commit());
  std::vector<std::pair<TileKey, TileRow>> rows;
  for (std::int64_t c = 0; c < 300; ++c) { // more rows than one statement takes
    TileRow r;
    r.bytes = 1000 + c;
    r.meta.contentType = c % 2 ? "image/png" : "image/jpeg";
    r.meta.etag = c % 3 ? "\"e" + std::to_string(c) + "\"" : "";
    r.meta.lastModified = "Tue, 01 Jun 2004 00:00:00 GMT";
    r.meta.expiresAt = c % 4 ? std::optional<std::int64_t>(9000 + c) : std::nullopt;
    r.meta.fetchedAt = 5000 + c;
    if (c % 5 == 0) {
      r.present = false;
      r.retryAfter = 7000 + c;
    }
    rows.emplace_back(TileKey{4, c / 16, c % 16}, r);
  }
  ASSERT_TRUE(a->begin());
  ASSERT_TRUE(a->putRows(many.id, rows));
  for (const auto& [k, r] : rows)
    ASSERT_TRUE(a->putRow(single.id, k, r));
  ASSERT_TRUE(a->commit());
  for (const auto& [k, r] : rows) {
    const auto x = a->lookup(many.id, k).value();
    const auto y = a->lookup(single.id, k).value();
    ASSERT_TRUE(x && y);
    EXPECT_EQ(x->present, y->present);
    EXPECT_EQ(x->bytes, y->bytes);
    EXPECT_EQ(x->retryAfter, y->retryAfter);
    EXPECT_EQ(x->meta.contentType, y->meta.contentType);
    EXPECT_EQ(x->meta.etag, y->meta.etag);
    EXPECT_EQ(x->meta.expiresAt, y->meta.expiresAt);
    EXPECT_EQ(x->meta.fetchedAt, y->meta.fetchedAt);
  }
  LevelStats sums[2];
  const auto counts = a->levelCounts();
  ASSERT_TRUE(counts);
  for (const auto& c : *counts) {
    LevelStats& s = sums[c.dataset == many.id ? 0 : 1];
    s.tiles += c.level.tiles;
    s.absent += c.level.absent;
    s.bytes += c.level.bytes;
  }
  EXPECT_EQ(sums[0].tiles, 300); // every row, the 60 absent ones too
  EXPECT_EQ(sums[0].absent, 60);
  EXPECT_EQ(sums[0].tiles, sums[1].tiles);
  EXPECT_EQ(sums[0].absent, sums[1].absent);
  EXPECT_EQ(sums[0].bytes, sums[1].bytes);
  EXPECT_EQ(a->totalBytes().value(), sums[0].bytes + sums[1].bytes); // the usage triggers
  // Replaced rows, and one key twice (the last wins).
  rows.resize(3);
  rows[0].second.bytes = 1;
  rows[1].second.bytes = 2;
  rows[2] = rows[0];
  rows[2].second.bytes = 3;
  ASSERT_TRUE(a->begin());
  ASSERT_TRUE(a->putRows(many.id, rows));
  ASSERT_TRUE(a->commit());
  EXPECT_EQ(a->lookup(many.id, rows[0].first).value()->bytes, 3);
  EXPECT_EQ(a->lookup(many.id, rows[1].first).value()->bytes, 2);
}
