#include "AnimateArgs.hpp"

#include <tellus/cli/LayerTimes.hpp>
#include <tellus/cli/Values.hpp>

#include <algorithm>
#include <cmath>
#include <utility>

namespace tellus::commands {

std::vector<cli::OptionSpec> animateOptions() {
  using K = cli::OptionKind;
  return {{"animate", K::Value, true},
          {"rate", K::Value},
          {"once", K::Flag},
          {"fetch-ahead", K::Value}};
}

namespace {

std::expected<planet::TimeAnimationOptions, std::string> playOptions(const cli::Args& a) {
  planet::TimeAnimationOptions o;
  o.loop = !a.flag("once");
  if (const auto r = a.get("rate")) {
    const auto v = cli::parseNumbers(*r, 1, 1);
    if (!v || !((*v)[0] > 0.0 && (*v)[0] <= 1000.0))
      return std::unexpected("--rate must be times a second in (0, 1000], got '" + *r + "'");
    o.instantsPerSecond = (*v)[0];
  }
  if (const auto k = a.get("fetch-ahead")) {
    const auto v = cli::parseNumbers(*k, 1, 1);
    if (!v || (*v)[0] < 0.0 || (*v)[0] > 16.0 || (*v)[0] != std::floor((*v)[0]))
      return std::unexpected("--fetch-ahead must be a whole number of times in [0, 16], got '" +
                             *k + "'");
    o.fetchAhead = static_cast<std::size_t>((*v)[0]);
  }
  return o;
}

} // namespace

std::expected<std::vector<LayerAnimationArg>, std::string>
animateArgs(const cli::Args& a, const PlanetTiles& tiles, planet::RendererOptions& ro) {
  const auto given = a.all("animate");
  if (given.empty()) {
    for (const char* o : {"rate", "once", "fetch-ahead"})
      if (a.flag(o)) return std::unexpected("--" + std::string(o) + " needs --animate");
    return std::vector<LayerAnimationArg>{};
  }
  const auto options = playOptions(a);
  if (!options) return std::unexpected(options.error());
  std::vector<std::string> drawn{ro.layer};
  for (const auto& o : ro.overlays)
    drawn.push_back(o.layer);
  std::vector<LayerAnimationArg> out;
  for (const std::string& arg : given) {
    const auto eq = arg.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == arg.size())
      return std::unexpected("--animate must be LAYER=TIMES (e.g. sst=2024-01-01/2024-12-01/P1M), "
                             "got '" +
                             arg + "'");
    const std::string name = arg.substr(0, eq);
    const auto at = std::find(drawn.begin(), drawn.end(), name);
    if (at == drawn.end())
      return std::unexpected("--animate names a layer that is not drawn (the base or an "
                             "--overlay): '" +
                             name + "'");
    const auto index = static_cast<std::size_t>(at - drawn.begin());
    if (std::any_of(out.begin(), out.end(), [&](const auto& x) { return x.layer == index; }))
      return std::unexpected("--animate names layer '" + name + "' twice");
    if (!tiles.ctx)
      return std::unexpected("--animate checks the layer's times against the local "
                             "configuration: not with --server");
    const LayerConfig* lc = tiles.ctx->config.layer(name);
    if (lc == nullptr) return std::unexpected("--animate: no layer '" + name + "'");
    auto times = cli::layerTimes(*lc, arg.substr(eq + 1));
    if (!times) return std::unexpected("--animate: " + times.error());
    auto anim = planet::TimeAnimation::create(std::move(*times), *options);
    if (!anim) return std::unexpected("--animate: " + anim.error());
    (index == 0 ? ro.time : ro.overlays[index - 1].time) = anim->instants().front();
    out.push_back({index, std::move(*anim)});
  }
  return out;
}

} // namespace tellus::commands
