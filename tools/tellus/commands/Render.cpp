// `tellus render`: headless globe rendering to PNG, one view or a flight of keyframes.

#include "Commands.hpp"
#include "PlanetTiles.hpp"

#include <tellus/planet/Camera.hpp>
#include <tellus/planet_gl/Renderer.hpp>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <expected>
#include <map>
#include <stdexcept>
#include <sys/resource.h>
#include <thread>

namespace fs = std::filesystem;

namespace tellus::commands {
namespace {

std::string renderStatsJson(const planet::RenderStats& s, double seconds, bool complete) {
  char buf[2048];
  std::snprintf(
      buf,
      sizeof buf,
      "{\n  \"complete\": %s,\n  \"seconds\": %.3f,\n  \"frames\": %llu,\n"
      "  \"nodes_visible\": %zu,\n  \"nodes_drawn\": %zu,\n  \"nodes_created\": %zu,\n"
      "  \"nodes_created_total\": %zu,\n  \"nodes_in_tree\": %zu,\n  \"max_level\": %d,\n"
      "  \"tiles_requested\": %zu,\n  \"tiles_received\": %zu,\n  \"tiles_absent\": %zu,\n"
      "  \"tiles_failed\": %zu,\n  \"tiles_in_flight\": %zu,\n  \"textures_decoded\": %zu,\n"
      "  \"decode_errors\": %zu,\n  \"textures_uploaded\": %zu,\n  \"bytes_received\": %zu,\n"
      "  \"bytes_uploaded\": %zu,\n  \"textures_resident\": %zu,\n  \"texture_bytes\": %zu,\n"
      "  \"textures_reused\": %zu,\n  \"textures_evicted\": %zu,\n"
      "  \"update_ms\": %.3f,\n  \"longest_update_ms\": %.3f,\n  \"frame_ms\": %.3f,\n  "
      "\"reversed_z\": %s,\n  \"gl\": ",
      complete ? "true" : "false",
      seconds,
      static_cast<unsigned long long>(s.frames),
      s.nodesVisible,
      s.nodesDrawn,
      s.nodesCreated,
      s.nodesCreatedTotal,
      s.nodesInTree,
      s.maxLevel,
      s.tilesRequested,
      s.tilesReceived,
      s.tilesAbsent,
      s.tilesFailed,
      s.tilesInFlight,
      s.texturesDecoded,
      s.decodeErrors,
      s.texturesUploaded,
      s.bytesReceived,
      s.bytesUploaded,
      s.texturesResident,
      s.textureBytes,
      s.texturesReused,
      s.texturesEvicted,
      s.updateMs,
      s.longestUpdateMs,
      s.frameMs,
      s.reversedZ ? "true" : "false");
  char terrain[768];
  std::snprintf(terrain,
                sizeof terrain,
                ",\n  \"height_tiles_requested\": %zu,\n  \"height_tiles_received\": %zu,\n"
                "  \"height_tiles_absent\": %zu,\n  \"height_tiles_failed\": %zu,\n"
                "  \"nodes_without_heights\": %zu,\n"
                "  \"meshes_built\": %zu,\n  \"meshes_built_last\": %zu,\n  \"mesh_ms\": %.3f,\n"
                "  \"mesh_ms_total\": %.3f,\n"
                "  \"edges_fixed\": %zu,\n  \"zero_area_triangles\": %zu,\n  \"camera_lifted\": %s",
                s.heightTilesRequested,
                s.heightTilesReceived,
                s.heightTilesAbsent,
                s.heightTilesFailed,
                s.nodesWithoutHeights,
                s.meshesBuilt,
                s.meshesBuiltLast,
                s.meshMs,
                s.meshMsTotal,
                s.edgesFixed,
                s.zeroAreaTriangles,
                s.cameraLifted ? "true" : "false");
  // The layers (issue #7): the base, then the overlays in drawing order.
  // The dome (issue #7): how the last frame was drawn, and the direct method's error estimate.
  char dome[128];
  if (std::isfinite(s.domeErrorPx)) // infinite (an edge that cannot be mapped): null
    std::snprintf(dome, sizeof dome, ",\n  \"dome_error_px\": %.4g", s.domeErrorPx);
  else
    std::snprintf(dome, sizeof dome, ",\n  \"dome_error_px\": null");
  std::string layers = ",\n  \"dome_method\": " + jsonString(s.domeMethod) + dome +
                       ",\n  \"dome_face_bytes\": " + std::to_string(s.domeFaceBytes) +
                       ",\n  \"dome_error\": " + jsonString(s.domeError) +
                       ",\n  \"passes\": " + std::to_string(s.passes) +
                       ",\n  \"overlays_per_pass\": " + std::to_string(s.overlaysPerPass) +
                       ",\n  \"layers\": [";
  for (std::size_t i = 0; i < s.layers.size(); ++i) {
    const auto& l = s.layers[i];
    char row[512];
    std::snprintf(row,
                  sizeof row,
                  ", \"opacity\": %.3f, \"visible\": %s, \"tiles_requested\": %zu, "
                  "\"tiles_received\": %zu, \"textures_resident\": %zu, \"swaps\": %zu}",
                  l.opacity,
                  l.visible ? "true" : "false",
                  l.tilesRequested,
                  l.tilesReceived,
                  l.texturesResident,
                  l.swaps);
    layers += std::string(i == 0 ? "\n    " : ",\n    ") + "{\"name\": " + jsonString(l.name) +
              ", \"time\": " + jsonString(l.time) +
              ", \"pending_time\": " + jsonString(l.pendingTime) + row;
  }
  layers += "\n  ]";
  return buf + jsonString(s.glVersion) + terrain + layers + "\n}\n";
}

/** The frame times of a render (",\n" and the keys that close the statistics object): median,
 * 95th and 99th percentile (nearest rank), longest, where the longest frame's time went, and every
 * frame's time, update (quadtree + streamer) time and process CPU time (every thread: on llvmpipe
 * the rasteriser's too; less disturbed by other processes than the wall clock) in order. */
std::string frameTimesJson(const std::vector<planet::FramePhases>& frames,
                           const std::vector<double>& cpuMs) {
  std::vector<double> sorted;
  sorted.reserve(frames.size());
  for (const auto& f : frames)
    sorted.push_back(f.total);
  std::sort(sorted.begin(), sorted.end());
  auto rank = [&](double q) {
    if (sorted.empty()) return 0.0;
    const auto i = static_cast<std::size_t>(std::ceil(q * static_cast<double>(sorted.size())));
    return sorted[std::clamp<std::size_t>(i, 1, sorted.size()) - 1];
  };
  planet::FramePhases worst;
  std::size_t worstIndex = 0;
  for (std::size_t i = 0; i < frames.size(); ++i)
    if (frames[i].total > worst.total) {
      worst = frames[i];
      worstIndex = i;
    }
  char buf[1024];
  std::snprintf(buf,
                sizeof buf,
                ",\n  \"median_frame_ms\": %.3f,\n  \"p95_frame_ms\": %.3f,\n  \"p99_frame_ms\": "
                "%.3f,\n  \"longest_frame_ms\": %.3f,\n  \"longest_frame\": {\"index\": %zu, "
                "\"update_ms\": %.3f, \"intake_ms\": %.3f, \"upload_ms\": %.3f, "
                "\"upload_bytes\": %zu, \"mesh_ms\": %.3f, \"meshes_created\": %zu, "
                "\"draw_ms\": %.3f, \"finish_ms\": %.3f}\n}\n",
                sorted.empty() ? 0.0 : sorted[sorted.size() / 2],
                rank(0.95),
                rank(0.99),
                sorted.empty() ? 0.0 : sorted.back(),
                worstIndex,
                worst.update,
                worst.intake,
                worst.upload,
                worst.uploadBytes,
                worst.mesh,
                worst.meshesCreated,
                worst.draw,
                worst.finish);
  std::string out = buf;
  out.resize(out.size() - 3); // "\n}\n"
  out += ",\n  \"frame_times_ms\": [";
  for (std::size_t i = 0; i < frames.size(); ++i) {
    char v[32];
    std::snprintf(v, sizeof v, "%s%.3f", i == 0 ? "" : ", ", frames[i].total);
    out += v;
  }
  out += "],\n  \"update_times_ms\": [";
  for (std::size_t i = 0; i < frames.size(); ++i) {
    char v[32];
    std::snprintf(v, sizeof v, "%s%.3f", i == 0 ? "" : ", ", frames[i].update);
    out += v;
  }
  out += "],\n  \"frame_cpu_ms\": [";
  for (std::size_t i = 0; i < cpuMs.size(); ++i) {
    char v[32];
    std::snprintf(v, sizeof v, "%s%.3f", i == 0 ? "" : ", ", cpuMs[i]);
    out += v;
  }
  return out + "]\n}\n";
}

/** A keyframe of `tellus render --path`: time in seconds and a camera pose. */
struct Keyframe {
  double time = 0.0;
  planet::CameraPose pose;
  /** "times": {"layer": "TIME", ...}: from this keyframe on, the layer shows that time (it swaps
   * once the new time's tiles are all there; with --wait-complete every frame waits for it). */
  std::map<std::string, std::string> times;
};

/**
 * Reads PATH.json: an array of objects (or {"keyframes": [...]}) with numbers time, lat, lon, alt
 * and optionally heading and tilt, times increasing, and optionally "times": {"layer": "TIME"}. A
 * small reader for just that shape: strings are keys, numbers are values; anything else is an error
 * naming the byte offset.
 */
std::expected<std::vector<Keyframe>, std::string> readPath(const fs::path& file) {
  std::FILE* f = std::fopen(file.c_str(), "rb");
  if (f == nullptr) return std::unexpected("cannot open " + file.string());
  std::string text;
  char buf[4096];
  for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, f)) > 0;)
    text.append(buf, n);
  std::fclose(f);
  std::size_t i = 0;
  auto fail = [&](const std::string& what) {
    return std::unexpected(file.string() + ": " + what + " at byte " + std::to_string(i));
  };
  auto ws = [&] {
    while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i])))
      ++i;
  };
  auto eat = [&](char c) {
    ws();
    if (i < text.size() && text[i] == c) {
      ++i;
      return true;
    }
    return false;
  };
  auto string = [&](std::string* out) {
    ws();
    if (i >= text.size() || text[i] != '"') return false;
    const auto end = text.find('"', i + 1);
    if (end == std::string::npos) return false;
    *out = text.substr(i + 1, end - i - 1);
    i = end + 1;
    return true;
  };
  auto number = [&](double* out) {
    ws();
    auto [ptr, ec] = std::from_chars(text.data() + i, text.data() + text.size(), *out);
    if (ec != std::errc{} || !std::isfinite(*out)) return false;
    i = static_cast<std::size_t>(ptr - text.data());
    return true;
  };
  bool wrapped = false;
  if (eat('{')) {
    std::string key;
    if (!string(&key) || key != "keyframes" || !eat(':')) return fail("expected \"keyframes\":");
    wrapped = true;
  }
  if (!eat('[')) return fail("expected an array of keyframes");
  std::vector<Keyframe> keys;
  while (!eat(']')) {
    if (!keys.empty() && !eat(',')) return fail("expected , or ]");
    if (!eat('{')) return fail("expected a keyframe object");
    Keyframe k;
    bool seen[6] = {};
    bool timesSeen = false;
    while (!eat('}')) {
      if ((seen[0] || seen[1] || seen[2] || seen[3] || seen[4] || seen[5] || timesSeen) &&
          !eat(','))
        return fail("expected , or }");
      std::string key;
      double v = 0.0;
      if (!string(&key) || !eat(':')) return fail("expected \"name\":");
      if (key == "times") {
        if (!eat('{')) return fail("expected {\"layer\": \"TIME\", ...}");
        while (!eat('}')) {
          if (!k.times.empty() && !eat(',')) return fail("expected , or }");
          std::string layer, value;
          if (!string(&layer) || !eat(':') || !string(&value))
            return fail("expected \"layer\": \"TIME\"");
          k.times[layer] = value;
        }
        timesSeen = true;
        continue;
      }
      if (!number(&v)) return fail("expected \"name\": number");
      static const char* names[6] = {"time", "lat", "lon", "alt", "heading", "tilt"};
      const auto at = std::find(std::begin(names), std::end(names), key);
      if (at == std::end(names)) return fail("unknown key '" + key + "'");
      const auto idx = static_cast<std::size_t>(at - std::begin(names));
      seen[idx] = true;
      double* fields[6] = {&k.time,
                           &k.pose.latDeg,
                           &k.pose.lonDeg,
                           &k.pose.altitudeM,
                           &k.pose.headingDeg,
                           &k.pose.tiltDeg};
      *fields[idx] = v;
    }
    if (!seen[0] || !seen[1] || !seen[2] || !seen[3])
      return fail("a keyframe needs time, lat, lon and alt");
    if (k.pose.latDeg < -90.0 || k.pose.latDeg > 90.0 || k.pose.altitudeM < -11000.0 ||
        k.pose.altitudeM > 1e10 || k.pose.tiltDeg < 0.0 || k.pose.tiltDeg > 180.0)
      return fail("keyframe out of range (lat [-90, 90], alt [-11000, 1e10], tilt [0, 180])");
    if (!keys.empty() && !(k.time > keys.back().time)) return fail("times must increase");
    keys.push_back(k);
  }
  if (wrapped && !eat('}')) return fail("expected }");
  ws();
  if (i != text.size()) return fail("trailing text");
  if (keys.empty()) return fail("no keyframes");
  return keys;
}

/** The pose at time t: linear in latitude and tilt, the short way round in longitude and heading,
 * geometric in altitude (a descent slows down as it nears the ground) when both are positive. */
planet::CameraPose poseAt(const std::vector<Keyframe>& keys, double t) {
  if (t <= keys.front().time) return keys.front().pose;
  if (t >= keys.back().time) return keys.back().pose;
  std::size_t k = 0;
  while (keys[k + 1].time < t)
    ++k;
  const auto& a = keys[k].pose;
  const auto& b = keys[k + 1].pose;
  const double u = (t - keys[k].time) / (keys[k + 1].time - keys[k].time);
  auto lerp = [u](double x, double y) { return x + (y - x) * u; };
  auto angle = [u](double x, double y) {
    const double d = std::remainder(y - x, 360.0);
    return x + d * u;
  };
  planet::CameraPose p;
  p.latDeg = std::clamp(lerp(a.latDeg, b.latDeg), -90.0, 90.0);
  p.lonDeg = angle(a.lonDeg, b.lonDeg);
  p.altitudeM = a.altitudeM > 0.0 && b.altitudeM > 0.0
                    ? std::exp(lerp(std::log(a.altitudeM), std::log(b.altitudeM)))
                    : lerp(a.altitudeM, b.altitudeM);
  p.headingDeg = angle(a.headingDeg, b.headingDeg);
  p.tiltDeg = lerp(a.tiltDeg, b.tiltDeg);
  return p;
}

} // namespace

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
  std::vector<Keyframe> keys;
  planet::CameraPose pose;
  const auto cameraArg = a.get("camera");
  const auto pathArg = a.get("path");
  const auto framesArg = a.get("frames");
  const auto out = a.get("out");
  if (pathArg || framesArg) {
    if (!pathArg || !framesArg || pathArg->empty() || framesArg->empty())
      return usage("--path PATH.json and --frames DIR go together", "");
    if (cameraArg || out) return usage("--path/--frames replace --camera and --out", "");
    auto read = readPath(*pathArg);
    if (!read) return usage(read.error().c_str(), *pathArg);
    keys = std::move(*read);
    pose = keys.front().pose;
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
    if (keys.empty() || !v || (*v)[0] < 1.0 || (*v)[0] > 100.0 || (*v)[0] != std::floor((*v)[0]))
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
  if (waitComplete || keys.empty()) ro.decodeNice = 0;
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
    std::string json = renderStatsJson(r.stats(), elapsed, complete);
    json.resize(json.size() - 3); // "\n}\n"
    json += frameTimesJson(frames, frameCpuMs);
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

  if (!keys.empty()) {
    // A flight: numbered PNGs at --fps. With --wait-complete every frame is complete (offline
    // show production); without, each image is one renderer frame (what a live viewer saw).
    std::error_code ec;
    fs::create_directories(*framesArg, ec);
    if (ec) {
      std::fprintf(stderr, "tellus render: %s: %s\n", framesArg->c_str(), ec.message().c_str());
      return kExitError;
    }
    const double duration = keys.back().time - keys.front().time;
    const auto count = static_cast<long long>(std::floor(duration * fps + 1e-9)) + 1;
    // Layer times of the keyframes: which renderer layers (0 the base, then the overlays) a name
    // means; every name must be drawn.
    std::vector<std::string> drawnNames{ro.layer};
    for (const auto& o : ro.overlays)
      drawnNames.push_back(o.layer);
    for (const Keyframe& k : keys)
      for (const auto& [name, value] : k.times)
        if (std::find(drawnNames.begin(), drawnNames.end(), name) == drawnNames.end())
          return usage("a keyframe's \"times\" names a layer that is not drawn", name);
    auto applyTimes = [&](double t) {
      std::map<std::string, std::string> now;
      for (const Keyframe& k : keys)
        if (k.time <= t + 1e-9)
          for (const auto& [name, value] : k.times)
            now[name] = value;
      for (const auto& [name, value] : now)
        for (std::size_t i = 0; i < drawnNames.size(); ++i)
          if (drawnNames[i] == name) r.setLayerTime(i, value);
    };
    bool allComplete = true;
    // --repeat: the flight again in the same renderer (what stays resident is not streamed again:
    // the later passes' frame times are the views' cost without streaming).
    for (long long n = 0; n < count * repeat; ++n) {
      const double at = keys.front().time + static_cast<double>(n % count) / fps;
      const planet::CameraPose p = poseAt(keys, at);
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
