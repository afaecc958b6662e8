#pragma once
/**
 * @file Context.hpp
 * @brief What every command starts from: the exit codes, the configuration (a YAML file or the
 * embedded default) and the cache it names, opened for the command's use.
 */

#include <tellus/cache/TileCache.hpp>
#include <tellus/cache/TileLeases.hpp>
#include <tellus/cache_s3/TieredTileStore.hpp>
#include <tellus/config/CommandLine.hpp>
#include <tellus/config/Config.hpp>

#include <cstddef>
#include <filesystem>
#include <memory>
#include <optional>

namespace tellus::commands {

inline constexpr int kExitOk = 0;
inline constexpr int kExitError = 1;
inline constexpr int kExitUsage = 2;
inline constexpr int kExitProblems = 3;  ///< cache verify found problems; seed had failures
inline constexpr int kExitCacheFull = 4; ///< seed: the cache refused tiles for lack of space

/** How a command uses the cache: what TileCache::Options it opens it with. */
enum class CacheUse {
  Read,  ///< inspect, maintain, render: the defaults
  Seed,  ///< many tiles written: index rows committed behind the files in batches
  Serve, ///< many clients: as many open tile files as the descriptor limit allows
};

struct Context {
  Config config;
  std::unique_ptr<TileCache> cache;
  /// Single-flight leases across instances: PostgreSQL's when cache.index is one (issue 27), else
  /// null (this process alone). Serve hands them to the tile service.
  std::shared_ptr<ITileLeases> leases;
  /// The local tier in front of an S3 store when `cache.s3.local_tier_limit` bounds it, else null.
  /// Serve shows its figures at /metrics.
  std::shared_ptr<TieredTileStore> boundedTier;
};

/** The bundled data: --data, else $TELLUS_DATA_DIR, else the source tree's data/. */
std::filesystem::path dataDir(const cli::Args& args);

/** --config FILE (with --cache over its cache root) or the embedded default (at --cache, else
 * the default cache root), validated. Says why on stderr and returns nullopt on failure. */
std::optional<Config> loadConfiguration(const cli::Args& args);

/** The configuration and its cache opened for `use`; says why on stderr and returns nullopt on
 * failure, and says so when a damaged index was rebuilt at open. */
std::optional<Context> setUp(const cli::Args& args, CacheUse use = CacheUse::Read);

/** Raises the soft descriptor limit as far as the hard one allows (nginx's worker_rlimit_nofile)
 * and returns how many tile files the cache may hold open: half of what `maxConnections` and
 * 256 others (SQLite, libcurl, logs, the listener) leave, within [64, 16384]. */
std::size_t descriptorBudget(int maxConnections);

} // namespace tellus::commands
