// `tellus cluster CONFIG`: the dome as a cluster of projector channels (issue 28,
// docs/design/cluster.md), run as `mpirun -n K tellus cluster CONFIG ...` with K = channels + 1.
// Rank 0 is the master: it owns the camera, the scene's time and the flight (--camera or --path)
// and broadcasts each frame's state (cluster::FrameState); rank i >= 1 renders channel i - 1 of
// CONFIG headless with its own frustum, LOD and culling, waits at the barrier (every rank) and
// only then writes its image (the swap): OUT/channel-NAME-FRAME.png. Every rank appends the
// digest of the state it drew to OUT/digest-NAME.txt (the master's: digest-master.txt).

#include "Commands.hpp"
#include "Context.hpp"
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
namespace {

/** The arguments every rank parses alike (mpirun gives each the same command line). */
struct ClusterArgs {
  std::vector<planet::Channel> channels;
  std::optional<planet::FlightPath> flight;
  planet::CameraPose pose;
  double fps = 25.0;
  fs::path out;
  bool waitComplete = false;
  double waitSeconds = 60.0;
  std::optional<std::array<double, 3>> background; ///< --background R,G,B in [0, 1]
};

std::string parseCluster(const cli::Args& a, ClusterArgs& c) {
  const auto mpcdiFile = a.get("mpcdi"); // a VESA MPCDI calibration instead of CONFIG.json
  if (a.positional.size() != (mpcdiFile ? 0u : 1u))
    return "a channel configuration CONFIG.json or --mpcdi FILE.mpcdi (not both) is required";
  auto channels = mpcdiFile ? mpcdi::readMpcdi(*mpcdiFile) : planet::readChannels(a.positional[0]);
  if (!channels) return channels.error();
  c.channels = std::move(*channels);
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
    for (const planet::Keyframe& k : read->keyframes())
      if (!k.layerTimes.empty() || !k.body.empty())
        return *path + ": a keyframe's \"times\" and \"body\" are not broadcast to channels yet";
    c.flight = std::move(*read);
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
  return {};
}

/** The frames of the show: the flight's at --fps, or the one view. */
std::int64_t frameCount(const ClusterArgs& c) {
  return c.flight ? c.flight->frameCount(c.fps) : 1;
}

bool appendLine(const fs::path& file, const std::string& line) {
  std::ofstream f(file, std::ios::app);
  f << line;
  return static_cast<bool>(f);
}

/** The master (rank 0): each frame's state broadcast, then the barrier. */
int runMaster(cluster::Comm& comm,
              const ClusterArgs& c,
              const planet::Body& body,
              std::optional<double> sceneTime,
              bool channelsWell) {
  const fs::path digests = c.out / "digest-master.txt";
  fs::remove(digests);
  if (!comm.allWell(channelsWell)) {
    std::fprintf(stderr, "tellus cluster: a channel could not start (its message above)\n");
    return kExitError;
  }
  const auto start = std::chrono::steady_clock::now();
  const std::int64_t count = frameCount(c);
  for (std::int64_t n = 0; n < count; ++n) {
    cluster::FrameState s;
    s.frame = n;
    if (c.flight) {
      const double at = c.flight->frameTimeS(n, c.fps);
      s.setPose(planet::flightPoseOver(*c.flight, at, body));
      if (const auto t = c.flight->sceneTimeAt(at)) sceneTime = t;
    } else {
      s.setPose(c.pose);
    }
    s.hasSceneTime = sceneTime ? 1 : 0;
    s.sceneTimeUnixS = sceneTime.value_or(0.0);
    comm.broadcast(s);
    if (!comm.allWell(appendLine(digests, cluster::digestLine(s)))) {
      std::fprintf(stderr,
                   "tellus cluster: frame %lld failed on a rank (its message above); stopped\n",
                   static_cast<long long>(n));
      return kExitError;
    }
  }
  cluster::FrameState end;
  end.frame = -1;
  comm.broadcast(end);
  std::printf("tellus cluster: %lld frames of %zu channels in %s after %.2f s\n",
              static_cast<long long>(count),
              c.channels.size(),
              c.out.string().c_str(),
              std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  return kExitOk;
}

/** Frames until complete (--wait-complete, up to its seconds) or one; whether it is complete. */
bool renderOne(planet::Renderer& r, const planet::CameraPose& pose, const ClusterArgs& c) {
  const auto begin = std::chrono::steady_clock::now();
  for (;;) {
    r.frame(pose);
    if (!c.waitComplete || r.complete()) return r.complete();
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count() >
        c.waitSeconds)
      return false;
    if (!r.busy() || r.stats().uploadsPending == 0)
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
}

/** A channel (rank >= 1): the master's state drawn, the barrier, then the image warped and
 * blended (when calibrated) and written. */
/** The channel's warp mesh and blend mask (none when not configured). */
struct Calibration {
  std::optional<planet::WarpMesh> warp;
  std::optional<std::vector<float>> blend;
};

int runChannel(cluster::Comm& comm,
               const ClusterArgs& c,
               const planet::Channel& channel,
               planet::Renderer* renderer,
               const Calibration& cal) {
  const fs::path digests = c.out / ("digest-" + channel.name + ".txt");
  fs::remove(digests);
  if (!comm.allWell(renderer != nullptr)) return kExitError;
  for (;;) {
    cluster::FrameState s;
    comm.broadcast(s);
    if (s.frame < 0) return kExitOk;
    renderer->setTime(s.hasSceneTime ? std::optional<double>(s.sceneTimeUnixS) : std::nullopt);
    bool well = renderOne(*renderer, s.pose(), c) || !c.waitComplete;
    if (!well)
      std::fprintf(stderr,
                   "tellus cluster: channel %s: frame %lld not complete after %g s\n",
                   channel.name.c_str(),
                   static_cast<long long>(s.frame),
                   c.waitSeconds);
    well = appendLine(digests, cluster::digestLine(s)) && well;
    if (!comm.allWell(well)) return kExitError; // the barrier before the swap
    char name[32];
    std::snprintf(name, sizeof name, "-%05lld.png", static_cast<long long>(s.frame));
    std::string err;
    planet::ChannelImage image{renderer->width(), renderer->height(), renderer->readPixels()};
    if (cal.warp || cal.blend) // the warp and blend pass (ChannelWarp.hpp)
      image = planet::warpAndBlend(image,
                                   image.width,
                                   image.height,
                                   cal.warp ? &*cal.warp : nullptr,
                                   cal.blend ? &*cal.blend : nullptr);
    if (!planet::writePngRgb(c.out / ("channel-" + channel.name + name),
                             image.width,
                             image.height,
                             image.rgba,
                             &err)) {
      std::fprintf(stderr, "tellus cluster: %s\n", err.c_str());
      comm.abort(kExitError); // the others wait at the next barrier: end them all
    }
  }
}

int runCluster(const cli::Args& a) {
  auto comm = cluster::Comm::init();
  if (!comm) {
    std::fprintf(stderr, "tellus cluster: %s\n", comm.error().c_str());
    return kExitError;
  }
  const int rank = (*comm)->rank();
  // Usage errors: every rank finds the same ones; rank 0 says them.
  auto say = [rank](const std::string& what, int code) {
    if (rank == 0) std::fprintf(stderr, "tellus cluster: %s (tellus --help)\n", what.c_str());
    return code;
  };
  ClusterArgs c;
  if (const auto bad = parseCluster(a, c); !bad.empty()) return say(bad, kExitUsage);
  if (static_cast<std::size_t>((*comm)->size()) != c.channels.size() + 1)
    return say("run with one rank per channel and the master: mpirun -n " +
                   std::to_string(c.channels.size() + 1) + " (got " +
                   std::to_string((*comm)->size()) + ")",
               kExitUsage);
  std::error_code ec;
  fs::create_directories(c.out, ec);
  if (ec) return say(c.out.string() + ": " + ec.message(), kExitError);
  planet::RendererOptions ro;
  ro.decodeNice = 0;
  auto tiles = openPlanetTiles(a, "cluster", ro);
  if (!tiles) return tiles.error(); // every rank opened the same: every rank fails alike
  if (auto bad = applySceneTime(a, tiles->sceneTime, kDefaultRenderTime, ro))
    return say(*bad, kExitUsage);
  hideNightLayers(a, tiles->night, ro);
  ro.legend = false;
  ro.fadeInSeconds = 0.0; // a channel's image must not depend on how long it took to draw
  const Geodesy geodesy(tiles->bodyFor(tiles->earth));
  if (rank == 0) return runMaster(**comm, c, geodesy.body(), ro.timeUnixSeconds, true);

  const planet::Channel& channel = c.channels[static_cast<std::size_t>(rank - 1)];
  const planet::ChannelFrame frame = planet::channelFrame(channel);
  ro.channelView = planet::RendererOptions::ChannelView{
      frame.forward, frame.up, ro.dome ? ro.dome->tiltDeg : 0.0};
  if (const auto d = domeArgs(a); d && d->tiltDeg) ro.channelView->domeTiltDeg = *d->tiltDeg;
  ro.dome.reset();
  ro.width = channel.width;
  ro.height = channel.height;
  ro.verticalFovDeg = channel.vfovDeg;
  if (c.background) ro.background = *c.background;
  if (const fs::path global = dataDir(a) / "bmng_2048x1024.jpg";
      tiles->body == "earth" && fs::exists(global))
    ro.globalImage = global;
  addSceneBodies(ro, tiles->sceneBodies, dataDir(a), tiles->earth);
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
  auto renderer = planet::Renderer::create(*tiles->source, geodesy, ro);
  if (!renderer) problem = renderer.error();
  if (!problem.empty())
    std::fprintf(stderr, "tellus cluster: channel %s: %s\n", channel.name.c_str(), problem.c_str());
  return runChannel(
      **comm, c, channel, renderer && problem.empty() ? renderer->get() : nullptr, cal);
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
                    {"mpcdi", K::Value}});
  return c;
}

} // namespace tellus::commands
