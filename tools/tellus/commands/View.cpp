// `tellus view`: the interactive globe in a GLFW window (planet::runViewer).

#include "AnimateArgs.hpp"
#include "Commands.hpp"
#include "Context.hpp"
#include "FlightRenderers.hpp"
#include "GlobeArgs.hpp"
#include "PlanetTiles.hpp"

#include <tellus/cli/Values.hpp>
#include <tellus/planet/FlightBodies.hpp>
#include <tellus/planet/SceneTime.hpp>
#include <tellus/planet/StarCatalogue.hpp>
#include <tellus/planet_gl/Renderer.hpp>
#include <tellus/planet_gl/Viewer.hpp>

#include <algorithm>
#include <cstdio>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace fs = std::filesystem;

namespace tellus::commands {
namespace {

int usage(const char* what, const std::string& got) {
  std::fprintf(stderr, "tellus view: %s, got '%s'\n", what, got.c_str());
  return kExitUsage;
}

/** --camera, --size, --threshold and --exit-after into the start pose and the options. */
int parseViewArgs(const cli::Args& a,
                  planet::CameraPose& pose,
                  planet::RendererOptions& ro,
                  planet::ViewerOptions& vo) {
  if (auto c = a.get("camera")) {
    const auto cam = cli::parseNumbers(*c, 3, 5);
    if (!cam || (*cam)[0] < -90.0 || (*cam)[0] > 90.0 || (*cam)[2] < -11000.0 || (*cam)[2] > 1e10 ||
        (cam->size() > 4 && ((*cam)[4] < 0.0 || (*cam)[4] > 180.0)))
      return usage("--camera must be LAT,LON,ALT[,HEADING,TILT] within range", *c);
    pose = {(*cam)[0],
            (*cam)[1],
            (*cam)[2],
            cam->size() > 3 ? (*cam)[3] : 0.0,
            cam->size() > 4 ? (*cam)[4] : 0.0};
  }
  const auto dome = domeArgs(a);
  if (!dome) return usage("bad --dome or --dome-tilt", dome.error());
  if (auto size = a.get("size")) {
    const auto wh = cli::parseSize(*size);
    if (!wh) return usage("--size must be WxH with 1 to 16384 pixels each", *size);
    ro.width = wh->first;
    ro.height = wh->second;
  }
  if (auto t = a.get("threshold")) {
    const auto v = cli::parseNumbers(*t, 1, 1);
    if (!v || (*v)[0] < 0.05 || (*v)[0] > 64.0)
      return usage("--threshold must be a number in [0.05, 64]", *t);
    ro.lodThreshold = (*v)[0];
  }
  if (auto e = a.get("exit-after")) {
    const auto v = cli::parseNumbers(*e, 1, 1);
    if (!v || (*v)[0] < 1) return usage("--exit-after must be a frame count", *e);
    vo.maxFrames = static_cast<std::uint64_t>((*v)[0]);
  }
  return kExitOk;
}

/** The view: a renderer per body of the scene (issue 26: the orbited one, then --bodies or
 * renderer.bodies), all in one window; B hands the window to the next body's renderer with the
 * eye kept (planet::poseOverOtherBody), the one left drawn as a coarse globe by the next. */
int runView(const cli::Args& a) {
  planet::CameraPose pose{20.0, 10.0, 2.0e7, 0.0, 0.0};
  planet::RendererOptions ro;
  ro.width = 1280;
  ro.height = 800;
  ro.visibleWindow = true;
  ro.windowTitle = "tellus";
  planet::ViewerOptions vo;
  if (const int rc = parseViewArgs(a, pose, ro, vo); rc != kExitOk) return rc;
  const auto earthModel = earthArg(a);
  if (!earthModel) return usage("--earth must be wgs84 or sphere", earthModel.error());
  auto tiles = openPlanetTiles(a, "view", ro);
  if (!tiles) return tiles.error();
  if (auto bad = applySceneTime(a, tiles->sceneTime, "now", ro)) {
    std::fprintf(stderr, "tellus view: %s\n", bad->c_str());
    return kExitUsage;
  }
  auto animations = animateArgs(a, *tiles, ro); // time that plays (issue 24)
  if (!animations) {
    std::fprintf(stderr, "tellus view: %s\n", animations.error().c_str());
    return kExitUsage;
  }
  hideNightLayers(a, tiles->night, ro);
  // Legends of value layers (issue 24): on in view unless renderer.legend or --no-legend says no.
  ro.legend = !a.flag("no-legend") && (a.flag("legend") || tiles->legend.value_or(true));
  if (const fs::path global = dataDir(a) / "bmng_2048x1024.jpg";
      tiles->body == "earth" && fs::exists(global))
    ro.globalImage = global;
  const EarthModel earth = earthModel->value_or(tiles->earth);
  const Geodesy geodesy(tiles->bodyFor(earth));
  // B: the scene's bodies in turn, this one first (issue 26); each body's renderer shows the
  // others (its own entry skipped).
  std::vector<std::string> bodies{tiles->body};
  for (const std::string& b : tiles->sceneBodies)
    if (std::find(bodies.begin(), bodies.end(), b) == bodies.end()) bodies.push_back(b);
  if (bodies.size() > 1 &&
      std::find(tiles->sceneBodies.begin(), tiles->sceneBodies.end(), tiles->body) ==
          tiles->sceneBodies.end())
    tiles->sceneBodies.push_back(tiles->body);
  addSceneBodies(ro, tiles->sceneBodies, dataDir(a), earth);
  auto renderers = makeBodyRenderers(a, "view", *tiles, bodies, geodesy, ro, earth);
  if (!renderers) return renderers.error();
  for (auto& anim : *animations)
    renderers->front().renderer->animateLayer(anim.layer, std::move(anim.animation));
  vo.start = pose;
  vo.sceneTime = ro.timeUnixSeconds;
  planet::ViewerOptions::End end;
  vo.end = &end;
  std::printf("tellus view: drag to move, wheel to zoom, W/S tilt, A/D heading, R reset, "
              "P screenshot, Esc quits; time: L faster, H slower, J backwards, K pause, N now%s\n",
              ro.overlays.empty() ? ""
                                  : "; layers: 0-9 select (1-9 show/hide), - = opacity, [ ] time");
  if (!animations->empty())
    std::printf("tellus view: --animate: Space plays or pauses, [ ] step the animated layer\n");
  std::uint64_t frames = 0;
  for (std::size_t at = 0;;) {
    BodyRenderer& shown = (*renderers)[at];
    vo.layerTimes = shown.layerTimes;
    vo.bodies.clear(); // this body first, then the others in turn
    for (std::size_t i = 0; i < bodies.size(); ++i)
      vo.bodies.push_back(bodies[(at + i) % bodies.size()]);
    if (bodies.size() > 1)
      std::printf(
          "tellus view: orbiting %s; B orbits %s\n", vo.bodies[0].c_str(), vo.bodies[1].c_str());
    std::fflush(stdout);
    end = {};
    frames += planet::runViewer(*shown.renderer, vo);
    if (end.nextBody.empty()) break;
    const std::size_t next = (at + 1) % bodies.size();
    const planet::Body& from = shown.renderer->geodesy().body();
    vo.start = planet::poseOverOtherBody(end.pose,
                                         from,
                                         (*renderers)[next].renderer->geodesy().body(),
                                         end.sceneTime.value_or(planet::kJ2000UnixSeconds));
    vo.sceneTime = end.sceneTime;
    at = next;
  }
  std::printf("tellus view: %llu frames\n", static_cast<unsigned long long>(frames));
  return kExitOk;
}

} // namespace

Command viewCommand() {
  Command c{"view", tileSourceOptions(), 0, &runView};
  const auto globe = globeOptions();
  c.options.insert(c.options.end(), globe.begin(), globe.end());
  c.options.push_back({"exit-after", cli::OptionKind::Value});
  const auto animate = animateOptions();
  c.options.insert(c.options.end(), animate.begin(), animate.end());
  return c;
}

} // namespace tellus::commands
