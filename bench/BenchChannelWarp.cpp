// A projector channel's warp and blend (issue 28): on the CPU (planet/ChannelWarp.hpp), what the
// headless cluster does to each channel's image before it writes it, and on the GL
// (planet/gl/src/ProjectorWarp.hpp), what `tellus cluster --window` does each frame before the
// swap, in the same run at the projector sizes of docs/design/cluster.md "A real dome, on paper".
// The GL side needs a display (xvfb-run); it is skipped without one. Figures in bench/RESULTS.md.

#include "GlContext.hpp"
#include "ProjectorWarp.hpp"

#include <tellus/planet/ChannelWarp.hpp>

#include <benchmark/benchmark.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <vector>

namespace {

void BM_WarpAndBlend(benchmark::State& state) {
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  const int scale = static_cast<int>(state.range(2)); // rendered at scale x the projector's size
  const auto n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  const auto rendered = n * static_cast<std::size_t>(scale * scale);
  tellus::planet::ChannelImage image{
      w * scale, h * scale, std::vector<std::uint8_t>(rendered * 4, 100)};
  const auto mesh = tellus::planet::WarpMesh::identity(65, 41);
  const std::vector<float> blend(n, 0.5f);
  state.counters["samples"] = tellus::planet::warpSubsamples(w * scale, h * scale, w, h);
  for (auto _ : state) {
    auto out = tellus::planet::warpAndBlend(image, w, h, &mesh, &blend);
    benchmark::DoNotOptimize(out.rgba.data());
  }
  state.counters["MP"] = static_cast<double>(n) / 1e6;
}

/** The GL pass: the scene's colour copied, warped, blended (glFinish: the frame's end). With
 * range(2) = 1 the projector image read back too (the channel's PNG). */
void BM_GlWarpAndBlend(benchmark::State& state) {
  using namespace tellus::planet;
  const char* display = std::getenv("DISPLAY");
  if (display == nullptr || *display == '\0') {
    state.SkipWithError("no DISPLAY: run under xvfb-run");
    return;
  }
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  const int scale = static_cast<int>(state.range(3)); // rendered at scale x the projector's size
  const auto n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  auto context = GlContext::create({});
  if (!context) {
    state.SkipWithError(context.error().c_str());
    return;
  }
  auto pass = ProjectorWarp::create((*context)->capabilities().glslHeader(),
                                    w * scale,
                                    h * scale,
                                    w,
                                    h,
                                    WarpMesh::identity(65, 41),
                                    std::vector<float>(n, 0.5f));
  if (!pass) {
    state.SkipWithError(pass.error().c_str());
    return;
  }
  GlRenderbuffer colour;
  glBindRenderbuffer(GL_RENDERBUFFER, colour.id());
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, w * scale, h * scale);
  GlFramebuffer scene;
  glBindFramebuffer(GL_FRAMEBUFFER, scene.id());
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, colour.id());
  glClearColor(0.4f, 0.4f, 0.4f, 1.0f);
  glClear(GL_COLOR_BUFFER_BIT);
  for (auto _ : state) {
    (*pass)->apply(scene.id());
    if (state.range(2) != 0) {
      auto out = (*pass)->readPixels();
      benchmark::DoNotOptimize(out.data());
    }
    glFinish();
  }
  state.counters["MP"] = static_cast<double>(n) / 1e6;
  state.counters["samples"] = warpSubsamples(w * scale, h * scale, w, h);
  state.SetLabel((*context)->capabilities().version);
}

} // namespace

// Arguments: the projector's width and height, (GL: whether read back), the render scale (1, 2;
// 3: more than twice, filtered with 2 x 2 samples a pixel).
BENCHMARK(BM_WarpAndBlend)
    ->Args({1024, 717, 1})
    ->Args({1920, 1200, 1})
    ->Args({1920, 1200, 2})
    ->Args({1920, 1200, 3})
    ->Unit(benchmark::kMillisecond)
    ->MinTime(2.0);
BENCHMARK(BM_GlWarpAndBlend)
    ->Args({1024, 717, 0, 1})
    ->Args({1920, 1200, 0, 1})
    ->Args({1920, 1200, 1, 1})
    ->Args({1920, 1200, 0, 2})
    ->Args({1920, 1200, 0, 3})
    ->Unit(benchmark::kMillisecond)
    ->MinTime(2.0);

BENCHMARK_MAIN();
