#pragma once
/**
 * @file GlobeArgs.hpp
 * @brief The options `render` and `view` (and `height`, some of them) share: the renderer's
 * settings of the configuration (YAML `renderer`) with what the command line gives over them.
 */

#include <tellus/config/CommandLine.hpp>
#include <tellus/config/Config.hpp>
#include <tellus/planet/Geodesy.hpp>
#include <tellus/planet_gl/Renderer.hpp>

#include <expected>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace tellus::commands {

/** --offline, --server, --geoid and --body: where render, view and height get their tiles. */
std::vector<cli::OptionSpec> tileSourceOptions();
/** What render and view both take: --camera, --bodies, --size, --layer, --threshold, --earth,
 * terrain, --overlay and the dome's options. */
std::vector<cli::OptionSpec> globeOptions();

/** `--earth wgs84|sphere`; nullopt when absent, the value given when bad. */
std::expected<std::optional<EarthModel>, std::string> earthArg(const cli::Args& a);

/** `--dome [FOV]` (also `--dome=FOV`), `--dome-tilt DEG` and `--dome-method direct|cube`: whether
 * the command line asks for the dome, and what it gives. An error text for a bad value. */
struct DomeArgs {
  bool on = false;
  std::optional<double> fovDeg, tiltDeg;
  std::optional<planet::DomeMethod> method;
};
std::expected<DomeArgs, std::string> domeArgs(const cli::Args& a);

/** renderer.atmosphere as the renderer's options (nullopt when disabled). */
std::optional<planet::RendererOptions::Atmosphere> atmosphereOptions(const AtmosphereSettings& s);

/** The configuration's `renderer` settings into `ro` and `earth`; what the command line gave
 * (--threshold, --dome, --dome-tilt, --dome-method) wins (the caller applies --earth). */
void applyRendererSettings(const RendererSettings& g,
                           const cli::Args& a,
                           planet::RendererOptions& ro,
                           EarthModel& earth);

/** --exaggeration, --min-relief-px, --edge-fixing, --geoid (checked only), --mesh-size,
 * --upload-per-frame, --vertices and --sun over the configuration's; the usage error, if any. */
std::optional<std::string> applyTerrainArgs(const cli::Args& a, planet::RendererOptions& ro);

/** The render's scene time when neither --time nor renderer.time gives one: the March equinox
 * of 2024 at noon UTC. Fixed, so that a render is reproducible (its --stats JSON records the
 * time as "scene_time"); at an equinox both hemispheres are lit alike (no polar night hides a
 * pole), and at noon UTC the day side is centred near Greenwich, the terminator near 90 E and
 * 90 W. `view` starts at now instead. */
inline constexpr const char* kDefaultRenderTime = "2024-03-20T12:00:00Z";

/** The scene's time (issue 23): --time, else `renderer.time` (configured), else `fallback`
 * ("now" for view, kDefaultRenderTime for render), parsed (ISO 8601 UTC or now, the system clock's
 * now) into ro.timeUnixSeconds. The error text for a bad value. */
std::optional<std::string> applySceneTime(const cli::Args& a,
                                          const std::string& configured,
                                          std::string_view fallback,
                                          planet::RendererOptions& ro);

/** --no-night, `renderer.night: false` (configured false), or no sunlight (--no-sun,
 * `renderer.sunlight: false`, and no --sun): the night layers (LayerOptions::night) hidden, so
 * that they are not fetched either. */
void hideNightLayers(const cli::Args& a, bool configured, planet::RendererOptions& ro);

/** `renderer.geoid` (the configuration's, or --geoid on|off): the elevation layer's
 * mean-sea-level heights onto the ellipsoid with the bundled EGM96 grid of the data directory.
 * An error text when the grid cannot be read. */
std::optional<std::string>
applyGeoid(const cli::Args& a, bool configured, planet::RendererOptions& ro);

/** `renderer.stars` (the configuration's, or off with --no-stars): the star background from the
 * bundled catalogue of the data directory (data/stars-hip-6.5.txt). An error text when it is on
 * and the catalogue cannot be read. */
std::optional<std::string>
applyStars(const cli::Args& a, const StarsSettings& configured, planet::RendererOptions& ro);

} // namespace tellus::commands
