#pragma once
/**
 * @file PlanetTiles.hpp
 * @brief What `render`, `view` and `height` share: where their tiles come from and the options of
 * the globe, as they were in main.cpp.
 */

#include "Commands.hpp"

#include <tellus/cache/TileSource.hpp>
#include <tellus/planet/Geodesy.hpp>
#include <tellus/planet/RegionalSource.hpp>
#include <tellus/planet_gl/Renderer.hpp>
#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/RemoteTileSource.hpp>
#include <tellus/proxy/TileService.hpp>

#include <expected>

namespace tellus::commands {

/** Where `render` and `view` get their tiles: the in-process tile service over the cache (the
 * default, fetching misses upstream as `serve` does), or a remote `tellus serve` (--server URL,
 * through its /layers.json and /tiles/). Also picks the layer: --layer, else the first imagery
 * layer. Returns an exit code on failure (usage errors 2, the rest 1) after saying why. */
struct PlanetTiles {
  std::optional<Context> ctx;
  std::unique_ptr<Fetcher> fetcher;
  std::unique_ptr<TileService> service;
  std::unique_ptr<RemoteTileSource> remote;
  std::unique_ptr<planet::RegionalTileSource> regional; ///< over service or remote, when used
  ITileSource* source = nullptr;
  EarthModel earth = EarthModel::Wgs84; ///< the configuration's renderer.earth
  /** Per renderer layer (base, overlays): the TIME values `view` steps through ([ and ]). */
  std::vector<std::vector<std::string>> layerTimes;
};

/** `--earth wgs84|sphere` of render and view; nullopt when absent, an error text when bad. */
std::expected<std::optional<EarthModel>, std::string> earthArg(const Args& a);

/** `--dome [FOV]` (also `--dome=FOV`) and
 * `--dome-tilt DEG` of render and view: whether the command line asks for the dome, and what it
 * gives. An error text for a bad value. */
struct DomeArgs {
  bool on = false;
  std::optional<double> fovDeg, tiltDeg;
  std::optional<planet::DomeMethod> method; ///< --dome-method direct|cube
};
std::expected<DomeArgs, std::string> domeArgs(const Args& a);

std::expected<PlanetTiles, int>
openPlanetTiles(const Args& a, const char* cmd, planet::RendererOptions& ro);

} // namespace tellus::commands
