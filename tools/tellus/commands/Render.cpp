// `tellus render`: headless globe rendering to PNG, one view or a flight of keyframes.

#include "Commands.hpp"
#include "PlanetTiles.hpp"

#include <tellus/planet/Camera.hpp>
#include <tellus/planet/FlightPath.hpp>
#include <tellus/planet_gl/RenderStatsJson.hpp>
#include <tellus/planet_gl/Renderer.hpp>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <expected>
#include <stdexcept>
#include <sys/resource.h>
#include <thread>

namespace fs = std::filesystem;

namespace tellus::commands {

int cmdRender(const Args& a) {
  auto usage = [](const char* what, const std::string& got) {
    if (got.empty())
      std::fprintf(stderr, "tellus render: %s (tellus --help)\n", what);
    else
      std::fprintf(stderr, "tellus render: %s, got '%s'\n", what, got.c_str());
    return kExitUsage;
  };
  const auto dome = domeArgs(a);
  if (!dome) return usage(dome.error().c_str(), "");
  // One view (--camera, --out) or a flight (--path, --frames).
  std::optional<planet::FlightPath> flight;
  planet::CameraPose pose;
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
    flight = std::move(*read);
    pose = flight->keyframes().front().pose;
  } else {
    if (!cameraArg) return usage("--camera LAT,LON,ALT[,HEADING,TILT] is required", "");
    const auto cam = parseNumbers(*cameraArg, 3, 5);
    if (!cam)
      return usage("--camera must be LAT,LON,ALT[,HEADING,TILT] (finite numbers)", *cameraArg);
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
  }
  double fps = 25.0;
  if (auto f = a.get("fps")) {
    const auto v = parseNumbers(*f, 1, 1);
    if (!v || (*v)[0] <= 0.0 || (*v)[0] > 1000.0) return usage("--fps must be in (0, 1000]", *f);
    fps = (*v)[0];
  }
  int repeat = 1;
  if (auto rp = a.get("repeat")) {
    const auto v = parseNumbers(*rp, 1, 1);
    if (!flight || !v || (*v)[0] < 1.0 || (*v)[0] > 100.0 || (*v)[0] != std::floor((*v)[0]))
      return usage("--repeat must be a whole number of flights in [1, 100] with --path", *rp);
    repeat = static_cast<int>((*v)[0]);
  }
  planet::RendererOptions ro;
  if (auto size = a.get("size")) {
    auto x = size->find('x');
    int w = 0, h = 0;
    std::string square; // --size N with --dome: N x N
    if (x == std::string::npos && dome->on) {
      square = *size + "x" + *size;
      size = square;
      x = size->find('x');
    }
    bool ok = x != std::string::npos;
    if (ok) {
      auto r1 = std::from_chars(size->data(), size->data() + x, w);
      auto r2 = std::from_chars(size->data() + x + 1, size->data() + size->size(), h);
      ok = r1.ec == std::errc{} && r1.ptr == size->data() + x && r2.ec == std::errc{} &&
           r2.ptr == size->data() + size->size() && w >= 1 && h >= 1 && w <= 16384 && h <= 16384;
    }
    if (!ok) return usage("--size must be WxH with 1 to 16384 pixels each", *size);
    if (dome->on && w != h) return usage("--dome draws a square image: --size N or NxN", *size);
    ro.width = w;
    ro.height = h;
  } else if (dome->on) {
    ro.width = ro.height = 1024;
  }
  double waitSeconds = 0.0;
  const bool waitComplete = a.flag("wait-complete");
  if (waitComplete) {
    waitSeconds = 60.0;
    if (const auto w = a.get("wait-complete"); w && !w->empty()) {
      const auto v = parseNumbers(*w, 1, 1);
      if (!v || (*v)[0] <= 0.0 || (*v)[0] > 86400.0)
        return usage("--wait-complete=SECONDS must be in (0, 86400]", *w);
      waitSeconds = (*v)[0];
    }
  }
  if (auto b = a.get("background")) {
    const auto v = parseNumbers(*b, 3, 3);
    if (!v || std::any_of(v->begin(), v->end(), [](double c) { return c < 0.0 || c > 255.0; }))
      return usage("--background must be R,G,B with each in 0-255", *b);
    for (std::size_t i = 0; i < 3; ++i)
      ro.background[i] = (*v)[i] / 255.0;
  }
  if (auto t = a.get("threshold")) {
    const auto v = parseNumbers(*t, 1, 1);
    if (!v || (*v)[0] < 0.05 || (*v)[0] > 64.0)
      return usage("--threshold must be a number in [0.05, 64]", *t);
    ro.lodThreshold = (*v)[0];
  }
  const auto earth = earthArg(a);
  if (!earth) return usage("--earth must be wgs84 or sphere", earth.error());
  try {
    (void)planet::Camera(Geodesy(earth->value_or(EarthModel::Wgs84)),
                         pose,
                         {ro.width, ro.height},
                         ro.verticalFovDeg);
  } catch (const std::invalid_argument& e) {
    return usage(e.what(), cameraArg.value_or(pathArg.value_or("")));
  }

  // Background work below the frame's priority only where frames are watched (a flight as
  // streamed): with --wait-complete, or a single view, the frames only serve to finish the image,
  // and on llvmpipe (drawing on the CPU) lower-priority decoders made completion 2-5x slower.
  if (waitComplete || !flight) ro.decodeNice = 0;
  auto tiles = openPlanetTiles(a, "render", ro);
  if (!tiles) return tiles.error();
  const Geodesy geodesy(earth->value_or(tiles->earth));
  // The always-resident global texture: the bundled Blue Marble.
  if (const fs::path global = dataDir(a) / "bmng_2048x1024.jpg"; fs::exists(global))
    ro.globalImage = global;
  auto renderer = planet::Renderer::create(*tiles->source, geodesy, ro);
  if (!renderer) {
    std::fprintf(stderr, "tellus render: %s\n", renderer.error().c_str());
    return kExitError;
  }
  planet::Renderer& r = **renderer;
  std::vector<planet::FramePhases> frames;
  std::vector<double> frameCpuMs;
  auto processCpuMs = [] {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    auto ms = [](const timeval& t) {
      return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_usec) * 1e-3;
    };
    return ms(u.ru_utime) + ms(u.ru_stime);
  };
  auto writeStats = [&](double elapsed, bool complete) {
    const auto statsFile = a.get("stats");
    if (!statsFile) return true;
    const std::string json =
        planet::renderStatsJson(r.stats(), {elapsed, complete, frames, frameCpuMs});
    std::FILE* f = std::fopen(statsFile->c_str(), "w");
    if (f == nullptr || std::fputs(json.c_str(), f) < 0 || std::fclose(f) != 0) {
      std::fprintf(stderr, "tellus render: cannot write %s\n", statsFile->c_str());
      return false;
    }
    return true;
  };
  // One image: frames until complete (--wait-complete, up to SECONDS) or for at most 2 s.
  const auto start = std::chrono::steady_clock::now();
  auto renderOne = [&](const planet::CameraPose& p, double limit, bool once) {
    const auto begin = std::chrono::steady_clock::now();
    for (;;) {
      const double cpu0 = processCpuMs();
      r.frame(p);
      frameCpuMs.push_back(processCpuMs() - cpu0);
      frames.push_back(r.stats().phases);
      const double t =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
      if (once || r.complete() || t > limit) break;
      // Nothing to upload: the next frame can only wait for tiles and decoders; drawing it at
      // once would take the CPU from them (on llvmpipe drawing is CPU work).
      if (!r.busy() || r.stats().uploadsPending == 0)
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    return r.complete();
  };
  auto notComplete = [&](const char* what) {
    const auto& s = r.stats();
    std::fprintf(
        stderr,
        "tellus render: %s was not complete after %g s (%zu nodes drawn, %zu tiles in flight, %zu "
        "failed, %zu decoding, %zu uploading); no image written\n",
        what,
        waitSeconds,
        s.nodesDrawn,
        s.tilesInFlight,
        s.tilesFailed,
        s.decodesPending,
        s.uploadsPending);
    return kExitError;
  };
  auto secondsSince = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };

  if (flight) {
    // A flight: numbered PNGs at --fps. With --wait-complete every frame is complete (offline
    // show production); without, each image is one renderer frame (what a live viewer saw).
    std::error_code ec;
    fs::create_directories(*framesArg, ec);
    if (ec) {
      std::fprintf(stderr, "tellus render: %s: %s\n", framesArg->c_str(), ec.message().c_str());
      return kExitError;
    }
    const long long count = flight->frameCount(fps);
    // Layer times of the keyframes: which renderer layers (0 the base, then the overlays) a name
    // means; every name must be drawn.
    std::vector<std::string> drawnNames{ro.layer};
    for (const auto& o : ro.overlays)
      drawnNames.push_back(o.layer);
    for (const planet::Keyframe& k : flight->keyframes())
      for (const auto& [name, value] : k.layerTimes)
        if (std::find(drawnNames.begin(), drawnNames.end(), name) == drawnNames.end())
          return usage("a keyframe's \"times\" names a layer that is not drawn", name);
    auto applyTimes = [&](double t) {
      for (const auto& [name, value] : flight->layerTimesAt(t))
        for (std::size_t i = 0; i < drawnNames.size(); ++i)
          if (drawnNames[i] == name) r.setLayerTime(i, value);
    };
    bool allComplete = true;
    // --repeat: the flight again in the same renderer (what stays resident is not streamed again:
    // the later passes' frame times are the views' cost without streaming).
    for (long long n = 0; n < count * repeat; ++n) {
      const double at = flight->frameTimeS(n % count, fps);
      const planet::CameraPose p = flight->poseAt(at);
      applyTimes(at);
      const bool complete = renderOne(p, waitSeconds, !waitComplete);
      allComplete = allComplete && complete;
      if (waitComplete && !complete) {
        writeStats(secondsSince(), false);
        return notComplete(("frame " + std::to_string(n % count)).c_str());
      }
      char name[32];
      std::snprintf(name, sizeof name, "frame_%05lld.png", n % count);
      std::string err;
      if (!planet::writePngRgb(
              fs::path(*framesArg) / name, r.width(), r.height(), r.readPixels(), &err)) {
        std::fprintf(stderr, "tellus render: %s\n", err.c_str());
        return kExitError;
      }
    }
    if (!writeStats(secondsSince(), allComplete)) return kExitError;
    std::printf("tellus render: %lld frames in %s after %.2f s (%s)\n",
                count,
                framesArg->c_str(),
                secondsSince(),
                allComplete ? "every frame complete" : "frames as streamed");
    return kExitOk;
  }

  const bool complete = renderOne(pose, waitComplete ? waitSeconds : 2.0, false);
  const double elapsed = secondsSince();
  if (!writeStats(elapsed, complete)) return kExitError;
  if (waitComplete && !complete) return notComplete("the view");
  std::string err;
  if (!planet::writePngRgb(*out, r.width(), r.height(), r.readPixels(), &err)) {
    std::fprintf(stderr, "tellus render: %s\n", err.c_str());
    return kExitError;
  }
  const auto& s = r.stats();
  std::printf("tellus render: %s %dx%d, %s after %.2f s and %llu frames (%zu nodes drawn, level "
              "%d, %zu tiles)\n",
              out->c_str(),
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

} // namespace tellus::commands
