// tellus: the composition root. Parses the command line, builds the configuration, wires the cache,
// the proxy and the planet together, and runs one subcommand.

#include <tellus/cache/TileCache.hpp>
#include <tellus/config/Config.hpp>
#include <tellus/proxy/LocalRasterSource.hpp>
#include <tellus/proxy/Seeder.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <unistd.h>
#include <vector>

namespace fs = std::filesystem;
using namespace tellus;

namespace {

constexpr int kExitOk = 0;
constexpr int kExitError = 1;
constexpr int kExitUsage = 2;
constexpr int kExitProblems = 3;

constexpr const char* kUsage = R"(usage: tellus <command> [options]

commands:
  seed     fill the cache from the layers' upstreams
             [--layer NAME]... [--levels A-B] [--bbox W,S,E,N] [--dry-run]
  cache    inspect and maintain the cache
             stats [--json] | verify | rebuild | prune --older-than DURATION [--layer NAME]
             [--include-pinned]       DURATION: e.g. 30d, 12h, 15m, 45s
  serve    WMS / World Wind tile server             (not built yet: issue #3)
  view     interactive globe                        (not built yet: issue #5)
  render   headless globe rendering to PNG          (not built yet: issue #5)

options for every command:
  --cache DIR   cache root (default: $TELLUS_CACHE, $XDG_CACHE_HOME/tellus or ~/.cache/tellus)
  --data DIR    bundled data of the embedded default (default: $TELLUS_DATA_DIR or the source tree)
  --config F    a configuration file (YAML: arrives with `tellus serve`, issue #3)
)";

/** Command-line arguments after the command words: --key value pairs and flags. */
struct Args {
  std::vector<std::string> positional;
  std::multimap<std::string, std::string> options;
  std::vector<std::string> errors;

  bool flag(const std::string& k) const { return options.contains(k); }
  std::optional<std::string> get(const std::string& k) const {
    auto it = options.find(k);
    if (it == options.end()) return std::nullopt;
    return it->second;
  }
  std::vector<std::string> all(const std::string& k) const {
    std::vector<std::string> v;
    for (auto [it, end] = options.equal_range(k); it != end; ++it)
      v.push_back(it->second);
    return v;
  }
};

Args parseArgs(int argc, char** argv, int first, const std::vector<std::string>& flags) {
  Args a;
  for (int i = first; i < argc; ++i) {
    std::string s = argv[i];
    if (!s.starts_with("--")) {
      a.positional.push_back(s);
      continue;
    }
    std::string key = s.substr(2);
    std::string value;
    if (const auto eq = key.find('='); eq != std::string::npos) {
      value = key.substr(eq + 1);
      key = key.substr(0, eq);
    } else if (std::find(flags.begin(), flags.end(), key) == flags.end()) {
      if (i + 1 >= argc) {
        a.errors.push_back("--" + key + " needs a value");
        continue;
      }
      value = argv[++i];
    }
    a.options.emplace(key, value);
  }
  return a;
}

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

struct Context {
  Config config;
  std::unique_ptr<TileCache> cache;
};

/** Builds the configuration and opens the cache; prints the error and returns nullopt on failure.
 */
std::optional<Context> setUp(const Args& a) {
  if (a.get("config")) {
    std::fprintf(
        stderr,
        "tellus: --config (YAML) is not built yet (issue #3); the embedded default is used "
        "without it\n");
    return std::nullopt;
  }
  const fs::path root = a.get("cache") ? fs::path(*a.get("cache")) : defaultCacheRoot();
  Context ctx{embeddedDefault(dataDir(a), root), nullptr};
  if (auto v = validate(ctx.config); !v) {
    std::fprintf(stderr, "tellus: configuration: %s\n", v.error().c_str());
    return std::nullopt;
  }
  TileCache::Options o;
  o.root = ctx.config.cache.root;
  o.sizeLimitBytes = ctx.config.cache.sizeLimitBytes;
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

int cmdSeed(const Args& a) {
  SeedOptions so;
  if (auto l = a.get("levels")) {
    auto r = parseLevels(*l);
    if (!r) {
      std::fprintf(stderr,
                   "tellus seed: --levels must be A or A-B with 0 <= A <= B, got '%s'\n",
                   l->c_str());
      return kExitUsage;
    }
    so.fromLevel = r->first;
    so.toLevel = r->second;
  }
  if (auto b = a.get("bbox")) {
    so.box = parseBbox(*b);
    if (!so.box) {
      std::fprintf(
          stderr, "tellus seed: --bbox must be W,S,E,N in degrees, got '%s'\n", b->c_str());
      return kExitUsage;
    }
  }
  so.dryRun = a.flag("dry-run");
  auto ctx = setUp(a);
  if (!ctx) return kExitError;
  std::vector<const LayerConfig*> layers;
  for (const auto& name : a.all("layer")) {
    const auto* l = ctx->config.layer(name);
    if (!l) {
      std::fprintf(stderr, "tellus seed: no layer '%s'\n", name.c_str());
      return kExitUsage;
    }
    layers.push_back(l);
  }
  if (layers.empty()) {
    for (const auto& l : ctx->config.layers)
      layers.push_back(&l);
  }
  int rc = kExitOk;
  for (const auto* layer : layers) {
    auto id = ctx->cache->registerDataset(layer->dataset);
    if (!id) {
      std::fprintf(
          stderr, "tellus seed: %s: %s\n", layer->name.c_str(), id.error().message.c_str());
      return kExitError;
    }
    auto source = LocalRasterSource::open(layer->upstream.path);
    if (!source) {
      std::fprintf(stderr, "tellus seed: %s: %s\n", layer->name.c_str(), source.error().c_str());
      return kExitError;
    }
    auto report = seedFromRaster(*ctx->cache, *id, *source, so);
    if (!report) {
      std::fprintf(
          stderr, "tellus seed: %s: %s\n", layer->name.c_str(), report.error().message.c_str());
      return kExitError;
    }
    std::printf("%-12s levels %d-%d: %lld tiles planned, %lld already cached, %lld written (%s), "
                "%lld failed%s\n",
                layer->name.c_str(),
                so.fromLevel,
                std::min(so.toLevel, layer->dataset.grid.numLevels - 1),
                static_cast<long long>(report->planned),
                static_cast<long long>(report->skipped),
                static_cast<long long>(report->written),
                humanBytes(report->bytes).c_str(),
                static_cast<long long>(report->failed),
                so.dryRun ? " (dry run)" : "");
    for (const auto& f : report->failures)
      std::fprintf(stderr, "  failed: %s\n", f.c_str());
    if (report->failed > 0) rc = kExitProblems;
  }
  return rc;
}

int cmdCacheStats(Context& ctx, bool json) {
  auto st = ctx.cache->stats();
  if (!st) {
    std::fprintf(stderr, "tellus cache stats: %s\n", st.error().message.c_str());
    return kExitError;
  }
  std::int64_t totalTiles = 0;
  std::int64_t totalBytes = 0;
  for (const auto& d : *st) {
    totalTiles += d.tiles;
    totalBytes += d.bytes;
  }
  if (json) {
    std::printf("{\"root\":%s,\"tiles\":%lld,\"bytes\":%lld,\"datasets\":[",
                jsonString(ctx.cache->root().string()).c_str(),
                static_cast<long long>(totalTiles),
                static_cast<long long>(totalBytes));
    for (std::size_t i = 0; i < st->size(); ++i) {
      const auto& d = (*st)[i];
      std::printf("%s{\"id\":%lld,\"server\":%s,\"name\":%s,\"folder\":%s,\"format\":%s,\"time\":%"
                  "s,\"pinned\":%s,"
                  "\"tiles\":%lld,\"bytes\":%lld,\"levels\":[",
                  i ? "," : "",
                  static_cast<long long>(d.dataset.id),
                  jsonString(d.dataset.spec.server).c_str(),
                  jsonString(d.dataset.spec.name).c_str(),
                  jsonString(d.dataset.folder).c_str(),
                  jsonString(d.dataset.spec.mimeType).c_str(),
                  jsonString(d.dataset.spec.time).c_str(),
                  d.dataset.spec.pinned ? "true" : "false",
                  static_cast<long long>(d.tiles),
                  static_cast<long long>(d.bytes));
      for (std::size_t j = 0; j < d.levels.size(); ++j) {
        const auto& l = d.levels[j];
        std::printf("%s{\"level\":%d,\"tiles\":%lld,\"absent\":%lld,\"bytes\":%lld}",
                    j ? "," : "",
                    l.level,
                    static_cast<long long>(l.tiles),
                    static_cast<long long>(l.absent),
                    static_cast<long long>(l.bytes));
      }
      std::printf("]}");
    }
    std::printf("]}\n");
    return kExitOk;
  }
  std::printf("cache %s: %lld tiles, %s\n",
              ctx.cache->root().c_str(),
              static_cast<long long>(totalTiles),
              humanBytes(totalBytes).c_str());
  for (const auto& d : *st) {
    std::printf("  %s/%s  %s%s%s  %lld tiles  %s\n",
                d.dataset.spec.server.c_str(),
                d.dataset.spec.name.c_str(),
                d.dataset.spec.mimeType.c_str(),
                d.dataset.spec.time.empty() ? "" : ("  time " + d.dataset.spec.time).c_str(),
                d.dataset.spec.pinned ? "  pinned" : "",
                static_cast<long long>(d.tiles),
                humanBytes(d.bytes).c_str());
    for (const auto& l : d.levels) {
      std::printf("    level %2d: %8lld tiles%s  %s\n",
                  l.level,
                  static_cast<long long>(l.tiles),
                  l.absent ? (" (" + std::to_string(l.absent) + " absent)").c_str() : "",
                  humanBytes(l.bytes).c_str());
    }
  }
  return kExitOk;
}

int cmdCache(const Args& a) {
  if (a.positional.empty()) {
    std::fprintf(stderr, "tellus cache: say stats, verify, rebuild or prune\n%s", kUsage);
    return kExitUsage;
  }
  const std::string& sub = a.positional[0];
  std::optional<std::chrono::milliseconds> olderThan;
  if (sub == "prune") {
    const auto d = a.get("older-than");
    olderThan = d ? parseDuration(*d) : std::nullopt;
    if (!olderThan) {
      std::fprintf(stderr,
                   "tellus cache prune: --older-than DURATION is required (e.g. 30d, 12h)\n");
      return kExitUsage;
    }
  } else if (sub != "stats" && sub != "verify" && sub != "rebuild") {
    std::fprintf(stderr, "tellus cache: unknown subcommand '%s'\n%s", sub.c_str(), kUsage);
    return kExitUsage;
  }
  auto ctx = setUp(a);
  if (!ctx) return kExitError;
  if (sub == "stats") return cmdCacheStats(*ctx, a.flag("json"));
  if (sub == "verify") {
    auto r = ctx->cache->verify();
    if (!r) {
      std::fprintf(stderr, "tellus cache verify: %s\n", r.error().message.c_str());
      return kExitError;
    }
    std::printf("index integrity: %s\n", r->integrity.c_str());
    auto list = [](const char* what, const std::vector<std::string>& v) {
      std::printf("%s: %zu\n", what, v.size());
      for (std::size_t i = 0; i < v.size() && i < 20; ++i)
        std::printf("  %s\n", v[i].c_str());
      if (v.size() > 20) std::printf("  ... and %zu more\n", v.size() - 20);
    };
    list("files without index rows", r->filesWithoutRows);
    list("index rows without files", r->rowsWithoutFiles);
    list("size mismatches", r->sizeMismatches);
    list("stray temp files", r->strayTempFiles);
    std::printf(r->ok() ? "cache is consistent\n"
                        : "cache has problems: `tellus cache rebuild` repairs the index\n");
    return r->ok() ? kExitOk : kExitProblems;
  }
  if (sub == "rebuild") {
    auto n = ctx->cache->rebuild();
    if (!n) {
      std::fprintf(stderr, "tellus cache rebuild: %s\n", n.error().message.c_str());
      return kExitError;
    }
    std::printf("index rebuilt from the tree: %lld tiles\n", static_cast<long long>(*n));
    return kExitOk;
  }
  PruneOptions po;
  po.olderThan = olderThan;
  po.datasetName = a.get("layer");
  po.includePinned = a.flag("include-pinned");
  auto n = ctx->cache->prune(po);
  if (!n) {
    std::fprintf(stderr, "tellus cache prune: %s\n", n.error().message.c_str());
    return kExitError;
  }
  std::printf("pruned %lld tiles\n", static_cast<long long>(*n));
  return kExitOk;
}

int run(int argc, char** argv) {
  if (argc < 2 || std::string_view(argv[1]) == "help" || std::string_view(argv[1]) == "--help") {
    std::fputs(kUsage, argc < 2 ? stderr : stdout);
    return argc < 2 ? kExitUsage : kExitOk;
  }
  const std::string_view cmd = argv[1];
  if (cmd == "--version") {
    std::printf("tellus %s\n", TELLUS_VERSION);
    return kExitOk;
  }
  const Args a = parseArgs(argc, argv, 2, {"json", "dry-run", "include-pinned"});
  for (const auto& e : a.errors)
    std::fprintf(stderr, "tellus %s: %s\n", argv[1], e.c_str());
  if (!a.errors.empty()) return kExitUsage;
  if (cmd == "seed") return cmdSeed(a);
  if (cmd == "cache") return cmdCache(a);
  if (cmd == "serve") {
    std::fprintf(stderr, "tellus serve: not built yet (issue #3: the WMS / World Wind proxy)\n");
    return kExitUsage;
  }
  if (cmd == "view" || cmd == "render") {
    std::fprintf(stderr, "tellus %s: not built yet (issue #5: the planet renderer)\n", argv[1]);
    return kExitUsage;
  }
  std::fprintf(stderr, "tellus: unknown command '%s'\n%s", argv[1], kUsage);
  return kExitUsage;
}

} // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tellus: %s\n", e.what());
    return kExitError;
  }
}
