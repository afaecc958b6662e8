// `tellus render`: headless globe rendering to PNG, one view (--camera, --out) or a flight of
// keyframes (--path, --frames; planet::FlightPath), with the statistics of --stats
// (planet::renderStatsJson).

#include "AnimateArgs.hpp"
#include "Commands.hpp"
#include "Context.hpp"
#include "FlightRenderers.hpp"
#include "GlobeArgs.hpp"
#include "PlanetTiles.hpp"

#include <tellus/cli/Values.hpp>
#include <tellus/mpcdi/Mpcdi.hpp>
#include <tellus/planet/Camera.hpp>
#include <tellus/planet/Channels.hpp>
#include <tellus/planet/FlightBodies.hpp>
#include <tellus/planet/FlightPath.hpp>
#include <tellus/planet/OrbitChoice.hpp>
#include <tellus/planet_gl/RenderStatsJson.hpp>
#include <tellus/planet_gl/Renderer.hpp>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <sys/resource.h>
#include <thread>
#include <vector>

namespace fs = std::filesystem;

namespace tellus::commands {
namespace {

int usage(const char* what, const std::string& got) {
  if (got.empty())
    std::fprintf(stderr, "tellus render: %s (tellus --help)\n", what);
  else
    std::fprintf(stderr, "tellus render: %s, got '%s'\n", what, got.c_str());
  return kExitUsage;
}

/** What to render: one view or a flight, and how long to wait for each image. */
struct RenderArgs {
  std::optional<planet::FlightPath> flight; ///< --path
  planet::CameraPose pose;                  ///< --camera, or the flight's first pose
  std::string out;                          ///< --out FILE.png of one view
  std::string frames;                       ///< --frames DIR of a flight
  /** --probe-frames DIR of a flight as streamed: before frame n >= 1, frame n - 1's state drawn
   * from frame n's pose (Renderer::redrawLast), the reference of bench/popping.sh. */
  std::string probeFrames;
  double fps = 25.0;
  int repeat = 1;
  bool waitComplete = false;
  double waitSeconds = 0.0; ///< --wait-complete[=SECONDS]: 60 s unless given
  std::optional<EarthModel> earth;
  /** The renderer's frame time for fades (RendererOptions::frameClock) in a flight as streamed:
   * the flight's own time, frame n at n / fps, so a fade spans the same frames however long each
   * takes to draw (what a viewer at --fps would see). */
  std::shared_ptr<double> flightClockS = std::make_shared<double>(0.0);
};

/** --camera LAT,LON,ALT[,HEADING,TILT] and --out, or --path and --frames. */
int parseViewOrFlight(const cli::Args& a, RenderArgs& r) {
  const auto cameraArg = a.get("camera");
  const auto pathArg = a.get("path");
  const auto framesArg = a.get("frames");
  const auto out = a.get("out");
  if (pathArg || framesArg) {
    if (!pathArg || !framesArg || pathArg->empty() || framesArg->empty())
      return usage("--path PATH.json and --frames DIR go together", "");
    if (cameraArg || out) return usage("--path/--frames replace --camera and --out", "");
    auto read = planet::FlightPath::read(*pathArg);
    if (!read) return usage(read.error().c_str(), *pathArg);
    r.flight = std::move(*read);
    r.pose = r.flight->keyframes().front().pose;
    r.frames = *framesArg;
    if (const auto probe = a.get("probe-frames")) {
      if (probe->empty() || a.flag("wait-complete"))
        return usage("--probe-frames DIR needs a flight as streamed (no --wait-complete)", *probe);
      r.probeFrames = *probe;
    }
    return kExitOk;
  }
  if (a.get("probe-frames")) return usage("--probe-frames DIR needs --path and --frames", "");
  if (!cameraArg) return usage("--camera LAT,LON,ALT[,HEADING,TILT] is required", "");
  const auto cam = cli::parseNumbers(*cameraArg, 3, 5);
  if (!cam)
    return usage("--camera must be LAT,LON,ALT[,HEADING,TILT] (finite numbers)", *cameraArg);
  planet::CameraPose& pose = r.pose;
  pose.latDeg = (*cam)[0];
  pose.lonDeg = (*cam)[1];
  pose.altitudeM = (*cam)[2];
  if (cam->size() > 3) pose.headingDeg = (*cam)[3];
  if (cam->size() > 4) pose.tiltDeg = (*cam)[4];
  if (pose.latDeg < -90.0 || pose.latDeg > 90.0)
    return usage("--camera latitude must be in [-90, 90]", *cameraArg);
  if (pose.altitudeM < -11000.0 || pose.altitudeM > 1e10)
    return usage("--camera altitude must be in [-11000, 1e10] metres", *cameraArg);
  if (pose.tiltDeg < 0.0 || pose.tiltDeg > 180.0)
    return usage("--camera tilt must be in [0, 180] degrees", *cameraArg);
  if (!out || out->empty()) return usage("--out FILE.png is required", "");
  r.out = *out;
  return kExitOk;
}

/** --fps and --repeat (a flight's). */
int parseFlightRate(const cli::Args& a, RenderArgs& r) {
  if (auto f = a.get("fps")) {
    const auto v = cli::parseNumbers(*f, 1, 1);
    if (!v || (*v)[0] <= 0.0 || (*v)[0] > 1000.0) return usage("--fps must be in (0, 1000]", *f);
    r.fps = (*v)[0];
  }
  if (auto rp = a.get("repeat")) {
    const auto v = cli::parseNumbers(*rp, 1, 1);
    if (!r.flight || !v || (*v)[0] < 1.0 || (*v)[0] > 100.0 || (*v)[0] != std::floor((*v)[0]))
      return usage("--repeat must be a whole number of flights in [1, 100] with --path", *rp);
    r.repeat = static_cast<int>((*v)[0]);
  }
  return kExitOk;
}

/** --size WxH (N with --dome: N x N; a dome is square, 1024 x 1024 unless given). */
int parseImageSize(const cli::Args& a, const DomeArgs& dome, planet::RendererOptions& ro) {
  auto size = a.get("size");
  if (!size) {
    if (dome.on) ro.width = ro.height = 1024;
    return kExitOk;
  }
  if (size->find('x') == std::string::npos && dome.on) size = *size + "x" + *size;
  const auto wh = cli::parseSize(*size);
  if (!wh) return usage("--size must be WxH with 1 to 16384 pixels each", *size);
  if (dome.on && wh->first != wh->second)
    return usage("--dome draws a square image: --size N or NxN", *size);
  ro.width = wh->first;
  ro.height = wh->second;
  return kExitOk;
}

/** --wait-complete[=SECONDS], --background R,G,B and --threshold T. */
int parseImageArgs(const cli::Args& a, RenderArgs& r, planet::RendererOptions& ro) {
  r.waitComplete = a.flag("wait-complete");
  if (r.waitComplete) {
    r.waitSeconds = 60.0;
    if (const auto w = a.get("wait-complete"); w && !w->empty()) {
      const auto v = cli::parseNumbers(*w, 1, 1);
      if (!v || (*v)[0] <= 0.0 || (*v)[0] > 86400.0)
        return usage("--wait-complete=SECONDS must be in (0, 86400]", *w);
      r.waitSeconds = (*v)[0];
    }
  }
  if (auto b = a.get("background")) {
    const auto v = cli::parseNumbers(*b, 3, 3);
    if (!v || std::any_of(v->begin(), v->end(), [](double c) { return c < 0.0 || c > 255.0; }))
      return usage("--background must be R,G,B with each in 0-255", *b);
    for (std::size_t i = 0; i < 3; ++i)
      ro.background[i] = (*v)[i] / 255.0;
  }
  if (auto t = a.get("threshold")) {
    const auto v = cli::parseNumbers(*t, 1, 1);
    if (!v || (*v)[0] < 0.05 || (*v)[0] > 64.0)
      return usage("--threshold must be a number in [0.05, 64]", *t);
    ro.lodThreshold = (*v)[0];
  }
  return kExitOk;
}

/** Every option of render checked, in the order the usage errors are reported, before anything
 * is opened. */
std::expected<RenderArgs, int> parseRenderArgs(const cli::Args& a, planet::RendererOptions& ro) {
  const auto dome = domeArgs(a);
  if (!dome) return std::unexpected(usage(dome.error().c_str(), ""));
  RenderArgs r;
  for (const auto& parse : {parseViewOrFlight, parseFlightRate})
    if (const int rc = parse(a, r); rc != kExitOk) return std::unexpected(rc);
  if (const int rc = parseImageSize(a, *dome, ro); rc != kExitOk) return std::unexpected(rc);
  if (const int rc = parseImageArgs(a, r, ro); rc != kExitOk) return std::unexpected(rc);
  const auto earth = earthArg(a);
  if (!earth) return std::unexpected(usage("--earth must be wgs84 or sphere", earth.error()));
  r.earth = *earth;
  try {
    (void)planet::Camera(Geodesy(r.earth.value_or(EarthModel::Wgs84)),
                         r.pose,
                         {ro.width, ro.height},
                         ro.verticalFovDeg);
  } catch (const std::invalid_argument& e) {
    return std::unexpected(usage(e.what(), a.get("camera").value_or(a.get("path").value_or(""))));
  }
  return r;
}

/** The process's CPU time so far (every thread: on llvmpipe the rasteriser's too). */
double processCpuMs() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  auto ms = [](const timeval& t) {
    return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_usec) * 1e-3;
  };
  return ms(u.ru_utime) + ms(u.ru_stime);
}

/** Frames drawn by the renderers of a render: each image drawn until complete (or for a while),
 * every frame's time and the body orbited (a flight between bodies) kept for --stats. */
class RenderSession {
public:
  RenderSession(planet::Renderer& r, const cli::Args& a, double waitSeconds)
      : r_(&r), statsFile_(a.get("stats")), waitSeconds_(waitSeconds) {}

  /** The renderer that draws from now on (a flight changed the body orbited at frame n). */
  void use(planet::Renderer& r, std::size_t n) {
    if (&r == r_) return;
    r_ = &r;
    switches_.push_back({n, r.geodesy().body().name});
  }

  double secondsSince() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }

  /** One image: frames until complete, for at most `limit` seconds, or just one (`once`). */
  bool renderOne(const planet::CameraPose& p, double limit, bool once) {
    const auto begin = std::chrono::steady_clock::now();
    for (;;) {
      const double cpu0 = processCpuMs();
      r_->frame(p);
      cpuMs_.push_back(processCpuMs() - cpu0);
      frames_.push_back(r_->stats().phases);
      const double t =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
      if (once || r_->complete() || t > limit) break;
      // Nothing to upload: the next frame can only wait for tiles and decoders; drawing it at
      // once would take the CPU from them (on llvmpipe drawing is CPU work).
      if (!r_->busy() || r_->stats().uploadsPending == 0)
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    return r_->complete();
  }

  /** --stats FILE.json, when asked for; false after saying why it could not be written. */
  bool writeStats(double elapsed, bool complete) const {
    if (!statsFile_) return true;
    const std::string json = planet::renderStatsJson(
        r_->stats(), {elapsed, complete, frames_, cpuMs_, r_->geodesy().body().name, switches_});
    std::FILE* f = std::fopen(statsFile_->c_str(), "w");
    if (f == nullptr || std::fputs(json.c_str(), f) < 0 || std::fclose(f) != 0) {
      std::fprintf(stderr, "tellus render: cannot write %s\n", statsFile_->c_str());
      return false;
    }
    return true;
  }

  int notComplete(const char* what) const {
    const auto& s = r_->stats();
    std::fprintf(stderr,
                 "tellus render: %s was not complete after %g s (%zu nodes drawn, %zu tiles in "
                 "flight, %zu failed, %zu decoding, %zu uploading); no image written\n",
                 what,
                 waitSeconds_,
                 s.nodesDrawn,
                 s.tilesInFlight,
                 s.tilesFailed,
                 s.decodesPending,
                 s.uploadsPending);
    return kExitError;
  }

private:
  planet::Renderer* r_;
  std::optional<std::string> statsFile_;
  double waitSeconds_;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
  std::vector<planet::FramePhases> frames_;
  std::vector<double> cpuMs_;
  std::vector<planet::OrbitSwitch> switches_;
};

bool writePng(const fs::path& file, planet::Renderer& r) {
  std::string err;
  if (planet::writePngRgb(file, r.width(), r.height(), r.readPixels(), &err)) return true;
  std::fprintf(stderr, "tellus render: %s\n", err.c_str());
  return false;
}

/** A flight: numbered PNGs at --fps. With --wait-complete every frame is complete (offline show
 * production); without, each image is one renderer frame (what a live viewer saw). Each frame is
 * drawn by the renderer of the body the camera orbits then (planet::OrbitSwitcher; one renderer
 * unless the keyframes name other bodies and --body does not pin one). */
int renderFlight(const RenderArgs& ra, std::vector<BodyRenderer>& rs, RenderSession& session) {
  const planet::FlightPath& flight = *ra.flight;
  std::error_code ec;
  fs::create_directories(ra.frames, ec);
  if (!ec && !ra.probeFrames.empty()) fs::create_directories(ra.probeFrames, ec);
  if (ec) {
    std::fprintf(stderr, "tellus render: %s: %s\n", ra.frames.c_str(), ec.message().c_str());
    return kExitError;
  }
  const std::int64_t count = flight.frameCount(ra.fps);
  // Layer times of the keyframes: which renderer layers (0 the base, then the overlays) a name
  // means; every name must be drawn by a body's renderer.
  for (const planet::Keyframe& k : flight.keyframes())
    for (const auto& [name, value] : k.layerTimes)
      if (std::none_of(rs.begin(), rs.end(), [&](const BodyRenderer& b) {
            return std::find(b.drawn.begin(), b.drawn.end(), name) != b.drawn.end();
          }))
        return usage("a keyframe's \"times\" names a layer that is not drawn", name);
  for (const BodyRenderer& b : rs)
    for (std::size_t i = 0; i < b.drawn.size(); ++i)
      for (const planet::Keyframe& k : flight.keyframes())
        if (b.renderer->layerAnimation(i) != nullptr && k.layerTimes.contains(b.drawn[i]))
          return usage("a keyframe's \"times\" names a layer that --animate plays", b.drawn[i]);
  std::vector<planet::Body> bodies;
  for (const BodyRenderer& b : rs)
    bodies.push_back(b.renderer->geodesy().body());
  planet::OrbitSwitcher orbit(std::move(bodies));
  bool allComplete = true;
  // --repeat: the flight again in the same renderer (what stays resident is not streamed again:
  // the later passes' frame times are the views' cost without streaming).
  for (std::int64_t n = 0; n < count * ra.repeat; ++n) {
    const double at = flight.frameTimeS(n % count, ra.fps);
    *ra.flightClockS = static_cast<double>(n) / ra.fps;
    const planet::CameraPose pose = orbit.flightPose(flight, at);
    const BodyRenderer& body = rs[orbit.current()];
    planet::Renderer& r = *body.renderer;
    session.use(r, static_cast<std::size_t>(n));
    for (const auto& [name, value] : flight.layerTimesAt(at))
      for (std::size_t i = 0; i < body.drawn.size(); ++i)
        if (body.drawn[i] == name) r.setLayerTime(i, value);
    if (const auto sceneTime = flight.sceneTimeAt(at)) r.setTime(*sceneTime);
    char name[32];
    std::snprintf(name, sizeof name, "frame_%05lld.png", static_cast<long long>(n % count));
    if (!ra.probeFrames.empty() && n > 0 && n < count) { // before the frame changes anything
      r.redrawLast(pose);
      if (!writePng(fs::path(ra.probeFrames) / name, r)) return kExitError;
    }
    const bool complete = session.renderOne(pose, ra.waitSeconds, !ra.waitComplete);
    allComplete = allComplete && complete;
    if (ra.waitComplete && !complete) {
      session.writeStats(session.secondsSince(), false);
      return session.notComplete(("frame " + std::to_string(n % count)).c_str());
    }
    if (!writePng(fs::path(ra.frames) / name, r)) return kExitError;
  }
  if (!session.writeStats(session.secondsSince(), allComplete)) return kExitError;
  std::printf("tellus render: %lld frames in %s after %.2f s (%s)\n",
              static_cast<long long>(count),
              ra.frames.c_str(),
              session.secondsSince(),
              allComplete ? "every frame complete" : "frames as streamed");
  return kExitOk;
}

/** One view: frames until complete (--wait-complete, up to SECONDS) or for at most 2 s. */
int renderView(const RenderArgs& ra, planet::Renderer& r, RenderSession& session) {
  const bool complete = session.renderOne(ra.pose, ra.waitComplete ? ra.waitSeconds : 2.0, false);
  const double elapsed = session.secondsSince();
  if (!session.writeStats(elapsed, complete)) return kExitError;
  if (ra.waitComplete && !complete) return session.notComplete("the view");
  if (!writePng(ra.out, r)) return kExitError;
  const auto& s = r.stats();
  std::printf("tellus render: %s %dx%d, %s after %.2f s and %llu frames (%zu nodes drawn, level "
              "%d, %zu tiles)\n",
              ra.out.c_str(),
              r.width(),
              r.height(),
              complete ? "complete" : "partial",
              elapsed,
              static_cast<unsigned long long>(s.frames),
              s.nodesDrawn,
              s.maxLevel,
              s.tilesReceived);
  return kExitOk;
}

/** --channel CONFIG[,NAME] (issue 28, bench/channel.sh): one projector channel's frustum and size
 * (CONFIG.json, or an .mpcdi file; NAME, else the first channel), as `tellus cluster` draws it;
 * its warp and blend are the cluster's. An empty message: no --channel. */
std::string applyChannelArg(const cli::Args& a, planet::RendererOptions& ro) {
  const auto arg = a.get("channel");
  if (!arg) return {};
  if (a.flag("dome") || a.get("size"))
    return "--channel has its own view and size: no --dome, --size";
  const auto comma = arg->rfind(',');
  const std::string file = arg->substr(0, comma);
  const std::string name = comma == std::string::npos ? std::string() : arg->substr(comma + 1);
  auto channels = file.ends_with(".mpcdi") ? mpcdi::readMpcdi(file) : planet::readChannels(file);
  if (!channels) return channels.error();
  const auto c = std::find_if(channels->begin(), channels->end(), [&](const planet::Channel& x) {
    return name.empty() || x.name == name;
  });
  if (c == channels->end()) return file + ": no channel named \"" + name + "\"";
  const planet::ChannelFrame f = planet::channelFrame(*c);
  ro.channelView =
      planet::RendererOptions::ChannelView{f.forward, f.up, ro.dome ? ro.dome->tiltDeg : 0.0};
  if (const auto d = domeArgs(a); d && d->tiltDeg) ro.channelView->domeTiltDeg = *d->tiltDeg;
  ro.dome.reset();
  ro.width = c->renderedWidth(); // the rendered image, before the cluster's warp pass
  ro.height = c->renderedHeight();
  ro.verticalFovDeg = c->vfovDeg;
  return {};
}

int runRender(const cli::Args& a) {
  planet::RendererOptions ro;
  const auto ra = parseRenderArgs(a, ro);
  if (!ra) return ra.error();
  // Background work below the frame's priority only where frames are watched (a flight as
  // streamed): with --wait-complete, or a single view, the frames only serve to finish the image,
  // and on llvmpipe (drawing on the CPU) lower-priority decoders made completion 2-5x slower.
  if (ra->waitComplete || !ra->flight) ro.decodeNice = 0;
  auto tiles = openPlanetTiles(a, "render", ro);
  if (!tiles) return tiles.error();
  if (auto bad = applySceneTime(a, tiles->sceneTime, kDefaultRenderTime, ro)) {
    std::fprintf(stderr, "tellus render: %s\n", bad->c_str());
    return kExitUsage;
  }
  hideNightLayers(a, tiles->night, ro);
  if (const auto bad = applyChannelArg(a, ro); !bad.empty()) return usage(bad.c_str(), "");
  // Legends of value layers (issue 24): off in render unless --legend or renderer.legend.
  ro.legend = a.flag("legend") || (!a.flag("no-legend") && tiles->legend.value_or(false));
  // Fading (renderer.fade_in) is for frames a viewer watches: --wait-complete writes only settled
  // images, which a fade would only delay (the image is the same: a fade ends before a frame is
  // complete). A flight as streamed fades on the flight's time.
  if (ra->waitComplete) ro.fadeInSeconds = 0.0;
  if (ra->flight && !ra->waitComplete)
    ro.frameClock = [clock = ra->flightClockS] { return *clock; };
  // Time that plays (issue 24) runs on the flight's clock: with --wait-complete each frame waits
  // for its time's swap, so frame n shows the time of n / fps (deterministic).
  auto animations = animateArgs(a, *tiles, ro);
  if (!animations) return usage(animations.error().c_str(), "");
  if (!animations->empty()) {
    if (!ra->flight) return usage("--animate needs a flight (--path, --frames)", "");
    ro.frameClock = [clock = ra->flightClockS] { return *clock; };
  }
  const Geodesy geodesy(tiles->bodyFor(ra->earth.value_or(tiles->earth)));
  // The always-resident global texture: the bundled Blue Marble (the Earth's only).
  if (const fs::path global = dataDir(a) / "bmng_2048x1024.jpg";
      tiles->body == "earth" && fs::exists(global))
    ro.globalImage = global;
  // Keyframes on other bodies (issue 26): flown in the common frame, each body a renderer of its
  // own that draws while the camera orbits it (unless --body pins the one orbited), every other
  // body a coarse globe in it.
  const auto bodies = orbitableBodies(a, ra->flight ? &*ra->flight : nullptr, tiles->body);
  if (ra->flight) {
    if (auto bad = planet::flightBodiesProblem(*ra->flight, geodesy.body()))
      return usage(bad->c_str(), "");
    addFlightSceneBodies(*tiles, *ra->flight, bodies);
  }
  addSceneBodies(ro, tiles->sceneBodies, dataDir(a), ra->earth.value_or(tiles->earth));
  auto renderers =
      makeBodyRenderers(a, "render", *tiles, bodies, geodesy, ro, ra->earth.value_or(tiles->earth));
  if (!renderers) return renderers.error();
  for (auto& anim : *animations)
    renderers->front().renderer->animateLayer(anim.layer, std::move(anim.animation));
  RenderSession session(*renderers->front().renderer, a, ra->waitSeconds);
  return ra->flight ? renderFlight(*ra, *renderers, session)
                    : renderView(*ra, *renderers->front().renderer, session);
}

} // namespace

Command renderCommand() {
  using K = cli::OptionKind;
  Command c{"render", tileSourceOptions(), 0, &runRender};
  const auto globe = globeOptions();
  c.options.insert(c.options.end(), globe.begin(), globe.end());
  const auto animate = animateOptions();
  c.options.insert(c.options.end(), animate.begin(), animate.end());
  c.options.insert(c.options.end(),
                   {{"out", K::Value},
                    {"wait-complete", K::OptionalValue},
                    {"background", K::Value},
                    {"stats", K::Value},
                    {"path", K::Value},
                    {"frames", K::Value},
                    {"probe-frames", K::Value},
                    {"fps", K::Value},
                    {"repeat", K::Value},
                    {"edge-fixing", K::Value},
                    {"mesh-size", K::Value},
                    {"upload-per-frame", K::Value},
                    {"vertices", K::Value},
                    {"channel", K::Value}});
  return c;
}

} // namespace tellus::commands
