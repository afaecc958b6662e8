// `tellus cluster CONFIG`: the dome as a cluster of projector channels (issue 28,
// docs/design/cluster.md), run as `mpirun -n K tellus cluster CONFIG ...` with K = channels + 1.
// Rank 0 is the master (ClusterMaster.cpp): it owns the camera, the scene's time and the flight
// (--camera or --path) and sends each frame's state (cluster::FrameState); rank i >= 1 renders
// channel i - 1 of CONFIG headless with its own frustum, LOD and culling (ClusterChannel.cpp),
// answers, waits for the master's go (the barrier) and only then writes its image (the swap):
// OUT/channel-NAME-FRAME.png. Every rank appends the digest of the state it drew to
// OUT/digest-NAME.txt (the master's: digest-master.txt). A channel started alone with
// --join NAME --port FILE rejoins a running master.

#include "ClusterArgs.hpp"
#include "ClusterControl.hpp"
#include "ClusterPreview.hpp"
#include "Commands.hpp"
#include "Context.hpp"
#include "FlightRenderers.hpp"
#include "GlobeArgs.hpp"
#include "PlanetTiles.hpp"

#include <tellus/cli/Values.hpp>
#include <tellus/cluster/Comm.hpp>
#include <tellus/mpcdi/Mpcdi.hpp>
#include <tellus/planet/ChannelWarp.hpp>
#include <tellus/planet/Channels.hpp>
#include <tellus/planet/FlightBodies.hpp>
#include <tellus/planet/FlightPath.hpp>
#include <tellus/planet_gl/Renderer.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace fs = std::filesystem;

namespace tellus::commands {

std::string parseCluster(const cli::Args& a, ClusterArgs& c) {
  const auto mpcdiFile = a.get("mpcdi"); // a VESA MPCDI calibration instead of CONFIG.json
  if (a.positional.size() != (mpcdiFile ? 0u : 1u))
    return "a channel configuration CONFIG.json or --mpcdi FILE.mpcdi (not both) is required";
  auto channels = mpcdiFile ? mpcdi::readMpcdi(*mpcdiFile) : planet::readChannels(a.positional[0]);
  if (!channels) return channels.error();
  c.channels = std::move(*channels);
  if (const auto scale = a.get("render-scale")) { // the rendered images against the projectors'
    const auto v = cli::parseNumbers(*scale, 1, 1);
    if (!v || !((*v)[0] >= 0.25) || (*v)[0] > 4.0)
      return "--render-scale must be in [0.25, 4]: " + *scale;
    for (planet::Channel& ch : c.channels)
      if (ch.renderWidth == 0) { // a size of its own in CONFIG.json stays
        ch.renderWidth = std::clamp(static_cast<int>(std::lround(ch.width * (*v)[0])), 1, 16384);
        ch.renderHeight = std::clamp(static_cast<int>(std::lround(ch.height * (*v)[0])), 1, 16384);
      }
  }
  if (a.flag("dome") || a.get("dome-method") || a.get("size"))
    return "--dome, --dome-method and --size are the domemaster's: each channel has its own view "
           "and size (--dome-tilt turns the dome the channels are given in)";
  const auto out = a.get("out");
  if (!out || out->empty()) return "--out DIR is required";
  c.out = *out;
  if (const auto dome = domeArgs(a); !dome) return dome.error();
  const auto camera = a.get("camera");
  const auto path = a.get("path");
  if (camera.has_value() == path.has_value())
    return "one of --camera LAT,LON,ALT[,HEADING,TILT] and --path PATH.json is required";
  if (path) {
    auto read = planet::FlightPath::read(*path);
    if (!read) return *path + ": " + read.error();
    c.flight = std::move(*read);
    c.pathFile = *path;
    if (const auto f = a.get("fps")) {
      const auto v = cli::parseNumbers(*f, 1, 1);
      if (!v || (*v)[0] <= 0.0 || (*v)[0] > 1000.0) return "--fps must be in (0, 1000]: " + *f;
      c.fps = (*v)[0];
    }
  } else {
    if (a.get("fps")) return "--fps needs --path";
    const auto v = cli::parseNumbers(*camera, 3, 5);
    if (!v) return "--camera must be LAT,LON,ALT[,HEADING,TILT]: " + *camera;
    c.pose = {
        (*v)[0], (*v)[1], (*v)[2], v->size() > 3 ? (*v)[3] : 0.0, v->size() > 4 ? (*v)[4] : 0.0};
    if (c.pose.latDeg < -90.0 || c.pose.latDeg > 90.0 || c.pose.tiltDeg < 0.0 ||
        c.pose.tiltDeg > 180.0)
      return "--camera latitude must be in [-90, 90] and tilt in [0, 180]: " + *camera;
  }
  if (const auto b = a.get("background")) {
    const auto v = cli::parseNumbers(*b, 3, 3);
    if (!v || std::any_of(v->begin(), v->end(), [](double x) { return x < 0.0 || x > 255.0; }))
      return "--background must be R,G,B with each in 0-255: " + *b;
    c.background = {(*v)[0] / 255.0, (*v)[1] / 255.0, (*v)[2] / 255.0};
  }
  c.waitComplete = a.flag("wait-complete");
  if (const auto w = a.get("wait-complete"); w && !w->empty()) {
    const auto v = cli::parseNumbers(*w, 1, 1);
    if (!v || (*v)[0] <= 0.0 || (*v)[0] > 86400.0)
      return "--wait-complete=SECONDS must be in (0, 86400]: " + *w;
    c.waitSeconds = (*v)[0];
  }
  c.loop = a.flag("loop");
  c.realtime = a.flag("realtime");
  if (const auto t = a.get("channel-timeout")) {
    const auto v = cli::parseNumbers(*t, 1, 1);
    if (!v || (*v)[0] <= 0.0 || (*v)[0] > 3600.0)
      return "--channel-timeout must be in (0, 3600] seconds: " + *t;
    c.channelTimeout = (*v)[0];
  }
  if (const auto p = a.get("port")) {
    if (p->empty()) return "--port FILE needs a file";
    c.port = *p;
  }
  if (const auto k = a.get("control")) c.control = *k;
  if (const auto j = a.get("join")) {
    if (c.port.empty()) return "--join NAME needs --port FILE (the master's)";
    if (std::none_of(c.channels.begin(), c.channels.end(), [&](const planet::Channel& ch) {
          return ch.name == *j;
        }))
      return "--join " + *j + ": no such channel in " + a.positional[0];
    c.join = *j;
  }
  return parseWindows(a, c);
}

bool appendLine(const fs::path& file, const std::string& line) {
  std::ofstream f(file, std::ios::app);
  f << line;
  return static_cast<bool>(f);
}

namespace {

/** The channel's renderer and calibration (problem: why it cannot draw), then its loop. */
int startChannel(cluster::Comm* comm,
                 const cli::Args& a,
                 const ClusterArgs& c,
                 const planet::Channel& channel,
                 PlanetTiles& tiles,
                 planet::RendererOptions ro) {
  const Geodesy geodesy(tiles.bodyFor(tiles.earth));
  const planet::ChannelFrame frame = planet::channelFrame(channel);
  ro.channelView = planet::RendererOptions::ChannelView{
      frame.forward, frame.up, ro.dome ? ro.dome->tiltDeg : 0.0};
  if (const auto d = domeArgs(a); d && d->tiltDeg) ro.channelView->domeTiltDeg = *d->tiltDeg;
  ro.dome.reset();
  ro.width = channel.renderedWidth(); // the projector's pixels come out of the warp pass
  ro.height = channel.renderedHeight();
  ro.verticalFovDeg = channel.vfovDeg;
  if (c.background) ro.background = *c.background;
  if (const fs::path global = dataDir(a) / "bmng_2048x1024.jpg";
      tiles.body == "earth" && fs::exists(global))
    ro.globalImage = global;
  addSceneBodies(ro, tiles.sceneBodies, dataDir(a), tiles.earth);
  if (c.window) {
    ro.visibleWindow = true;
    ro.presentOnRequest = true; // after the master's go
    ro.windowTitle = "tellus cluster: channel " + channel.name;
  }
  Calibration cal;
  std::string problem;
  if (channel.warpMesh) cal.warp = *channel.warpMesh; // an MPCDI file's, in memory
  if (channel.blendMask) cal.blend = *channel.blendMask;
  if (!channel.warp.empty() && !cal.warp) {
    if (auto w = planet::readWarpMesh(channel.warp))
      cal.warp = std::move(*w);
    else
      problem = w.error();
  }
  if (!channel.blend.empty() && !cal.blend) {
    if (auto b = planet::readBlendMask(channel.blend, channel.width, channel.height))
      cal.blend = std::move(*b);
    else
      problem = b.error();
  }
  if (c.window && (cal.warp || cal.blend || scaled(channel))) // the warp and blend on the GPU
    ro.projectorWarp = planet::RendererOptions::ProjectorCalibration{
        cal.warp, cal.blend, channel.width, channel.height};
  // A renderer for each body the flight orbits (one unless its keyframes name others), as
  // `tellus render --path` makes them; the master's state says which one draws.
  std::vector<BodyRenderer> bodies;
  std::vector<planet::Renderer*> renderers;
  if (problem.empty()) {
    auto made = makeBodyRenderers(a, "cluster", tiles, c.bodies, geodesy, ro, tiles.earth);
    if (made)
      bodies = std::move(*made);
    else
      problem = "a renderer could not be made (above)";
  }
  if (!problem.empty()) {
    std::fprintf(stderr, "tellus cluster: channel %s: %s\n", channel.name.c_str(), problem.c_str());
  } else { // a first frame off the clock (shaders, the global image): the master's come in time
    for (BodyRenderer& b : bodies) {
      const planet::Body& over = b.renderer->geodesy().body();
      b.renderer->frame(c.flight ? planet::flightPoseOver(*c.flight, 0.0, over) : c.pose);
      renderers.push_back(b.renderer.get());
    }
  }
  std::unique_ptr<cluster::Comm> joined;
  if (comm == nullptr) { // --join: the renderer is ready, the master's next frame is drawn
    if (!problem.empty()) return kExitError;
    auto j = cluster::Comm::join(c.port, channel.name, 60.0);
    if (!j) {
      std::fprintf(
          stderr, "tellus cluster: channel %s: %s\n", channel.name.c_str(), j.error().c_str());
      return kExitError;
    }
    joined = std::move(*j);
    comm = joined.get();
  }
  return runChannel(*comm, c, channel, renderers, cal, joined != nullptr);
}

int runCluster(const cli::Args& a) {
  ClusterArgs c;
  std::unique_ptr<cluster::Comm> comm;
  int rank = 0;
  if (a.get("join")) { // a channel restarted alone: its own mpirun job
    if (const auto bad = parseCluster(a, c); !bad.empty()) {
      std::fprintf(stderr, "tellus cluster: %s (tellus --help)\n", bad.c_str());
      return kExitUsage;
    }
  } else {
    auto init = cluster::Comm::init();
    if (!init) {
      std::fprintf(stderr, "tellus cluster: %s\n", init.error().c_str());
      return kExitError;
    }
    comm = std::move(*init);
    rank = comm->rank();
  }
  // Usage errors: every rank finds the same ones; rank 0 says them.
  auto say = [rank](const std::string& what, int code) {
    if (rank == 0) std::fprintf(stderr, "tellus cluster: %s (tellus --help)\n", what.c_str());
    return code;
  };
  if (comm) {
    if (const auto bad = parseCluster(a, c); !bad.empty()) return say(bad, kExitUsage);
    if (static_cast<std::size_t>(comm->size()) != c.channels.size() + 1)
      return say("run with one rank per channel and the master: mpirun -n " +
                     std::to_string(c.channels.size() + 1) + " (got " +
                     std::to_string(comm->size()) + ")",
                 kExitUsage);
  }
  std::error_code ec;
  fs::create_directories(c.out, ec);
  if (ec) return say(c.out.string() + ": " + ec.message(), kExitError);
  planet::RendererOptions ro;
  ro.decodeNice = 0;
  auto tiles = openPlanetTiles(a, "cluster", ro);
  // Every rank says whether it opened the cache, so that all stop together when one could not:
  // the others would wait for its first answer for ever.
  if (comm && !comm->allWell(tiles.has_value())) return tiles ? kExitError : tiles.error();
  if (!tiles) return tiles.error();
  if (auto bad = applySceneTime(a, tiles->sceneTime, kDefaultRenderTime, ro))
    return say(*bad, kExitUsage);
  hideNightLayers(a, tiles->night, ro);
  if (c.flight) // a keyframe's "times" name layers the channels draw (the base or an overlay)
    for (const planet::Keyframe& k : c.flight->keyframes())
      for (const auto& [name, value] : k.layerTimes)
        if (ro.layer != name && std::none_of(ro.overlays.begin(),
                                             ro.overlays.end(),
                                             [&](const auto& o) { return o.layer == name; }))
          return say("a keyframe's \"times\" names a layer that is not drawn: " + name, kExitUsage);
  ro.legend = false;
  ro.fadeInSeconds = 0.0; // a channel's image must not depend on how long it took to draw
  // Keyframes on other bodies (issue 26): every rank derives the same bodies from --path; the
  // master picks the one orbited each frame (planet::OrbitSwitcher) and says which (FrameState's
  // body); each channel draws it with that body's renderer.
  const Geodesy first(tiles->bodyFor(tiles->earth));
  if (c.flight)
    if (auto bad = planet::flightBodiesProblem(*c.flight, first.body()))
      return say(*bad, kExitUsage);
  c.bodies = orbitableBodies(a, c.flight ? &*c.flight : nullptr, tiles->body);
  // The layers the console may set, every rank alike: the base, then the overlays.
  c.layers.push_back({ro.layer, 1.0, true, {}});
  for (const auto& o : ro.overlays)
    c.layers.push_back({o.layer, o.opacity, o.visible, {}});
  for (std::size_t i = 0; i < c.layers.size() && i < tiles->layerTimes.size(); ++i)
    c.layers[i].times = tiles->layerTimes[i];
  if (c.flight) addFlightSceneBodies(*tiles, *c.flight, c.bodies);
  if (comm && rank == 0) {
    std::vector<planet::Body> bodies{first.body()};
    for (std::size_t i = 1; i < c.bodies.size(); ++i)
      bodies.push_back(resolveBody(c.bodies[i], nullptr, tiles->earth));
    std::unique_ptr<Console> console;
    if (!c.control.empty()) {
      std::vector<ConsoleLayer> layers;
      for (const ClusterLayer& l : c.layers)
        layers.push_back({l.name, l.times});
      auto started = Console::start(c.control, std::move(layers));
      if (!started) {
        std::fprintf(stderr, "tellus cluster: %s\n", started.error().c_str());
        comm->abort(kExitUsage); // the channels wait for the master's first frame
      }
      console = std::move(*started);
      std::printf("tellus cluster: control on http://127.0.0.1:%u\n", console->port());
      std::fflush(stdout);
    }
    std::unique_ptr<Preview> preview;
    if (c.preview > 0) {
      auto opened = Preview::open(a, c, *tiles, ro);
      if (!opened) {
        std::fprintf(stderr, "tellus cluster: %s\n", opened.error().c_str());
        comm->abort(kExitError); // the channels wait for the master's first frame
      }
      preview = std::move(*opened);
    }
    return runMaster(*comm, c, std::move(bodies), ro.timeUnixSeconds, console.get(), preview.get());
  }
  const auto byName = [&](const planet::Channel& ch) { return ch.name == c.join; };
  const planet::Channel& channel =
      comm ? c.channels[static_cast<std::size_t>(rank - 1)]
           : *std::find_if(c.channels.begin(), c.channels.end(), byName);
  return startChannel(comm.get(), a, c, channel, *tiles, ro);
}

} // namespace

Command clusterCommand() {
  using K = cli::OptionKind;
  Command c{"cluster", tileSourceOptions(), 1, &runCluster};
  const auto globe = globeOptions();
  c.options.insert(c.options.end(), globe.begin(), globe.end());
  c.options.insert(c.options.end(),
                   {{"out", K::Value},
                    {"wait-complete", K::OptionalValue},
                    {"background", K::Value},
                    {"path", K::Value},
                    {"fps", K::Value},
                    {"mpcdi", K::Value},
                    {"loop", K::Flag},
                    {"realtime", K::Flag},
                    {"channel-timeout", K::Value},
                    {"port", K::Value},
                    {"join", K::Value},
                    {"control", K::Value},
                    {"window", K::Flag},
                    {"render-scale", K::Value},
                    {"preview", K::OptionalValue}});
  return c;
}

} // namespace tellus::commands
