// `tellus view`: the interactive globe in a GLFW window (planet::runViewer).

#include "AnimateArgs.hpp"
#include "Commands.hpp"
#include "Context.hpp"
#include "GlobeArgs.hpp"
#include "PlanetTiles.hpp"

#include <tellus/cli/Values.hpp>
#include <tellus/planet/FlightBodies.hpp>
#include <tellus/planet/SceneTime.hpp>
#include <tellus/planet/StarCatalogue.hpp>
#include <tellus/planet_gl/Renderer.hpp>
#include <tellus/planet_gl/Viewer.hpp>

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

/** One renderer's view of one body (issue 26: B ends it to orbit the next body; `next` then says
 * which, with the other bodies and the eye's pose over it). */
struct NextBody {
  std::string body;
  std::vector<std::string> others;
  planet::CameraPose pose;
  std::optional<double> sceneTime;
};

int viewBody(const cli::Args& a, NextBody& next) {
  planet::CameraPose pose{20.0, 10.0, 2.0e7, 0.0, 0.0};
  planet::RendererOptions ro;
  ro.width = 1280;
  ro.height = 800;
  ro.visibleWindow = true;
  ro.windowTitle = "tellus";
  planet::ViewerOptions vo;
  if (const int rc = parseViewArgs(a, pose, ro, vo); rc != kExitOk) return rc;
  const auto earth = earthArg(a);
  if (!earth) return usage("--earth must be wgs84 or sphere", earth.error());
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
  const Geodesy geodesy(tiles->bodyFor(earth->value_or(tiles->earth)));
  addSceneBodies(ro, tiles->sceneBodies, dataDir(a), earth->value_or(tiles->earth));
  auto renderer = planet::Renderer::create(*tiles->source, geodesy, ro);
  if (!renderer) {
    std::fprintf(stderr, "tellus view: %s\n", renderer.error().c_str());
    return kExitError;
  }
  for (auto& anim : *animations)
    (*renderer)->animateLayer(anim.layer, std::move(anim.animation));
  vo.start = pose;
  vo.layerTimes = tiles->layerTimes;
  vo.sceneTime = ro.timeUnixSeconds;
  // B: the scene's bodies in turn, this one first (issue 26).
  vo.bodies = {tiles->body};
  for (const std::string& b : tiles->sceneBodies)
    if (b != tiles->body) vo.bodies.push_back(b);
  planet::ViewerOptions::End end;
  vo.end = &end;
  std::printf("tellus view: drag to move, wheel to zoom, W/S tilt, A/D heading, R reset, "
              "P screenshot, Esc quits; time: L faster, H slower, J backwards, K pause, N now%s\n",
              ro.overlays.empty() ? ""
                                  : "; layers: 0-9 select (1-9 show/hide), - = opacity, [ ] time");
  if (!animations->empty())
    std::printf("tellus view: --animate: Space plays or pauses, [ ] step the animated layer\n");
  std::fflush(stdout);
  if (vo.bodies.size() > 1)
    std::printf(
        "tellus view: orbiting %s; B orbits %s\n", tiles->body.c_str(), vo.bodies[1].c_str());
  std::fflush(stdout);
  const auto frames = planet::runViewer(**renderer, vo);
  std::printf("tellus view: %llu frames\n", static_cast<unsigned long long>(frames));
  if (!end.nextBody.empty()) {
    const planet::Body to = resolveBody(end.nextBody, nullptr, earth->value_or(tiles->earth));
    next.body = end.nextBody;
    next.others.assign(vo.bodies.begin(), vo.bodies.end());
    std::erase(next.others, end.nextBody);
    next.sceneTime = end.sceneTime;
    next.pose = planet::poseOverOtherBody(
        end.pose, geodesy.body(), to, end.sceneTime.value_or(planet::kJ2000UnixSeconds));
  }
  return kExitOk;
}

/** The view, once per body orbited: B makes the next body's renderer with the eye kept. */
int runView(const cli::Args& first) {
  cli::Args a = first;
  for (;;) {
    NextBody next;
    if (const int rc = viewBody(a, next); rc != kExitOk || next.body.empty()) return rc;
    char camera[160];
    std::snprintf(camera,
                  sizeof camera,
                  "%.17g,%.17g,%.17g,%.17g,%.17g",
                  next.pose.latDeg,
                  next.pose.lonDeg,
                  next.pose.altitudeM,
                  next.pose.headingDeg,
                  next.pose.tiltDeg);
    std::string others;
    for (const std::string& b : next.others)
      others += (others.empty() ? "" : ",") + b;
    for (const char* o : {"body", "bodies", "camera", "time"})
      a.options.erase(o);
    a.options.emplace("body", next.body);
    a.options.emplace("bodies", others);
    a.options.emplace("camera", camera);
    if (next.sceneTime) a.options.emplace("time", planet::formatSceneTime(*next.sceneTime));
  }
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
