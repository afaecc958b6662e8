#pragma once
/**
 * @file PlanetTiles.hpp
 * @brief Where `render`, `view` and `height` get their tiles: the in-process tile service over
 * the cache (the default, fetching misses upstream as `serve` does), or a remote `tellus serve`
 * (--server URL, through its /layers.json and /tiles/). Also picks the layers drawn: --layer, else
 * renderer.layers, else the first imagery layer; the overlays; the elevation layer and its
 * decoders; the geoid.
 */

#include "Bodies.hpp"
#include "Context.hpp"

#include <tellus/cache/TileSource.hpp>
#include <tellus/config/CommandLine.hpp>
#include <tellus/planet/Geodesy.hpp>
#include <tellus/planet/RegionalSource.hpp>
#include <tellus/planet_gl/Renderer.hpp>
#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/RemoteTileSource.hpp>
#include <tellus/proxy/TileService.hpp>

#include <expected>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace tellus::commands {

struct PlanetTiles {
  std::optional<Context> ctx; ///< the local configuration and cache (not with --server)
  std::unique_ptr<Fetcher> fetcher;
  std::unique_ptr<TileService> service;
  std::unique_ptr<RemoteTileSource> remote;
  std::unique_ptr<planet::RegionalTileSource> regional; ///< over service or remote, when used
  ITileSource* source = nullptr;                        ///< what the renderer reads
  EarthModel earth = EarthModel::Wgs84;                 ///< the configuration's renderer.earth
  /** The body shown (--body, else renderer.body; issue 26): only its layers are drawn. */
  std::string body = "earth";
  std::optional<BodyConfig> configuredBody; ///< when body is one of the configuration's
  std::unique_ptr<BareLayerSource> bare;    ///< when no imagery layer lies on the body
  /** The scene's other bodies (--bodies, else renderer.bodies; issue 26): earth, moon, mars. */
  std::vector<std::string> sceneBodies;
  /** The body as the renderer's Geodesy takes it (the Earth in the model given). */
  planet::Body bodyFor(EarthModel model) const {
    if (configuredBody) return bodyFromConfig(*configuredBody);
    return resolveBody(body, nullptr, model);
  }
  /** Per renderer layer (base, overlays): the TIME values `view` steps through ([ and ]). */
  std::vector<std::vector<std::string>> layerTimes;
  /** The configuration's `renderer.time` ("" = none) and `renderer.night` (issue 23). */
  std::string sceneTime;
  bool night = true;
  /** The configuration's `renderer.legend` (issue 24); nullopt: the command's default. */
  std::optional<bool> legend;
  /** The sources of the other bodies' renderers (tilesForBody): bare globes, regional layers. */
  std::vector<std::unique_ptr<ITileSource>> bodySources;
};

/** What the renderer of another body of a flight reads (issue 26: the camera orbits the body it
 * is near, docs/design/bodies.md "Flying between bodies"). */
struct BodyTiles {
  planet::RendererOptions ro;
  ITileSource* source = nullptr;
  std::vector<std::vector<std::string>> layerTimes; ///< as PlanetTiles::layerTimes
};

/** The tile source and the layers for command `cmd` ("render", "view", "height"), filling `ro`
 * from the configuration and the command line. The exit code on failure (usage errors 2, the
 * rest 1) after saying why. */
std::expected<PlanetTiles, int>
openPlanetTiles(const cli::Args& a, const char* cmd, planet::RendererOptions& ro);

/** The options and source of `body`'s renderer beside the one openPlanetTiles chose for t.body:
 * `base` (its size, dome, sun, stars, air, ...) with the layers chosen for `body` as --body
 * would choose them (renderer.layers on that body, else its first imagery layer, else the bare
 * globe; its elevation layer; the geoid on the Earth only) but for --layer and --overlay, which
 * name t.body's layers. With --server: `base` over the server's layers. The exit code after
 * saying why. */
std::expected<BodyTiles, int> tilesForBody(const cli::Args& a,
                                           const char* cmd,
                                           PlanetTiles& t,
                                           const std::string& body,
                                           const planet::RendererOptions& base);

} // namespace tellus::commands
