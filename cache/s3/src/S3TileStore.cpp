// The S3 tile store (S3TileStore.hpp): immutable objects, one PUT to write, one GET to read.

#include "S3Client.hpp"
#include "S3Keys.hpp"

#include <tellus/cache/TilePath.hpp>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <sys/statvfs.h>
#include <thread>
#include <unistd.h>

namespace tellus {

namespace {

using Result = ITileStore::Result;
using Bytes = std::vector<std::byte>;

std::span<const std::byte> bytesOf(std::string_view s) {
  return {reinterpret_cast<const std::byte*>(s.data()), s.size()};
}

/** A version from an object's ETag (an MD5 of its bytes for a simple PUT): a replaced tile has
 * another one. */
TileVersion versionOf(std::string_view etag) {
  return TileVersion{0x53330000u, stableHash64(etag)};
}

/** The state every staged tile and removal shares with the store. */
struct Shared {
  explicit Shared(const S3TileStoreOptions& o) : options(o), client(o), layout(o.location.prefix) {}

  S3TileStoreOptions options;
  s3::Client client;
  s3::KeyLayout layout;
  /** 1: If-None-Match PUTs work; 0: unknown; -1: refused (Swift's s3api): look first. */
  std::atomic<int> conditionalPut{0};

  std::string encoded(const std::string& key) const { return s3::uriEncode(key, true); }

  s3::Response get(const std::string& key) {
    return client.send(s3::Request{"GET", encoded(key), {}, {}, {}});
  }
  s3::Response put(const std::string& key, std::span<const std::byte> bytes, bool ifNoneMatch) {
    const std::string path = encoded(key); // the request only views it
    s3::Request r{"PUT", path, {}, bytes, {}};
    if (ifNoneMatch) r.headers.emplace_back("If-None-Match: *");
    return client.send(r);
  }
  s3::Response del(const std::string& key) {
    return client.send(s3::Request{"DELETE", encoded(key), {}, {}, {}});
  }

  CacheError error(std::string_view what, const std::string& key, const s3::Response& r) const {
    return CacheError{CacheErrc::Io,
                      "S3 " + std::string(what) + " of " + key + " in bucket " +
                          options.location.bucket + " at " + options.endpoint + ": " +
                          r.describe()};
  }

  /** The bytes as an unlinked file of the local folder (ENOSPC/EFBIG: DiskFull). */
  std::expected<std::shared_ptr<const TileFile>, CacheError>
  localFile(std::span<const std::byte> bytes, const std::string& what) const {
    const int fd = ::open(options.localFolder.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
    auto fail = [&](int err) {
      const bool full = err == ENOSPC || err == EFBIG || err == EDQUOT;
      return std::unexpected(CacheError{full ? CacheErrc::DiskFull : CacheErrc::Io,
                                        "cannot write " + what + " to the local folder " +
                                            options.localFolder.string() + ": " +
                                            std::strerror(err)});
    };
    if (fd < 0) return fail(errno);
    std::size_t done = 0;
    while (done < bytes.size()) {
      const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) {
        const int err = n < 0 ? errno : ENOSPC;
        ::close(fd);
        return fail(err);
      }
      done += static_cast<std::size_t>(n);
    }
    return std::make_shared<const TileFile>(fd, static_cast<std::int64_t>(bytes.size()));
  }

  /** Stores `bytes` at `key` unless an object with other bytes is there (a refresh: left to
   * store(), in the writer's transaction, which keeps the old bytes for a rollback). `done`: the
   * object holds these bytes now; `created`: this call made it. Run when the tile is staged, on
   * the caller's thread: the PUTs of many tiles go out in parallel, not one after another on the
   * index's writer thread (bench/RESULTS.md, issue 27). */
  Result storeIfAbsent(const std::string& key,
                       std::span<const std::byte> bytes,
                       bool& done,
                       bool& created) {
    done = created = false;
    if (conditionalPut.load() >= 0) {
      const auto r = put(key, bytes, true);
      if (r.ok()) {
        conditionalPut.store(1);
        done = created = true;
        return {};
      }
      if (r.status == 412) return {}; // an object is there: store() compares
      if (r.status != 501) return std::unexpected(error("PUT", key, r));
      conditionalPut.store(-1);
    }
    const auto old = get(key);
    if (old.ok()) {
      const auto oldBytes = bytesOf(old.body);
      done = std::equal(oldBytes.begin(), oldBytes.end(), bytes.begin(), bytes.end());
      return {};
    }
    if (old.status != 404) return std::unexpected(error("GET", key, old));
    const auto r = put(key, bytes, false);
    if (!r.ok()) return std::unexpected(error("PUT", key, r));
    done = created = true;
    return {};
  }

  /** Puts `bytes` at `key`; says what was there before (nullopt: nothing) in `previous`. */
  Result store(const std::string& key,
               std::span<const std::byte> bytes,
               std::optional<Bytes>& previous,
               bool& created) {
    previous.reset();
    created = false;
    if (conditionalPut.load() >= 0) {
      const auto r = put(key, bytes, true);
      if (r.ok()) {
        conditionalPut.store(1);
        created = true;
        return {};
      }
      if (r.status != 412 && r.status != 501) return std::unexpected(error("PUT", key, r));
      if (r.status == 501) conditionalPut.store(-1); // refused: look first from now on
    }
    // There may be an object: the same bytes (another instance stored this tile: done) or a
    // refresh's old ones (kept for a rollback).
    const auto old = get(key);
    if (old.status != 404 && !old.ok()) return std::unexpected(error("GET", key, old));
    if (old.ok()) {
      const auto oldBytes = bytesOf(old.body);
      if (std::equal(oldBytes.begin(), oldBytes.end(), bytes.begin(), bytes.end())) return {};
      previous = Bytes(oldBytes.begin(), oldBytes.end());
    }
    const auto r = put(key, bytes, false);
    if (!r.ok()) return std::unexpected(error("PUT", key, r));
    created = !previous;
    return {};
  }
};

class S3StagedTile final : public StagedTile {
public:
  /** `done`, `created`: what Shared::storeIfAbsent did when the tile was staged. */
  S3StagedTile(std::shared_ptr<Shared> shared,
               std::string key,
               Bytes bytes,
               std::shared_ptr<const TileFile> file,
               bool done,
               bool created)
      : shared_(std::move(shared)), key_(std::move(key)), bytes_(std::move(bytes)),
        file_(std::move(file)), created_(created), done_(done), installed_(created) {}

  Result install() override {
    if (done_) return {}; // stored when staged: a rollback (install or not) removes what it made
    auto r = shared_->store(key_, bytes_, previous_, created_);
    installed_ = r.has_value();
    return r;
  }
  void finish(bool committed) override {
    if (installed_ && !committed) {
      if (previous_)
        shared_->put(key_, *previous_, false); // the refreshed tile's old bytes back
      else if (created_)
        shared_->del(key_);
    }
    installed_ = false;
    previous_.reset();
  }
  std::optional<StoredTile> open(std::int64_t size) const override {
    if (file_->size() != size) return std::nullopt;
    return StoredTile{file_, TileVersion{0x53330001u, stableHash64(key_)}};
  }

private:
  std::shared_ptr<Shared> shared_;
  std::string key_;
  Bytes bytes_;
  std::shared_ptr<const TileFile> file_;
  std::optional<Bytes> previous_;
  bool created_ = false;
  bool done_ = false;
  bool installed_ = false;
};

class S3Removal final : public StagedRemoval {
public:
  S3Removal(std::shared_ptr<Shared> shared, std::string key)
      : shared_(std::move(shared)), key_(std::move(key)) {}

  Result hide() override {
    const auto old = shared_->get(key_);
    if (old.status == 404) return {};
    if (!old.ok()) return std::unexpected(shared_->error("GET", key_, old));
    aside_ = Bytes(bytesOf(old.body).begin(), bytesOf(old.body).end());
    const auto r = shared_->del(key_);
    if (!r.ok() && r.status != 404) {
      aside_.reset();
      return std::unexpected(shared_->error("DELETE", key_, r));
    }
    return {};
  }
  void finish(bool committed) override {
    if (aside_ && !committed) shared_->put(key_, *aside_, false);
    aside_.reset();
  }

private:
  std::shared_ptr<Shared> shared_;
  std::string key_;
  std::optional<Bytes> aside_;
};

class S3TileStore final : public ITileStore {
public:
  explicit S3TileStore(std::shared_ptr<Shared> shared) : s_(std::move(shared)) {}

  Result prepareDataset(std::string_view) override { return {}; }

  std::optional<std::string> readDescriptor(std::string_view folder) override {
    auto r = s_->get(s_->layout.descriptor(folder));
    if (!r.ok()) return std::nullopt;
    return std::move(r.body);
  }

  Result writeDescriptor(std::string_view folder, std::string_view text) override {
    const auto key = s_->layout.descriptor(folder);
    const auto r = s_->put(key, bytesOf(text), false); // a whole object replaces the old one
    if (!r.ok()) return std::unexpected(s_->error("PUT", key, r));
    return {};
  }

  std::optional<StoredTile> open(const TileLocation& at, std::int64_t size) override {
    const auto key = s_->layout.tile(at);
    const auto r = s_->get(key);
    if (!r.ok() || static_cast<std::int64_t>(r.body.size()) != size) return std::nullopt;
    auto file = s_->localFile(bytesOf(r.body), key);
    if (!file) return std::nullopt;
    return StoredTile{std::move(*file), versionOf(r.etag)};
  }

  std::optional<TileStat> stat(const TileLocation& at) override {
    const auto r =
        s_->client.send(s3::Request{"HEAD", s_->encoded(s_->layout.tile(at)), {}, {}, {}});
    if (!r.ok() || r.contentLength < 0) return std::nullopt;
    return TileStat{r.contentLength, versionOf(r.etag)};
  }
  std::expected<std::optional<TileStat>, CacheError> statOrError(const TileLocation& at) override {
    const auto r =
        s_->client.send(s3::Request{"HEAD", s_->encoded(s_->layout.tile(at)), {}, {}, {}});
    if (r.status == 404) return std::nullopt;
    if (!r.ok() || r.contentLength < 0)
      return std::unexpected(CacheError{CacheErrc::Io, "S3 HEAD of a tile: " + r.describe()});
    return TileStat{r.contentLength, versionOf(r.etag)};
  }

  std::expected<std::shared_ptr<StagedTile>, CacheError>
  stage(const TileLocation& at, std::span<const std::byte> bytes) override {
    auto key = s_->layout.tile(at);
    auto file = s_->localFile(bytes, key);
    if (!file) return std::unexpected(file.error());
    bool done = false, created = false;
    if (auto stored = s_->storeIfAbsent(key, bytes, done, created); !stored)
      return std::unexpected(stored.error());
    return std::make_shared<S3StagedTile>(
        s_, std::move(key), Bytes(bytes.begin(), bytes.end()), std::move(*file), done, created);
  }

  /** A metatile's PUTs in parallel (one after another they cost a round trip each, and the last
   * tile's clients wait for all): up to kParallelPuts threads take the tiles in turn. */
  std::expected<std::vector<std::shared_ptr<StagedTile>>, CacheError>
  stageMany(std::span<const TileToStage> tiles) override {
    constexpr std::size_t kParallelPuts = 8;
    std::vector<std::expected<std::shared_ptr<StagedTile>, CacheError>> out(
        tiles.size(), std::unexpected(CacheError{CacheErrc::Io, "not staged"}));
    std::atomic<std::size_t> next{0};
    auto work = [&] {
      for (std::size_t i = next++; i < tiles.size(); i = next++)
        out[i] = stage(tiles[i].at, tiles[i].bytes);
    };
    {
      std::vector<std::jthread> helpers;
      for (std::size_t n = 1; n < std::min(kParallelPuts, tiles.size()); ++n)
        helpers.emplace_back(work);
      work();
    }
    std::vector<std::shared_ptr<StagedTile>> staged;
    std::optional<CacheError> failed;
    for (auto& r : out) {
      if (r)
        staged.push_back(std::move(*r));
      else if (!failed)
        failed = std::move(r.error());
    }
    if (!failed) return staged;
    for (const auto& t : staged)
      t->finish(false); // what its PUT made goes again
    return std::unexpected(std::move(*failed));
  }

  std::shared_ptr<StagedRemoval> stageRemoval(const TileLocation& at) override {
    return std::make_shared<S3Removal>(s_, s_->layout.tile(at));
  }

  void remove(const TileLocation& at) override { s_->del(s_->layout.tile(at)); }

  Result lockChanges(std::chrono::milliseconds) override { return {}; }
  void unlockChanges() override {}

  std::optional<DiskSpace> freeSpace() const override {
    struct statvfs v {};
    if (::statvfs(s_->options.localFolder.c_str(), &v) != 0) return std::nullopt;
    return DiskSpace{static_cast<std::uint64_t>(v.f_bavail) * v.f_frsize,
                     static_cast<std::uint64_t>(v.f_favail)};
  }

  std::size_t removeDeadTemps(std::string_view) override { return 0; }

  std::vector<std::string> datasetFolders() override {
    std::vector<std::string> out;
    findFolders(s_->layout.folder(""), 0, out);
    return out;
  }

  /** Folders ("server/dataset": several levels) are those holding a dataset.txt; one delimited
   * listing per level, never a listing of the tiles. */
  void findFolders(const std::string& under, int depth, std::vector<std::string>& out) {
    const std::string root = s_->layout.folder("");
    std::vector<std::string> below;
    bool isDataset = false;
    list(under, true, [&](const s3::ListPage& page) {
      for (const auto& o : page.objects)
        isDataset = isDataset || o.key == under + "dataset.txt";
      for (const auto& p : page.commonPrefixes)
        if (p.starts_with(under) && p.size() > under.size()) below.push_back(p);
    });
    if (isDataset) {
      out.push_back(under.substr(root.size(), under.size() - root.size() - 1));
      return; // below it are its tiles
    }
    if (depth >= 4) return;
    for (const auto& p : below)
      findFolders(p, depth + 1, out);
  }

  void scan(std::string_view folder, const EntryVisitor& visit) override {
    if (folder.empty()) return; // nothing is kept beside the datasets
    const std::string root = s_->layout.folder(folder);
    list(root, false, [&](const s3::ListPage& page) {
      for (const auto& o : page.objects) {
        if (!o.key.starts_with(root)) continue;
        const std::string rest = o.key.substr(root.size());
        StoreEntry e;
        e.path = s3::KeyLayout::entryPath(folder, rest);
        e.kind = rest == "dataset.txt" ? StoreEntry::Kind::Descriptor : StoreEntry::Kind::Tile;
        e.size = o.size;
        e.modified = o.modified;
        visit(e);
      }
    });
  }

  void removeEntry(std::string_view folder, std::string_view path) override {
    s_->del(s_->layout.keyOfEntry(folder, path));
  }

  /** ListObjectsV2 of everything under `prefix` (with a '/' delimiter: one level), page by page;
   * false when a page failed. The query is built sorted, as SigV4 wants it. */
  bool list(const std::string& prefix,
            bool delimited,
            const std::function<void(const s3::ListPage&)>& each) {
    std::optional<std::string> token;
    do {
      std::string q;
      if (token) q += "continuation-token=" + s3::uriEncode(*token, false) + "&";
      if (delimited) q += "delimiter=%2F&";
      q += "list-type=2&max-keys=" + std::to_string(std::clamp(s_->options.listPageKeys, 1, 1000));
      q += "&prefix=" + s3::uriEncode(prefix, false);
      const auto r = s_->client.send(s3::Request{"GET", "", q, {}, {}});
      if (!r.ok()) return false;
      const auto page = s3::parseListPage(r.body);
      if (!page) return false;
      each(*page);
      token = page->nextToken;
    } while (token);
    return true;
  }

private:
  std::shared_ptr<Shared> s_;
};

} // namespace

std::expected<std::unique_ptr<ITileStore>, CacheError>
openS3TileStore(const S3TileStoreOptions& options) {
  if (options.endpoint.empty() || options.location.bucket.empty())
    return std::unexpected(
        CacheError{CacheErrc::InvalidArgument, "S3 store: no endpoint or bucket"});
  std::error_code ec;
  std::filesystem::create_directories(options.localFolder, ec);
  if (ec) {
    return std::unexpected(CacheError{CacheErrc::Io,
                                      "cannot create the S3 store's local folder " +
                                          options.localFolder.string() + ": " + ec.message()});
  }
  auto shared = std::make_shared<Shared>(options);
  const std::string q =
      "list-type=2&max-keys=1&prefix=" + s3::uriEncode(shared->layout.folder(""), false);
  const auto r = shared->client.send(s3::Request{"GET", "", q, {}, {}});
  if (!r.ok()) {
    return std::unexpected(CacheError{CacheErrc::Io,
                                      "S3 bucket " + options.location.bucket + " at " +
                                          options.endpoint + " does not answer: " + r.describe()});
  }
  return std::make_unique<S3TileStore>(std::move(shared));
}

} // namespace tellus
