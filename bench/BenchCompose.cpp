// GetMap composition, the CPU of one 1024x768 map from 512-pixel tiles (the peers' arbitrary-box
// benchmark size): the sampling alone, and decode + sample + encode as tellus serve does it.
// Side by side in one run; ratios are what to compare. Run with bench/run.sh.

#include <tellus/cache/TileGrid.hpp>
#include <tellus/proxy/Compose.hpp>
#include <tellus/proxy/ImageCodec.hpp>

#include <benchmark/benchmark.h>

#include <array>
#include <map>
#include <tuple>

using namespace tellus;

namespace {

TileGrid grid() {
  return *TileGrid::create(GridSpec{Sector{}, 36.0, 512, 512, 4});
}

/** A smooth colour field, so the JPEGs are realistic in size. */
std::vector<std::uint8_t> tilePixels(const TileKey& k) {
  std::vector<std::uint8_t> px(512 * 512 * 3);
  for (int y = 0; y < 512; ++y)
    for (int x = 0; x < 512; ++x) {
      auto* p = &px[static_cast<std::size_t>((y * 512 + x) * 3)];
      p[0] = static_cast<std::uint8_t>((x + k.col * 37) & 255);
      p[1] = static_cast<std::uint8_t>((y + k.row * 53) & 255);
      p[2] = static_cast<std::uint8_t>(((x ^ y) >> 2) & 255);
    }
  return px;
}

// A 60 x 45 degree box over 1024 x 768 pixels: level 1 (18-degree tiles), 5 x 4 tiles.
const Sector kBox{-100.3, 10.2, -40.3, 55.2};

void BM_SampleOnly(benchmark::State& state) {
  const TileGrid g = grid();
  const int level = composeLevel(g, kBox, 1024, 768, 0);
  const auto keys = *composeTiles(g, kBox, 1024, 768, level, 256);
  std::map<std::tuple<std::int64_t, std::int64_t>, std::vector<std::uint8_t>> pixels;
  std::map<std::tuple<std::int64_t, std::int64_t>, TileSamples> views;
  for (const auto& t : keys) {
    auto& p = pixels[{t.key.row, t.key.col}] = tilePixels(t.key);
    views[{t.key.row, t.key.col}] = TileSamples{512, 512, 3, p.data(), nullptr};
  }
  const TileLookup lookup = [&](const TileKey& k) -> const TileSamples* {
    const auto it = views.find({k.row, k.col});
    return k.level == level && it != views.end() ? &it->second : nullptr;
  };
  std::vector<std::uint8_t> canvas(1024 * 768 * 3);
  for (auto _ : state) {
    composeImagery(g, kBox, 1024, 768, level, 0, lookup, 1.0, canvas, 3);
    benchmark::DoNotOptimize(canvas.data());
  }
  state.counters["tiles"] = static_cast<double>(keys.size());
}
BENCHMARK(BM_SampleOnly)->Unit(benchmark::kMillisecond);

void BM_DecodeSampleEncodeJpeg(benchmark::State& state) {
  const TileGrid g = grid();
  const int level = composeLevel(g, kBox, 1024, 768, 0);
  const auto keys = *composeTiles(g, kBox, 1024, 768, level, 256);
  std::map<std::tuple<std::int64_t, std::int64_t>, std::vector<std::byte>> jpegs;
  std::map<std::tuple<std::int64_t, std::int64_t>, std::array<std::int32_t, 4>> regions;
  for (const auto& t : keys) {
    const auto px = tilePixels(t.key);
    jpegs[{t.key.row, t.key.col}] = *encodeImage("image/jpeg", 512, 512, 3, px.data());
    regions[{t.key.row, t.key.col}] = t.region;
  }
  std::vector<std::uint8_t> canvas(1024 * 768 * 3);
  std::size_t bytes = 0;
  for (auto _ : state) {
    std::map<std::tuple<std::int64_t, std::int64_t>,
             std::pair<std::vector<std::uint8_t>, TileSamples>>
        decoded;
    for (const auto& [rc, jpeg] : jpegs) {
      auto& [px, view] = decoded[rc];
      const auto ch = decodeImageryInto(jpeg, "image/jpeg", 512, 512, px, &regions[rc]);
      view = TileSamples{512, 512, *ch, px.data(), nullptr};
    }
    const TileLookup lookup = [&](const TileKey& k) -> const TileSamples* {
      const auto it = decoded.find({k.row, k.col});
      return k.level == level && it != decoded.end() ? &it->second.second : nullptr;
    };
    composeImagery(g, kBox, 1024, 768, level, 0, lookup, 1.0, canvas, 3);
    const auto out = encodeImage("image/jpeg", 1024, 768, 3, canvas.data());
    bytes = out->size();
    benchmark::DoNotOptimize(out->data());
  }
  state.counters["tiles"] = static_cast<double>(keys.size());
  state.counters["jpeg_bytes"] = static_cast<double>(bytes);
}
BENCHMARK(BM_DecodeSampleEncodeJpeg)->Unit(benchmark::kMillisecond);

} // namespace

BENCHMARK_MAIN();
