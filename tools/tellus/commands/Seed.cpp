// `tellus seed`: fills the cache from the layers' upstreams. Remote upstreams (and local ones when
// refreshing or at a time) go through the tile service as `tellus serve` fetches them, with its
// caps, single-flight and validation; a local raster is cut into tiles directly.

#include "Commands.hpp"
#include "Context.hpp"
#include "Purge.hpp"

#include <tellus/cache/TileGrid.hpp>
#include <tellus/cache_pg/PgSeedJob.hpp>
#include <tellus/cli/LayerTimes.hpp>
#include <tellus/cli/ProxyFromConfig.hpp>
#include <tellus/cli/Values.hpp>
#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/HttpCaching.hpp>
#include <tellus/proxy/LocalRasterSource.hpp>
#include <tellus/proxy/Seeder.hpp>
#include <tellus/proxy/TileService.hpp>
#include <tellus/proxy/Wms.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <expected>
#include <memory>
#include <string>
#include <unistd.h>
#include <vector>

namespace tellus::commands {
namespace {

using cli::humanBytes;

/** What the command line asks of a seeding run. */
struct SeedArgs {
  SeedOptions range; ///< --levels, --bbox, --dry-run
  /** --concurrency, --rate, --retries, --refresh; its time is --time as written (one instant, a
   * list or a range: seedLayers expands it per layer). */
  ServiceSeedOptions remote;
  double metaTiles = 0; ///< --meta-tiles; 0: each upstream's own
};

/** A progress line: a bar on a terminal (redrawn in place), else a plain line every 5 s. */
class SeedProgressPrinter {
public:
  SeedProgressPrinter(std::string layer, std::int64_t planned)
      : layer_(std::move(layer)), planned_(planned), tty_(::isatty(STDERR_FILENO) == 1) {}
  SeedProgressPrinter(const SeedProgressPrinter&) = delete;
  SeedProgressPrinter& operator=(const SeedProgressPrinter&) = delete;
  ~SeedProgressPrinter() {
    if (tty_) std::fputs("\n", stderr);
  }

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

/** --NAME as a number in [lo, hi] into `out` (left as it is when absent); false after saying
 * why. */
bool numberArg(const cli::Args& a, const char* key, double lo, double hi, double& out) {
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
}

/** The command line's seeding options, checked before anything is opened; kExitUsage after
 * saying why. */
std::expected<SeedArgs, int> parseSeedArgs(const cli::Args& a) {
  SeedArgs s;
  SeedOptions& so = s.range;
  if (auto l = a.get("levels")) {
    auto r = cli::parseLevels(*l);
    if (!r) {
      std::fprintf(stderr,
                   "tellus seed: --levels must be A or A-B with 0 <= A <= B, got '%s'\n",
                   l->c_str());
      return std::unexpected(kExitUsage);
    }
    so.fromLevel = r->first;
    so.toLevel = r->second;
  }
  if (auto b = a.get("bbox")) {
    so.box = cli::parseBbox(*b);
    if (!so.box) {
      std::fprintf(
          stderr, "tellus seed: --bbox must be W,S,E,N in degrees, got '%s'\n", b->c_str());
      return std::unexpected(kExitUsage);
    }
  }
  so.dryRun = a.flag("dry-run");
  double concurrency = 4, retries = 2;
  if (!numberArg(a, "concurrency", 1, 256, concurrency) ||
      !numberArg(a, "rate", 0, 1e6, s.remote.rate) || !numberArg(a, "retries", 0, 100, retries) ||
      !numberArg(a, "meta-tiles", 1, 16, s.metaTiles))
    return std::unexpected(kExitUsage);
  if (s.metaTiles != std::floor(s.metaTiles)) {
    std::fprintf(stderr, "tellus seed: --meta-tiles must be a whole number\n");
    return std::unexpected(kExitUsage);
  }
  s.remote.concurrency = static_cast<int>(concurrency);
  s.remote.retries = static_cast<int>(retries);
  s.remote.refresh = a.flag("refresh");
  s.remote.time = a.get("time").value_or("");
  return s;
}

/** A layer to seed and the times to seed it at ("" for a layer without a TIME dimension). */
struct LayerPlan {
  const LayerConfig* layer = nullptr;
  std::vector<std::string> times;
};

/** The layers to seed: each --layer, else every layer; each with the times of --time (one
 * instant, a list or a range A/B/P, every instant checked against the layer's declared TIME
 * dimension as a WMS client's would be: cli::layerTimes), else its default time. Everything is
 * checked before anything is fetched. kExitUsage after saying why. */
std::expected<std::vector<LayerPlan>, int>
seedLayers(const cli::Args& a, const Config& config, const std::string& time) {
  std::vector<LayerPlan> plans;
  for (const auto& name : a.all("layer")) {
    const auto* l = config.layer(name);
    if (!l) {
      std::fprintf(stderr, "tellus seed: no layer '%s'\n", name.c_str());
      return std::unexpected(kExitUsage);
    }
    plans.push_back({l, {}});
  }
  if (plans.empty()) {
    for (const auto& l : config.layers)
      plans.push_back({&l, {}});
  }
  for (LayerPlan& p : plans) {
    const LayerConfig* l = p.layer;
    if (!time.empty() && !l->time.enabled()) {
      std::fprintf(
          stderr, "tellus seed: layer '%s' has no TIME dimension; drop --time\n", l->name.c_str());
      return std::unexpected(kExitUsage);
    }
    if (time.empty()) { // its default time, in its own spelling ("" without a dimension)
      const auto t =
          resolveTimeDimension(l->name, l->time.values, l->time.period, l->time.defaultValue, "");
      p.times = {t.value_or("")};
      continue;
    }
    auto times = cli::layerTimes(*l, time);
    if (!times) {
      std::fprintf(stderr,
                   "tellus seed: --time for layer '%s': %s\n",
                   l->name.c_str(),
                   times.error().c_str());
      return std::unexpected(kExitUsage);
    }
    p.times = std::move(*times);
  }
  return plans;
}

/** The tile service seeding goes through, as `serve` fetches but within --concurrency. */
std::expected<std::unique_ptr<TileService>, std::string>
seedingService(Context& ctx, Fetcher& fetcher, const SeedArgs& s) {
  auto specs = cli::proxySpecs(ctx.config);
  // --concurrency is what an upstream sees: at most that many requests to it at once. Twice as
  // many tiles are in the pipeline, so that while fetched tiles are validated and stored the
  // upstream is already answering the next ones (with the window equal to the requests, each
  // slot waited for validation and fsync: 0.72x of what MapServer served alone,
  // bench/RESULTS.md).
  for (auto& u : specs.upstreams) {
    u.policy.maxConnections = std::min(u.policy.maxConnections, s.remote.concurrency);
    if (s.metaTiles >= 1) u.metaTiles = static_cast<int>(s.metaTiles);
  }
  // Storing a fetched tile waits for fsync: as many workers as requests in flight, so that the
  // disk's waits overlap instead of queueing behind two workers.
  TileServiceOptions options;
  options.renderThreads = std::max(options.renderThreads, s.remote.concurrency);
  // A shared index: each metatile (or tile) fetched under its lease, as `serve` fetches them.
  options.leases = ctx.leases;
  options.keepUnstoredBytes = 0; // a seeder asks for each tile once: nothing to keep it for
  return TileService::create(
      *ctx.cache, fetcher, std::move(specs.upstreams), std::move(specs.layers), options);
}

/** One layer through the tile service, at `time`, with a progress line; its exit code. */
int seedThroughTheService(TileService& service,
                          TileCache& cache,
                          const LayerConfig& layer,
                          const SeedArgs& s,
                          const std::string& time) {
  const SeedOptions& so = s.range;
  ServiceSeedOptions opts = s.remote;
  opts.time = time;
  opts.concurrency = 2 * s.remote.concurrency;
  opts.range = so;
  opts.estimateBytesPerTile = estimateTileBytes(cache, layer);
  std::int64_t planned = 0;
  {
    ServiceSeedOptions count = opts;
    count.range.dryRun = true;
    if (auto c = seedThroughService(service, cache, layer.name, count)) planned = c->planned;
  }
  SeedProgressPrinter printer(layer.name, planned);
  auto report =
      seedThroughService(service, cache, layer.name, opts, [&](const SeedReport& r, double sec) {
        if (!so.dryRun) printer(r, sec);
      });
  if (!report) {
    std::fprintf(stderr, "tellus seed: %s: %s\n", layer.name.c_str(), report.error().c_str());
    return kExitError;
  }
  if (!so.dryRun) return printSeedSummary(layer, so, *report);
  std::printf("%-12s levels %d-%d: %lld tiles, about %s (dry run)\n",
              layer.name.c_str(),
              so.fromLevel,
              std::min(so.toLevel, layer.dataset.grid.numLevels - 1),
              static_cast<long long>(report->planned),
              humanBytes(report->bytes).c_str());
  return kExitOk;
}

/** One layer as a job shared with every `tellus seed` of the same command on the same PostgreSQL
 * index (issue 27): band by band (a level's row of tiles), each band seeded by the one seeder that
 * took it (PgSeedJob: SELECT ... FOR UPDATE SKIP LOCKED); its exit code. */
int seedSharedJob(TileService& service,
                  TileCache& cache,
                  const LayerConfig& layer,
                  const SeedArgs& s,
                  const std::string& time,
                  const PgConnectOptions& connect) {
  auto grid = TileGrid::create(layer.dataset.grid);
  if (!grid) {
    std::fprintf(stderr, "tellus seed: %s: %s\n", layer.name.c_str(), grid.error().c_str());
    return kExitError;
  }
  const Sector box = s.range.box ? *s.range.box : layer.dataset.grid.sector;
  const std::int32_t top = std::min(s.range.toLevel, grid->numLevels() - 1);
  std::vector<SeedBand> bands;
  for (std::int32_t level = s.range.fromLevel; level <= top; ++level) {
    for (std::int64_t row = 0; row < grid->rowCount(level); ++row) {
      const Sector rs = grid->sectorOf(TileKey{level, row, 0});
      if (rs.north > box.south && rs.south < box.north) bands.push_back(SeedBand{level, row});
    }
  }
  char name[256];
  std::snprintf(name,
                sizeof name,
                "%s|%s|%d-%d|%.17g,%.17g,%.17g,%.17g",
                datasetFolder(layer.dataset).c_str(),
                time.c_str(),
                s.range.fromLevel,
                top,
                box.west,
                box.south,
                box.east,
                box.north);
  auto job = PgSeedJob::open(connect, name, bands);
  if (!job) {
    std::fprintf(stderr, "tellus seed: %s: %s\n", layer.name.c_str(), job.error().message.c_str());
    return kExitError;
  }
  SeedReport total;
  std::int64_t bandsSeeded = 0;
  for (;;) {
    auto band = (*job)->next();
    if (!band) {
      std::fprintf(
          stderr, "tellus seed: %s: %s\n", layer.name.c_str(), band.error().message.c_str());
      return kExitError;
    }
    if (!*band) break;
    ServiceSeedOptions opts = s.remote;
    opts.time = time;
    opts.concurrency = 2 * s.remote.concurrency;
    opts.range = s.range;
    opts.range.fromLevel = opts.range.toLevel = (*band)->level;
    // The band's row, inside the box; its edges pulled in so that no neighbouring row is taken.
    const Sector rs = grid->sectorOf(TileKey{(*band)->level, (*band)->row, 0});
    const double eps = (rs.north - rs.south) * 1e-6;
    opts.range.box = Sector{box.west,
                            std::max(box.south, rs.south) + eps,
                            box.east,
                            std::min(box.north, rs.north) - eps};
    auto report = seedThroughService(service, cache, layer.name, opts);
    if (!report) {
      std::fprintf(stderr, "tellus seed: %s: %s\n", layer.name.c_str(), report.error().c_str());
      return kExitError;
    }
    ++bandsSeeded;
    total.planned += report->planned;
    total.skipped += report->skipped;
    total.written += report->written;
    total.absent += report->absent;
    total.retried += report->retried;
    total.failed += report->failed;
    total.notStored += report->notStored;
    total.bytes += report->bytes;
    for (auto& f : report->failures)
      if (total.failures.size() < 5) total.failures.push_back(std::move(f));
    if (!report->stoppedBecause.empty()) {
      total.stoppedBecause = report->stoppedBecause;
      break;
    }
  }
  std::printf("%-12s shared job: %lld of %zu bands seeded here\n",
              layer.name.c_str(),
              static_cast<long long>(bandsSeeded),
              bands.size());
  return printSeedSummary(layer, s.range, total);
}

/** One layer cut from its local raster straight into the cache; its exit code. */
int seedFromTheRaster(TileCache& cache,
                      const LayerConfig& layer,
                      const UpstreamConfig& upstream,
                      const SeedOptions& so) {
  auto id = cache.registerDataset(layer.dataset);
  if (!id) {
    std::fprintf(stderr, "tellus seed: %s: %s\n", layer.name.c_str(), id.error().message.c_str());
    return id.error().code == CacheErrc::DiskFull ? kExitCacheFull : kExitError;
  }
  auto source = LocalRasterSource::open(upstream.path);
  if (!source) {
    std::fprintf(stderr, "tellus seed: %s: %s\n", layer.name.c_str(), source.error().c_str());
    return kExitError;
  }
  SeedOptions withNoData = so;
  withNoData.noData = cli::layerSpec(layer).noData; // a value layer's own values.no_data
  auto report = seedFromRaster(cache, *id, *source, withNoData);
  if (!report) {
    std::fprintf(
        stderr, "tellus seed: %s: %s\n", layer.name.c_str(), report.error().message.c_str());
    return kExitError;
  }
  return printSeedSummary(layer, so, *report);
}

int runSeed(const cli::Args& a) {
  const auto s = parseSeedArgs(a);
  if (!s) return s.error();
  auto ctx = setUp(a, CacheUse::Seed);
  if (!ctx) return kExitError;
  const auto plans = seedLayers(a, ctx->config, s->remote.time);
  if (!plans) return plans.error();
  int rc = kExitOk;
  Fetcher fetcher;
  std::unique_ptr<TileService> service; // made when the first layer needs it
  for (const LayerPlan& plan : *plans) {
    const LayerConfig* layer = plan.layer;
    const UpstreamConfig* upstream = ctx->config.upstream(layer->upstream);
    const bool local = upstream && upstream->type == UpstreamConfig::Type::Local;
    for (std::size_t i = 0; i < plan.times.size(); ++i) {
      // A layer with a TIME dimension is seeded at each time of --time, else at its default.
      const std::string& layerTime = plan.times[i];
      if (plan.times.size() > 1) {
        std::printf("%s: time %zu of %zu: %s\n",
                    layer->name.c_str(),
                    i + 1,
                    plan.times.size(),
                    layerTime.c_str());
        std::fflush(stdout);
      }
      int layerRc = kExitOk;
      if (!local || s->remote.refresh || !layerTime.empty()) {
        if (!service) {
          auto created = seedingService(*ctx, fetcher, *s);
          if (!created) {
            std::fprintf(stderr, "tellus seed: %s\n", created.error().c_str());
            return kExitError;
          }
          service = std::move(*created);
        }
        if (!ctx->config.cache.index.empty() && !s->range.dryRun) {
          PgConnectOptions connect;
          connect.conninfo = ctx->config.cache.index;
          connect.passwordFile = ctx->config.cache.indexPasswordFile;
          layerRc = seedSharedJob(*service, *ctx->cache, *layer, *s, layerTime, connect);
        } else {
          layerRc = seedThroughTheService(*service, *ctx->cache, *layer, *s, layerTime);
        }
      } else {
        layerRc = seedFromTheRaster(*ctx->cache, *layer, *upstream, s->range);
      }
      if (layerRc == kExitCacheFull) return kExitCacheFull; // the next would not fit either
      if (layerRc == kExitError) return kExitError;
      // Refreshed tiles replace what shared caches in front of `tellus serve` keep: purged by
      // the layer's key at this time (server.cdn.purge).
      if (s->remote.refresh && !purgeCdn(ctx->config, {layerKey(layer->name, layerTime)}, "seed"))
        rc = kExitError;
      if (layerRc != kExitOk) rc = layerRc;
    }
  }
  return rc;
}

} // namespace

Command seedCommand() {
  using K = cli::OptionKind;
  return {"seed",
          {{"layer", K::Value, true},
           {"levels", K::Value},
           {"bbox", K::Value},
           {"dry-run", K::Flag},
           {"time", K::Value},
           {"concurrency", K::Value},
           {"rate", K::Value},
           {"retries", K::Value},
           {"refresh", K::Flag},
           {"meta-tiles", K::Value}},
          0,
          &runSeed};
}

} // namespace tellus::commands
