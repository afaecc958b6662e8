#pragma once
// The cache's suite over every implementation of its index and tile store: a value-parameterised
// fixture whose parameter is the backend (SQLite + files, memory; PostgreSQL + files in
// tellus_cache_pg_tests, which sets sharedIndexOpener(); S3 with the SQLite index in
// tellus_cache_s3_tests, which sets s3StoreFactory(): this executable links neither). Each root is
// one cache: a folder for SQLite + files, an index and a store in memory kept across reopenings for
// memory, a database of its own and a folder for PostgreSQL. Time is a ManualClock shared by every
// cache of a test.

#include "../support/CacheFixtures.hpp"
#include "../support/MemoryTileIndex.hpp"
#include "../support/MemoryTileStore.hpp"
#include "../support/TempDir.hpp"

#include <tellus/cache/Clock.hpp>
#include <tellus/cache/TileCache.hpp>
#include <tellus/cache/TileIndex.hpp>
#include <tellus/cache/TileStore.hpp>

#include <gtest/gtest.h>

#include <expected>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <sys/resource.h>
#include <vector>

namespace tellus::test {

enum class Backend { SqliteFiles, Memory, PostgresFiles, S3, S3Tiered };

inline std::string backendName(const ::testing::TestParamInfo<Backend>& info) {
  switch (info.param) {
  case Backend::SqliteFiles:
    return "SqliteFiles";
  case Backend::Memory:
    return "Memory";
  case Backend::PostgresFiles:
    return "PostgresFiles";
  case Backend::S3:
    return "S3";
  case Backend::S3Tiered:
    return "S3Tiered";
  }
  return "?";
}

/** The backends the contract runs on in this executable (tests/cache/Backends.cpp: SQLite and
 * memory; tests/cache_pg/: PostgreSQL; tellus_cache_s3_tests instantiates S3 and S3Tiered). */
std::vector<Backend> contractBackends();

/** Opens the index of a server-backed backend (PostgreSQL) for the cache at `root`: the same
 * root, the same database. Set by the executable that runs such a backend. */
using SharedIndexOpener = std::function<std::expected<std::shared_ptr<ITileIndex>, CacheError>(
    const std::filesystem::path& root, bool readOnly)>;
inline SharedIndexOpener& sharedIndexOpener() {
  static SharedIndexOpener opener;
  return opener;
}

/** Backend::S3's store for a cache root (its own key prefix, its local folder under the root);
 * `tiered`: behind the file tree under the root (S3Tiered). */
using S3StoreFactory =
    std::function<std::shared_ptr<ITileStore>(const std::filesystem::path&, bool tiered)>;
inline S3StoreFactory& s3StoreFactory() {
  static S3StoreFactory factory;
  return factory;
}

class CacheBackendTest : public ::testing::TestWithParam<Backend> {
protected:
  std::shared_ptr<ManualClock> clock = std::make_shared<ManualClock>();
  TempDir dir{"backend"};

  /** Options of a cache at `root` (default: the test's folder): no fsync, the manual clock. */
  TileCache::Options options(const std::filesystem::path& root = {}) const {
    TileCache::Options o;
    o.root = root.empty() ? dir.path() : root;
    o.fsyncTiles = false;
    o.clock = clock;
    return o;
  }

  /** Opens (or reopens) the cache at o.root on this test's backend. */
  std::unique_ptr<TileCache> open(const TileCache::Options& o) {
    auto c = GetParam() == Backend::SqliteFiles ? TileCache::open(o)
             : GetParam() == Backend::Memory
                 ? TileCache::open(o, memoryAt(o.root).index, memoryAt(o.root).store)
             : GetParam() == Backend::PostgresFiles ? openShared(o)
                                                    : openS3(o);
    EXPECT_TRUE(c) << (c ? "" : c.error().message);
    return c ? std::move(*c) : nullptr;
  }
  std::unique_ptr<TileCache> open(std::uint64_t sizeLimitBytes = 0) {
    auto o = options();
    o.sizeLimitBytes = sizeLimitBytes;
    return open(o);
  }

  /** The tile store under the cache at `root` (files: another view of the same tree). */
  ITileStore& store(const std::filesystem::path& root = {}) {
    const auto at = root.empty() ? dir.path() : root;
    if (GetParam() == Backend::Memory) return *memoryAt(at).store;
    if (GetParam() == Backend::S3 || GetParam() == Backend::S3Tiered) return *s3At(at);
    auto& s = fileStores_[at.string()];
    if (!s) s = std::move(*openFileTileStore(FileTileStoreOptions{at, false, false}));
    return *s;
  }

  /** Where a tile of a registered dataset is stored. */
  static TileLocation at(const DatasetInfo& d, const TileKey& key) {
    return TileLocation{d.folder, d.spec.extension, key};
  }

  /** Makes the store refuse tiles of `tileBytes` bytes (`full`) or take them again. Files: a
   * file-size limit below them (EFBIG, for this process); memory: its capacity. */
  void fillStore(bool full, std::size_t tileBytes) {
    if (GetParam() == Backend::Memory) {
      auto& s = *memoryAt(dir.path()).store;
      s.setCapacity(full ? std::optional(s.usedBytes() + tileBytes / 2) : std::nullopt);
      return;
    }
    if (full) {
      ::getrlimit(RLIMIT_FSIZE, &savedLimit_);
      rlimit lim = savedLimit_;
      lim.rlim_cur = tileBytes / 2;
      ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &lim), 0);
      limited_ = true;
    } else if (limited_) {
      ::setrlimit(RLIMIT_FSIZE, &savedLimit_);
      limited_ = false;
    }
  }

  void TearDown() override {
    if (limited_) ::setrlimit(RLIMIT_FSIZE, &savedLimit_);
  }

private:
  std::expected<std::unique_ptr<TileCache>, CacheError> openShared(const TileCache::Options& o) {
    auto index = sharedIndexOpener()(o.root, o.readOnly);
    if (!index) return std::unexpected(index.error());
    auto store = openFileTileStore(FileTileStoreOptions{o.root, o.readOnly, o.fsyncTiles});
    if (!store) return std::unexpected(store.error());
    return TileCache::open(o, *index, std::shared_ptr<ITileStore>(std::move(*store)));
  }
  std::expected<std::unique_ptr<TileCache>, CacheError> openS3(const TileCache::Options& o) {
    if (!o.readOnly) std::filesystem::create_directories(o.root); // the local index's folder
    auto index = openSqliteTileIndex(
        SqliteTileIndexOptions{o.root, o.readOnly, o.busyTimeout, o.readConnections, o.clock});
    if (!index) return std::unexpected(index.error());
    return TileCache::open(o, std::move(*index), s3At(o.root));
  }
  std::shared_ptr<ITileStore> s3At(const std::filesystem::path& root) {
    auto& s = fileStores_[root.string()];
    if (!s) s = s3StoreFactory()(root, GetParam() == Backend::S3Tiered);
    return s;
  }

  struct Memory {
    std::shared_ptr<MemoryTileIndex> index;
    std::shared_ptr<MemoryTileStore> store;
  };
  Memory& memoryAt(const std::filesystem::path& root) {
    auto& m = memory_[root.string()];
    if (!m.index) {
      m.index = std::make_shared<MemoryTileIndex>();
      m.store = std::make_shared<MemoryTileStore>(clock);
    }
    return m;
  }

  std::map<std::string, Memory> memory_;
  std::map<std::string, std::shared_ptr<ITileStore>> fileStores_;
  rlimit savedLimit_{};
  bool limited_ = false;
};

} // namespace tellus::test
