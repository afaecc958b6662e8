// Terrain CPU costs (issue #6): one elevation tile decoded into metres (BIL16, 150 x 150, World
// Wind's size), a node mesh built from the height function with no side fixed and with all four
// sides fixed (the edge fixing's own cost per mesh), the height function alone, and the geoid
// applied to one tile (issue #8: h = H + N at each of its 22,500 samples, on the decoding worker).
// Run: build/bench/tellus_bench_terrain (bench/RESULTS.md, "Terrain").
#include <tellus/codec/Bil16.hpp>
#include <tellus/planet/Geoid.hpp>
#include <tellus/planet/Terrain.hpp>

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <vector>

using namespace tellus;
using namespace tellus::planet;

namespace {

double relief(double lat, double lon) {
  double h = 0.0, a = 3000.0, f = 0.35;
  for (int i = 0; i < 9; ++i) {
    h += a * std::sin(f * lat + i) * std::cos(f * lon + 2.0 * i);
    a *= 0.55;
    f *= 2.1;
  }
  return h;
}

std::vector<std::byte> bil16Tile(int w, int h) {
  std::vector<std::int16_t> heights;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      heights.push_back(static_cast<std::int16_t>(std::lround(relief(y * 0.01, x * 0.01))));
  return codec::encodeBil16(w, h, heights.data());
}

void BM_DecodeBil16Tile150(benchmark::State& state) {
  const auto bytes = bil16Tile(150, 150);
  HeightEncoding enc;
  enc.noData = -32768;
  for (auto _ : state) {
    auto t = decodeBil16({3, 10, 20}, 150, 150, bytes, enc);
    benchmark::DoNotOptimize(t);
  }
}
BENCHMARK(BM_DecodeBil16Tile150);

/** The geoid applied to a decoded 150 x 150 tile (level 3 over the Alps): what renderer.geoid adds
 * to the decoding worker's work per elevation tile. */
void BM_ApplyGeoidTile150(benchmark::State& state) {
  auto geoid = Geoid::open(std::string(TELLUS_BENCH_DATA_DIR) + "/" + kGeoidFileName);
  if (!geoid) throw std::runtime_error(geoid.error());
  const VerticalDatum datum(std::make_shared<const Geoid>(std::move(*geoid)));
  const auto bytes = bil16Tile(150, 150);
  HeightEncoding enc;
  enc.noData = -32768;
  const HeightTile tile = *decodeBil16({3, 21, 74}, 150, 150, bytes, enc);
  const Sector sector{5.0, 45.0, 7.5, 47.5};
  for (auto _ : state) {
    HeightTile t = tile;
    applyVerticalDatum(t, sector, datum);
    benchmark::DoNotOptimize(t.metres.data());
  }
}
BENCHMARK(BM_ApplyGeoidTile150);

/** A field of 150-px tiles at level 3 around the Alps, the heights a level-6 node reads. */
const HeightField& alps() {
  static const HeightField field = [] {
    GridSpec spec;
    spec.levelZeroDeltaDeg = 20.0;
    spec.tileWidth = spec.tileHeight = 150;
    spec.numLevels = 6;
    const TileGrid grid = *TileGrid::create(spec);
    HeightField f(grid);
    const auto keys = grid.keysCovering({0, 40, 20, 55}, 3);
    for (const TileKey& k : *keys) {
      std::vector<double> raw(150 * 150);
      const Sector s = grid.sectorOf(k);
      for (int y = 0; y < 150; ++y)
        for (int x = 0; x < 150; ++x)
          raw[static_cast<std::size_t>(y * 150 + x)] =
              relief(s.north - (y + 0.5) * (s.north - s.south) / 150,
                     s.west + (x + 0.5) * (s.east - s.west) / 150);
      f.insert(*heightTileFromSamples(k, 150, 150, raw, {}));
    }
    return f;
  }();
  return field;
}

void BM_TerrainMesh(benchmark::State& state) {
  const Geodesy wgs;
  const HeightField& f = alps();
  const Sector node{7.03125, 45.0, 7.59375, 45.5625}; // level 6 of the 36-degree grid
  const Sector coarse{5.625, 45.0, 7.875, 47.25}; // a level-4 neighbour on every side (sizes only)
  std::array<EdgeAdapt, 4> edges{};
  const bool fixed = state.range(0) != 0;
  if (fixed) {
    edges[0] = {true, {7.03125, 45.5625, 9.28125, 47.8125}, {}}; // north: 4x wider
    edges[1] = {true, {7.59375, 43.875, 9.84375, 46.125}, {}};   // east: 4x taller
    edges[2] = {true, {5.90625, 42.75, 8.15625, 45.0}, {}};      // south
    edges[3] = {true, {4.78125, 43.875, 7.03125, 46.125}, {}};   // west
  }
  (void)coarse;
  const int n = static_cast<int>(state.range(1));
  std::size_t zeroArea = 0;
  for (auto _ : state) {
    const TerrainMesh m = buildTerrainMesh(
        wgs, node, n, [&](double lat, double lon) { return f.heightAt(lat, lon); }, edges);
    zeroArea = m.zeroAreaTriangles;
    benchmark::DoNotOptimize(m.vertices.data());
  }
  state.counters["zero_area_triangles"] = static_cast<double>(zeroArea);
}
BENCHMARK(BM_TerrainMesh)->ArgsProduct({{0, 1}, {17, 33, 65, 129}})->ArgNames({"fixed", "n"});

/** A polar cap's mesh at the default mesh size: 129 columns, 33 rows (arg 33) against a square
 * 129 x 129 grid (arg 129, what a cap took before its rows followed the other nodes'). */
void BM_CapMesh(benchmark::State& state) {
  const Geodesy wgs;
  const HeightField& f = alps();
  const Sector cap{-180.0, 84.375, 180.0, 90.0}; // level 3 of the 36-degree grid
  const int rows = static_cast<int>(state.range(0));
  for (auto _ : state) {
    const TerrainMesh m = buildTerrainMesh(
        wgs, cap, 129, [&](double lat, double lon) { return f.heightAt(lat, lon); }, {}, rows);
    benchmark::DoNotOptimize(m.vertices.data());
  }
}
BENCHMARK(BM_CapMesh)->Arg(33)->Arg(129)->ArgNames({"rows"});

void BM_HeightAt(benchmark::State& state) {
  const HeightField& f = alps();
  double lat = 45.1, sum = 0.0;
  for (auto _ : state) {
    sum += f.heightAt(lat, 7.3);
    lat += 1e-4;
    if (lat > 46.0) lat = 45.1;
  }
  benchmark::DoNotOptimize(sum);
}
BENCHMARK(BM_HeightAt);

} // namespace

BENCHMARK_MAIN();
