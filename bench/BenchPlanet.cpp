// The planet's CPU update pass (traversal + culling + LOD + draw list, and the texture streamer's
// scoring and requests) per frame, on scripted camera paths, and the nodes a top-down view of the
// pole draws against the same view of the equator. Issue #5's goals: under 1 ms for 2,000 visible
// nodes; nodes drawn and tiles requested at most 1.3x the minimum the view needs; pole <= 1.5x
// equator. Run with bench/run.sh; figures in bench/RESULTS.md ("The planet's update pass").

#include <tellus/cache/TileGrid.hpp>
#include <tellus/cache/TileSource.hpp>
#include <tellus/planet/Camera.hpp>
#include <tellus/planet/Geodesy.hpp>
#include <tellus/planet/Quadtree.hpp>
#include <tellus/planet/TextureLru.hpp>
#include <tellus/planet/TextureStreamer.hpp>

#include <benchmark/benchmark.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <functional>
#include <numbers>
#include <unordered_set>
#include <vector>

using namespace tellus;
using namespace tellus::planet;

namespace {

TileGrid worldWindGrid() {
  GridSpec spec;
  spec.levelZeroDeltaDeg = 36.0;
  spec.numLevels = 25;
  return *TileGrid::create(spec);
}

QuadtreeParams params(double threshold) {
  QuadtreeParams p;
  p.lod = {512, 512, threshold};
  p.maxSplitsPerFrame = 1000000;
  p.maxNodes = 10000000;
  return p;
}

void converge(Quadtree& tree, const Camera& cam) {
  for (int i = 0; i < 400; ++i) {
    const FrameStats& s = tree.update(cam);
    if (s.created == 0 && s.splitsDeferred == 0) break;
  }
}

/** An in-memory tile source that answers every request at once (inside request()), so the
 * streamer's decisions are real and nothing waits: a warm local cache at its limit. */
class InstantSource : public ITileSource {
public:
  std::size_t requests = 0;
  std::optional<DatasetSpec> describe(std::string_view, std::string_view) const override {
    return std::nullopt;
  }
  TileRequestId request(const TileAddress&, double, Callback done) override {
    ++requests;
    TileResult r;
    r.status = TileStatus::Ok;
    r.bytes.resize(64);
    done(std::move(r));
    return requests;
  }
  void reprioritize(TileRequestId, double) override {}
  bool cancel(TileRequestId) override { return false; }
};

double threadCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

/**
 * What the view needs at least, by casting rays through a grid of pixels (every `stride`-th
 * pixel; each sample stands for a stride x stride cell):
 * - `pixels`: pixels that see the globe; `areaMinimum` = pixels / (tile texels / threshold^2),
 *   issue #5's "screen pixels / texels per tile": what tiles would cost if each covered exactly
 *   its texels' worth of pixels.
 * - `pyramidTiles`: the tiles a per-pixel choice would use: at each sample the coarsest level
 *   whose texels project within threshold pixels along both axes (from the local Jacobian of
 *   latitude/longitude over the screen), every tile of that level the cell's lat/long box touches
 *   (so polar slivers narrower than a cell count). This is the floor for any renderer of this
 *   pyramid: the tree's own excess is the ratio to it, the pyramid's level quantisation is the
 *   gap between it and areaMinimum.
 */
struct ViewMinimum {
  double pixels = 0.0;
  double areaMinimum = 0.0;
  std::size_t pyramidTiles = 0;
};

struct Ray {
  bool hit = false;
  double lat = 0.0, lon = 0.0;
};

Ray castRay(const Camera& cam, double a, double b, double px, double py) {
  const double w = cam.viewport().width, h = cam.viewport().height;
  const double ty = std::tan(0.5 * cam.verticalFovDeg() * std::numbers::pi / 180.0);
  const double tx = ty * w / h;
  const double ndcX = 2.0 * px / w - 1.0, ndcY = 1.0 - 2.0 * py / h;
  const glm::dvec3 dir = cam.forward() + ndcX * tx * cam.right() + ndcY * ty * cam.up();
  // The ellipsoid is the unit sphere after scaling x, y by 1/a and z by 1/b.
  const glm::dvec3 s(1.0 / a, 1.0 / a, 1.0 / b);
  const glm::dvec3 o = cam.position() * s, d = dir * s;
  const double A = glm::dot(d, d), B = 2.0 * glm::dot(o, d), C = glm::dot(o, o) - 1.0;
  const double disc = B * B - 4.0 * A * C;
  Ray r;
  if (disc < 0.0) return r;
  const double t = (-B - std::sqrt(disc)) / (2.0 * A);
  if (!(t > 0.0)) return r;
  const glm::dvec3 p = cam.position() + t * dir;
  // Geodetic latitude of a surface point: the normal is (x / a^2, y / a^2, z / b^2).
  r.hit = true;
  r.lat = std::atan2(p.z / (b * b), std::hypot(p.x, p.y) / (a * a)) * 180.0 / std::numbers::pi;
  r.lon = std::atan2(p.y, p.x) * 180.0 / std::numbers::pi;
  return r;
}

ViewMinimum viewMinimum(const Camera& cam,
                        const Geodesy& g,
                        const TileGrid& grid,
                        const LodParams& lod,
                        int stride,
                        std::unordered_set<TileKey, TileKeyHash>* tiles) {
  const double a = g.equatorialRadius(), b = g.polarRadius();
  const int w = cam.viewport().width, h = cam.viewport().height;
  const double texels = static_cast<double>(lod.tileWidthPx) * lod.tileHeightPx;
  ViewMinimum m;
  std::unordered_set<TileKey, TileKeyHash> local;
  auto& set = tiles ? *tiles : local;
  std::unordered_set<TileKey, TileKeyHash> frame;
  for (int y = stride / 2; y < h; y += stride)
    for (int x = stride / 2; x < w; x += stride) {
      const Ray c = castRay(cam, a, b, x, y);
      if (!c.hit) continue;
      m.pixels += static_cast<double>(stride) * stride;
      const Ray ex = castRay(cam, a, b, x + 1.0, y), ey = castRay(cam, a, b, x, y + 1.0);
      if (!ex.hit || !ey.hit) continue;
      auto wrap = [](double d) { return d > 180.0 ? d - 360.0 : (d < -180.0 ? d + 360.0 : d); };
      // Jacobian of (lat, lon) over (pixel x, pixel y), degrees per pixel.
      const double j11 = ex.lat - c.lat, j12 = ey.lat - c.lat;
      const double j21 = wrap(ex.lon - c.lon), j22 = wrap(ey.lon - c.lon);
      const double det = j11 * j22 - j12 * j21;
      if (!(std::abs(det) > 0.0)) continue;
      // Pixels per degree of latitude / longitude: |J^-1 e_lat|, |J^-1 e_lon|.
      const double pxPerLat = std::hypot(j22, -j21) / std::abs(det);
      const double pxPerLon = std::hypot(-j12, j11) / std::abs(det);
      // A texel of level L spans delta_L / texels degrees; it must be <= threshold pixels.
      const double texDeg =
          lod.threshold / std::max(pxPerLat * grid.spec().levelZeroDeltaDeg / lod.tileHeightPx,
                                   pxPerLon * grid.spec().levelZeroDeltaDeg / lod.tileWidthPx);
      int level = texDeg >= 1.0 ? 0 : static_cast<int>(std::ceil(-std::log2(texDeg)));
      level = std::clamp(level, 0, grid.numLevels() - 1);
      // The cell's lat/long box: half a stride either way along both screen axes.
      const double half = 0.5 * stride;
      const double dLat = half * (std::abs(j11) + std::abs(j12));
      const double dLon = half * (std::abs(j21) + std::abs(j22));
      const double delta = grid.spec().levelZeroDeltaDeg / std::ldexp(1.0, level);
      const auto first = grid.keyAt(std::max(-90.0, c.lat - dLat), c.lon - dLon, level);
      const auto last = grid.keyAt(std::min(90.0, c.lat + dLat), c.lon + dLon, level);
      if (!first || !last) continue;
      const std::int64_t cols = grid.colCount(level);
      std::int64_t span = last->col - first->col;
      if (span < 0) span += cols; // across the antimeridian
      if (2.0 * dLon >= 360.0 - delta) span = cols - 1;
      for (std::int64_t r = first->row; r <= last->row; ++r)
        for (std::int64_t i = 0; i <= span; ++i)
          frame.insert({level, r, (first->col + i) % cols});
    }
  set.insert(frame.begin(), frame.end());
  m.pyramidTiles = frame.size();
  m.areaMinimum = m.pixels / (texels / (lod.threshold * lod.threshold));
  return m;
}

/** A frame of the renderer without GL: tree, streamer, LRU; uploads are instant. */
struct Renderer {
  const Geodesy& g;
  Quadtree tree;
  InstantSource source;
  TextureStreamer streamer;
  TextureLru lru;
  double now = 0.0;
  static constexpr std::size_t kTextureBytes = 512 * 512 * 4 * 4 / 3; // RGBA8 with mipmaps

  Renderer(const Geodesy& geodesy, const QuadtreeParams& p)
      : g(geodesy), tree(geodesy, worldWindGrid(), p), streamer(source, {"layer", "", 32}),
        lru(std::size_t{8} << 30) {} // accounting only: large enough for any frame here

  /** Returns the CPU seconds of the update pass (tree.update + streamer.update). */
  double frame(const Camera& cam) {
    lru.beginFrame();
    const double t0 = threadCpuSeconds();
    tree.update(cam);
    streamer.update(tree, cam, now, &lru);
    const double t1 = threadCpuSeconds();
    now += 1.0 / 60.0;
    // What the GL layer would do next: decode and upload the nodes whose tiles all arrived.
    streamer.takeReceived();
    auto upload = [&](Node& n) {
      if (n.texture == TextureState::Decoding) {
        lru.insert(n.key(), kTextureBytes);
        n.texture = TextureState::Finished;
      } else if (lru.resident(n.key())) {
        lru.use(n.key());
      }
    };
    for (const auto& r : tree.roots())
      if (r) upload(*r);
    for (Node* n : tree.drawList())
      upload(*n);
    for (const NodeKey& k : lru.takeEvicted())
      streamer.forget(k);
    return t1 - t0;
  }
};

struct PathFrame {
  CameraPose pose;
};

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/** Runs a path once (after one warm-up pass over the same path, so the tree and the textures of
 * the path exist and the timings are the steady state a user flying it again sees; the first,
 * cold pass's node creation is reported apart). */
void runPath(benchmark::State& state,
             const std::function<CameraPose(int)>& pose,
             int frames,
             Viewport vp = {1024, 768}) {
  const Geodesy g;
  // Arg 1: the local texels (LodParams::perspectiveAware, the default); 0: the corner test alone.
  const QuadtreeParams p = [&] {
    QuadtreeParams q;
    q.lod = {512, 512, 1.0, state.range(0) != 0};
    q.maxSplitsPerFrame = 64;
    q.maxNodes = 50000;
    return q;
  }();
  for (auto _ : state) {
    Renderer cold(g, p);
    std::vector<double> coldMs, ms, nodes, visible, tiles, nodeRatio, tileRatio, tileRatioPyr;
    std::unordered_set<TileKey, TileKeyHash> neededAll;
    for (int f = 0; f < frames; ++f)
      coldMs.push_back(1e3 * cold.frame(Camera(g, pose(f), vp, 45.0)));
    const std::size_t requestedCold = cold.source.requests;
    // The steady pass: the same path again, the tree and textures warm; what each frame draws
    // and asks for against what the view needs.
    for (int f = 0; f < frames; ++f) {
      const Camera cam(g, pose(f), vp, 45.0);
      ms.push_back(1e3 * cold.frame(cam));
      const FrameStats& s = cold.tree.stats();
      std::size_t t = 0;
      for (const Node* n : cold.tree.drawList())
        t += static_cast<std::size_t>(n->key().span);
      const ViewMinimum m = viewMinimum(cam, g, cold.tree.grid(), p.lod, 4, &neededAll);
      nodes.push_back(static_cast<double>(s.drawn));
      visible.push_back(static_cast<double>(s.visible));
      tiles.push_back(static_cast<double>(t));
      if (m.areaMinimum > 0.5) {
        nodeRatio.push_back(static_cast<double>(s.drawn) / std::max(1.0, m.areaMinimum));
        tileRatio.push_back(static_cast<double>(t) / std::max(1.0, m.areaMinimum));
        tileRatioPyr.push_back(static_cast<double>(t) /
                               static_cast<double>(std::max<std::size_t>(1, m.pyramidTiles)));
      }
    }
    auto mx = [](const std::vector<double>& v) {
      return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end());
    };
    state.counters["upd_ms_med"] = median(ms);
    state.counters["upd_ms_max"] = mx(ms);
    state.counters["cold_ms_med"] = median(coldMs);
    state.counters["cold_ms_max"] = mx(coldMs);
    state.counters["visible_max"] = mx(visible);
    state.counters["nodes_med"] = median(nodes);
    state.counters["nodes_max"] = mx(nodes);
    state.counters["tiles_med"] = median(tiles);
    state.counters["tiles_max"] = mx(tiles);
    state.counters["nodes/min_med"] = median(nodeRatio);
    state.counters["nodes/min_max"] = mx(nodeRatio);
    state.counters["tiles/min_med"] = median(tileRatio);
    state.counters["tiles/pyr_med"] = median(tileRatioPyr);
    state.counters["tiles/pyr_max"] = mx(tileRatioPyr);
    state.counters["requested"] = static_cast<double>(requestedCold);
    state.counters["requested/pyr"] =
        static_cast<double>(requestedCold) /
        static_cast<double>(std::max<std::size_t>(1, neededAll.size()));
  }
}

constexpr int kFrames = 240; // four seconds at 60 fps

/** Orbit at 20,000 km: once around the globe at 20 degrees north, top down. */
void BM_PathOrbit20000Km(benchmark::State& state) {
  runPath(
      state,
      [](int f) {
        return CameraPose{20.0, -180.0 + 360.0 * f / kFrames, 2e7, 0.0, 0.0};
      },
      kFrames);
}

/** Descent from 20,000 km to 1 km over the Alps (exponential in altitude), top down. */
void BM_PathDescentAlps(benchmark::State& state) {
  runPath(
      state,
      [](int f) {
        const double t = static_cast<double>(f) / (kFrames - 1);
        return CameraPose{46.5, 8.0, 2e7 * std::pow(1e3 / 2e7, t), 0.0, 0.0};
      },
      kFrames);
}

/** Descent over the Alps again, looking 60 degrees from the nadir (the tilted case). */
void BM_PathDescentAlpsTilted(benchmark::State& state) {
  runPath(
      state,
      [](int f) {
        const double t = static_cast<double>(f) / (kFrames - 1);
        return CameraPose{46.5, 8.0, 2e7 * std::pow(2e3 / 2e7, t), 0.0, 60.0};
      },
      kFrames);
}

/** The same descent in a 1920x1080 window: the view is more tiles across, so the partly
 * visible tiles on its borders weigh less against screen pixels / texels per tile. */
void BM_PathDescentAlps1080p(benchmark::State& state) {
  runPath(state,
          [](int f) {
            const double t = static_cast<double>(f) / (kFrames - 1);
            return CameraPose{46.5, 8.0, 2e7 * std::pow(1e3 / 2e7, t), 0.0, 0.0};
          },
          kFrames,
          {1920, 1080});
}

/** A pole pass: a low orbit (500 km) along the meridian 10 E from 60 N over the pole to 60 N on
 * the meridian 170 W, heading north then south, top down. */
void BM_PathPolePass(benchmark::State& state) {
  runPath(
      state,
      [](int f) {
        const double along = 60.0 + 60.0 * f / (kFrames - 1); // 60 .. 120 "degrees north"
        if (along <= 90.0) return CameraPose{along, 10.0, 5e5, 0.0, 0.0};
        return CameraPose{180.0 - along, -170.0, 5e5, 180.0, 0.0};
      },
      kFrames);
}

/** A fast pan: 1,000 km up at 30 N, 1.5 degrees of longitude a frame (the whole view changes in
 * about six frames), top down. */
void BM_PathFastPan(benchmark::State& state) {
  runPath(
      state,
      [](int f) {
        return CameraPose{30.0, -180.0 + 1.5 * f, 1e6, 0.0, 0.0};
      },
      kFrames);
}

BENCHMARK(BM_PathOrbit20000Km)->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_PathDescentAlps)->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_PathDescentAlps1080p)->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_PathDescentAlpsTilted)->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_PathPolePass)->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_PathFastPan)->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond)->Iterations(1);

/** A tilted view from 300 km with a low threshold: a few thousand visible nodes, every frame the
 * same (the steady state: nothing created, everything traversed and tested). */
void BM_UpdatePass(benchmark::State& state) {
  const Geodesy g;
  QuadtreeParams p = params(0.125);
  p.tightFrustumCulling = state.range(0) != 0;  // 0: the bounding sphere alone
  p.lod.perspectiveAware = state.range(1) != 0; // 0: the corner test alone
  Quadtree tree(g, worldWindGrid(), p);
  const Camera cam(g, {30.0, 10.0, 3e5, 0.0, 70.0}, {1920, 1080});
  converge(tree, cam);
  for (auto _ : state)
    benchmark::DoNotOptimize(&tree.update(cam));
  state.counters["visible"] = static_cast<double>(tree.stats().visible);
  state.counters["drawn"] = static_cast<double>(tree.stats().drawn);
  state.counters["visited"] = static_cast<double>(tree.stats().visited);
}
BENCHMARK(BM_UpdatePass)->Args({1, 1})->Args({1, 0})->Args({0, 1})->Unit(benchmark::kMicrosecond);

/** The update pass over the pole with polar caps (arg 1) and without (merged rows only), beside
 * the mid-latitude view of BM_UpdatePass (view 0): view 1 looks at the pole from 88 N tilted 70
 * degrees, view 2 straight down on it; both from 300 km, threshold 0.125 as above. A cap's exact
 * horizon test and its 16-wedge LOD/score cost more per node than a plain node's. */
void BM_UpdatePassAtThePole(benchmark::State& state) {
  const Geodesy g;
  QuadtreeParams p = params(0.125);
  p.polarCaps = state.range(1) != 0;
  Quadtree tree(g, worldWindGrid(), p);
  const CameraPose poses[] = {
      {30.0, 10.0, 3e5, 0.0, 70.0}, {88.0, 10.0, 3e5, 0.0, 70.0}, {90.0, 0.0, 3e5, 0.0, 0.0}};
  const Camera cam(g, poses[state.range(0)], {1920, 1080});
  converge(tree, cam);
  std::size_t created = 0;
  for (auto _ : state)
    created += tree.update(cam).created;
  state.counters["visible"] = static_cast<double>(tree.stats().visible);
  state.counters["drawn"] = static_cast<double>(tree.stats().drawn);
  state.counters["visited"] = static_cast<double>(tree.stats().visited);
  state.counters["created"] = static_cast<double>(created); // 0: the tree has settled
}
BENCHMARK(BM_UpdatePassAtThePole)->ArgsProduct({{0, 1, 2}, {1, 0}})->Unit(benchmark::kMicrosecond);

/** The same view with the streamer's pass after the tree's (all textures resident: the steady
 * state of the whole CPU update; the time is tree.update + streamer.update on the thread's CPU
 * clock, without the simulated uploads and LRU bookkeeping around them). */
void BM_UpdatePassWithStreamer(benchmark::State& state) {
  const Geodesy g;
  QuadtreeParams p = params(0.125);
  p.lod.perspectiveAware = state.range(0) != 0;
  Renderer r(g, p);
  const Camera cam(g, {30.0, 10.0, 3e5, 0.0, 70.0}, {1920, 1080});
  for (int i = 0; i < 400; ++i) {
    r.frame(cam);
    if (r.tree.stats().created == 0 && r.streamer.stats().candidates == 0) break;
  }
  for (auto _ : state)
    state.SetIterationTime(r.frame(cam)); // the update pass's thread CPU time, not the uploads
  state.counters["visible"] = static_cast<double>(r.tree.stats().visible);
  state.counters["drawn"] = static_cast<double>(r.tree.stats().drawn);
  state.counters["candidates"] = static_cast<double>(r.streamer.stats().candidates);
}
BENCHMARK(BM_UpdatePassWithStreamer)
    ->Arg(1)
    ->Arg(0)
    ->Unit(benchmark::kMicrosecond)
    ->UseManualTime();

/** Drawn nodes of a top-down view at an altitude (arg, km) over the pole, and the equator's. */
void BM_PoleVersusEquatorNodes(benchmark::State& state) {
  const Geodesy g;
  const double altitude = static_cast<double>(state.range(0)) * 1000.0;
  std::size_t pole = 0, equator = 0;
  QuadtreeParams q = params(1.0);
  q.lod.perspectiveAware = state.range(1) != 0;
  for (auto _ : state) {
    Quadtree p(g, worldWindGrid(), q);
    converge(p, Camera(g, {90.0, 0.0, altitude, 0.0, 0.0}, {1024, 768}));
    Quadtree e(g, worldWindGrid(), q);
    converge(e, Camera(g, {0.0, 10.0, altitude, 0.0, 0.0}, {1024, 768}));
    pole = p.stats().drawn;
    equator = e.stats().drawn;
  }
  state.counters["pole_nodes"] = static_cast<double>(pole);
  state.counters["equator_nodes"] = static_cast<double>(equator);
  state.counters["ratio"] = equator ? static_cast<double>(pole) / static_cast<double>(equator) : 0;
}
BENCHMARK(BM_PoleVersusEquatorNodes)
    ->ArgsProduct({{20, 200, 1000, 2000, 6000, 20000}, {1, 0}})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

} // namespace

BENCHMARK_MAIN();
