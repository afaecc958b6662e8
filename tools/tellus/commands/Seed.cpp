// `tellus seed`: fills the cache from the layers' upstreams.

#include "Commands.hpp"

#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/LocalRasterSource.hpp>
#include <tellus/proxy/Seeder.hpp>
#include <tellus/proxy/TileService.hpp>
#include <tellus/proxy/Wms.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <unistd.h>

namespace tellus::commands {
namespace {

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

} // namespace

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

} // namespace tellus::commands
