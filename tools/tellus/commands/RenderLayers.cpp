#include "RenderLayers.hpp"

#include <tellus/cli/Values.hpp>

#include <cstdio>
#include <utility>
#include <vector>

namespace tellus::commands {
namespace {

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

} // namespace

bool applyRenderLayers(const RendererSettings& g,
                       const Config* config,
                       const cli::Args& a,
                       planet::RendererOptions& ro,
                       PlanetTiles& t,
                       const char* cmd,
                       const std::string& body,
                       bool overlayArgs) {
  RenderLayers layers(g, config, ro, body);
  layers.fromSettings();
  if (overlayArgs)
    for (const std::string& v : a.all("overlay"))
      if (!layers.fromOverlayArg(v, cmd)) return false;
  return layers.finish(t, cmd);
}

} // namespace tellus::commands
