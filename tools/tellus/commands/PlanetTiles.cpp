#include "PlanetTiles.hpp"

#include <tellus/planet/Geoid.hpp>
#include <tellus/planet/Terrain.hpp>
#include <tellus/proxy/ImageCodec.hpp>

#include <algorithm>
#include <array>
#include <cstdio>

namespace tellus::commands {
namespace {

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

} // namespace

/** `--earth wgs84|sphere` of render and view; nullopt when absent, an error text when bad. */
std::expected<std::optional<EarthModel>, std::string> earthArg(const Args& a) {
  const auto e = a.get("earth");
  if (!e) return std::nullopt;
  if (*e == "wgs84") return EarthModel::Wgs84;
  if (*e == "sphere") return EarthModel::Sphere;
  return std::unexpected(*e);
}

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

namespace {

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

} // namespace

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
  TileServiceOptions tso = cli::tileServiceOptions(config.server);
  tso.offline = a.flag("offline") || tso.offline;
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

} // namespace tellus::commands
