#include "PlanetTiles.hpp"

#include "GlobeArgs.hpp"

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

/** A value layer (or an elevation layer shown as colours; issue 24) drawn by the renderer: its
 * format and scale from `layers[].values`, the colour map and range of the renderer's entry when
 * it gives them (rl may be null: --overlay). nullopt for imagery. */
std::optional<planet::ValueLayerOptions> valueOptions(const LayerConfig& lc,
                                                      const RenderLayerSettings* rl) {
  if (!lc.isValueLayer()) return std::nullopt;
  const ValueSettings& v = lc.values;
  planet::ValueLayerOptions o;
  o.format = v.format;
  o.colourMap = rl != nullptr && !rl->colourMap.empty() ? rl->colourMap : v.colourMap;
  o.min = v.min;
  o.max = v.max;
  o.scaling = v.scaling;
  o.outOfRange = v.outOfRange;
  o.rangeFromData = v.rangeFromData;
  o.lowPercent = v.lowPercent;
  o.highPercent = v.highPercent;
  if (rl != nullptr && rl->range) {
    o.min = (*rl->range)[0];
    o.max = (*rl->range)[1];
    o.rangeFromData = false;
  }
  if (o.rangeFromData && o.scaling == values::Scaling::Log && !(o.min > 0.0)) {
    o.min = 1.0; // the fallback until the data gives a range: any valid log range
    o.max = 10.0;
  }
  o.title = lc.title.empty() ? lc.name : lc.title;
  return o;
}

/** The layers drawn over the base chosen before (issue #7): renderer.layers[1..] of the
 * configuration, then each --overlay NAME[,OPACITY]; the base's time from renderer.layers[0] when
 * it is the base. Regional datasets (renderer.layers[].regional, renderer.terrain.regional) make
 * each such layer one combined layer through a RegionalTileSource over the source. False after
 * saying why. */
class RenderLayers {
public:
  RenderLayers(const RendererSettings& g,
               const Config* config,
               planet::RendererOptions& ro,
               std::string body)
      : g_(g), config_(config), ro_(ro), body_(std::move(body)) {}

  /** renderer.layers of the configuration. */
  void fromSettings() {
    if (!g_.layers.empty() && g_.layers.front().layer == ro_.layer) {
      ro_.time = g_.layers.front().time;
      combine(ro_.layer, g_.layers.front().regional);
    }
    for (std::size_t i = 1; i < g_.layers.size(); ++i) {
      const RenderLayerSettings& l = g_.layers[i];
      if (!onBody(layerConfig(l.layer), body_)) continue; // another body's layer (issue 26)
      planet::LayerOptions o;
      o.layer = l.layer;
      o.time = l.time;
      const LayerConfig* lc = layerConfig(l.layer);
      o.opacity = l.opacity.value_or(lc != nullptr ? lc->opacity : 1.0);
      o.visible = l.visible;
      o.maxLevel = l.maxLevel;
      o.night = l.night;
      if (lc != nullptr) o.values = valueOptions(*lc, &l);
      ro_.overlays.push_back(o);
      combine(l.layer, l.regional);
    }
  }

  /** --overlay NAME[,OPACITY]; false after saying why. */
  bool fromOverlayArg(const std::string& v, const char* cmd) {
    planet::LayerOptions o;
    const auto comma = v.find(',');
    o.layer = v.substr(0, comma);
    const LayerConfig* lc = layerConfig(o.layer);
    o.opacity = lc != nullptr ? lc->opacity : 1.0;
    if (comma != std::string::npos) {
      const auto op = cli::parseNumbers(v.substr(comma + 1), 1, 1);
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
    if (lc != nullptr && !onBody(lc, body_)) {
      std::fprintf(stderr,
                   "tellus %s: --overlay '%s' lies on the %s, not on the %s (--body)\n",
                   cmd,
                   o.layer.c_str(),
                   lc->dataset.body.c_str(),
                   body_.c_str());
      return false;
    }
    if (o.layer.empty() || (config_ != nullptr && lc == nullptr)) {
      std::fprintf(stderr,
                   "tellus %s: --overlay must name an imagery or value layer, got '%s'\n",
                   cmd,
                   v.c_str());
      return false;
    }
    if (lc != nullptr) o.values = valueOptions(*lc, nullptr);
    ro_.overlays.push_back(o);
    return true;
  }

  /** The combined layers over `t.source` (the elevation layer's too), and each drawn layer's
   * TIME values; false after saying why. */
  bool finish(PlanetTiles& t, const char* cmd) {
    if (!ro_.elevationLayer.empty()) combine(ro_.elevationLayer, g_.terrain.regional);
    if (!combined_.empty()) {
      auto r = planet::RegionalTileSource::create(*t.source, std::move(combined_));
      if (!r) {
        std::fprintf(stderr, "tellus %s: %s\n", cmd, r.error().c_str());
        return false;
      }
      t.regional = std::move(*r);
      t.source = t.regional.get();
    }
    const auto timesOf = [&](const std::string& name) {
      const LayerConfig* lc = layerConfig(name);
      return lc != nullptr ? lc->time.values : std::vector<std::string>{};
    };
    t.layerTimes.push_back(timesOf(ro_.layer));
    for (const auto& o : ro_.overlays)
      t.layerTimes.push_back(timesOf(o.layer));
    return true;
  }

private:
  const LayerConfig* layerConfig(const std::string& name) const {
    return config_ != nullptr ? config_->layer(name) : nullptr;
  }
  void combine(const std::string& name, const std::vector<std::string>& regional) {
    if (regional.empty()) return;
    std::vector<std::string> datasets{name};
    datasets.insert(datasets.end(), regional.begin(), regional.end());
    for (const auto& c : combined_)
      if (c.name == name && c.datasets == datasets) return;
    combined_.push_back({name, std::move(datasets)});
  }

  const RendererSettings& g_;
  const Config* config_; ///< nullptr with --server: names are the server's
  planet::RendererOptions& ro_;
  std::string body_;
  std::vector<planet::CombinedLayer> combined_;
};

bool applyRenderLayers(const RendererSettings& g,
                       const Config* config,
                       const cli::Args& a,
                       planet::RendererOptions& ro,
                       PlanetTiles& t,
                       const char* cmd) {
  RenderLayers layers(g, config, ro, t.body);
  layers.fromSettings();
  for (const std::string& v : a.all("overlay"))
    if (!layers.fromOverlayArg(v, cmd)) return false;
  return layers.finish(t, cmd);
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
  if (!applyRenderLayers(settings, nullptr, a, ro, t, cmd)) return std::unexpected(kExitUsage);
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
  if (!applyRenderLayers(config.renderer, &config, a, ro, t, cmd))
    return std::unexpected(kExitUsage);
  return t;
}

} // namespace

std::expected<PlanetTiles, int>
openPlanetTiles(const cli::Args& a, const char* cmd, planet::RendererOptions& ro) {
  if (const auto server = a.get("server")) return openRemote(a, *server, cmd, ro);
  return openLocal(a, cmd, ro);
}

} // namespace tellus::commands
