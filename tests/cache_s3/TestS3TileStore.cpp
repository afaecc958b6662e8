// The S3 tile store against a real S3 server (Swift + s3api on loopback, S3Server.hpp): what the
// cache's contract (S3ContractSetup.cpp) does not say about object storage. Unit tests of the
// key layout, the listing parser, URLs and credentials need no server.

#include "../../cache/s3/src/S3Client.hpp"
#include "../../cache/s3/src/S3Keys.hpp"
#include "S3Server.hpp"

#include <tellus/cache/TileFile.hpp>
#include <tellus/cache_s3/TieredTileStore.hpp>

#include <curl/curl.h>

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <set>
#include <sys/resource.h>

using namespace tellus;
namespace fs = std::filesystem;

namespace {

std::vector<std::byte> bytes(std::string_view s) {
  const auto* p = reinterpret_cast<const std::byte*>(s.data());
  return {p, p + s.size()};
}

std::string text(const StoredTile& t) {
  const auto all = t.file->readAll();
  if (!all) return "<unreadable>";
  return std::string(reinterpret_cast<const char*>(all->data()), all->size());
}

class S3StoreIntegration : public ::testing::Test {
protected:
  test::TempDir dir{"s3store"};
  std::string prefix = test::uniquePrefix("store");

  std::unique_ptr<ITileStore> open(const std::string& p = {}) {
    auto& server = test::S3Server::get();
    EXPECT_TRUE(server.ok()) << server.error();
    auto s = openS3TileStore(server.options(p.empty() ? prefix : p, dir.path() / "local"));
    EXPECT_TRUE(s) << (s ? "" : s.error().message);
    return s ? std::move(*s) : nullptr;
  }

  static std::expected<void, CacheError>
  put(ITileStore& s, const TileLocation& at, std::string_view body, bool commit = true) {
    auto staged = s.stage(at, bytes(body));
    if (!staged) return std::unexpected(staged.error());
    auto r = (*staged)->install();
    (*staged)->finish(r && commit);
    EXPECT_TRUE(r) << (r ? "" : r.error().message);
    return r;
  }
};

const TileLocation kTile{"srv/ds", "jpg", TileKey{3, 5, 9}};

} // namespace

TEST_F(S3StoreIntegration, StoresReadsListsAndRemovesATile) {
  auto s = open();
  ASSERT_TRUE(s);
  EXPECT_FALSE(s->open(kTile, 5));
  ASSERT_TRUE(put(*s, kTile, "hello"));
  const auto t = s->open(kTile, 5);
  ASSERT_TRUE(t);
  EXPECT_EQ(text(*t), "hello");
  EXPECT_FALSE(s->open(kTile, 4)); // not the size the index says: not that tile
  const auto st = s->stat(kTile);
  ASSERT_TRUE(st);
  EXPECT_EQ(st->size, 5);
  EXPECT_EQ(st->version, t->version);

  ASSERT_TRUE(s->writeDescriptor("srv/ds", "name: ds\n"));
  EXPECT_EQ(s->readDescriptor("srv/ds"), "name: ds\n");
  EXPECT_EQ(s->datasetFolders(), std::vector<std::string>{"srv/ds"});
  std::vector<std::string> paths;
  s->scan("srv/ds", [&](const StoreEntry& e) { paths.push_back(e.path); });
  std::sort(paths.begin(), paths.end());
  EXPECT_EQ(paths, (std::vector<std::string>{"3/5/5_9.jpg", "dataset.txt"}));

  s->removeEntry("srv/ds", "3/5/5_9.jpg");
  EXPECT_FALSE(s->open(kTile, 5));
  EXPECT_FALSE(s->stat(kTile));
}

// A listing is a page of at most 1,000 keys (the servers' limit): a scan and a folder search
// follow the continuation tokens. Pages of 3 keys here: 11 entries of a dataset in 4 pages, and
// 7 dataset folders found through paged delimited listings.
TEST_F(S3StoreIntegration, ListingsFollowEveryPage) {
  auto& server = test::S3Server::get();
  ASSERT_TRUE(server.ok()) << server.error();
  auto options = server.options(prefix, dir.path() / "local");
  options.listPageKeys = 3;
  auto opened = openS3TileStore(options);
  ASSERT_TRUE(opened) << opened.error().message;
  ITileStore& s = **opened;
  std::vector<std::string> folders;
  for (int d = 0; d < 7; ++d) {
    folders.push_back("srv/ds" + std::to_string(d));
    ASSERT_TRUE(s.writeDescriptor(folders.back(), "name: ds\n"));
  }
  std::vector<std::string> expected{"dataset.txt"};
  for (std::int64_t c = 0; c < 10; ++c) {
    ASSERT_TRUE(put(s, TileLocation{"srv/ds0", "jpg", TileKey{3, 5, c}}, "tile"));
    expected.push_back("3/5/5_" + std::to_string(c) + ".jpg");
  }
  std::vector<std::string> paths;
  s.scan("srv/ds0", [&](const StoreEntry& e) { paths.push_back(e.path); });
  std::sort(paths.begin(), paths.end());
  std::sort(expected.begin(), expected.end());
  EXPECT_EQ(paths, expected);
  auto found = s.datasetFolders();
  std::sort(found.begin(), found.end());
  EXPECT_EQ(found, folders);
}

TEST_F(S3StoreIntegration, AnotherInstanceStoringTheSameTileSucceedsAndARefreshReplacesIt) {
  auto a = open();
  auto b = open();
  ASSERT_TRUE(a && b);
  ASSERT_TRUE(put(*a, kTile, "same"));
  ASSERT_TRUE(put(*b, kTile, "same")); // already there: success, nothing rewritten
  EXPECT_EQ(text(*a->open(kTile, 4)), "same");
  ASSERT_TRUE(put(*b, kTile, "newer")); // a refresh
  EXPECT_EQ(text(*a->open(kTile, 5)), "newer");
  ASSERT_TRUE(put(*a, kTile, "rolled", false)); // the index's commit failed: the old bytes back
  EXPECT_EQ(text(*a->open(kTile, 5)), "newer");
  const TileLocation fresh{"srv/ds", "jpg", TileKey{3, 1, 1}};
  ASSERT_TRUE(put(*a, fresh, "gone", false)); // a new tile rolled back is removed
  EXPECT_FALSE(a->stat(fresh));
}

TEST_F(S3StoreIntegration, ANewTileIsPutWhenStagedAndARollbackWithoutInstallRemovesIt) {
  // The PUT is made on the storing thread (stage), not on the index's writer thread (install):
  // tiles of many workers go out at once. A row never committed leaves no object behind.
  auto s = open();
  ASSERT_TRUE(s);
  const TileLocation t{"srv/ds", "jpg", TileKey{4, 2, 7}};
  auto staged = s->stage(t, bytes("early"));
  ASSERT_TRUE(staged) << staged.error().message;
  const auto st = s->stat(t);
  ASSERT_TRUE(st) << "not stored when staged";
  EXPECT_EQ(st->size, 5);
  (*staged)->finish(false); // the writer failed before it installed anything
  EXPECT_FALSE(s->stat(t)) << "a tile without a row was left in the bucket";
  // Staged, installed and committed: kept.
  auto kept = s->stage(t, bytes("kept!"));
  ASSERT_TRUE(kept);
  ASSERT_TRUE((*kept)->install());
  (*kept)->finish(true);
  EXPECT_EQ(text(*s->open(t, 5)), "kept!");
}

TEST_F(S3StoreIntegration, AStagedRemovalHidesTheTileAndARollbackPutsItBack) {
  auto s = open();
  ASSERT_TRUE(put(*s, kTile, "keep"));
  auto r = s->stageRemoval(kTile);
  ASSERT_TRUE(r->hide());
  EXPECT_FALSE(s->stat(kTile));
  r->finish(false);
  EXPECT_EQ(text(*s->open(kTile, 4)), "keep");
  auto r2 = s->stageRemoval(kTile);
  ASSERT_TRUE(r2->hide());
  r2->finish(true);
  EXPECT_FALSE(s->stat(kTile));
}

namespace {

struct Cut {
  std::size_t sent = 0;
  std::size_t stopAt = 0;
};

std::size_t discard(char*, std::size_t size, std::size_t n, void*) {
  return size * n;
}

std::size_t cutUpload(char* buf, std::size_t size, std::size_t n, void* user) {
  auto* c = static_cast<Cut*>(user);
  if (c->sent >= c->stopAt) return CURL_READFUNC_ABORT; // the writer dies mid-upload
  const std::size_t k = std::min(size * n, c->stopAt - c->sent);
  std::memset(buf, 'x', k);
  c->sent += k;
  return k;
}

/** A signed PUT of `declared` bytes that stops after `sent` of them, or (`sent` == declared)
 * one whose x-amz-content-sha256 names other bytes. Returns the HTTP status (0: cut). */
long brokenPut(const std::string& key, std::size_t declared, std::size_t sent) {
  auto& server = test::S3Server::get();
  CURL* curl = curl_easy_init();
  const std::string url = server.value("S3_ENDPOINT") + "/" + server.value("S3_BUCKET") + "/" +
                          s3::uriEncode(key, true);
  const std::string sigv4 = "aws:amz:" + server.value("S3_REGION") + ":s3";
  const std::string user = server.value("AWS_ACCESS_KEY_ID");
  const std::string pass = server.value("AWS_SECRET_ACCESS_KEY");
  const std::string hash = "x-amz-content-sha256: " + s3::sha256Hex(bytes("not these bytes"));
  // No "Expect:" header to drop 100-continue: libcurl 7.88 would sign it although it sends none.
  curl_slist* headers = curl_slist_append(nullptr, hash.c_str());
  Cut cut{0, sent};
  curl_easy_setopt(curl, CURLOPT_URL, url.c_str());
  curl_easy_setopt(curl, CURLOPT_AWS_SIGV4, sigv4.c_str());
  curl_easy_setopt(curl, CURLOPT_USERNAME, user.c_str());
  curl_easy_setopt(curl, CURLOPT_PASSWORD, pass.c_str());
  curl_easy_setopt(curl, CURLOPT_HTTPHEADER, headers);
  curl_easy_setopt(curl, CURLOPT_UPLOAD, 1L);
  curl_easy_setopt(curl, CURLOPT_READFUNCTION, cutUpload);
  curl_easy_setopt(curl, CURLOPT_READDATA, &cut);
  curl_easy_setopt(curl, CURLOPT_WRITEFUNCTION, discard);
  curl_easy_setopt(curl, CURLOPT_INFILESIZE_LARGE, static_cast<curl_off_t>(declared));
  curl_easy_setopt(curl, CURLOPT_TIMEOUT, 10L);
  const CURLcode rc = curl_easy_perform(curl);
  long status = 0;
  curl_easy_getinfo(curl, CURLINFO_RESPONSE_CODE, &status);
  curl_slist_free_all(headers);
  curl_easy_cleanup(curl);
  return rc == CURLE_OK ? status : 0;
}

} // namespace

TEST_F(S3StoreIntegration, ACutOrWrongUploadNeverLeavesAReadableObject) {
  auto s = open();
  ASSERT_TRUE(s);
  const s3::KeyLayout layout(prefix);
  // Killed mid-upload: 100000 bytes announced, 40000 sent.
  EXPECT_EQ(brokenPut(layout.tile(kTile), 100000, 40000), 0);
  EXPECT_FALSE(s->stat(kTile));
  EXPECT_FALSE(s->open(kTile, 40000));
  // All the bytes, but not the ones signed (a torn buffer): refused.
  const long status = brokenPut(layout.tile(kTile), 1000, 1000);
  EXPECT_GE(status, 400);
  EXPECT_FALSE(s->stat(kTile));
  // An old tile stays whole when its replacement is cut.
  ASSERT_TRUE(put(*s, kTile, "whole"));
  EXPECT_EQ(brokenPut(layout.tile(kTile), 100000, 40000), 0);
  EXPECT_EQ(text(*s->open(kTile, 5)), "whole");
}

TEST_F(S3StoreIntegration, CredentialsNeverAppearInErrors) {
  auto& server = test::S3Server::get();
  ASSERT_TRUE(server.ok()) << server.error();
  auto o = server.options(prefix, dir.path() / "local");
  o.credentials.secretAccessKey = "wrong-secret-Zq9";
  auto bad = openS3TileStore(o);
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error().code, CacheErrc::Io);
  EXPECT_NE(bad.error().message.find("403"), std::string::npos) << bad.error().message;
  EXPECT_EQ(bad.error().message.find("wrong-secret-Zq9"), std::string::npos);
  EXPECT_EQ(bad.error().message.find(o.credentials.accessKeyId), std::string::npos);

  // Nothing listening at the endpoint: the endpoint is named, the credentials are not.
  o.credentials.secretAccessKey = server.value("AWS_SECRET_ACCESS_KEY");
  o.endpoint = "http://127.0.0.1:1";
  auto down = openS3TileStore(o);
  ASSERT_FALSE(down);
  EXPECT_EQ(down.error().message.find(o.credentials.secretAccessKey), std::string::npos);
  EXPECT_NE(down.error().message.find("127.0.0.1:1"), std::string::npos) << down.error().message;
  // A store whose server goes away: the failed PUT names the tile, not the key.
  o.endpoint = server.value("S3_ENDPOINT");
  auto s = openS3TileStore(o);
  ASSERT_TRUE(s);
  const std::string secret = o.credentials.secretAccessKey;
  o.credentials.secretAccessKey = "rotated-Zq9";
  auto rotated = openS3TileStore(o);
  ASSERT_FALSE(rotated);
  EXPECT_EQ(rotated.error().message.find("rotated-Zq9"), std::string::npos);
  EXPECT_EQ(rotated.error().message.find(secret), std::string::npos);
}

TEST_F(S3StoreIntegration, AFullLocalFolderIsDiskFull) {
  auto s = open();
  ASSERT_TRUE(s);
  rlimit saved{};
  ::getrlimit(RLIMIT_FSIZE, &saved);
  rlimit lim = saved;
  lim.rlim_cur = 100;
  ::signal(SIGXFSZ, SIG_IGN);
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &lim), 0);
  auto staged = s->stage(kTile, std::vector<std::byte>(1000, std::byte{1}));
  ::setrlimit(RLIMIT_FSIZE, &saved);
  ASSERT_FALSE(staged);
  EXPECT_EQ(staged.error().code, CacheErrc::DiskFull);
  EXPECT_FALSE(s->stat(kTile)); // nothing was sent
}

// ------------------------------------------------------------------------------ no server

TEST(S3Keys, SpreadOverPrefixesAndNamedLikeTheFileTree) {
  const s3::KeyLayout layout("p/q");
  EXPECT_EQ(layout.descriptor("srv/ds"), "p/q/srv/ds/dataset.txt");
  const std::string k = layout.tile(kTile);
  EXPECT_TRUE(k.starts_with("p/q/srv/ds/")) << k;
  EXPECT_TRUE(k.ends_with("/3/5/5_9.jpg")) << k;
  std::set<std::string> spreads;
  for (int row = 0; row < 16; ++row)
    for (int col = 0; col < 16; ++col)
      spreads.insert(s3::KeyLayout::spread("srv/ds", TileKey{4, row, col}));
  EXPECT_GT(spreads.size(), 240u); // 256 tiles over 65536 prefixes: few collisions
  const std::string rest = k.substr(std::string("p/q/srv/ds/").size());
  EXPECT_EQ(s3::KeyLayout::entryPath("srv/ds", rest), "3/5/5_9.jpg");
  EXPECT_EQ(layout.keyOfEntry("srv/ds", "3/5/5_9.jpg"), k);
  EXPECT_EQ(s3::KeyLayout::entryPath("srv/ds", "zzzz/3/5/5_9.jpg"),
            "zzzz/3/5/5_9.jpg"); // a stray object stays itself
  EXPECT_EQ(layout.keyOfEntry("srv/ds", "zzzz/x"), "p/q/srv/ds/zzzz/x");
}

TEST(S3Keys, ParsesAListingPage) {
  const auto page = s3::parseListPage(
      "<?xml version='1.0'?><ListBucketResult><IsTruncated>true</IsTruncated>"
      "<Contents><Key>a/b&amp;c.jpg</Key><LastModified>2024-03-20T18:00:01.500Z</LastModified>"
      "<Size>42</Size></Contents><CommonPrefixes><Prefix>a/</Prefix></CommonPrefixes>"
      "<NextContinuationToken>tok/en=</NextContinuationToken></ListBucketResult>");
  ASSERT_TRUE(page);
  ASSERT_EQ(page->objects.size(), 1u);
  EXPECT_EQ(page->objects[0].key, "a/b&c.jpg");
  EXPECT_EQ(page->objects[0].size, 42);
  EXPECT_EQ(page->objects[0].modified, 1710957601500);
  EXPECT_EQ(page->commonPrefixes, std::vector<std::string>{"a/"});
  EXPECT_EQ(page->nextToken, "tok/en=");
  EXPECT_FALSE(s3::parseListPage("<Error><Code>AccessDenied</Code></Error>"));
  EXPECT_EQ(s3::uriEncode("a b/c~", true), "a%20b/c~");
  EXPECT_EQ(s3::uriEncode("a/b", false), "a%2Fb");
}

TEST(S3Url, ParsesBucketAndPrefix) {
  const auto u = parseS3Url("s3://tiles/prod/eu/");
  ASSERT_TRUE(u);
  EXPECT_EQ(u->bucket, "tiles");
  EXPECT_EQ(u->prefix, "prod/eu");
  EXPECT_EQ(parseS3Url("s3://tiles")->prefix, "");
  for (const char* bad : {"http://x/y", "s3://", "s3:///p", "s3://Upper/p", "s3://b/a//c"}) {
    const auto r = parseS3Url(bad);
    ASSERT_FALSE(r) << bad;
    EXPECT_EQ(r.error().code, CacheErrc::InvalidArgument);
  }
}

TEST(S3Credentials, FromTheEnvironmentElseAFileAndNeverInTheMessage) {
  test::TempDir dir{"s3cred"};
  const auto file = dir.path() / "credentials";
  std::ofstream(file) << "[other]\naws_access_key_id = NO\naws_secret_access_key = NO\n"
                      << "[default]\naws_access_key_id = AKFILE\n"
                      << "aws_secret_access_key = file-secret\n";
  ::unsetenv("AWS_PROFILE");
  ::setenv("AWS_ACCESS_KEY_ID", "AKENV", 1);
  ::setenv("AWS_SECRET_ACCESS_KEY", "env-secret", 1);
  EXPECT_EQ(s3CredentialsFromEnvironment(file)->accessKeyId, "AKENV");
  ::unsetenv("AWS_ACCESS_KEY_ID");
  ::unsetenv("AWS_SECRET_ACCESS_KEY");
  const auto c = s3CredentialsFromEnvironment(file);
  ASSERT_TRUE(c);
  EXPECT_EQ(c->accessKeyId, "AKFILE");
  EXPECT_EQ(c->secretAccessKey, "file-secret");
  std::ofstream(file) << "[default]\naws_access_key_id = AKHALF\n";
  const auto none = s3CredentialsFromEnvironment(file);
  ASSERT_FALSE(none);
  EXPECT_EQ(none.error().message.find("AKHALF"), std::string::npos);
  EXPECT_NE(none.error().message.find("AWS_ACCESS_KEY_ID"), std::string::npos);
}

TEST_F(S3StoreIntegration, TheLocalTierTakesACopyOfWhatItReadsFromTheSharedStore) {
  std::shared_ptr<ITileStore> shared = open();
  ASSERT_TRUE(shared);
  std::shared_ptr<ITileStore> local =
      std::move(*openFileTileStore(FileTileStoreOptions{dir.path() / "tier", false, false}));
  auto tiered = makeTieredTileStore(local, shared);
  ASSERT_TRUE(tiered->prepareDataset("srv/ds"));
  ASSERT_TRUE(put(*shared, kTile, "another instance stored it"));
  EXPECT_FALSE(local->stat(kTile));
  const auto t = tiered->open(kTile, 26);
  ASSERT_TRUE(t);
  EXPECT_EQ(text(*t), "another instance stored it");
  const auto copy = local->open(kTile, 26); // the next read is a local hit
  ASSERT_TRUE(copy);
  EXPECT_EQ(text(*copy), "another instance stored it");
  // Writes reach both tiers; removals leave neither.
  const TileLocation other{"srv/ds", "jpg", TileKey{3, 2, 2}};
  ASSERT_TRUE(put(*tiered, other, "both"));
  EXPECT_TRUE(local->stat(other));
  EXPECT_TRUE(shared->stat(other));
  tiered->remove(other);
  EXPECT_FALSE(local->stat(other));
  EXPECT_FALSE(shared->stat(other));
}

TEST_F(S3StoreIntegration, ALocalCopyOfAnotherVersionIsReplacedFromTheSharedStore) {
  std::shared_ptr<ITileStore> shared = open();
  ASSERT_TRUE(shared);
  std::shared_ptr<ITileStore> local =
      std::move(*openFileTileStore(FileTileStoreOptions{dir.path() / "tier", false, false}));
  auto tiered = makeTieredTileStore(local, shared);
  ASSERT_TRUE(tiered->prepareDataset("srv/ds"));
  ASSERT_TRUE(put(*tiered, kTile, "version one"));
  // Another instance refreshes the tile: new bytes of the same size in the shared store, a row
  // whose fetched-at is not the copy's (a minute behind it: only equality counts).
  ASSERT_TRUE(put(*shared, kTile, "version two"));
  const auto rowFetchedAt = std::chrono::duration_cast<std::chrono::milliseconds>(
                                std::chrono::system_clock::now().time_since_epoch())
                                .count() -
                            60000;
  TileLocation unknown = kTile; // no row's time: the local copy is served
  const auto old = tiered->open(unknown, 11);
  ASSERT_TRUE(old);
  EXPECT_EQ(text(*old), "version one");
  TileLocation newer = kTile;
  newer.fetchedAt = rowFetchedAt;
  const auto fresh = tiered->open(newer, 11);
  ASSERT_TRUE(fresh);
  EXPECT_EQ(text(*fresh), "version two");
  const auto copy = local->open(kTile, 11); // the local copy replaced
  ASSERT_TRUE(copy);
  EXPECT_EQ(text(*copy), "version two");
}

TEST_F(S3StoreIntegration, ALocalTierLimitKeepsTheTreeUnderItAndEveryTileIsStillServed) {
  std::shared_ptr<ITileStore> shared = open();
  ASSERT_TRUE(shared);
  const fs::path root = dir.path() / "tier";
  std::shared_ptr<ITileStore> local =
      std::move(*openFileTileStore(FileTileStoreOptions{root, false, false}));
  constexpr std::uint64_t kLimit = 20000; // 20 of the 60 tiles of 1,000 bytes
  auto tiered = makeTieredTileStore(local, shared, LocalTierOptions{kLimit, 0.9, root, {}});
  ASSERT_TRUE(tiered->prepareDataset("srv/ds"));
  auto at = [](int i) { return TileLocation{"srv/ds", "jpg", TileKey{6, 1, i}}; };
  auto body = [](int i) { return std::to_string(1000000 + i) + std::string(993, 'b'); };
  // The local tile files really on disk (not the record): every file that is not a temp or a
  // descriptor under the dataset folder.
  auto onDisk = [&] {
    std::uint64_t bytes = 0;
    for (const auto& e : fs::recursive_directory_iterator(root / "srv/ds")) {
      const std::string name = e.path().filename().string();
      if (e.is_regular_file() && !name.starts_with('.') && name != "dataset.txt")
        bytes += e.file_size();
    }
    return bytes;
  };
  for (int i = 0; i < 60; ++i)
    ASSERT_TRUE(put(*tiered, at(i), body(i)));
  tiered->settle();
  EXPECT_LE(onDisk(), kLimit);
  EXPECT_GE(tiered->localTier().evictions, 40U);
  for (int i = 0; i < 60; ++i) { // every tile served: from the local tier or the bucket
    const auto t = tiered->open(at(i), 1000);
    ASSERT_TRUE(t) << i;
    EXPECT_EQ(text(*t), body(i)) << i;
    EXPECT_TRUE(shared->stat(at(i))) << i; // the bucket keeps them all
  }
  tiered->settle();
  EXPECT_LE(onDisk(), kLimit);
  EXPECT_LE(tiered->localTier().bytes, kLimit);
}
