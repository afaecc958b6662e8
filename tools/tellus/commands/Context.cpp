#include "Context.hpp"

#include <tellus/cache/TileIndex.hpp>
#include <tellus/cache/TileStore.hpp>
#include <tellus/cache_pg/PgTileIndex.hpp>
#include <tellus/cache_pg/PgTileLeases.hpp>
#include <tellus/cache_s3/S3TileStore.hpp>
#include <tellus/cache_s3/TieredTileStore.hpp>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <sys/resource.h>
#include <utility>

namespace fs = std::filesystem;

namespace tellus::commands {

fs::path dataDir(const cli::Args& a) {
  if (auto d = a.get("data")) return *d;
  if (const char* e = std::getenv("TELLUS_DATA_DIR"); e && *e) return e;
  return TELLUS_SOURCE_DATA_DIR;
}

std::optional<Config> loadConfiguration(const cli::Args& a) {
  Config config;
  if (auto file = a.get("config")) {
    auto loaded = loadConfig(*file);
    if (!loaded) {
      std::fprintf(stderr, "tellus: configuration: %s\n", loaded.error().toString().c_str());
      return std::nullopt;
    }
    config = std::move(*loaded);
    if (auto c = a.get("cache")) config.cache.root = *c;
  } else {
    const fs::path root = a.get("cache") ? fs::path(*a.get("cache")) : defaultCacheRoot();
    config = embeddedDefault(dataDir(a), root);
  }
  if (auto v = validate(config); !v) {
    std::fprintf(stderr, "tellus: configuration: %s\n", v.error().c_str());
    return std::nullopt;
  }
  return config;
}

std::size_t descriptorBudget(int maxConnections) {
  rlimit rl{};
  if (::getrlimit(RLIMIT_NOFILE, &rl) != 0) return 64;
  const rlim_t wanted = std::min<rlim_t>(rl.rlim_max, 1 << 20);
  if (rl.rlim_cur < wanted) {
    rlimit raised = rl;
    raised.rlim_cur = wanted;
    if (::setrlimit(RLIMIT_NOFILE, &raised) == 0) rl = raised;
  }
  const auto limit = static_cast<long long>(std::min<rlim_t>(rl.rlim_cur, 1 << 20));
  const long long spare = limit - maxConnections - 256; // SQLite, libcurl, logs, the listener
  return static_cast<std::size_t>(std::clamp(spare / 2, 64LL, 16384LL));
}

namespace {

/** The tile store `cache.store` names: the file tree under the root (the embedded default), or
 * S3-compatible object storage (issue 27) with the file tree in front (`cache.s3.local_tier`,
 * bounded by `cache.s3.local_tier_limit`); read tiles land in `<root>/s3-local` (unlinked files)
 * on their way. */
std::expected<std::shared_ptr<ITileStore>, CacheError> openStore(Context& ctx,
                                                                 const TileCache::Options& o) {
  const auto& c = ctx.config.cache;
  if (c.store.empty()) {
    auto files = openFileTileStore(FileTileStoreOptions{o.root, o.readOnly, o.fsyncTiles});
    if (!files) return std::unexpected(files.error());
    return std::shared_ptr<ITileStore>(std::move(*files));
  }
  auto url = parseS3Url(c.store);
  if (!url) return std::unexpected(url.error());
  auto credentials = s3CredentialsFromEnvironment(c.s3.credentialsFile);
  if (!credentials) return std::unexpected(credentials.error());
  S3TileStoreOptions so;
  so.endpoint = c.s3.endpoint;
  so.region = c.s3.region;
  so.location = std::move(*url);
  so.credentials = std::move(*credentials);
  so.localFolder = o.root / "s3-local";
  auto s3 = openS3TileStore(so);
  if (!s3) return std::unexpected(s3.error());
  std::shared_ptr<ITileStore> store = std::move(*s3);
  if (c.s3.localTier) { // the file tree under the root in front of the bucket
    auto local = openFileTileStore(FileTileStoreOptions{o.root, o.readOnly, o.fsyncTiles});
    if (!local) return std::unexpected(local.error());
    LocalTierOptions tier;
    tier.limitBytes = o.readOnly ? 0 : c.s3.localTierLimitBytes; // offline media: kept whole
    tier.root = o.root;
    std::shared_ptr<TieredTileStore> tiered =
        makeTieredTileStore(std::move(*local), std::move(store), tier);
    if (tier.limitBytes > 0) ctx.boundedTier = tiered;
    store = std::move(tiered);
  }
  return store;
}

/** A cache that is not the embedded default (issue 27): the index in SQLite under the root or in
 * PostgreSQL (`cache.index`, shared by several instances, with the single-flight leases), the
 * tiles where `cache.store` says (a folder every instance mounts, or object storage). */
std::expected<std::unique_ptr<TileCache>, CacheError> openScaledOut(Context& ctx,
                                                                    const TileCache::Options& o) {
  std::error_code ec;
  if (!o.readOnly) fs::create_directories(o.root, ec); // the local index's, tier's folder
  auto store = openStore(ctx, o);
  if (!store) return std::unexpected(store.error());
  if (ctx.config.cache.index.empty()) {
    auto index = openSqliteTileIndex(
        SqliteTileIndexOptions{o.root, o.readOnly, o.busyTimeout, o.readConnections, o.clock});
    if (!index) return std::unexpected(index.error());
    return TileCache::open(o, std::move(*index), std::move(*store));
  }
  PgConnectOptions connect;
  connect.conninfo = ctx.config.cache.index;
  connect.passwordFile = ctx.config.cache.indexPasswordFile;
  PgTileIndexOptions io;
  io.connect = connect;
  io.readOnly = o.readOnly;
  auto index = openPgTileIndex(io);
  if (!index) return std::unexpected(index.error());
  auto leases = openPgTileLeases(connect);
  if (!leases) return std::unexpected(leases.error());
  ctx.leases = std::move(*leases);
  return TileCache::open(o, std::shared_ptr<ITileIndex>(std::move(*index)), std::move(*store));
}

} // namespace

std::optional<Context> setUp(const cli::Args& a, CacheUse use) {
  auto config = loadConfiguration(a);
  if (!config) return std::nullopt;
  Context ctx{std::move(*config), nullptr, nullptr, nullptr};
  TileCache::Options o;
  o.root = ctx.config.cache.root;
  o.sizeLimitBytes = ctx.config.cache.sizeLimitBytes;
  // A seeder writes many tiles: rows are committed behind the files in batches (bench/RESULTS.md).
  o.indexWriteBehind = use == CacheUse::Seed;
  if (use == CacheUse::Serve)
    o.openFiles = descriptorBudget(ctx.config.server.limits.maxConnections);
  const bool embedded = ctx.config.cache.index.empty() && ctx.config.cache.store.empty();
  auto cache = embedded ? TileCache::open(o) : openScaledOut(ctx, o);
  if (!cache) {
    std::fprintf(stderr, "tellus: cache %s: %s\n", o.root.c_str(), cache.error().message.c_str());
    return std::nullopt;
  }
  if ((*cache)->wasRebuiltAtOpen()) {
    std::fprintf(
        stderr,
        "tellus: the cache index was damaged; it was moved aside and rebuilt from the tree\n");
  }
  ctx.cache = std::move(*cache);
  return ctx;
}

} // namespace tellus::commands
