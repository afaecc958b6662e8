// What the commands share: the option values, the configuration and the cache, the proxy's
// specs of the configuration.

#include "Commands.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sys/resource.h>

namespace fs = std::filesystem;

namespace tellus::commands {

fs::path dataDir(const Args& a) {
  if (auto d = a.get("data")) return *d;
  if (const char* e = std::getenv("TELLUS_DATA_DIR"); e && *e) return e;
  return TELLUS_SOURCE_DATA_DIR;
}

std::string jsonString(std::string_view s) {
  std::string o = "\"";
  for (const char c : s) {
    if (c == '"' || c == '\\') {
      o += '\\';
      o += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      o += buf;
    } else {
      o += c;
    }
  }
  return o + "\"";
}

/** Raises the soft descriptor limit as far as the hard one allows (nginx's worker_rlimit_nofile)
 * and returns how many tile files the cache may hold open: half of what the connections leave. */
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

/** Builds the configuration and opens the cache; prints the error and returns nullopt on failure.
 */
std::optional<Context> setUp(const Args& a, bool seeding, bool serving) {
  Context ctx;
  if (auto file = a.get("config")) {
    auto loaded = loadConfig(*file);
    if (!loaded) {
      std::fprintf(stderr, "tellus: configuration: %s\n", loaded.error().toString().c_str());
      return std::nullopt;
    }
    ctx.config = std::move(*loaded);
    if (auto c = a.get("cache")) ctx.config.cache.root = *c;
  } else {
    const fs::path root = a.get("cache") ? fs::path(*a.get("cache")) : defaultCacheRoot();
    ctx.config = embeddedDefault(dataDir(a), root);
  }
  if (auto v = validate(ctx.config); !v) {
    std::fprintf(stderr, "tellus: configuration: %s\n", v.error().c_str());
    return std::nullopt;
  }
  const fs::path root = ctx.config.cache.root;
  TileCache::Options o;
  o.root = ctx.config.cache.root;
  o.sizeLimitBytes = ctx.config.cache.sizeLimitBytes;
  // A seeder writes many tiles: rows are committed behind the files in batches (bench/RESULTS.md).
  o.indexWriteBehind = seeding;
  if (serving) o.openFiles = descriptorBudget(ctx.config.server.limits.maxConnections);
  auto cache = TileCache::open(o);
  if (!cache) {
    std::fprintf(stderr, "tellus: cache %s: %s\n", root.c_str(), cache.error().message.c_str());
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
