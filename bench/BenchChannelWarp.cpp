// A projector channel's warp and blend on the CPU (issue 28, planet/ChannelWarp.hpp): what the
// headless cluster does to each channel's image before it writes it, at the projector sizes of
// docs/design/cluster.md "A real dome, on paper". Figures in bench/RESULTS.md.

#include <tellus/planet/ChannelWarp.hpp>

#include <benchmark/benchmark.h>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace {

void BM_WarpAndBlend(benchmark::State& state) {
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  const auto n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  tellus::planet::ChannelImage image{w, h, std::vector<std::uint8_t>(n * 4, 100)};
  const auto mesh = tellus::planet::WarpMesh::identity(65, 41);
  const std::vector<float> blend(n, 0.5f);
  for (auto _ : state) {
    auto out = tellus::planet::warpAndBlend(image, w, h, &mesh, &blend);
    benchmark::DoNotOptimize(out.rgba.data());
  }
  state.counters["MP"] = static_cast<double>(n) / 1e6;
}

} // namespace

BENCHMARK(BM_WarpAndBlend)
    ->Args({1024, 717})
    ->Args({1920, 1200})
    ->Unit(benchmark::kMillisecond)
    ->MinTime(2.0);

BENCHMARK_MAIN();
