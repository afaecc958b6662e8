// tellus: the composition root. Parses the command line, builds the configuration, wires the cache,
// the proxy and the planet together, and runs one subcommand.

#include <tellus/cache/GeoPackage.hpp>
#include <tellus/cache/TileCache.hpp>
#include <tellus/config/CommandLine.hpp>
#include <tellus/config/Config.hpp>
#include <tellus/planet/Geodesy.hpp>
#include <tellus/planet/Geoid.hpp>
#include <tellus/planet/RegionalSource.hpp>
#include <tellus/planet/Terrain.hpp>
#include <tellus/planet_gl/Renderer.hpp>
#include <tellus/planet_gl/Viewer.hpp>
#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/HttpServer.hpp>
#include <tellus/proxy/ImageCodec.hpp>
#include <tellus/proxy/LocalRasterSource.hpp>
#include <tellus/proxy/Log.hpp>
#include <tellus/proxy/ProxyFrontEnd.hpp>
#include <tellus/proxy/RemoteTileSource.hpp>
#include <tellus/proxy/Seeder.hpp>
#include <tellus/proxy/TileService.hpp>
#include <tellus/proxy/WebPage.hpp>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <expected>
#include <filesystem>
#include <future>
#include <limits>
#include <map>
#include <optional>
#include <pthread.h>
#include <string>
#include <string_view>
#include <sys/resource.h>
#include <thread>
#include <unistd.h>
#include <vector>

namespace fs = std::filesystem;
using namespace tellus;

namespace {

constexpr int kExitOk = 0;
constexpr int kExitError = 1;
constexpr int kExitUsage = 2;
constexpr int kExitProblems = 3;
constexpr int kExitCacheFull = 4; // seed: the cache refused tiles for lack of space

constexpr const char* kUsage = R"(usage: tellus <command> [options]

commands:
  seed     fill the cache from the layers' upstreams
             [--layer NAME]... [--levels A-B] [--bbox W,S,E,N] [--dry-run]
             [--time T] [--concurrency N] [--rate TILES/S] [--retries N] [--refresh]
             [--meta-tiles N]         N x N tiles per WMS GetMap (default: the upstream's
                                      meta_tiles, 4; 1 = one GetMap per tile)
  cache    inspect and maintain the cache
             stats [--json] | verify | rebuild
             | prune --older-than DURATION [--layer NAME] [--include-pinned] [--dry-run]
                                      DURATION: e.g. 30d, 12h, 15m, 45s; says what it removes
                                      (every layer unless --layer) before it does
             | export --gpkg FILE --layer NAME [--levels A-B] | import --gpkg FILE --layer NAME
  serve    the WMS / World Wind tile server
             [--listen HOST:PORT] [--threads N] [--offline]
             [--log-level error|warn|info|debug] [--access-log FILE|-]
  render   headless globe rendering to PNG (an X display or xvfb-run)
             --camera LAT,LON,ALT[,HEADING,TILT] --out FILE.png [--size WxH]
             [--wait-complete[=SECONDS]] [--background R,G,B] [--stats FILE.json]
             [--layer NAME] [--threshold T] [--earth wgs84|sphere] [--offline | --server URL]
             [--dome [FOV]] [--dome-tilt DEG]  a domemaster (angular fisheye, FOV 180 up to
                                      220 degrees, --size N: N x N, black outside the circle)
             [--dome-method direct|cube]  one pass through the fisheye (default) or cube
                                      faces and a warp (renderer.dome.method)
             or a flight: --path PATH.json --frames DIR [--fps N] [--repeat N] instead of
             --camera/--out
             (PATH.json: [{"time":0,"lat":..,"lon":..,"alt":..,"heading":..,"tilt":..,
              "times":{"LAYER":"TIME"}}, ...]: a layer's time from that keyframe on)
  view     the interactive globe (a GLFW window)
             [--camera LAT,LON,ALT[,HEADING,TILT]] [--size WxH] [--layer NAME] [--threshold T]
             [--earth wgs84|sphere] [--offline | --server URL] [--dome [FOV]] [--dome-tilt DEG] [--dome-method direct|cube]; drag, wheel, W/S tilt, A/D heading, R reset, P screenshot, Esc
             render and view: [--no-terrain] [--exaggeration X] [--sun LAT,LON]
             [--min-relief-px PX] (renderer.terrain.min_relief_px: heights only where relief shows)
             [--overlay NAME[,OPACITY]]... (imagery over the base; also renderer.layers);
             view: 0-9 select a layer (1-9 also show/hide it), - = opacity, , . order,
             ; ' deepest level, [ ] its time
             render: [--edge-fixing on|off] (off shows the cracks it closes; for comparisons)
             render, view and height: [--geoid on|off] (renderer.geoid: mean-sea-level heights
             onto the ellipsoid, h = H + N)
             render, for the speed/accuracy sweep (bench/trade.sh): [--mesh-size N]
             [--upload-per-frame BYTES] [--vertices double|float]
  height   the terrain height in metres at a point, from the elevation layer's deepest level
             --lat A --lon B [--elevation LAYER] [--datum msl|ellipsoid] [--offline | --server URL]
             (prints H above mean sea level, or h = H + N with --datum ellipsoid; both on stderr)

options for every command (anything else is refused with exit code 2; --help prints this):
  --cache DIR   cache root (default: $TELLUS_CACHE, $XDG_CACHE_HOME/tellus or ~/.cache/tellus)
  --data DIR    bundled data of the embedded default (default: $TELLUS_DATA_DIR or the source tree)
  --config F    a YAML configuration (docs/CONFIG.md; default: the embedded default)
)";

using cli::Args;

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
std::optional<Context> setUp(const Args& a, bool seeding = false, bool serving = false) {
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

std::pair<std::vector<UpstreamSpec>, std::vector<LayerSpec>> proxySpecs(const Config& c);

/** A progress line: a bar on a terminal (redrawn in place), else a plain line every 5 s. */
class SeedProgressPrinter {
public:
  SeedProgressPrinter(std::string layer, std::int64_t planned)
      : layer_(std::move(layer)), planned_(planned), tty_(::isatty(STDERR_FILENO) == 1) {}
  void operator()(const SeedReport& r, double seconds) {
    const std::int64_t done = r.skipped + r.written + r.absent + r.failed;
    const std::int64_t fetched = r.written + r.absent + r.failed;
    const double rate = seconds > 0 ? static_cast<double>(fetched) / seconds : 0.0;
    const std::int64_t left = std::max<std::int64_t>(0, planned_ - done);
    const double eta = rate > 0 ? static_cast<double>(left) / rate : 0.0;
    const double frac =
        planned_ > 0 ? static_cast<double>(done) / static_cast<double>(planned_) : 1;
    char line[256];
    if (tty_) {
      const int width = 24;
      std::string bar(static_cast<std::size_t>(width), '.');
      for (int i = 0; i < static_cast<int>(frac * width) && i < width; ++i)
        bar[static_cast<std::size_t>(i)] = '#';
      std::snprintf(line,
                    sizeof line,
                    "\r%-12s [%s] %lld/%lld %5.1f%%  %.0f tiles/s  %s  ETA %.0fs  failed %lld ",
                    layer_.c_str(),
                    bar.c_str(),
                    static_cast<long long>(done),
                    static_cast<long long>(planned_),
                    100.0 * frac,
                    rate,
                    humanBytes(r.bytes).c_str(),
                    eta,
                    static_cast<long long>(r.failed));
      std::fputs(line, stderr);
      return;
    }
    if (seconds - lastLine_ < 5.0 && done < planned_) return;
    lastLine_ = seconds;
    std::snprintf(line,
                  sizeof line,
                  "%s: %lld/%lld tiles (%.1f%%), %.0f tiles/s, %s, ETA %.0f s, %lld failed\n",
                  layer_.c_str(),
                  static_cast<long long>(done),
                  static_cast<long long>(planned_),
                  100.0 * frac,
                  rate,
                  humanBytes(r.bytes).c_str(),
                  eta,
                  static_cast<long long>(r.failed));
    std::fputs(line, stderr);
  }
  ~SeedProgressPrinter() {
    if (tty_) std::fputs("\n", stderr);
  }

private:
  std::string layer_;
  std::int64_t planned_;
  bool tty_;
  double lastLine_ = -10.0;
};

/** Bytes per tile for a dry run's estimate: exact for bil16, else the mean of what the cache
 * already holds of this layer, else a typical size for the format. */
std::int64_t estimateTileBytes(TileCache& cache, const LayerConfig& layer) {
  const auto& g = layer.dataset.grid;
  const std::int64_t pixels = std::int64_t{g.tileWidth} * g.tileHeight;
  if (layer.dataset.mimeType == "application/bil16") return pixels * 2;
  if (auto stats = cache.stats()) {
    std::int64_t tiles = 0, bytes = 0;
    for (const auto& d : *stats) {
      if (d.dataset.spec.name != layer.name) continue;
      tiles += d.tiles;
      bytes += d.bytes;
    }
    if (tiles > 0 && bytes > 0) return bytes / tiles;
  }
  if (layer.dataset.mimeType == "image/jpeg") return pixels / 12; // about 0.7 bit per pixel
  return pixels * 2;                                              // PNG/TIFF: a guess
}

/** The one summary line of a seeded layer (both seeding paths), its failures, and why it stopped
 * early (a full cache). The exit code it calls for: 0, kExitProblems or kExitCacheFull. */
int printSeedSummary(const LayerConfig& layer, const SeedOptions& so, const SeedReport& r) {
  std::printf("%-12s levels %d-%d: %lld tiles planned, %lld already cached, %lld written (%s), "
              "%lld absent upstream, %lld retried, %lld failed%s%s\n",
              layer.name.c_str(),
              so.fromLevel,
              std::min(so.toLevel, layer.dataset.grid.numLevels - 1),
              static_cast<long long>(r.planned),
              static_cast<long long>(r.skipped),
              static_cast<long long>(r.written),
              humanBytes(r.bytes).c_str(),
              static_cast<long long>(r.absent),
              static_cast<long long>(r.retried),
              static_cast<long long>(r.failed),
              r.notStored ? (", " + std::to_string(r.notStored) + " not stored").c_str() : "",
              so.dryRun ? " (dry run)" : "");
  for (const auto& f : r.failures)
    std::fprintf(stderr, "  failed: %s\n", f.c_str());
  if (!r.stoppedBecause.empty()) {
    const std::int64_t done = r.skipped + r.written + r.absent + r.failed + r.notStored;
    std::fprintf(stderr,
                 "tellus seed: %s: stopped, the cache refuses tiles: %s\n"
                 "  %lld tiles stored, %lld fetched but not stored, %lld not fetched; free "
                 "space and run the same command again (it resumes)\n",
                 layer.name.c_str(),
                 r.stoppedBecause.c_str(),
                 static_cast<long long>(r.written),
                 static_cast<long long>(r.notStored),
                 static_cast<long long>(std::max<std::int64_t>(0, r.planned - done)));
    return kExitCacheFull;
  }
  return r.failed == 0 ? kExitOk : kExitProblems;
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
  ServiceSeedOptions sso;
  auto number = [&](const char* key, double lo, double hi, double& out) {
    const auto v = a.get(key);
    if (!v) return true;
    char* end = nullptr;
    const double x = std::strtod(v->c_str(), &end);
    if (v->empty() || *end != '\0' || !(x >= lo && x <= hi)) {
      std::fprintf(stderr,
                   "tellus seed: --%s must be a number in [%g, %g], got '%s'\n",
                   key,
                   lo,
                   hi,
                   v->c_str());
      return false;
    }
    out = x;
    return true;
  };
  double concurrency = 4, retries = 2, metaTiles = 0;
  if (!number("concurrency", 1, 256, concurrency) || !number("rate", 0, 1e6, sso.rate) ||
      !number("retries", 0, 100, retries) || !number("meta-tiles", 1, 16, metaTiles))
    return kExitUsage;
  if (metaTiles != std::floor(metaTiles)) {
    std::fprintf(stderr, "tellus seed: --meta-tiles must be a whole number\n");
    return kExitUsage;
  }
  sso.concurrency = static_cast<int>(concurrency);
  sso.retries = static_cast<int>(retries);
  sso.refresh = a.flag("refresh");
  sso.time = a.get("time").value_or("");
  auto ctx = setUp(a, /*seeding=*/true);
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
  // TIME: checked against each layer's dimension, as a WMS client's would be.
  for (const LayerConfig* l : layers) {
    const auto t = resolveTimeDimension(
        l->name, l->time.values, l->time.period, l->time.defaultValue, sso.time);
    if (!t) {
      std::fprintf(stderr,
                   "tellus seed: --time for layer '%s': %s\n",
                   l->name.c_str(),
                   t.error().message.c_str());
      return kExitUsage;
    }
    if (!sso.time.empty() && t->empty()) {
      std::fprintf(
          stderr, "tellus seed: layer '%s' has no TIME dimension; drop --time\n", l->name.c_str());
      return kExitUsage;
    }
  }

  int rc = kExitOk;
  // Remote upstreams go through the tile service, as `tellus serve` fetches them.
  Fetcher fetcher;
  std::unique_ptr<TileService> service;
  for (const auto* layer : layers) {
    const UpstreamConfig* upstream = ctx->config.upstream(layer->upstream);
    const bool local = upstream && upstream->type == UpstreamConfig::Type::Local;
    // A layer with a TIME dimension is seeded at --time, else at its default time.
    const std::string layerTime =
        resolveTimeDimension(
            layer->name, layer->time.values, layer->time.period, layer->time.defaultValue, sso.time)
            .value_or(sso.time);
    if (!local || sso.refresh || !layerTime.empty()) {
      if (!service) {
        auto [ups, lays] = proxySpecs(ctx->config);
        // --concurrency is what an upstream sees: at most that many requests to it at once.
        // Twice as many tiles are in the pipeline, so that while fetched tiles are validated
        // and stored the upstream is already answering the next ones (with the window equal to
        // the requests, each slot waited for validation and fsync: 0.72x of what MapServer
        // served alone, bench/RESULTS.md).
        for (auto& u : ups) {
          u.policy.maxConnections = std::min(u.policy.maxConnections, sso.concurrency);
          if (metaTiles >= 1) u.metaTiles = static_cast<int>(metaTiles);
        }
        // Storing a fetched tile waits for fsync: as many workers as requests in flight, so
        // that the disk's waits overlap instead of queueing behind two workers.
        TileServiceOptions serviceOptions;
        serviceOptions.renderThreads = std::max(serviceOptions.renderThreads, sso.concurrency);
        auto created = TileService::create(
            *ctx->cache, fetcher, std::move(ups), std::move(lays), serviceOptions);
        if (!created) {
          std::fprintf(stderr, "tellus seed: %s\n", created.error().c_str());
          return kExitError;
        }
        service = std::move(*created);
      }
      ServiceSeedOptions opts = sso;
      opts.time = layerTime;
      opts.concurrency = 2 * sso.concurrency;
      opts.range = so;
      opts.estimateBytesPerTile = estimateTileBytes(*ctx->cache, *layer);
      std::int64_t planned = 0;
      {
        ServiceSeedOptions count = opts;
        count.range.dryRun = true;
        if (auto c = seedThroughService(*service, *ctx->cache, layer->name, count))
          planned = c->planned;
      }
      SeedProgressPrinter printer(layer->name, planned);
      auto report = seedThroughService(
          *service, *ctx->cache, layer->name, opts, [&](const SeedReport& r, double s) {
            if (!so.dryRun) printer(r, s);
          });
      if (!report) {
        std::fprintf(stderr, "tellus seed: %s: %s\n", layer->name.c_str(), report.error().c_str());
        return kExitError;
      }
      if (so.dryRun) {
        std::printf("%-12s levels %d-%d: %lld tiles, about %s (dry run)\n",
                    layer->name.c_str(),
                    so.fromLevel,
                    std::min(so.toLevel, layer->dataset.grid.numLevels - 1),
                    static_cast<long long>(report->planned),
                    humanBytes(report->bytes).c_str());
        continue;
      }
      const int layerRc = printSeedSummary(*layer, so, *report);
      if (layerRc == kExitCacheFull) return kExitCacheFull; // the next layers would not fit either
      if (layerRc != kExitOk) rc = layerRc;
      continue;
    }
    auto id = ctx->cache->registerDataset(layer->dataset);
    if (!id) {
      std::fprintf(
          stderr, "tellus seed: %s: %s\n", layer->name.c_str(), id.error().message.c_str());
      return id.error().code == CacheErrc::DiskFull ? kExitCacheFull : kExitError;
    }
    auto source = LocalRasterSource::open(upstream->path);
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
    const int layerRc = printSeedSummary(*layer, so, *report);
    if (layerRc == kExitCacheFull) return kExitCacheFull;
    if (layerRc != kExitOk) rc = layerRc;
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
    std::fprintf(
        stderr, "tellus cache: say stats, verify, rebuild, prune, export or import\n%s", kUsage);
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
  } else if (sub == "export" || sub == "import") {
    if (!a.get("gpkg") || a.all("layer").size() != 1) {
      std::fprintf(
          stderr, "tellus cache %s: --gpkg FILE and one --layer NAME are required\n", sub.c_str());
      return kExitUsage;
    }
  } else if (sub != "stats" && sub != "verify" && sub != "rebuild") {
    std::fprintf(stderr, "tellus cache: unknown subcommand '%s'\n%s", sub.c_str(), kUsage);
    return kExitUsage;
  }
  auto ctx = setUp(a);
  if (!ctx) return kExitError;
  if (sub == "stats") return cmdCacheStats(*ctx, a.flag("json"));
  if (sub == "export" || sub == "import") {
    const std::string name = a.all("layer").front();
    const auto* layer = ctx->config.layer(name);
    if (!layer) {
      std::fprintf(stderr, "tellus cache %s: no layer '%s'\n", sub.c_str(), name.c_str());
      return kExitUsage;
    }
    auto id = ctx->cache->registerDataset(layer->dataset);
    if (!id) {
      std::fprintf(stderr, "tellus cache %s: %s\n", sub.c_str(), id.error().message.c_str());
      return kExitError;
    }
    const fs::path file = *a.get("gpkg");
    std::int32_t from = 0, to = std::numeric_limits<std::int32_t>::max();
    if (auto l = a.get("levels")) {
      auto r = parseLevels(*l);
      if (!r) {
        std::fprintf(
            stderr, "tellus cache export: --levels must be A or A-B, got '%s'\n", l->c_str());
        return kExitUsage;
      }
      from = r->first;
      to = r->second;
    }
    auto r = sub == "export" ? exportGeoPackage(*ctx->cache, *id, file, from, to)
                             : importGeoPackage(*ctx->cache, *id, file);
    if (!r) {
      std::fprintf(stderr, "tellus cache %s: %s\n", sub.c_str(), r.error().message.c_str());
      return kExitError;
    }
    std::printf("%s %s: %lld tiles (%s), levels %d-%d, %s\n",
                sub == "export" ? "exported" : "imported",
                name.c_str(),
                static_cast<long long>(r->tiles),
                humanBytes(r->bytes).c_str(),
                r->minLevel,
                r->maxLevel,
                file.c_str());
    return kExitOk;
  }
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
    if (r->tempFilesInUse > 0) {
      std::printf("temp files of running writers: %lld (not a problem)\n",
                  static_cast<long long>(r->tempFilesInUse));
    }
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
  if (const auto name = po.datasetName) {
    // A layer that neither the configuration nor the cache knows is a typo: refuse it rather
    // than remove nothing (or, before, everything).
    const auto held = ctx->cache->datasets();
    const bool known =
        ctx->config.layer(*name) != nullptr ||
        std::any_of(held.begin(), held.end(), [&](const auto& d) { return d.spec.name == *name; });
    if (!known) {
      std::vector<std::string_view> names;
      for (const auto& l : ctx->config.layers)
        names.push_back(l.name);
      for (const auto& d : held)
        names.push_back(d.spec.name);
      const auto guess = cli::closestName(*name, names);
      std::fprintf(stderr,
                   "tellus cache prune: no layer '%s' in the configuration or the cache%s\n",
                   name->c_str(),
                   guess ? (" (did you mean " + std::string(*guess) + "?)").c_str() : "");
      return kExitUsage;
    }
  }
  // Say what goes before it goes: which layers, which of their tiles, how many.
  const auto doomed = ctx->cache->prunable(po);
  if (!doomed) {
    std::fprintf(stderr, "tellus cache prune: %s\n", doomed.error().message.c_str());
    return kExitError;
  }
  std::int64_t doomedTiles = 0;
  std::int64_t doomedBytes = 0;
  for (const auto& d : *doomed) {
    doomedTiles += d.tiles;
    doomedBytes += d.bytes;
  }
  std::printf("%s tiles fetched more than %s ago from %s%s: %lld tiles, %s\n",
              a.flag("dry-run") ? "would remove" : "removing",
              a.get("older-than")->c_str(),
              po.datasetName ? ("layer " + *po.datasetName).c_str() : "EVERY layer",
              po.includePinned ? " (pinned ones too)" : " (pinned layers kept)",
              static_cast<long long>(doomedTiles),
              humanBytes(doomedBytes).c_str());
  for (const auto& d : *doomed) {
    std::printf("  %s/%s%s%s: %lld tiles, %s\n",
                d.dataset.spec.server.c_str(),
                d.dataset.spec.name.c_str(),
                d.dataset.spec.time.empty() ? "" : " time ",
                d.dataset.spec.time.c_str(),
                static_cast<long long>(d.tiles),
                humanBytes(d.bytes).c_str());
  }
  if (a.flag("dry-run")) return kExitOk;
  auto n = ctx->cache->prune(po);
  if (!n) {
    std::fprintf(stderr, "tellus cache prune: %s\n", n.error().message.c_str());
    return kExitError;
  }
  std::printf("pruned %lld tiles\n", static_cast<long long>(*n));
  return kExitOk;
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

int cmdServe(const Args& a) {
  auto ctx = setUp(a, false, /*serving=*/true);
  if (!ctx) return kExitError;
  ServerSettings server = ctx->config.server;
  if (auto listen = a.get("listen")) {
    const auto colon = listen->rfind(':');
    int port = -1;
    if (colon != std::string::npos) {
      const std::string p = listen->substr(colon + 1);
      auto [ptr, ec] = std::from_chars(p.data(), p.data() + p.size(), port);
      if (ec != std::errc{} || ptr != p.data() + p.size()) port = -1;
    }
    if (colon == std::string::npos || port < 0 || port > 65535) {
      std::fprintf(stderr,
                   "tellus serve: --listen must be HOST:PORT (port 0 = any), got '%s'\n",
                   listen->c_str());
      return kExitUsage;
    }
    server.listenHost = listen->substr(0, colon);
    server.listenPort = static_cast<std::uint16_t>(port);
  }
  if (auto t = a.get("threads")) {
    int n = -1;
    auto [ptr, ec] = std::from_chars(t->data(), t->data() + t->size(), n);
    if (ec != std::errc{} || ptr != t->data() + t->size() || n < 0 || n > 256) {
      std::fprintf(stderr,
                   "tellus serve: --threads must be 0-256 (0 = one per core but one), got '%s'\n",
                   t->c_str());
      return kExitUsage;
    }
    server.threads = n;
  }
  if (a.flag("offline")) server.offline = true;
  if (auto l = a.get("log-level")) server.logLevel = *l;
  if (auto l = a.get("access-log")) server.accessLog = *l;
  const auto level = parseLogLevel(server.logLevel);
  if (!level) {
    std::fprintf(stderr,
                 "tellus serve: --log-level must be error, warn, info or debug, got '%s'\n",
                 server.logLevel.c_str());
    return kExitUsage;
  }
  logger().setLevel(*level);
  if (std::string err; !logger().openAccessLog(server.accessLog, &err)) {
    std::fprintf(stderr, "tellus serve: %s\n", err.c_str());
    return kExitError;
  }

  // Signals are taken by sigwait below: block them before any thread starts.
  sigset_t stopSignals;
  sigemptyset(&stopSignals);
  sigaddset(&stopSignals, SIGINT);
  sigaddset(&stopSignals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stopSignals, nullptr);

  Fetcher fetcher;
  auto [upstreams, layers] = proxySpecs(ctx->config);
  TileServiceOptions tso;
  tso.offline = server.offline;
  auto tiles =
      TileService::create(*ctx->cache, fetcher, std::move(upstreams), std::move(layers), tso);
  if (!tiles) {
    std::fprintf(stderr, "tellus serve: %s\n", tiles.error().c_str());
    return kExitError;
  }
  FrontEndOptions fo;
  fo.publicUrl = server.publicUrl;
  fo.cors = server.cors;
  fo.exceptionsHttpStatus = server.exceptionsHttpStatus;
  fo.offlineResponse = server.offlineResponse == OfflineResponse::Blank
                           ? FrontEndOptions::OfflineResponse::Blank
                           : FrontEndOptions::OfflineResponse::Exception;
  fo.limits.maxWidth = server.limits.maxWidth;
  fo.maxMapPixels = server.limits.maxMapPixels;
  fo.maxTilesPerMap = static_cast<std::size_t>(server.limits.maxTilesPerMap);
  fo.decodedTileCacheBytes = static_cast<std::size_t>(server.limits.decodedTileCache);
  fo.jpegQuality = server.jpegQuality;
  fo.composeThreads = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  fo.limits.maxHeight = server.limits.maxHeight;
  fo.maxParamBytes = server.limits.maxParamBytes;
  fo.fetchesPerClientPerMinute = server.limits.fetchesPerClientPerMinute;
  ProxyFrontEnd front(**tiles, fo);
  HttpServerOptions ho;
  ho.host = server.listenHost;
  ho.port = server.listenPort;
  ho.maxConnections = static_cast<std::size_t>(std::max(1, server.limits.maxConnections));
  ho.maxHeaderBytes = server.limits.maxHeaderBytes;
  ho.requestTimeout = server.limits.requestTimeout;
  ho.keepAliveTimeout = server.limits.keepaliveTimeout;
  ho.requestsPerSecond = server.limits.requestsPerSecond;
  ho.threads = server.threads;
  HttpServer http(ho, [&front](HttpRequest&& r, Responder respond) {
    front.handle(std::move(r), std::move(respond));
  });
  if (auto started = http.start(); !started) {
    std::fprintf(stderr, "tellus serve: %s\n", started.error().c_str());
    return kExitError;
  }
  const std::string host = ho.host == "0.0.0.0" || ho.host == "::" ? "127.0.0.1" : ho.host;
  const std::string base = "http://" + host + ":" + std::to_string(http.port());
  std::printf("tellus serve: listening on %s (cache %s%s)\n",
              base.c_str(),
              ctx->config.cache.root.c_str(),
              server.offline ? ", offline" : "");
  if (webPageEmbedded()) std::printf("  map page      %s/\n", base.c_str());
  std::printf("  capabilities  %s/wms?SERVICE=WMS&REQUEST=GetCapabilities\n", base.c_str());
  std::printf("  metrics       %s/metrics  (Prometheus)\n", base.c_str());
  for (const auto& l : (*tiles)->layers()) {
    const auto& g = l.dataset.grid;
    std::printf(
        "  %-12s  %s/wwtile?T=%s&L=0&X=0&Y=0\n", l.name.c_str(), base.c_str(), l.name.c_str());
    std::printf(
        "  %-12s  %s/wms?SERVICE=WMS&REQUEST=GetMap&VERSION=1.3.0&LAYERS=%s&STYLES=&CRS=CRS:84"
        "&BBOX=%g,%g,%g,%g&WIDTH=%d&HEIGHT=%d&FORMAT=%s\n",
        "",
        base.c_str(),
        l.name.c_str(),
        g.sector.west,
        g.sector.south,
        g.sector.west + g.levelZeroDeltaDeg,
        g.sector.south + g.levelZeroDeltaDeg,
        g.tileWidth,
        g.tileHeight,
        l.dataset.mimeType.c_str());
  }
  std::printf("Ctrl-C stops it.\n");
  std::fflush(stdout);
  int signal = 0;
  sigwait(&stopSignals, &signal);
  std::printf("tellus serve: stopping (%s)\n", signal == SIGINT ? "SIGINT" : "SIGTERM");
  http.stop();
  return kExitOk;
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

std::string renderStatsJson(const planet::RenderStats& s, double seconds, bool complete) {
  char buf[2048];
  std::snprintf(
      buf,
      sizeof buf,
      "{\n  \"complete\": %s,\n  \"seconds\": %.3f,\n  \"frames\": %llu,\n"
      "  \"nodes_visible\": %zu,\n  \"nodes_drawn\": %zu,\n  \"nodes_created\": %zu,\n"
      "  \"nodes_created_total\": %zu,\n  \"nodes_in_tree\": %zu,\n  \"max_level\": %d,\n"
      "  \"tiles_requested\": %zu,\n  \"tiles_received\": %zu,\n  \"tiles_absent\": %zu,\n"
      "  \"tiles_failed\": %zu,\n  \"tiles_in_flight\": %zu,\n  \"textures_decoded\": %zu,\n"
      "  \"decode_errors\": %zu,\n  \"textures_uploaded\": %zu,\n  \"bytes_received\": %zu,\n"
      "  \"bytes_uploaded\": %zu,\n  \"textures_resident\": %zu,\n  \"texture_bytes\": %zu,\n"
      "  \"textures_reused\": %zu,\n  \"textures_evicted\": %zu,\n"
      "  \"update_ms\": %.3f,\n  \"longest_update_ms\": %.3f,\n  \"frame_ms\": %.3f,\n  "
      "\"reversed_z\": %s,\n  \"gl\": ",
      complete ? "true" : "false",
      seconds,
      static_cast<unsigned long long>(s.frames),
      s.nodesVisible,
      s.nodesDrawn,
      s.nodesCreated,
      s.nodesCreatedTotal,
      s.nodesInTree,
      s.maxLevel,
      s.tilesRequested,
      s.tilesReceived,
      s.tilesAbsent,
      s.tilesFailed,
      s.tilesInFlight,
      s.texturesDecoded,
      s.decodeErrors,
      s.texturesUploaded,
      s.bytesReceived,
      s.bytesUploaded,
      s.texturesResident,
      s.textureBytes,
      s.texturesReused,
      s.texturesEvicted,
      s.updateMs,
      s.longestUpdateMs,
      s.frameMs,
      s.reversedZ ? "true" : "false");
  char terrain[768];
  std::snprintf(terrain,
                sizeof terrain,
                ",\n  \"height_tiles_requested\": %zu,\n  \"height_tiles_received\": %zu,\n"
                "  \"height_tiles_absent\": %zu,\n  \"height_tiles_failed\": %zu,\n"
                "  \"nodes_without_heights\": %zu,\n"
                "  \"meshes_built\": %zu,\n  \"meshes_built_last\": %zu,\n  \"mesh_ms\": %.3f,\n"
                "  \"mesh_ms_total\": %.3f,\n"
                "  \"edges_fixed\": %zu,\n  \"zero_area_triangles\": %zu,\n  \"camera_lifted\": %s",
                s.heightTilesRequested,
                s.heightTilesReceived,
                s.heightTilesAbsent,
                s.heightTilesFailed,
                s.nodesWithoutHeights,
                s.meshesBuilt,
                s.meshesBuiltLast,
                s.meshMs,
                s.meshMsTotal,
                s.edgesFixed,
                s.zeroAreaTriangles,
                s.cameraLifted ? "true" : "false");
  // The layers (issue #7): the base, then the overlays in drawing order.
  // The dome (issue #7): how the last frame was drawn, and the direct method's error estimate.
  char dome[128];
  if (std::isfinite(s.domeErrorPx)) // infinite (an edge that cannot be mapped): null
    std::snprintf(dome, sizeof dome, ",\n  \"dome_error_px\": %.4g", s.domeErrorPx);
  else
    std::snprintf(dome, sizeof dome, ",\n  \"dome_error_px\": null");
  std::string layers = ",\n  \"dome_method\": " + jsonString(s.domeMethod) + dome +
                       ",\n  \"dome_face_bytes\": " + std::to_string(s.domeFaceBytes) +
                       ",\n  \"dome_error\": " + jsonString(s.domeError) +
                       ",\n  \"passes\": " + std::to_string(s.passes) +
                       ",\n  \"overlays_per_pass\": " + std::to_string(s.overlaysPerPass) +
                       ",\n  \"layers\": [";
  for (std::size_t i = 0; i < s.layers.size(); ++i) {
    const auto& l = s.layers[i];
    char row[512];
    std::snprintf(row,
                  sizeof row,
                  ", \"opacity\": %.3f, \"visible\": %s, \"tiles_requested\": %zu, "
                  "\"tiles_received\": %zu, \"textures_resident\": %zu, \"swaps\": %zu}",
                  l.opacity,
                  l.visible ? "true" : "false",
                  l.tilesRequested,
                  l.tilesReceived,
                  l.texturesResident,
                  l.swaps);
    layers += std::string(i == 0 ? "\n    " : ",\n    ") + "{\"name\": " + jsonString(l.name) +
              ", \"time\": " + jsonString(l.time) +
              ", \"pending_time\": " + jsonString(l.pendingTime) + row;
  }
  layers += "\n  ]";
  return buf + jsonString(s.glVersion) + terrain + layers + "\n}\n";
}

/** The frame times of a render (",\n" and the keys that close the statistics object): median,
 * 95th and 99th percentile (nearest rank), longest, where the longest frame's time went, and every
 * frame's time, update (quadtree + streamer) time and process CPU time (every thread: on llvmpipe
 * the rasteriser's too; less disturbed by other processes than the wall clock) in order. */
std::string frameTimesJson(const std::vector<planet::FramePhases>& frames,
                           const std::vector<double>& cpuMs) {
  std::vector<double> sorted;
  sorted.reserve(frames.size());
  for (const auto& f : frames)
    sorted.push_back(f.total);
  std::sort(sorted.begin(), sorted.end());
  auto rank = [&](double q) {
    if (sorted.empty()) return 0.0;
    const auto i = static_cast<std::size_t>(std::ceil(q * static_cast<double>(sorted.size())));
    return sorted[std::clamp<std::size_t>(i, 1, sorted.size()) - 1];
  };
  planet::FramePhases worst;
  std::size_t worstIndex = 0;
  for (std::size_t i = 0; i < frames.size(); ++i)
    if (frames[i].total > worst.total) {
      worst = frames[i];
      worstIndex = i;
    }
  char buf[1024];
  std::snprintf(buf,
                sizeof buf,
                ",\n  \"median_frame_ms\": %.3f,\n  \"p95_frame_ms\": %.3f,\n  \"p99_frame_ms\": "
                "%.3f,\n  \"longest_frame_ms\": %.3f,\n  \"longest_frame\": {\"index\": %zu, "
                "\"update_ms\": %.3f, \"intake_ms\": %.3f, \"upload_ms\": %.3f, "
                "\"upload_bytes\": %zu, \"mesh_ms\": %.3f, \"meshes_created\": %zu, "
                "\"draw_ms\": %.3f, \"finish_ms\": %.3f}\n}\n",
                sorted.empty() ? 0.0 : sorted[sorted.size() / 2],
                rank(0.95),
                rank(0.99),
                sorted.empty() ? 0.0 : sorted.back(),
                worstIndex,
                worst.update,
                worst.intake,
                worst.upload,
                worst.uploadBytes,
                worst.mesh,
                worst.meshesCreated,
                worst.draw,
                worst.finish);
  std::string out = buf;
  out.resize(out.size() - 3); // "\n}\n"
  out += ",\n  \"frame_times_ms\": [";
  for (std::size_t i = 0; i < frames.size(); ++i) {
    char v[32];
    std::snprintf(v, sizeof v, "%s%.3f", i == 0 ? "" : ", ", frames[i].total);
    out += v;
  }
  out += "],\n  \"update_times_ms\": [";
  for (std::size_t i = 0; i < frames.size(); ++i) {
    char v[32];
    std::snprintf(v, sizeof v, "%s%.3f", i == 0 ? "" : ", ", frames[i].update);
    out += v;
  }
  out += "],\n  \"frame_cpu_ms\": [";
  for (std::size_t i = 0; i < cpuMs.size(); ++i) {
    char v[32];
    std::snprintf(v, sizeof v, "%s%.3f", i == 0 ? "" : ", ", cpuMs[i]);
    out += v;
  }
  return out + "]\n}\n";
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

/** A keyframe of `tellus render --path`: time in seconds and a camera pose. */
struct Keyframe {
  double time = 0.0;
  planet::CameraPose pose;
  /** "times": {"layer": "TIME", ...}: from this keyframe on, the layer shows that time (it swaps
   * once the new time's tiles are all there; with --wait-complete every frame waits for it). */
  std::map<std::string, std::string> times;
};

/**
 * Reads PATH.json: an array of objects (or {"keyframes": [...]}) with numbers time, lat, lon, alt
 * and optionally heading and tilt, times increasing, and optionally "times": {"layer": "TIME"}. A
 * small reader for just that shape: strings are keys, numbers are values; anything else is an error
 * naming the byte offset.
 */
std::expected<std::vector<Keyframe>, std::string> readPath(const fs::path& file) {
  std::FILE* f = std::fopen(file.c_str(), "rb");
  if (f == nullptr) return std::unexpected("cannot open " + file.string());
  std::string text;
  char buf[4096];
  for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, f)) > 0;)
    text.append(buf, n);
  std::fclose(f);
  std::size_t i = 0;
  auto fail = [&](const std::string& what) {
    return std::unexpected(file.string() + ": " + what + " at byte " + std::to_string(i));
  };
  auto ws = [&] {
    while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i])))
      ++i;
  };
  auto eat = [&](char c) {
    ws();
    if (i < text.size() && text[i] == c) {
      ++i;
      return true;
    }
    return false;
  };
  auto string = [&](std::string* out) {
    ws();
    if (i >= text.size() || text[i] != '"') return false;
    const auto end = text.find('"', i + 1);
    if (end == std::string::npos) return false;
    *out = text.substr(i + 1, end - i - 1);
    i = end + 1;
    return true;
  };
  auto number = [&](double* out) {
    ws();
    auto [ptr, ec] = std::from_chars(text.data() + i, text.data() + text.size(), *out);
    if (ec != std::errc{} || !std::isfinite(*out)) return false;
    i = static_cast<std::size_t>(ptr - text.data());
    return true;
  };
  bool wrapped = false;
  if (eat('{')) {
    std::string key;
    if (!string(&key) || key != "keyframes" || !eat(':')) return fail("expected \"keyframes\":");
    wrapped = true;
  }
  if (!eat('[')) return fail("expected an array of keyframes");
  std::vector<Keyframe> keys;
  while (!eat(']')) {
    if (!keys.empty() && !eat(',')) return fail("expected , or ]");
    if (!eat('{')) return fail("expected a keyframe object");
    Keyframe k;
    bool seen[6] = {};
    bool timesSeen = false;
    while (!eat('}')) {
      if ((seen[0] || seen[1] || seen[2] || seen[3] || seen[4] || seen[5] || timesSeen) &&
          !eat(','))
        return fail("expected , or }");
      std::string key;
      double v = 0.0;
      if (!string(&key) || !eat(':')) return fail("expected \"name\":");
      if (key == "times") {
        if (!eat('{')) return fail("expected {\"layer\": \"TIME\", ...}");
        while (!eat('}')) {
          if (!k.times.empty() && !eat(',')) return fail("expected , or }");
          std::string layer, value;
          if (!string(&layer) || !eat(':') || !string(&value))
            return fail("expected \"layer\": \"TIME\"");
          k.times[layer] = value;
        }
        timesSeen = true;
        continue;
      }
      if (!number(&v)) return fail("expected \"name\": number");
      static const char* names[6] = {"time", "lat", "lon", "alt", "heading", "tilt"};
      const auto at = std::find(std::begin(names), std::end(names), key);
      if (at == std::end(names)) return fail("unknown key '" + key + "'");
      const auto idx = static_cast<std::size_t>(at - std::begin(names));
      seen[idx] = true;
      double* fields[6] = {&k.time,
                           &k.pose.latDeg,
                           &k.pose.lonDeg,
                           &k.pose.altitudeM,
                           &k.pose.headingDeg,
                           &k.pose.tiltDeg};
      *fields[idx] = v;
    }
    if (!seen[0] || !seen[1] || !seen[2] || !seen[3])
      return fail("a keyframe needs time, lat, lon and alt");
    if (k.pose.latDeg < -90.0 || k.pose.latDeg > 90.0 || k.pose.altitudeM < -11000.0 ||
        k.pose.altitudeM > 1e10 || k.pose.tiltDeg < 0.0 || k.pose.tiltDeg > 180.0)
      return fail("keyframe out of range (lat [-90, 90], alt [-11000, 1e10], tilt [0, 180])");
    if (!keys.empty() && !(k.time > keys.back().time)) return fail("times must increase");
    keys.push_back(k);
  }
  if (wrapped && !eat('}')) return fail("expected }");
  ws();
  if (i != text.size()) return fail("trailing text");
  if (keys.empty()) return fail("no keyframes");
  return keys;
}

/** The pose at time t: linear in latitude and tilt, the short way round in longitude and heading,
 * geometric in altitude (a descent slows down as it nears the ground) when both are positive. */
planet::CameraPose poseAt(const std::vector<Keyframe>& keys, double t) {
  if (t <= keys.front().time) return keys.front().pose;
  if (t >= keys.back().time) return keys.back().pose;
  std::size_t k = 0;
  while (keys[k + 1].time < t)
    ++k;
  const auto& a = keys[k].pose;
  const auto& b = keys[k + 1].pose;
  const double u = (t - keys[k].time) / (keys[k + 1].time - keys[k].time);
  auto lerp = [u](double x, double y) { return x + (y - x) * u; };
  auto angle = [u](double x, double y) {
    const double d = std::remainder(y - x, 360.0);
    return x + d * u;
  };
  planet::CameraPose p;
  p.latDeg = std::clamp(lerp(a.latDeg, b.latDeg), -90.0, 90.0);
  p.lonDeg = angle(a.lonDeg, b.lonDeg);
  p.altitudeM = a.altitudeM > 0.0 && b.altitudeM > 0.0
                    ? std::exp(lerp(std::log(a.altitudeM), std::log(b.altitudeM)))
                    : lerp(a.altitudeM, b.altitudeM);
  p.headingDeg = angle(a.headingDeg, b.headingDeg);
  p.tiltDeg = lerp(a.tiltDeg, b.tiltDeg);
  return p;
}

/** Where `render` and `view` get their tiles: the in-process tile service over the cache (the
 * default, fetching misses upstream as `serve` does), or a remote `tellus serve` (--server URL,
 * through its /layers.json and /tiles/). Also picks the layer: --layer, else the first imagery
 * layer. Returns an exit code on failure (usage errors 2, the rest 1) after saying why. */
struct PlanetTiles {
  std::optional<Context> ctx;
  std::unique_ptr<Fetcher> fetcher;
  std::unique_ptr<TileService> service;
  std::unique_ptr<RemoteTileSource> remote;
  std::unique_ptr<planet::RegionalTileSource> regional; ///< over service or remote, when used
  ITileSource* source = nullptr;
  EarthModel earth = EarthModel::Wgs84; ///< the configuration's renderer.earth
  /** Per renderer layer (base, overlays): the TIME values `view` steps through ([ and ]). */
  std::vector<std::vector<std::string>> layerTimes;
};

/** The layers drawn over the base chosen before (issue #7): renderer.layers[1..] of the
 * configuration, then each --overlay NAME[,OPACITY]; the base's time from renderer.layers[0] when
 * it is the base. Regional datasets (renderer.layers[].regional, renderer.terrain.regional) make
 * each such layer one combined layer through a RegionalTileSource over the source. False after
 * saying why. */
bool applyRenderLayers(const RendererSettings& g,
                       const Config* config,
                       const Args& a,
                       planet::RendererOptions& ro,
                       PlanetTiles& t,
                       const char* cmd) {
  std::vector<planet::CombinedLayer> combined;
  const auto combine = [&](const std::string& name, const std::vector<std::string>& regional) {
    if (regional.empty()) return;
    std::vector<std::string> datasets{name};
    datasets.insert(datasets.end(), regional.begin(), regional.end());
    for (const auto& c : combined)
      if (c.name == name && c.datasets == datasets) return;
    combined.push_back({name, std::move(datasets)});
  };
  const bool baseFromConfig = !g.layers.empty() && g.layers.front().layer == ro.layer;
  if (baseFromConfig) {
    ro.time = g.layers.front().time;
    combine(ro.layer, g.layers.front().regional);
  }
  for (std::size_t i = 1; i < g.layers.size(); ++i) {
    const RenderLayerSettings& l = g.layers[i];
    planet::LayerOptions o;
    o.layer = l.layer;
    o.time = l.time;
    const LayerConfig* lc = config != nullptr ? config->layer(l.layer) : nullptr;
    o.opacity = l.opacity.value_or(lc != nullptr ? lc->opacity : 1.0);
    o.visible = l.visible;
    o.maxLevel = l.maxLevel;
    ro.overlays.push_back(o);
    combine(l.layer, l.regional);
  }
  for (const std::string& v : a.all("overlay")) {
    planet::LayerOptions o;
    const auto comma = v.find(',');
    o.layer = v.substr(0, comma);
    const LayerConfig* lc = config != nullptr ? config->layer(o.layer) : nullptr;
    o.opacity = lc != nullptr ? lc->opacity : 1.0;
    if (comma != std::string::npos) {
      const auto op = parseNumbers(v.substr(comma + 1), 1, 1);
      if (!op || !((*op)[0] >= 0.0 && (*op)[0] <= 1.0)) {
        std::fprintf(stderr,
                     "tellus %s: --overlay must be NAME[,OPACITY] with OPACITY in [0, 1], got "
                     "'%s'\n",
                     cmd,
                     v.c_str());
        return false;
      }
      o.opacity = (*op)[0];
    }
    if (o.layer.empty() ||
        (config != nullptr && (lc == nullptr || lc->kind != LayerKind::Imagery))) {
      std::fprintf(
          stderr, "tellus %s: --overlay must name an imagery layer, got '%s'\n", cmd, v.c_str());
      return false;
    }
    ro.overlays.push_back(o);
  }
  if (!ro.elevationLayer.empty()) combine(ro.elevationLayer, g.terrain.regional);
  if (!combined.empty()) {
    auto r = planet::RegionalTileSource::create(*t.source, std::move(combined));
    if (!r) {
      std::fprintf(stderr, "tellus %s: %s\n", cmd, r.error().c_str());
      return false;
    }
    t.regional = std::move(*r);
    t.source = t.regional.get();
  }
  const auto timesOf = [&](const std::string& name) {
    const LayerConfig* lc = config != nullptr ? config->layer(name) : nullptr;
    return lc != nullptr ? lc->time.values : std::vector<std::string>{};
  };
  t.layerTimes.push_back(timesOf(ro.layer));
  for (const auto& o : ro.overlays)
    t.layerTimes.push_back(timesOf(o.layer));
  return true;
}

/** `--earth wgs84|sphere` of render and view; nullopt when absent, an error text when bad. */
std::expected<std::optional<EarthModel>, std::string> earthArg(const Args& a) {
  const auto e = a.get("earth");
  if (!e) return std::nullopt;
  if (*e == "wgs84") return EarthModel::Wgs84;
  if (*e == "sphere") return EarthModel::Sphere;
  return std::unexpected(*e);
}

/** `--dome [FOV]` (also `--dome=FOV`) and
 * `--dome-tilt DEG` of render and view: whether the command line asks for the dome, and what it
 * gives. An error text for a bad value. */
struct DomeArgs {
  bool on = false;
  std::optional<double> fovDeg, tiltDeg;
  std::optional<planet::DomeMethod> method; ///< --dome-method direct|cube
};
std::expected<DomeArgs, std::string> domeArgs(const Args& a) {
  DomeArgs d;
  d.on = a.flag("dome");
  std::optional<std::string> fov;
  if (const auto v = a.get("dome"); v && !v->empty()) fov = *v;
  if (fov) {
    const auto v = parseNumbers(*fov, 1, 1);
    if (!v || !((*v)[0] > 0.0 && (*v)[0] <= 220.0))
      return std::unexpected("--dome FOV must be in (0, 220] degrees, got '" + *fov + "'");
    d.fovDeg = (*v)[0];
  }
  if (const auto t = a.get("dome-tilt")) {
    const auto v = parseNumbers(*t, 1, 1);
    if (!v || !((*v)[0] >= -180.0 && (*v)[0] <= 180.0))
      return std::unexpected("--dome-tilt must be in [-180, 180] degrees, got '" + *t + "'");
    d.tiltDeg = (*v)[0];
  }
  if (const auto m = a.get("dome-method")) {
    if (*m == "direct")
      d.method = planet::DomeMethod::Direct;
    else if (*m == "cube")
      d.method = planet::DomeMethod::Cube;
    else
      return std::unexpected("--dome-method must be direct or cube, got '" + *m + "'");
  }
  return d;
}

/** The configuration's `renderer` settings; what the command line gave (--threshold, --earth,
 * --dome, --dome-tilt) wins (the caller applies --earth). */
void applyRendererSettings(const RendererSettings& g,
                           const Args& a,
                           planet::RendererOptions& ro,
                           EarthModel& earth) {
  earth = g.earth == EarthShape::Sphere ? EarthModel::Sphere : EarthModel::Wgs84;
  if (!a.get("threshold")) ro.lodThreshold = g.lodThreshold;
  ro.meshSize = g.meshSize;
  ro.verticalFovDeg = g.fovDeg;
  ro.textureBudgetBytes = static_cast<std::size_t>(g.textureBudget);
  ro.uploadBytesPerFrame = static_cast<std::size_t>(g.uploadPerFrame);
  ro.maxInFlight = static_cast<std::size_t>(g.maxInFlight);
  ro.maxSplitsPerFrame = g.maxSplitsPerFrame;
  ro.decodeThreads = g.decodeThreads;
  ro.overlaysPerPass = g.overlaysPerPass;
  ro.verticalExaggeration = g.terrain.exaggeration;
  ro.terrainClearanceM = g.terrain.clearanceM;
  ro.terrainMinReliefPx = g.terrain.minReliefPx;
  ro.sunLatLon = g.terrain.sun;
  if (const auto d = domeArgs(a); d && (d->on || g.dome.enabled)) {
    ro.dome = planet::DomeOptions{
        d->fovDeg.value_or(g.dome.fovDeg), d->tiltDeg.value_or(g.dome.tiltDeg), g.dome.faceScale};
    ro.dome->method = d->method.value_or(g.dome.method == DomeSettings::Method::Cube
                                             ? planet::DomeMethod::Cube
                                             : planet::DomeMethod::Direct);
    ro.dome->directMaxErrorPx = g.dome.directMaxErrorPx;
    // A domemaster is square: without --size, the smaller side of the default.
    if (!a.get("size")) ro.width = ro.height = std::min(ro.width, ro.height);
  }
}

/** --exaggeration X and --sun LAT,LON over the configuration's renderer.terrain. */
std::optional<std::string> applyTerrainArgs(const Args& a, planet::RendererOptions& ro) {
  if (auto e = a.get("exaggeration")) {
    const auto v = parseNumbers(*e, 1, 1);
    if (!v || !((*v)[0] > 0.0 && (*v)[0] <= 100.0))
      return "--exaggeration must be a number in (0, 100], got '" + *e + "'";
    ro.verticalExaggeration = (*v)[0];
  }
  if (auto e = a.get("min-relief-px")) {
    const auto v = parseNumbers(*e, 1, 1);
    if (!v || !((*v)[0] >= 0.0 && (*v)[0] <= 100.0))
      return "--min-relief-px must be a number in [0, 100], got '" + *e + "'";
    ro.terrainMinReliefPx = (*v)[0];
  }
  if (auto e = a.get("edge-fixing")) {
    if (*e != "on" && *e != "off") return "--edge-fixing must be on or off, got '" + *e + "'";
    ro.fixEdges = *e == "on";
  }
  if (auto e = a.get("geoid"); e && *e != "on" && *e != "off")
    return "--geoid must be on or off, got '" + *e + "'";
  if (auto e = a.get("mesh-size")) {
    const auto v = parseNumbers(*e, 1, 1);
    const double d = v ? (*v)[0] : 0.0;
    const int n = d >= 3.0 && d <= 257.0 ? static_cast<int>(d) : 0; // no cast out of range
    if (!v || n == 0 || static_cast<double>(n) != d || ((n - 1) & (n - 2)) != 0)
      return "--mesh-size must be 2^k + 1 in [3, 257], got '" + *e + "'";
    ro.meshSize = n;
  }
  if (auto e = a.get("upload-per-frame")) {
    const auto v = parseNumbers(*e, 1, 1);
    if (!v || !((*v)[0] >= 4096.0 && (*v)[0] <= 1e10))
      return "--upload-per-frame must be bytes in [4096, 1e10], got '" + *e + "'";
    ro.uploadBytesPerFrame = static_cast<std::size_t>((*v)[0]);
  }
  if (auto e = a.get("vertices")) {
    if (*e != "double" && *e != "float")
      return "--vertices must be double or float, got '" + *e + "'";
    ro.fp64Vertices = *e == "double";
  }
  if (auto e = a.get("sun")) {
    const auto v = parseNumbers(*e, 2, 2);
    if (!v || (*v)[0] < -90.0 || (*v)[0] > 90.0)
      return "--sun must be LAT,LON of the subsolar point, got '" + *e + "'";
    ro.sunLatLon = std::array<double, 2>{(*v)[0], (*v)[1]};
  }
  return std::nullopt;
}

/** `renderer.geoid` (the configuration's, or --geoid on|off): the elevation layer's mean-sea-level
 * heights onto the ellipsoid with the bundled EGM96 grid of the data directory. An error text when
 * the grid cannot be read. */
std::optional<std::string> applyGeoid(const Args& a, bool configured, planet::RendererOptions& ro) {
  bool on = configured;
  if (auto g = a.get("geoid")) on = *g == "on"; // checked by applyTerrainArgs
  ro.verticalDatum = {};
  if (!on || (ro.elevationLayer.empty() && !a.get("elevation"))) return std::nullopt;
  auto geoid = Geoid::open(dataDir(a) / kGeoidFileName);
  if (!geoid) return geoid.error() + " (renderer.geoid: false or --geoid off draws without it)";
  ro.verticalDatum = VerticalDatum(std::make_shared<const Geoid>(std::move(*geoid)));
  return std::nullopt;
}

std::expected<PlanetTiles, int>
openPlanetTiles(const Args& a, const char* cmd, planet::RendererOptions& ro) {
  auto usage = [cmd](const char* what, const std::string& got) {
    std::fprintf(stderr, "tellus %s: %s, got '%s'\n", cmd, what, got.c_str());
    return kExitUsage;
  };
  PlanetTiles t;
  const auto layerArg = a.get("layer");
  if (const auto server = a.get("server")) {
    if (a.flag("offline"))
      return std::unexpected(usage("--server and --offline exclude each other", *server));
    bool terrain = !a.flag("no-terrain");
    RendererSettings settings;
    bool geoid = RendererSettings{}.geoid;
    if (const auto file = a.get("config")) { // only its renderer settings matter here
      auto loaded = loadConfig(*file);
      if (!loaded) {
        std::fprintf(stderr, "tellus: configuration: %s\n", loaded.error().toString().c_str());
        return std::unexpected(kExitError);
      }
      applyRendererSettings(loaded->renderer, a, ro, t.earth);
      terrain = terrain && loaded->renderer.terrain.enabled;
      settings = loaded->renderer;
      geoid = loaded->renderer.geoid;
    }
    if (!layerArg && !settings.layers.empty()) ro.layer = settings.layers.front().layer;
    if (auto bad = applyTerrainArgs(a, ro)) {
      std::fprintf(stderr, "tellus %s: %s\n", cmd, bad->c_str());
      return std::unexpected(kExitUsage);
    }
    auto remote = RemoteTileSource::connect(*server);
    if (!remote) {
      std::fprintf(stderr, "tellus %s: %s\n", cmd, remote.error().c_str());
      return std::unexpected(kExitError);
    }
    for (const RemoteLayer& l : (*remote)->layers())
      if (!l.elevation && (layerArg ? l.name == *layerArg : ro.layer.empty())) ro.layer = l.name;
    if (ro.layer.empty()) {
      if (layerArg)
        return std::unexpected(
            usage("--layer must name an imagery layer of the server", *layerArg));
      std::fprintf(stderr, "tellus %s: %s has no imagery layer\n", cmd, server->c_str());
      return std::unexpected(kExitError);
    }
    if (terrain)
      for (const RemoteLayer& l : (*remote)->layers())
        if (l.elevation) {
          ro.elevationLayer = l.name;
          break;
        }
    if (auto bad = applyGeoid(a, geoid, ro)) {
      std::fprintf(stderr, "tellus %s: %s\n", cmd, bad->c_str());
      return std::unexpected(kExitError);
    }
    t.remote = std::move(*remote);
    t.source = t.remote.get();
    if (!applyRenderLayers(settings, nullptr, a, ro, t, cmd)) return std::unexpected(kExitUsage);
    return t;
  }
  t.ctx = setUp(a);
  if (!t.ctx) return std::unexpected(kExitError);
  const Config& config = t.ctx->config;
  applyRendererSettings(config.renderer, a, ro, t.earth);
  if (auto bad = applyTerrainArgs(a, ro)) {
    std::fprintf(stderr, "tellus %s: %s\n", cmd, bad->c_str());
    return std::unexpected(kExitUsage);
  }
  // Imagery that is neither JPEG nor PNG (a layer of format image/tiff): the proxy's decoder,
  // through the imaging module (OpenImageIO), on the renderer's decoder threads. TIFF is the only
  // other imagery format a layer can have (config validation), so a tile without a content type
  // (a remote server that sent none) is read as one.
  ro.imageDecoder = [](std::span<const std::byte> bytes,
                       std::string_view type,
                       int w,
                       int h) -> std::expected<planet::RgbaImage, std::string> {
    auto img = decodeImagery(bytes, type.empty() ? std::string_view("image/tiff") : type, w, h);
    if (!img) return std::unexpected(img.error());
    planet::RgbaImage out{img->width, img->height, {}};
    const auto n = static_cast<std::size_t>(img->width) * static_cast<std::size_t>(img->height);
    out.pixels.resize(n * 4);
    const auto c = static_cast<std::size_t>(img->channels);
    for (std::size_t i = 0; i < n; ++i) {
      for (std::size_t k = 0; k < 3; ++k)
        out.pixels[i * 4 + k] = img->pixels[i * c + k];
      out.pixels[i * 4 + 3] = c == 4 ? img->pixels[i * 4 + 3] : 255;
    }
    return out;
  };
  if (config.renderer.terrain.enabled && !a.flag("no-terrain"))
    for (const auto& l : config.layers)
      if (l.kind == LayerKind::Elevation &&
          (config.renderer.terrain.layer.empty() || l.name == config.renderer.terrain.layer)) {
        ro.elevationLayer = l.name;
        ro.elevationEncoding = {l.elevation.scale, l.elevation.offset, l.elevation.noData};
        // The proxy's decoder: BIL16, 16-bit PNG and Int16 TIFF (the imaging module), the same
        // reading of the tiles as the maps `serve` composes from them.
        ro.heightDecoder = [](const TileKey& key,
                              int w,
                              int h,
                              std::span<const std::byte> bytes,
                              std::string_view type,
                              const planet::HeightEncoding& enc)
            -> std::expected<planet::HeightTile, std::string> {
          auto raw = decodeHeights(bytes, type, w, h);
          if (!raw) return std::unexpected(raw.error());
          std::vector<double> samples(raw->begin(), raw->end());
          return planet::heightTileFromSamples(key, w, h, samples, enc);
        };
        break;
      }
  if (auto bad = applyGeoid(a, config.renderer.geoid, ro)) {
    std::fprintf(stderr, "tellus %s: %s\n", cmd, bad->c_str());
    return std::unexpected(kExitError);
  }
  if (layerArg) {
    const auto* layer = config.layer(*layerArg);
    if (layer == nullptr || layer->kind != LayerKind::Imagery)
      return std::unexpected(
          usage("--layer must name an imagery layer of the configuration", *layerArg));
    ro.layer = *layerArg;
  } else if (!config.renderer.layers.empty()) {
    ro.layer = config.renderer.layers.front().layer;
  } else {
    for (const auto& candidate : config.layers)
      if (candidate.kind == LayerKind::Imagery) {
        ro.layer = candidate.name;
        break;
      }
    if (ro.layer.empty()) {
      std::fprintf(stderr, "tellus %s: the configuration has no imagery layer\n", cmd);
      return std::unexpected(kExitError);
    }
  }
  t.fetcher = std::make_unique<Fetcher>();
  auto [upstreams, layers] = proxySpecs(config);
  TileServiceOptions tso;
  tso.offline = a.flag("offline") || config.server.offline;
  // Tiles rendered from local rasters (a cold cache) are background work here: at the decoders'
  // priority, below the thread that draws (on llvmpipe they competed with rasterising).
  tso.workerNice = ro.decodeNice;
  auto tiles =
      TileService::create(*t.ctx->cache, *t.fetcher, std::move(upstreams), std::move(layers), tso);
  if (!tiles) {
    std::fprintf(stderr, "tellus %s: %s\n", cmd, tiles.error().c_str());
    return std::unexpected(kExitError);
  }
  t.service = std::move(*tiles);
  t.source = t.service.get();
  if (!applyRenderLayers(config.renderer, &config, a, ro, t, cmd))
    return std::unexpected(kExitUsage);
  return t;
}

int cmdRender(const Args& a) {
  auto usage = [](const char* what, const std::string& got) {
    if (got.empty())
      std::fprintf(stderr, "tellus render: %s (tellus --help)\n", what);
    else
      std::fprintf(stderr, "tellus render: %s, got '%s'\n", what, got.c_str());
    return kExitUsage;
  };
  const auto dome = domeArgs(a);
  if (!dome) return usage(dome.error().c_str(), "");
  // One view (--camera, --out) or a flight (--path, --frames).
  std::vector<Keyframe> keys;
  planet::CameraPose pose;
  const auto cameraArg = a.get("camera");
  const auto pathArg = a.get("path");
  const auto framesArg = a.get("frames");
  const auto out = a.get("out");
  if (pathArg || framesArg) {
    if (!pathArg || !framesArg || pathArg->empty() || framesArg->empty())
      return usage("--path PATH.json and --frames DIR go together", "");
    if (cameraArg || out) return usage("--path/--frames replace --camera and --out", "");
    auto read = readPath(*pathArg);
    if (!read) return usage(read.error().c_str(), *pathArg);
    keys = std::move(*read);
    pose = keys.front().pose;
  } else {
    if (!cameraArg) return usage("--camera LAT,LON,ALT[,HEADING,TILT] is required", "");
    const auto cam = parseNumbers(*cameraArg, 3, 5);
    if (!cam)
      return usage("--camera must be LAT,LON,ALT[,HEADING,TILT] (finite numbers)", *cameraArg);
    pose.latDeg = (*cam)[0];
    pose.lonDeg = (*cam)[1];
    pose.altitudeM = (*cam)[2];
    if (cam->size() > 3) pose.headingDeg = (*cam)[3];
    if (cam->size() > 4) pose.tiltDeg = (*cam)[4];
    if (pose.latDeg < -90.0 || pose.latDeg > 90.0)
      return usage("--camera latitude must be in [-90, 90]", *cameraArg);
    if (pose.altitudeM < -11000.0 || pose.altitudeM > 1e10)
      return usage("--camera altitude must be in [-11000, 1e10] metres", *cameraArg);
    if (pose.tiltDeg < 0.0 || pose.tiltDeg > 180.0)
      return usage("--camera tilt must be in [0, 180] degrees", *cameraArg);
    if (!out || out->empty()) return usage("--out FILE.png is required", "");
  }
  double fps = 25.0;
  if (auto f = a.get("fps")) {
    const auto v = parseNumbers(*f, 1, 1);
    if (!v || (*v)[0] <= 0.0 || (*v)[0] > 1000.0) return usage("--fps must be in (0, 1000]", *f);
    fps = (*v)[0];
  }
  int repeat = 1;
  if (auto rp = a.get("repeat")) {
    const auto v = parseNumbers(*rp, 1, 1);
    if (keys.empty() || !v || (*v)[0] < 1.0 || (*v)[0] > 100.0 || (*v)[0] != std::floor((*v)[0]))
      return usage("--repeat must be a whole number of flights in [1, 100] with --path", *rp);
    repeat = static_cast<int>((*v)[0]);
  }
  planet::RendererOptions ro;
  if (auto size = a.get("size")) {
    auto x = size->find('x');
    int w = 0, h = 0;
    std::string square; // --size N with --dome: N x N
    if (x == std::string::npos && dome->on) {
      square = *size + "x" + *size;
      size = square;
      x = size->find('x');
    }
    bool ok = x != std::string::npos;
    if (ok) {
      auto r1 = std::from_chars(size->data(), size->data() + x, w);
      auto r2 = std::from_chars(size->data() + x + 1, size->data() + size->size(), h);
      ok = r1.ec == std::errc{} && r1.ptr == size->data() + x && r2.ec == std::errc{} &&
           r2.ptr == size->data() + size->size() && w >= 1 && h >= 1 && w <= 16384 && h <= 16384;
    }
    if (!ok) return usage("--size must be WxH with 1 to 16384 pixels each", *size);
    if (dome->on && w != h) return usage("--dome draws a square image: --size N or NxN", *size);
    ro.width = w;
    ro.height = h;
  } else if (dome->on) {
    ro.width = ro.height = 1024;
  }
  double waitSeconds = 0.0;
  const bool waitComplete = a.flag("wait-complete");
  if (waitComplete) {
    waitSeconds = 60.0;
    if (const auto w = a.get("wait-complete"); w && !w->empty()) {
      const auto v = parseNumbers(*w, 1, 1);
      if (!v || (*v)[0] <= 0.0 || (*v)[0] > 86400.0)
        return usage("--wait-complete=SECONDS must be in (0, 86400]", *w);
      waitSeconds = (*v)[0];
    }
  }
  if (auto b = a.get("background")) {
    const auto v = parseNumbers(*b, 3, 3);
    if (!v || std::any_of(v->begin(), v->end(), [](double c) { return c < 0.0 || c > 255.0; }))
      return usage("--background must be R,G,B with each in 0-255", *b);
    for (std::size_t i = 0; i < 3; ++i)
      ro.background[i] = (*v)[i] / 255.0;
  }
  if (auto t = a.get("threshold")) {
    const auto v = parseNumbers(*t, 1, 1);
    if (!v || (*v)[0] < 0.05 || (*v)[0] > 64.0)
      return usage("--threshold must be a number in [0.05, 64]", *t);
    ro.lodThreshold = (*v)[0];
  }
  const auto earth = earthArg(a);
  if (!earth) return usage("--earth must be wgs84 or sphere", earth.error());
  try {
    (void)planet::Camera(Geodesy(earth->value_or(EarthModel::Wgs84)),
                         pose,
                         {ro.width, ro.height},
                         ro.verticalFovDeg);
  } catch (const std::invalid_argument& e) {
    return usage(e.what(), cameraArg.value_or(pathArg.value_or("")));
  }

  // Background work below the frame's priority only where frames are watched (a flight as
  // streamed): with --wait-complete, or a single view, the frames only serve to finish the image,
  // and on llvmpipe (drawing on the CPU) lower-priority decoders made completion 2-5x slower.
  if (waitComplete || keys.empty()) ro.decodeNice = 0;
  auto tiles = openPlanetTiles(a, "render", ro);
  if (!tiles) return tiles.error();
  const Geodesy geodesy(earth->value_or(tiles->earth));
  // The always-resident global texture: the bundled Blue Marble.
  if (const fs::path global = dataDir(a) / "bmng_2048x1024.jpg"; fs::exists(global))
    ro.globalImage = global;
  auto renderer = planet::Renderer::create(*tiles->source, geodesy, ro);
  if (!renderer) {
    std::fprintf(stderr, "tellus render: %s\n", renderer.error().c_str());
    return kExitError;
  }
  planet::Renderer& r = **renderer;
  std::vector<planet::FramePhases> frames;
  std::vector<double> frameCpuMs;
  auto processCpuMs = [] {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    auto ms = [](const timeval& t) {
      return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_usec) * 1e-3;
    };
    return ms(u.ru_utime) + ms(u.ru_stime);
  };
  auto writeStats = [&](double elapsed, bool complete) {
    const auto statsFile = a.get("stats");
    if (!statsFile) return true;
    std::string json = renderStatsJson(r.stats(), elapsed, complete);
    json.resize(json.size() - 3); // "\n}\n"
    json += frameTimesJson(frames, frameCpuMs);
    std::FILE* f = std::fopen(statsFile->c_str(), "w");
    if (f == nullptr || std::fputs(json.c_str(), f) < 0 || std::fclose(f) != 0) {
      std::fprintf(stderr, "tellus render: cannot write %s\n", statsFile->c_str());
      return false;
    }
    return true;
  };
  // One image: frames until complete (--wait-complete, up to SECONDS) or for at most 2 s.
  const auto start = std::chrono::steady_clock::now();
  auto renderOne = [&](const planet::CameraPose& p, double limit, bool once) {
    const auto begin = std::chrono::steady_clock::now();
    for (;;) {
      const double cpu0 = processCpuMs();
      r.frame(p);
      frameCpuMs.push_back(processCpuMs() - cpu0);
      frames.push_back(r.stats().phases);
      const double t =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
      if (once || r.complete() || t > limit) break;
      // Nothing to upload: the next frame can only wait for tiles and decoders; drawing it at
      // once would take the CPU from them (on llvmpipe drawing is CPU work).
      if (!r.busy() || r.stats().uploadsPending == 0)
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    return r.complete();
  };
  auto notComplete = [&](const char* what) {
    const auto& s = r.stats();
    std::fprintf(
        stderr,
        "tellus render: %s was not complete after %g s (%zu nodes drawn, %zu tiles in flight, %zu "
        "failed, %zu decoding, %zu uploading); no image written\n",
        what,
        waitSeconds,
        s.nodesDrawn,
        s.tilesInFlight,
        s.tilesFailed,
        s.decodesPending,
        s.uploadsPending);
    return kExitError;
  };
  auto secondsSince = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };

  if (!keys.empty()) {
    // A flight: numbered PNGs at --fps. With --wait-complete every frame is complete (offline
    // show production); without, each image is one renderer frame (what a live viewer saw).
    std::error_code ec;
    fs::create_directories(*framesArg, ec);
    if (ec) {
      std::fprintf(stderr, "tellus render: %s: %s\n", framesArg->c_str(), ec.message().c_str());
      return kExitError;
    }
    const double duration = keys.back().time - keys.front().time;
    const auto count = static_cast<long long>(std::floor(duration * fps + 1e-9)) + 1;
    // Layer times of the keyframes: which renderer layers (0 the base, then the overlays) a name
    // means; every name must be drawn.
    std::vector<std::string> drawnNames{ro.layer};
    for (const auto& o : ro.overlays)
      drawnNames.push_back(o.layer);
    for (const Keyframe& k : keys)
      for (const auto& [name, value] : k.times)
        if (std::find(drawnNames.begin(), drawnNames.end(), name) == drawnNames.end())
          return usage("a keyframe's \"times\" names a layer that is not drawn", name);
    auto applyTimes = [&](double t) {
      std::map<std::string, std::string> now;
      for (const Keyframe& k : keys)
        if (k.time <= t + 1e-9)
          for (const auto& [name, value] : k.times)
            now[name] = value;
      for (const auto& [name, value] : now)
        for (std::size_t i = 0; i < drawnNames.size(); ++i)
          if (drawnNames[i] == name) r.setLayerTime(i, value);
    };
    bool allComplete = true;
    // --repeat: the flight again in the same renderer (what stays resident is not streamed again:
    // the later passes' frame times are the views' cost without streaming).
    for (long long n = 0; n < count * repeat; ++n) {
      const double at = keys.front().time + static_cast<double>(n % count) / fps;
      const planet::CameraPose p = poseAt(keys, at);
      applyTimes(at);
      const bool complete = renderOne(p, waitSeconds, !waitComplete);
      allComplete = allComplete && complete;
      if (waitComplete && !complete) {
        writeStats(secondsSince(), false);
        return notComplete(("frame " + std::to_string(n % count)).c_str());
      }
      char name[32];
      std::snprintf(name, sizeof name, "frame_%05lld.png", n % count);
      std::string err;
      if (!planet::writePngRgb(
              fs::path(*framesArg) / name, r.width(), r.height(), r.readPixels(), &err)) {
        std::fprintf(stderr, "tellus render: %s\n", err.c_str());
        return kExitError;
      }
    }
    if (!writeStats(secondsSince(), allComplete)) return kExitError;
    std::printf("tellus render: %lld frames in %s after %.2f s (%s)\n",
                count,
                framesArg->c_str(),
                secondsSince(),
                allComplete ? "every frame complete" : "frames as streamed");
    return kExitOk;
  }

  const bool complete = renderOne(pose, waitComplete ? waitSeconds : 2.0, false);
  const double elapsed = secondsSince();
  if (!writeStats(elapsed, complete)) return kExitError;
  if (waitComplete && !complete) return notComplete("the view");
  std::string err;
  if (!planet::writePngRgb(*out, r.width(), r.height(), r.readPixels(), &err)) {
    std::fprintf(stderr, "tellus render: %s\n", err.c_str());
    return kExitError;
  }
  const auto& s = r.stats();
  std::printf("tellus render: %s %dx%d, %s after %.2f s and %llu frames (%zu nodes drawn, level "
              "%d, %zu tiles)\n",
              out->c_str(),
              r.width(),
              r.height(),
              complete ? "complete" : "partial",
              elapsed,
              static_cast<unsigned long long>(s.frames),
              s.nodesDrawn,
              s.maxLevel,
              s.tilesReceived);
  return kExitOk;
}

/** One tile, waited for (the tile source answers on its own threads). */
TileResult fetchTile(ITileSource& source, const TileAddress& address, std::chrono::seconds limit) {
  auto done = std::make_shared<std::promise<TileResult>>();
  auto answer = done->get_future();
  source.request(address, 1.0, [done](TileResult&& r) { done->set_value(std::move(r)); });
  if (answer.wait_for(limit) != std::future_status::ready) {
    TileResult late;
    late.status = TileStatus::Failed;
    late.message = "no answer within " + std::to_string(limit.count()) + " s";
    return late;
  }
  return answer.get();
}

// `tellus height --lat A --lon B`: the terrain height there from the deepest level of the elevation
// layer that has a tile at the point (with the neighbours its bilinear taps reach), the same
// height function the renderer draws (planet::HeightField).
int cmdHeight(const Args& a) {
  auto usage = [](const char* what, const std::string& got) {
    std::fprintf(stderr, "tellus height: %s, got '%s'\n", what, got.c_str());
    return kExitUsage;
  };
  const auto latArg = a.get("lat"), lonArg = a.get("lon");
  if (!latArg || !lonArg) return usage("--lat and --lon are required", "");
  const auto lat = parseNumbers(*latArg, 1, 1), lon = parseNumbers(*lonArg, 1, 1);
  if (!lat || !((*lat)[0] >= -90.0 && (*lat)[0] <= 90.0))
    return usage("--lat must be a latitude in [-90, 90]", *latArg);
  if (!lon || !std::isfinite((*lon)[0])) return usage("--lon must be a longitude", *lonArg);
  const auto datumArg = a.get("datum");
  if (datumArg && *datumArg != "msl" && *datumArg != "ellipsoid")
    return usage("--datum must be msl or ellipsoid", *datumArg);
  planet::RendererOptions ro;
  auto tiles = openPlanetTiles(a, "height", ro);
  if (!tiles) return tiles.error();
  if (const auto layer = a.get("elevation")) ro.elevationLayer = *layer;
  if (ro.elevationLayer.empty()) {
    std::fprintf(stderr, "tellus height: no elevation layer (renderer.terrain)\n");
    return kExitError;
  }
  const auto spec = tiles->source->describe(ro.elevationLayer, "");
  if (!spec) return usage("--elevation must name an elevation layer", ro.elevationLayer);
  const auto grid = TileGrid::create(spec->grid);
  if (!grid) {
    std::fprintf(stderr, "tellus height: %s\n", grid.error().c_str());
    return kExitError;
  }
  // Two readings of the same tiles: as the layer gives them (H, above mean sea level) and as the
  // renderer draws them (h = H + N when renderer.geoid is on, applyVerticalDatum per tile).
  planet::HeightField field(*grid);
  planet::HeightField drawn(*grid);
  const double la = (*lat)[0], lo = std::remainder((*lon)[0], 360.0);
  int level = grid->numLevels() - 1;
  std::string lastError;
  for (; level >= 0; --level) {
    const auto centre = grid->keyAt(la, lo == 180.0 ? -180.0 : lo, level);
    if (!centre) continue;
    // The tile at the point, then the neighbours within one sample of it (bilinear taps).
    const Sector s = grid->sectorOf(*centre);
    const double dx = (s.east - s.west) / grid->spec().tileWidth;
    const double dy = (s.north - s.south) / grid->spec().tileHeight;
    std::vector<TileKey> keys{*centre};
    for (const double y : {la - dy, la, la + dy})
      for (const double x : {lo - dx, lo, lo + dx}) {
        const auto k = grid->keyAt(std::clamp(y, -90.0, 90.0), std::remainder(x, 360.0), level);
        if (k && std::find(keys.begin(), keys.end(), *k) == keys.end()) keys.push_back(*k);
      }
    bool haveCentre = false;
    for (const TileKey& k : keys) {
      const TileResult r =
          fetchTile(*tiles->source, {ro.elevationLayer, "", k}, std::chrono::seconds(60));
      if (r.status != TileStatus::Ok) {
        if (r.status == TileStatus::Failed) lastError = r.message;
        continue;
      }
      const int tw = grid->spec().tileWidth, th = grid->spec().tileHeight;
      auto t =
          ro.heightDecoder
              ? ro.heightDecoder(k, tw, th, r.bytes, r.contentType, ro.elevationEncoding)
              : planet::decodeHeightTile(k, tw, th, r.bytes, r.contentType, ro.elevationEncoding);
      if (!t) {
        lastError = t.error();
        continue;
      }
      planet::HeightTile onEllipsoid = *t;
      planet::applyVerticalDatum(onEllipsoid, grid->sectorOf(k), ro.verticalDatum);
      field.insert(std::move(*t));
      drawn.insert(std::move(onEllipsoid));
      haveCentre = haveCentre || k == *centre;
    }
    if (haveCentre) break;
  }
  if (level < 0) {
    std::fprintf(stderr,
                 "tellus height: no elevation tile at %.6f, %.6f%s%s\n",
                 la,
                 lo,
                 lastError.empty() ? "" : ": ",
                 lastError.c_str());
    return kExitError;
  }
  const double H = field.heightAt(la, lo), h = drawn.heightAt(la, lo);
  const bool ellipsoid = datumArg && *datumArg == "ellipsoid";
  if (ellipsoid && !ro.verticalDatum.usesGeoid()) {
    std::fprintf(stderr, "tellus height: --datum ellipsoid needs the geoid (--geoid on)\n");
    return kExitUsage;
  }
  std::printf("%.2f\n", ellipsoid ? h : H);
  if (ro.verticalDatum.usesGeoid())
    std::fprintf(stderr,
                 "tellus height: layer %s, level %d: H %.2f m above mean sea level, h = H + N "
                 "%.2f m above the WGS84 ellipsoid (N %.2f m, EGM96; the renderer draws h); "
                 "printed: %s\n",
                 ro.elevationLayer.c_str(),
                 level,
                 H,
                 h,
                 h - H,
                 ellipsoid ? "h" : "H");
  else
    std::fprintf(stderr,
                 "tellus height: layer %s, level %d: H %.2f m above mean sea level, drawn as a "
                 "height above the ellipsoid (the geoid off); printed: H\n",
                 ro.elevationLayer.c_str(),
                 level,
                 H);
  return kExitOk;
}

int cmdView(const Args& a) {
  auto usage = [](const char* what, const std::string& got) {
    std::fprintf(stderr, "tellus view: %s, got '%s'\n", what, got.c_str());
    return kExitUsage;
  };
  planet::CameraPose pose{20.0, 10.0, 2.0e7, 0.0, 0.0};
  if (auto c = a.get("camera")) {
    const auto cam = parseNumbers(*c, 3, 5);
    if (!cam || (*cam)[0] < -90.0 || (*cam)[0] > 90.0 || (*cam)[2] < -11000.0 || (*cam)[2] > 1e10 ||
        (cam->size() > 4 && ((*cam)[4] < 0.0 || (*cam)[4] > 180.0)))
      return usage("--camera must be LAT,LON,ALT[,HEADING,TILT] within range", *c);
    pose = {(*cam)[0],
            (*cam)[1],
            (*cam)[2],
            cam->size() > 3 ? (*cam)[3] : 0.0,
            cam->size() > 4 ? (*cam)[4] : 0.0};
  }
  const auto dome = domeArgs(a);
  if (!dome) return usage("bad --dome or --dome-tilt", dome.error());
  planet::RendererOptions ro;
  ro.width = 1280;
  ro.height = 800;
  ro.visibleWindow = true;
  ro.windowTitle = "tellus";
  if (auto size = a.get("size")) {
    const auto wh = parseSize(*size);
    if (!wh) return usage("--size must be WxH with 1 to 16384 pixels each", *size);
    ro.width = wh->first;
    ro.height = wh->second;
  }
  if (auto t = a.get("threshold")) {
    const auto v = parseNumbers(*t, 1, 1);
    if (!v || (*v)[0] < 0.05 || (*v)[0] > 64.0)
      return usage("--threshold must be a number in [0.05, 64]", *t);
    ro.lodThreshold = (*v)[0];
  }
  planet::ViewerOptions vo;
  if (auto e = a.get("exit-after")) {
    const auto v = parseNumbers(*e, 1, 1);
    if (!v || (*v)[0] < 1) return usage("--exit-after must be a frame count", *e);
    vo.maxFrames = static_cast<std::uint64_t>((*v)[0]);
  }
  const auto earth = earthArg(a);
  if (!earth) return usage("--earth must be wgs84 or sphere", earth.error());
  auto tiles = openPlanetTiles(a, "view", ro);
  if (!tiles) return tiles.error();
  if (const fs::path global = dataDir(a) / "bmng_2048x1024.jpg"; fs::exists(global))
    ro.globalImage = global;
  const Geodesy geodesy(earth->value_or(tiles->earth));
  auto renderer = planet::Renderer::create(*tiles->source, geodesy, ro);
  if (!renderer) {
    std::fprintf(stderr, "tellus view: %s\n", renderer.error().c_str());
    return kExitError;
  }
  vo.start = pose;
  vo.layerTimes = tiles->layerTimes;
  std::printf("tellus view: drag to move, wheel to zoom, W/S tilt, A/D heading, R reset, "
              "P screenshot, Esc quits%s\n",
              ro.overlays.empty() ? ""
                                  : "; layers: 0-9 select (1-9 show/hide), - = opacity, [ ] time");
  std::fflush(stdout);
  const auto frames = planet::runViewer(**renderer, vo);
  std::printf("tellus view: %llu frames\n", static_cast<unsigned long long>(frames));
  return kExitOk;
}

/** The options of every command: what is not listed here is refused (exit 2) with a
 * suggestion, never ignored. */
std::optional<cli::CommandSpec> commandSpec(std::string_view cmd) {
  using cli::OptionKind;
  using K = OptionKind;
  std::vector<cli::OptionSpec> o = {{"config", K::Value}, {"cache", K::Value}, {"data", K::Value}};
  auto add = [&](std::initializer_list<cli::OptionSpec> more) { o.insert(o.end(), more); };
  std::size_t positional = 0;
  if (cmd == "seed") {
    add({{"layer", K::Value, true},
         {"levels", K::Value},
         {"bbox", K::Value},
         {"dry-run", K::Flag},
         {"time", K::Value},
         {"concurrency", K::Value},
         {"rate", K::Value},
         {"retries", K::Value},
         {"refresh", K::Flag},
         {"meta-tiles", K::Value}});
  } else if (cmd == "cache") {
    // The union of the subcommands' options; checkCacheSubcommand narrows it to the one given.
    add({{"json", K::Flag},
         {"older-than", K::Value},
         {"layer", K::Value},
         {"include-pinned", K::Flag},
         {"dry-run", K::Flag},
         {"gpkg", K::Value},
         {"levels", K::Value}});
    positional = 1;
  } else if (cmd == "serve") {
    add({{"listen", K::Value},
         {"threads", K::Value},
         {"offline", K::Flag},
         {"log-level", K::Value},
         {"access-log", K::Value}});
  } else if (cmd == "render" || cmd == "view" || cmd == "height") {
    add({{"offline", K::Flag}, {"server", K::Value}, {"geoid", K::Value}});
    if (cmd == "height") {
      add({{"lat", K::Value}, {"lon", K::Value}, {"elevation", K::Value}, {"datum", K::Value}});
    } else {
      add({{"camera", K::Value},
           {"size", K::Value},
           {"layer", K::Value},
           {"threshold", K::Value},
           {"earth", K::Value},
           {"no-terrain", K::Flag},
           {"exaggeration", K::Value},
           {"min-relief-px", K::Value},
           {"sun", K::Value},
           {"overlay", K::Value, true},
           {"dome", K::OptionalValue},
           {"dome-tilt", K::Value},
           {"dome-method", K::Value}});
    }
    if (cmd == "render") {
      add({{"out", K::Value},
           {"wait-complete", K::OptionalValue},
           {"background", K::Value},
           {"stats", K::Value},
           {"path", K::Value},
           {"frames", K::Value},
           {"fps", K::Value},
           {"repeat", K::Value},
           {"edge-fixing", K::Value},
           {"mesh-size", K::Value},
           {"upload-per-frame", K::Value},
           {"vertices", K::Value}});
    }
    if (cmd == "view") add({{"exit-after", K::Value}});
  } else {
    return std::nullopt;
  }
  return cli::CommandSpec{std::string(cmd), std::move(o), positional};
}

/** `cache <subcommand>`: the subcommand is known and every option given is one of its own (a
 * `--json` on prune is a mistake, not something to ignore). The error text, or nothing. */
std::optional<std::string> checkCacheSubcommand(const Args& a) {
  static const std::map<std::string, std::vector<std::string>, std::less<>> own = {
      {"stats", {"json"}},
      {"verify", {}},
      {"rebuild", {}},
      {"prune", {"older-than", "layer", "include-pinned", "dry-run"}},
      {"export", {"gpkg", "layer", "levels"}},
      {"import", {"gpkg", "layer"}}};
  if (a.positional.empty()) return "say stats, verify, rebuild, prune, export or import";
  const auto sub = own.find(a.positional.front());
  if (sub == own.end()) {
    std::vector<std::string_view> names;
    for (const auto& [n, _] : own)
      names.push_back(n);
    std::string msg = "unknown subcommand '" + a.positional.front() + "'";
    if (const auto s = cli::closestName(a.positional.front(), names))
      msg += " (did you mean " + std::string(*s) + "?)";
    return msg;
  }
  for (const auto& [k, v] : a.options) {
    if (k == "config" || k == "cache" || k == "data") continue;
    if (std::find(sub->second.begin(), sub->second.end(), k) == sub->second.end())
      return "--" + k + " is not an option of cache " + sub->first;
  }
  return std::nullopt;
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
  const auto spec = commandSpec(cmd);
  if (!spec) {
    std::fprintf(stderr, "tellus: unknown command '%s'\n%s", argv[1], kUsage);
    return kExitUsage;
  }
  const std::vector<std::string> words(argv + 2, argv + argc);
  for (const auto& w : words) {
    if (w == "--") break;
    if (w == "--help" || w == "-h") {
      std::fputs(kUsage, stdout);
      return kExitOk;
    }
  }
  auto parsed = cli::parse(*spec, words);
  if (!parsed) {
    std::fprintf(stderr, "tellus %s: %s (tellus --help)\n", argv[1], parsed.error().c_str());
    return kExitUsage;
  }
  const Args& a = *parsed;
  if (cmd == "cache") {
    if (auto err = checkCacheSubcommand(a)) {
      std::fprintf(stderr, "tellus cache: %s (tellus --help)\n", err->c_str());
      return kExitUsage;
    }
  }
  if (cmd == "seed") return cmdSeed(a);
  if (cmd == "cache") return cmdCache(a);
  if (cmd == "serve") return cmdServe(a);
  if (cmd == "render") return cmdRender(a);
  if (cmd == "view") return cmdView(a);
  if (cmd == "height") return cmdHeight(a);
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
