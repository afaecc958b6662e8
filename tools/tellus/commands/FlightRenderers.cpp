#include "FlightRenderers.hpp"

#include "Context.hpp"

#include <algorithm>
#include <cstdio>
#include <filesystem>

namespace tellus::commands {
namespace {

std::vector<std::string> layerNames(const planet::RendererOptions& ro) {
  std::vector<std::string> drawn{ro.layer};
  for (const auto& o : ro.overlays)
    drawn.push_back(o.layer);
  return drawn;
}

} // namespace

std::vector<std::string>
orbitableBodies(const cli::Args& a, const planet::FlightPath* flight, const std::string& first) {
  std::vector<std::string> bodies{first};
  if (flight == nullptr || a.get("body")) return bodies;
  for (const planet::Keyframe& k : flight->keyframes())
    if (!k.body.empty() && std::find(bodies.begin(), bodies.end(), k.body) == bodies.end())
      bodies.push_back(k.body);
  return bodies;
}

void addFlightSceneBodies(PlanetTiles& t,
                          const planet::FlightPath& flight,
                          const std::vector<std::string>& bodies) {
  auto& scene = t.sceneBodies;
  for (const planet::Keyframe& k : flight.keyframes())
    if (!k.body.empty() && std::find(scene.begin(), scene.end(), k.body) == scene.end())
      scene.push_back(k.body);
  if (bodies.size() > 1 && std::find(scene.begin(), scene.end(), t.body) == scene.end())
    scene.push_back(t.body);
}

std::expected<std::vector<BodyRenderer>, int>
makeBodyRenderers(const cli::Args& a,
                  const char* cmd,
                  PlanetTiles& t,
                  const std::vector<std::string>& bodies,
                  const Geodesy& first,
                  const planet::RendererOptions& ro,
                  EarthModel earth) {
  std::vector<BodyRenderer> out;
  for (const std::string& name : bodies) {
    BodyRenderer b{name, nullptr, {}, t.layerTimes, nullptr};
    const Geodesy* geodesy = &first;
    ITileSource* source = t.source;
    planet::RendererOptions o = ro;
    if (!out.empty()) {
      auto tiles = tilesForBody(a, cmd, t, name, ro);
      if (!tiles) return std::unexpected(tiles.error());
      o = std::move(tiles->ro);
      source = tiles->source;
      b.layerTimes = std::move(tiles->layerTimes);
      if (o.visibleWindow) o.shareWindowOf = out.front().renderer.get(); // view's B (issue 26)
      b.geodesy = std::make_unique<Geodesy>(resolveBody(name, nullptr, earth));
      geodesy = b.geodesy.get();
      if (const auto global = dataDir(a) / "bmng_2048x1024.jpg";
          name == "earth" && std::filesystem::exists(global))
        o.globalImage = global;
    }
    b.drawn = layerNames(o);
    auto r = planet::Renderer::create(*source, *geodesy, std::move(o));
    if (!r) {
      std::fprintf(stderr, "tellus %s: %s\n", cmd, r.error().c_str());
      return std::unexpected(kExitError);
    }
    b.renderer = std::move(*r);
    out.push_back(std::move(b));
  }
  return out;
}

} // namespace tellus::commands
