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

std::optional<std::pair<int, int>> parseLevels(std::string_view s) {
  int a = 0;
  int b = 0;
  const auto dash = s.find('-');
  const std::string_view first = s.substr(0, dash);
  auto r1 = std::from_chars(first.data(), first.data() + first.size(), a);
  if (r1.ec != std::errc{} || r1.ptr != first.data() + first.size()) return std::nullopt;
  if (dash == std::string_view::npos) return std::pair{a, a};
  const std::string_view second = s.substr(dash + 1);
  auto r2 = std::from_chars(second.data(), second.data() + second.size(), b);
  if (r2.ec != std::errc{} || r2.ptr != second.data() + second.size() || b < a || a < 0)
    return std::nullopt;
  return std::pair{a, b};
}

std::optional<Sector> parseBbox(const std::string& s) {
  double v[4];
  const char* p = s.c_str();
  for (int i = 0; i < 4; ++i) {
    char* end = nullptr;
    v[i] = std::strtod(p, &end);
    if (end == p || !std::isfinite(v[i])) return std::nullopt;
    p = end;
    if (i < 3) {
      if (*p != ',') return std::nullopt;
      ++p;
    }
  }
  if (*p != '\0') return std::nullopt;
  return Sector{v[0], v[1], v[2], v[3]};
}

std::optional<std::chrono::milliseconds> parseDuration(std::string_view s) {
  if (s.size() < 2) return std::nullopt;
  long long n = 0;
  const auto r = std::from_chars(s.data(), s.data() + s.size() - 1, n);
  if (r.ec != std::errc{} || r.ptr != s.data() + s.size() - 1 || n < 0) return std::nullopt;
  switch (s.back()) {
  case 's':
    return std::chrono::seconds(n);
  case 'm':
    return std::chrono::minutes(n);
  case 'h':
    return std::chrono::hours(n);
  case 'd':
    return std::chrono::hours(24 * n);
  default:
    return std::nullopt;
  }
}

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

std::string humanBytes(std::int64_t b) {
  char buf[32];
  if (b >= 1LL << 30)
    std::snprintf(buf, sizeof buf, "%.1f GiB", static_cast<double>(b) / (1LL << 30));
  else if (b >= 1LL << 20)
    std::snprintf(buf, sizeof buf, "%.1f MiB", static_cast<double>(b) / (1LL << 20));
  else if (b >= 1LL << 10)
    std::snprintf(buf, sizeof buf, "%.1f KiB", static_cast<double>(b) / (1LL << 10));
  else
    std::snprintf(buf, sizeof buf, "%lld B", static_cast<long long>(b));
  return buf;
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

/** The configuration's upstreams and layers in the proxy's terms. */
std::pair<std::vector<UpstreamSpec>, std::vector<LayerSpec>> proxySpecs(const Config& c) {
  std::vector<UpstreamSpec> ups;
  for (const auto& u : c.upstreams) {
    UpstreamSpec s;
    s.name = u.name;
    s.type = u.type == UpstreamConfig::Type::Local ? UpstreamSpec::Type::Local
             : u.type == UpstreamConfig::Type::Wms ? UpstreamSpec::Type::Wms
                                                   : UpstreamSpec::Type::WorldWind;
    s.path = u.path;
    s.url = u.url;
    s.wmsVersion = u.wmsVersion;
    s.crs = u.crs;
    s.metaTiles = u.metaTiles;
    s.policy.maxConnections = u.maxConnections;
    s.policy.connectTimeout = u.connectTimeout;
    s.policy.timeout = u.timeout;
    s.policy.retries = u.retries;
    s.policy.retryBackoff = u.retryBackoff;
    s.policy.failureThreshold = u.failureThreshold;
    s.policy.openInterval = u.openInterval;
    s.policy.maxRetryAfterWait = u.maxRetryAfterWait;
    s.policy.headers = u.headers;
    s.policy.redirects = u.redirects == RedirectPolicy::Any ? UpstreamPolicy::Redirects::Any
                         : u.redirects == RedirectPolicy::None
                             ? UpstreamPolicy::Redirects::None
                             : UpstreamPolicy::Redirects::SameOrigin;
    ups.push_back(std::move(s));
  }
  std::vector<LayerSpec> layers;
  for (const auto& l : c.layers) {
    LayerSpec s;
    s.name = l.name;
    s.title = l.title;
    s.abstract = l.abstract;
    s.dataset = l.dataset;
    s.upstream = l.upstream;
    s.upstreamLayer = l.upstreamLayer;
    s.firstLevel = l.firstLevel;
    s.elevation = l.kind == LayerKind::Elevation;
    s.noData = static_cast<std::int16_t>(std::clamp(l.elevation.noData, -32768.0, 32767.0));
    s.ttl = l.ttl;
    s.opacity = l.opacity;
    s.maxAge = l.maxAge;
    s.timeValues = l.time.values;
    s.timePeriod = l.time.period;
    s.timeDefault = l.time.defaultValue;
    layers.push_back(std::move(s));
  }
  return {std::move(ups), std::move(layers)};
}

/** Comma-separated finite numbers (count within [minCount, maxCount]). */
std::optional<std::vector<double>>
parseNumbers(const std::string& s, std::size_t minCount, std::size_t maxCount) {
  std::vector<double> v;
  std::size_t pos = 0;
  while (pos <= s.size()) {
    const auto comma = std::min(s.find(',', pos), s.size());
    const std::string part = s.substr(pos, comma - pos);
    double d = 0.0;
    auto [ptr, ec] = std::from_chars(part.data(), part.data() + part.size(), d);
    if (part.empty() || ec != std::errc{} || ptr != part.data() + part.size() || !std::isfinite(d))
      return std::nullopt;
    v.push_back(d);
    pos = comma + 1;
  }
  if (v.size() < minCount || v.size() > maxCount) return std::nullopt;
  return v;
}

/** WxH with 1 to 16384 pixels each. */
std::optional<std::pair<int, int>> parseSize(const std::string& size) {
  const auto x = size.find('x');
  if (x == std::string::npos) return std::nullopt;
  int w = 0, h = 0;
  auto r1 = std::from_chars(size.data(), size.data() + x, w);
  auto r2 = std::from_chars(size.data() + x + 1, size.data() + size.size(), h);
  if (r1.ec != std::errc{} || r1.ptr != size.data() + x || r2.ec != std::errc{} ||
      r2.ptr != size.data() + size.size() || w < 1 || h < 1 || w > 16384 || h > 16384)
    return std::nullopt;
  return std::pair{w, h};
}

} // namespace tellus::commands
