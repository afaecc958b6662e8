#pragma once
/**
 * @file FlightRenderers.hpp
 * @brief The renderers of a flight between bodies (issue 26, docs/design/bodies.md "Flying
 * between bodies"): one per body the camera may orbit, each with that body's quadtree, layers,
 * terrain and air and the other bodies as coarse globes; planet::OrbitSwitcher says which one
 * draws each frame. One renderer when the flight stays on one body (or --body pins it).
 */

#include "PlanetTiles.hpp"

#include <tellus/config/CommandLine.hpp>
#include <tellus/planet/FlightPath.hpp>
#include <tellus/planet/Geodesy.hpp>
#include <tellus/planet_gl/Renderer.hpp>

#include <expected>
#include <memory>
#include <string>
#include <vector>

namespace tellus::commands {

/** One body's renderer. */
struct BodyRenderer {
  std::string body;
  std::unique_ptr<Geodesy> geodesy; ///< what the renderer draws (null: the command's, the first)
  std::vector<std::string> drawn;   ///< its layers' names: the base, then the overlays
  std::vector<std::vector<std::string>> layerTimes; ///< per layer, its TIME values (view's [ ])
  std::unique_ptr<planet::Renderer> renderer;
};

/** The bodies a flight's camera may orbit: `first` (t.body), then, unless --body pinned it, each
 * other body the keyframes name, in their order. */
std::vector<std::string>
orbitableBodies(const cli::Args& a, const planet::FlightPath* flight, const std::string& first);

/** The bodies a flight's keyframes name added to t.sceneBodies (each drawn as a coarse globe by
 * the others' renderers; a renderer skips its own body's entry), and t.body too when the camera
 * may orbit another of `bodies` (orbitableBodies). */
void addFlightSceneBodies(PlanetTiles& t,
                          const planet::FlightPath& flight,
                          const std::vector<std::string>& bodies);

/** A renderer for each body of `bodies` (the first from `first` and `ro` over t.source, as a
 * single-body render makes it; the others from tilesForBody with ro's other settings, the Blue
 * Marble as the Earth's global texture from the data directory; with ro.visibleWindow they draw
 * in the first one's window). The exit code after saying why. */
std::expected<std::vector<BodyRenderer>, int>
makeBodyRenderers(const cli::Args& a,
                  const char* cmd,
                  PlanetTiles& t,
                  const std::vector<std::string>& bodies,
                  const Geodesy& first,
                  const planet::RendererOptions& ro,
                  EarthModel earth);

} // namespace tellus::commands
