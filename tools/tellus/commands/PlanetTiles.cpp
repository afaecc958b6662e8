#include "PlanetTiles.hpp"

#include "GlobeArgs.hpp"
#include "RenderLayers.hpp"

#include <tellus/cli/ProxyFromConfig.hpp>
#include <tellus/cli/Values.hpp>
#include <tellus/planet/Terrain.hpp>
#include <tellus/proxy/ImageCodec.hpp>

#include <cstdio>
#include <filesystem>
#include <span>
#include <string_view>
#include <utility>

namespace tellus::commands {
namespace {

/** render and view draw the sky; height (which shares the tile sources) needs no stars. */
bool drawsStars(const char* cmd) {
  return std::string_view(cmd) != "height";
}

/** Imagery that is neither JPEG nor PNG (a layer of format image/tiff): the proxy's decoder,
 * through the imaging module (OpenImageIO), on the renderer's decoder threads, as RGBA. TIFF is
 * the only other imagery format a layer can have (config validation), so a tile without a content
 * type (a remote server that sent none) is read as one. */
std::expected<planet::RgbaImage, std::string>
decodeImageryAsRgba(std::span<const std::byte> bytes, std::string_view type, int w, int h) {
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
}

/** The proxy's decoder of heights: BIL16, 16-bit PNG and Int16 TIFF (the imaging module), the
 * same reading of the tiles as the maps `serve` composes from them. */
std::expected<planet::HeightTile, std::string>
decodeHeightsAsTile(const TileKey& key,
                    int w,
                    int h,
                    std::span<const std::byte> bytes,
                    std::string_view type,
                    const planet::HeightEncoding& enc) {
  auto raw = decodeHeights(bytes, type, w, h);
  if (!raw) return std::unexpected(raw.error());
  std::vector<double> samples(raw->begin(), raw->end());
  return planet::heightTileFromSamples(key, w, h, samples, enc);
}

/** The server's layers: --layer (an imagery layer of the server), else the configuration's, else
 * the first imagery layer; its first elevation layer unless terrain is off. The exit code after
 * saying why, or 0. */
int chooseRemoteLayers(const RemoteTileSource& remote,
                       const cli::Args& a,
                       const std::string& server,
                       bool terrain,
                       const char* cmd,
                       planet::RendererOptions& ro) {
  const auto layerArg = a.get("layer");
  for (const RemoteLayer& l : remote.layers())
    if (!l.elevation && (layerArg ? l.name == *layerArg : ro.layer.empty())) ro.layer = l.name;
  if (ro.layer.empty()) {
    if (layerArg) {
      std::fprintf(stderr,
                   "tellus %s: --layer must name an imagery layer of the server, got '%s'\n",
                   cmd,
                   layerArg->c_str());
      return kExitUsage;
    }
    std::fprintf(stderr, "tellus %s: %s has no imagery layer\n", cmd, server.c_str());
    return kExitError;
  }
  if (terrain)
    for (const RemoteLayer& l : remote.layers())
      if (l.elevation) {
        ro.elevationLayer = l.name;
        break;
      }
  return kExitOk;
}

/** The body shown (--body, else renderer.body) into t; false after saying why. */
bool setBody(const cli::Args& a, const Config* config, PlanetTiles& t, const char* cmd) {
  auto body = chooseBody(a, config);
  if (!body) {
    std::fprintf(stderr, "tellus %s: %s\n", cmd, body.error().c_str());
    return false;
  }
  t.body = *body;
  auto others = chooseSceneBodies(a, config);
  if (!others) {
    std::fprintf(stderr, "tellus %s: %s\n", cmd, others.error().c_str());
    return false;
  }
  t.sceneBodies = std::move(*others);
  if (config != nullptr)
    if (const BodyConfig* b = config->body(t.body)) t.configuredBody = *b;
  return true;
}

/** --server URL: the layers of a remote `tellus serve`; of --config only its renderer settings
 * matter. */
std::expected<PlanetTiles, int> openRemote(const cli::Args& a,
                                           const std::string& server,
                                           const char* cmd,
                                           planet::RendererOptions& ro) {
  if (a.flag("offline")) {
    std::fprintf(stderr,
                 "tellus %s: --server and --offline exclude each other, got '%s'\n",
                 cmd,
                 server.c_str());
    return std::unexpected(kExitUsage);
  }
  PlanetTiles t;
  bool terrain = !a.flag("no-terrain");
  RendererSettings settings;
  if (const auto file = a.get("config")) {
    auto loaded = loadConfig(*file);
    if (!loaded) {
      std::fprintf(stderr, "tellus: configuration: %s\n", loaded.error().toString().c_str());
      return std::unexpected(kExitError);
    }
    applyRendererSettings(loaded->renderer, a, ro, t.earth);
    terrain = terrain && loaded->renderer.terrain.enabled;
    if (!setBody(a, &*loaded, t, cmd)) return std::unexpected(kExitUsage);
    t.sceneTime = loaded->renderer.time;
    t.night = loaded->renderer.night;
    t.legend = loaded->renderer.legend;
    settings = loaded->renderer;
  }
  if (!a.get("config") && !setBody(a, nullptr, t, cmd)) return std::unexpected(kExitUsage);
  ro.atmosphere = atmosphereOptions(settings.atmosphere); // the configuration's default: on
  if (ro.atmosphere) // the tables' cache: under --cache or the default cache root
    ro.atmosphere->tableCacheDir =
        ((a.get("cache") ? std::filesystem::path(*a.get("cache")) : defaultCacheRoot()) /
         "atmosphere")
            .string();
  if (!a.get("layer") && !settings.layers.empty()) ro.layer = settings.layers.front().layer;
  if (auto bad = applyTerrainArgs(a, ro)) {
    std::fprintf(stderr, "tellus %s: %s\n", cmd, bad->c_str());
    return std::unexpected(kExitUsage);
  }
  auto remote = RemoteTileSource::connect(server);
  if (!remote) {
    std::fprintf(stderr, "tellus %s: %s\n", cmd, remote.error().c_str());
    return std::unexpected(kExitError);
  }
  if (const int rc = chooseRemoteLayers(**remote, a, server, terrain, cmd, ro); rc != kExitOk)
    return std::unexpected(rc);
  if (auto bad = applyGeoid(a, settings.geoid && t.body == "earth", ro)) {
    std::fprintf(stderr, "tellus %s: %s\n", cmd, bad->c_str());
    return std::unexpected(kExitError);
  }
  if (auto bad = drawsStars(cmd) ? applyStars(a, settings.stars, ro) : std::nullopt) {
    std::fprintf(stderr, "tellus %s: %s\n", cmd, bad->c_str());
    return std::unexpected(kExitError);
  }
  t.remote = std::move(*remote);
  t.source = t.remote.get();
  if (!applyRenderLayers(settings, nullptr, a, ro, t, cmd, t.body))
    return std::unexpected(kExitUsage);
  return t;
}

/** renderer.terrain: the elevation layer (its name, or the first one) unless turned off. */
void chooseElevation(const Config& config,
                     const cli::Args& a,
                     const std::string& body,
                     planet::RendererOptions& ro) {
  if (!config.renderer.terrain.enabled || a.flag("no-terrain")) return;
  for (const auto& l : config.layers)
    if (l.kind == LayerKind::Elevation && l.dataset.body == body &&
        (config.renderer.terrain.layer.empty() || l.name == config.renderer.terrain.layer)) {
      ro.elevationLayer = l.name;
      ro.elevationEncoding = {l.elevation.scale, l.elevation.offset, l.elevation.noData};
      ro.heightDecoder = &decodeHeightsAsTile;
      return;
    }
}

/** The base layer on the body: --layer (an imagery layer), else renderer.layers[0], else the
 * first imagery layer; kBareLayer (the body's bare globe) when none lies on the body. The exit
 * code after saying why, or 0. */
int chooseBase(const Config& config,
               const cli::Args& a,
               const std::string& body,
               const char* cmd,
               planet::RendererOptions& ro) {
  if (const auto layerArg = a.get("layer")) {
    const auto* layer = config.layer(*layerArg);
    if (layer == nullptr || layer->kind != LayerKind::Imagery) {
      std::fprintf(stderr,
                   "tellus %s: --layer must name an imagery layer of the configuration, got '%s'\n",
                   cmd,
                   layerArg->c_str());
      return kExitUsage;
    }
    if (!onBody(layer, body)) {
      std::fprintf(stderr,
                   "tellus %s: --layer '%s' lies on the %s, not on the %s (--body)\n",
                   cmd,
                   layerArg->c_str(),
                   layer->dataset.body.c_str(),
                   body.c_str());
      return kExitUsage;
    }
    ro.layer = *layerArg;
  } else if (!config.renderer.layers.empty() &&
             onBody(config.layer(config.renderer.layers.front().layer), body)) {
    ro.layer = config.renderer.layers.front().layer;
  } else {
    for (const auto& candidate : config.layers)
      if (candidate.kind == LayerKind::Imagery && candidate.dataset.body == body) {
        ro.layer = candidate.name;
        break;
      }
    if (ro.layer.empty() && body == "earth") {
      std::fprintf(stderr, "tellus %s: the configuration has no imagery layer\n", cmd);
      return kExitError;
    }
    if (ro.layer.empty()) {
      std::fprintf(stderr,
                   "tellus %s: no imagery layer lies on the %s: its globe is drawn in the "
                   "fallback colour\n",
                   cmd,
                   body.c_str());
      ro.layer = kBareLayer;
    }
  }
  return kExitOk;
}

/** The configuration's layers through the in-process tile service over its cache. */
std::expected<PlanetTiles, int>
openLocal(const cli::Args& a, const char* cmd, planet::RendererOptions& ro) {
  PlanetTiles t;
  t.ctx = setUp(a);
  if (!t.ctx) return std::unexpected(kExitError);
  const Config& config = t.ctx->config;
  if (!setBody(a, &config, t, cmd)) return std::unexpected(kExitUsage);
  applyRendererSettings(config.renderer, a, ro, t.earth);
  if (ro.atmosphere) // the tables' cache, under the cache root
    ro.atmosphere->tableCacheDir = (config.cache.root / "atmosphere").string();
  t.sceneTime = config.renderer.time;
  t.night = config.renderer.night;
  t.legend = config.renderer.legend;
  if (auto bad = applyTerrainArgs(a, ro)) {
    std::fprintf(stderr, "tellus %s: %s\n", cmd, bad->c_str());
    return std::unexpected(kExitUsage);
  }
  ro.imageDecoder = &decodeImageryAsRgba;
  chooseElevation(config, a, t.body, ro);
  if (auto bad = applyGeoid(a, config.renderer.geoid && t.body == "earth", ro)) {
    std::fprintf(stderr, "tellus %s: %s\n", cmd, bad->c_str());
    return std::unexpected(kExitError);
  }
  if (auto bad = drawsStars(cmd) ? applyStars(a, config.renderer.stars, ro) : std::nullopt) {
    std::fprintf(stderr, "tellus %s: %s\n", cmd, bad->c_str());
    return std::unexpected(kExitError);
  }
  if (const int rc = chooseBase(config, a, t.body, cmd, ro); rc != kExitOk)
    return std::unexpected(rc);
  t.fetcher = std::make_unique<Fetcher>();
  auto specs = cli::proxySpecs(config);
  TileServiceOptions tso = cli::tileServiceOptions(config.server);
  tso.offline = a.flag("offline") || tso.offline;
  tso.keepUnstoredBytes = config.cache.keepUnstoredBytes;
  // Tiles rendered from local rasters (a cold cache) are background work here: at the decoders'
  // priority, below the thread that draws (on llvmpipe they competed with rasterising).
  tso.workerNice = ro.decodeNice;
  auto tiles = TileService::create(
      *t.ctx->cache, *t.fetcher, std::move(specs.upstreams), std::move(specs.layers), tso);
  if (!tiles) {
    std::fprintf(stderr, "tellus %s: %s\n", cmd, tiles.error().c_str());
    return std::unexpected(kExitError);
  }
  t.service = std::move(*tiles);
  t.source = t.service.get();
  if (ro.layer == kBareLayer) {
    t.bare = std::make_unique<BareLayerSource>(*t.source);
    t.source = t.bare.get();
  }
  if (!applyRenderLayers(config.renderer, &config, a, ro, t, cmd, t.body))
    return std::unexpected(kExitUsage);
  return t;
}

} // namespace

std::expected<PlanetTiles, int>
openPlanetTiles(const cli::Args& a, const char* cmd, planet::RendererOptions& ro) {
  if (const auto server = a.get("server")) return openRemote(a, *server, cmd, ro);
  return openLocal(a, cmd, ro);
}

std::expected<BodyTiles, int> tilesForBody(const cli::Args& a,
                                           const char* cmd,
                                           PlanetTiles& t,
                                           const std::string& body,
                                           const planet::RendererOptions& base) {
  BodyTiles out{base, t.source, t.layerTimes};
  if (!t.ctx || body == t.body) return out; // --server: its layers are not filtered by body
  const Config& config = t.ctx->config;
  cli::Args b = a; // --layer and --overlay are the first body's; the geoid the Earth's
  b.options.erase("layer");
  b.options.erase("overlay");
  if (body != "earth") b.options.erase("geoid");
  planet::RendererOptions& ro = out.ro;
  ro.layer.clear();
  ro.time.clear();
  ro.overlays.clear();
  ro.elevationLayer.clear();
  ro.heightDecoder = nullptr;
  ro.globalImage.clear();
  chooseElevation(config, b, body, ro);
  if (auto bad = applyGeoid(b, config.renderer.geoid && body == "earth", ro)) {
    std::fprintf(stderr, "tellus %s: %s\n", cmd, bad->c_str());
    return std::unexpected(kExitError);
  }
  if (const int rc = chooseBase(config, b, body, cmd, ro); rc != kExitOk)
    return std::unexpected(rc);
  PlanetTiles own; // the regional source over this body's, kept in t
  own.source = t.service.get();
  if (ro.layer == kBareLayer) {
    t.bodySources.push_back(std::make_unique<BareLayerSource>(*own.source));
    own.source = t.bodySources.back().get();
  }
  if (!applyRenderLayers(config.renderer, &config, b, ro, own, cmd, body, false))
    return std::unexpected(kExitUsage);
  if (own.regional) t.bodySources.push_back(std::move(own.regional));
  out.source = own.source;
  out.layerTimes = std::move(own.layerTimes);
  return out;
}

} // namespace tellus::commands
