// The bodies' ephemeris per call (issue 26): what placing the Moon and Mars and lighting them
// costs a frame, beside the lighting's own sun (astro::sunDirectionEcef) measured in the same run.
// Run: build/bench/tellus_bench_ephemeris; figures in bench/RESULTS.md ("The bodies'
// ephemeris").

#include <tellus/planet/Astronomy.hpp>
#include <tellus/planet/Ephemeris.hpp>
#include <tellus/planet/IauRotation.hpp>
#include <tellus/planet/Moon.hpp>
#include <tellus/planet/SceneBodies.hpp>

#include <benchmark/benchmark.h>

#include <cstdint>
#include <vector>

using namespace tellus::planet;
using namespace tellus::planet::astro;

namespace {

constexpr double kStart = 1.7e9; // 2023-11-14; each iteration a minute later

void BM_SunDirectionEcef(benchmark::State& state) {
  double t = kStart;
  for (auto _ : state) {
    benchmark::DoNotOptimize(sunDirectionEcef(t));
    t += 60.0;
  }
}
BENCHMARK(BM_SunDirectionEcef);

void BM_MoonPositionEcef(benchmark::State& state) {
  double t = kStart;
  for (auto _ : state) {
    benchmark::DoNotOptimize(moonPositionEcef(t));
    t += 60.0;
  }
}
BENCHMARK(BM_MoonPositionEcef);

void BM_IauMoonMatrix(benchmark::State& state) {
  double t = kStart;
  for (auto _ : state) {
    benchmark::DoNotOptimize(iauBodyFixedToCelestial(iauMoon(), t));
    t += 60.0;
  }
}
BENCHMARK(BM_IauMoonMatrix);

/** Arg: 0 the Earth, 1 the Moon, 2 Mars. */
void BM_SunDirectionInBody(benchmark::State& state) {
  const auto body = static_cast<EphemerisBody>(state.range(0));
  double t = kStart;
  for (auto _ : state) {
    benchmark::DoNotOptimize(sunDirectionInBody(body, t));
    t += 60.0;
  }
  state.SetLabel(ephemerisBodyName(body));
}
BENCHMARK(BM_SunDirectionInBody)->Arg(0)->Arg(1)->Arg(2);

/** A scene body's CPU work a frame (issue 26, planet/gl/src/BodiesPass.cpp): the Moon placed in
 * the Earth's frame, then its 128 x 64 globe's 8,385 vertices made camera-relative in double. */
void BM_PlaceMoonInTheEarthsFrame(benchmark::State& state) {
  double t = kStart;
  for (auto _ : state) {
    benchmark::DoNotOptimize(placeBody(EphemerisBody::earth, EphemerisBody::moon, t));
    t += 60.0;
  }
}
BENCHMARK(BM_PlaceMoonInTheEarthsFrame);

void BM_DistantGlobeCameraRelative(benchmark::State& state) {
  const DistantGlobe moon(moonBody());
  const BodyPlacement at = placeBody(EphemerisBody::earth, EphemerisBody::moon, kStart);
  std::vector<float> out;
  glm::dvec3 eye(7.0e6, 0.0, 0.0);
  for (auto _ : state) {
    moon.cameraRelative(at, eye, out);
    benchmark::DoNotOptimize(out.data());
    eye.y += 1.0;
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(moon.vertexCount()));
}
BENCHMARK(BM_DistantGlobeCameraRelative);

} // namespace

BENCHMARK_MAIN();
