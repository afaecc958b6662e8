// `tellus serve`: the WMS / WMTS / World Wind tile server over the cache, until SIGINT or SIGTERM.

#include "Commands.hpp"
#include "Context.hpp"

#include <tellus/cli/ProxyFromConfig.hpp>
#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/HttpServer.hpp>
#include <tellus/proxy/Log.hpp>
#include <tellus/proxy/ProxyFrontEnd.hpp>
#include <tellus/proxy/TileService.hpp>
#include <tellus/proxy/WebPage.hpp>

#include <charconv>
#include <csignal>
#include <cstdio>
#include <pthread.h>
#include <string>
#include <thread>

namespace tellus::commands {
namespace {

/** --listen, --threads, --offline, --log-level and --access-log over YAML `server`, and the log
 * set up from them; kExitUsage or kExitError after saying why. */
int applyServeArgs(const cli::Args& a, ServerSettings& server) {
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
  return kExitOk;
}

/** Where to point a browser or a client: the page, the capabilities, the metrics and a tile and a
 * map of each layer. */
void printEndpoints(const std::string& base,
                    const Context& ctx,
                    const ServerSettings& server,
                    const TileService& tiles) {
  std::printf("tellus serve: listening on %s (cache %s%s)\n",
              base.c_str(),
              ctx.config.cache.root.c_str(),
              server.offline ? ", offline" : "");
  if (webPageEmbedded()) std::printf("  map page      %s/\n", base.c_str());
  std::printf("  capabilities  %s/wms?SERVICE=WMS&REQUEST=GetCapabilities\n", base.c_str());
  std::printf("  WMTS          %s/wmts/1.0.0/WMTSCapabilities.xml\n", base.c_str());
  std::printf("  metrics       %s/metrics  (Prometheus)\n", base.c_str());
  for (const auto& l : tiles.layers()) {
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
}

int runServe(const cli::Args& a) {
  auto ctx = setUp(a, CacheUse::Serve);
  if (!ctx) return kExitError;
  ServerSettings server = ctx->config.server;
  if (const int rc = applyServeArgs(a, server); rc != kExitOk) return rc;

  // Signals are taken by sigwait below: block them before any thread starts.
  sigset_t stopSignals;
  sigemptyset(&stopSignals);
  sigaddset(&stopSignals, SIGINT);
  sigaddset(&stopSignals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stopSignals, nullptr);

  Fetcher fetcher;
  auto specs = cli::proxySpecs(ctx->config);
  TileServiceOptions tileOptions = cli::tileServiceOptions(server);
  tileOptions.leases = ctx->leases;
  tileOptions.keepUnstoredBytes = ctx->config.cache.keepUnstoredBytes;
  // Several instances: a miss fetches its metatile under the metatile's lease (one upstream
  // request for the tiles of a metatile however they are spread over the instances).
  tileOptions.metaTilesOnMiss = ctx->leases != nullptr;
  if (auto tier = ctx->boundedTier) {
    tileOptions.localTier = [tier] {
      const auto s = tier->localTier();
      return LocalTierMetrics{s.bytes, s.evictions};
    };
  }
  auto tiles = TileService::create(*ctx->cache,
                                   fetcher,
                                   std::move(specs.upstreams),
                                   std::move(specs.layers),
                                   std::move(tileOptions));
  if (!tiles) {
    std::fprintf(stderr, "tellus serve: %s\n", tiles.error().c_str());
    return kExitError;
  }
  const int cores = static_cast<int>(std::thread::hardware_concurrency());
  ProxyFrontEnd front(**tiles, cli::frontEndOptions(server, cores));
  const HttpServerOptions ho = cli::httpServerOptions(server);
  HttpServer http(ho, [&front](HttpRequest&& r, Responder respond) {
    front.handle(std::move(r), std::move(respond));
  });
  if (auto started = http.start(); !started) {
    std::fprintf(stderr, "tellus serve: %s\n", started.error().c_str());
    return kExitError;
  }
  const std::string host = ho.host == "0.0.0.0" || ho.host == "::" ? "127.0.0.1" : ho.host;
  printEndpoints("http://" + host + ":" + std::to_string(http.port()), *ctx, server, **tiles);
  int signal = 0;
  sigwait(&stopSignals, &signal);
  std::printf("tellus serve: stopping (%s)\n", signal == SIGINT ? "SIGINT" : "SIGTERM");
  http.stop();
  return kExitOk;
}

} // namespace

Command serveCommand() {
  using K = cli::OptionKind;
  return {"serve",
          {{"listen", K::Value},
           {"threads", K::Value},
           {"offline", K::Flag},
           {"log-level", K::Value},
           {"access-log", K::Value}},
          0,
          &runServe};
}

} // namespace tellus::commands
