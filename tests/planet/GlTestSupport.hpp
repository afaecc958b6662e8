#pragma once
// Shared by the rendered planet tests (label gl): the display check, layers of the tests' fake tile
// source that need no network (absent everywhere; texels that say where they are), the embedded
// default's Blue Marble through the proxy's tile service, and rendering until complete.

#include "../support/CacheFixtures.hpp"
#include "../support/FakeTileSource.hpp"
#include "../support/TempDir.hpp"

#include <tellus/planet/Camera.hpp>
#include <tellus/planet/Geodesy.hpp>
#include <tellus/planet_gl/Renderer.hpp>
#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/TileService.hpp>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace tellus::planet::gltest {

inline const std::filesystem::path kBlueMarble =
    std::filesystem::path(TELLUS_TEST_DATA_DIR) / "bmng_2048x1024.jpg";

inline bool haveDisplay() {
  const char* d = std::getenv("DISPLAY");
  return d != nullptr && *d != '\0';
}

using tellus::test::FakeTileSource;

/** Every tile absent (the renderer draws the global texture only): the layer of a FakeTileSource
 * for every name, `FakeTileSource source(absentLayer(grid))`. */
inline FakeTileSource::Layer absentLayer(GridSpec grid) {
  return {"absent", grid, "image/png", FakeTileSource::absent()};
}

/** Tiles whose texels say where they are: red = column in the tile, green = row, blue = level
 * times bluePerLevel (at most blueMax). Any level of the grid exists. */
inline FakeTileSource::Answer rampTiles(GridSpec grid, int bluePerLevel = 10, int blueMax = 250) {
  auto tiles = std::make_shared<std::map<int, std::vector<std::byte>>>(); // by level
  return [=](const TileAddress& a) {
    auto& t = (*tiles)[a.key.level];
    if (t.empty()) {
      const int w = grid.tileWidth, h = grid.tileHeight;
      std::vector<std::uint8_t> px(static_cast<std::size_t>(w * h * 4));
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          auto* p = &px[static_cast<std::size_t>((y * w + x) * 4)];
          p[0] = static_cast<std::uint8_t>(x);
          p[1] = static_cast<std::uint8_t>(y);
          p[2] = static_cast<std::uint8_t>(std::min(blueMax, a.key.level * bluePerLevel));
          p[3] = 255;
        }
      t = encodePngRgba(w, h, px);
    }
    return FakeTileSource::result(TileStatus::Ok, t, "image/png");
  };
}

/** rampTiles() as the layer of a FakeTileSource for every name (named "ramp"). */
inline FakeTileSource::Layer rampLayer(GridSpec grid, int bluePerLevel = 10, int blueMax = 250) {
  return {"ramp", grid, "image/png", rampTiles(grid, bluePerLevel, blueMax)};
}

/** The embedded default's bluemarble layer through the proxy's tile service over a cache. */
struct BlueMarbleService {
  explicit BlueMarbleService(const char* dirName = "render-gl") : dir(dirName) {
    UpstreamSpec bm;
    bm.name = "local";
    bm.type = UpstreamSpec::Type::Local;
    bm.path = kBlueMarble;
    LayerSpec imagery;
    imagery.name = "bluemarble";
    imagery.upstream = "local";
    imagery.dataset.grid = GridSpec{Sector{}, 36.0, 512, 512, 3};
    imagery.dataset.mimeType = "image/jpeg";
    auto s = TileService::create(*cache, fetcher, {bm}, {imagery}, TileServiceOptions{});
    if (s) service = std::move(*s);
  }
  test::TempDir dir;
  std::unique_ptr<TileCache> cache = test::openTestCache(dir.path());
  Fetcher fetcher;
  std::unique_ptr<TileService> service;
};

struct Rendered {
  std::vector<std::uint8_t> pixels;
  RenderStats stats;
  bool complete = false;
};

inline RendererOptions options(const std::string& layer, int w, int h) {
  RendererOptions o;
  o.layer = layer;
  o.width = w;
  o.height = h;
  o.globalImage = kBlueMarble;
  return o;
}

/** Does the ray through the pixel centre hit the Earth model shrunk by `shrink` (a fraction)?
 * (A camera inside the shrunk model counts as a hit.) */
inline bool rayHitsEarth(const Camera& cam, const Geodesy& g, int px, int py, double shrink) {
  const auto vp = cam.viewport();
  const double t = std::tan(cam.verticalFovDeg() * M_PI / 360.0);
  const double aspect = static_cast<double>(vp.width) / vp.height;
  const double nx = 2.0 * (px + 0.5) / vp.width - 1.0;
  const double ny = 1.0 - 2.0 * (py + 0.5) / vp.height;
  glm::dvec3 d = cam.forward() + cam.right() * (nx * t * aspect) + cam.up() * (ny * t);
  const double a = g.equatorialRadius() * (1.0 - shrink), b = g.polarRadius() * (1.0 - shrink);
  const glm::dvec3 s(1.0 / a, 1.0 / a, 1.0 / b);
  const glm::dvec3 o = cam.position() * s;
  d = d * s;
  const double A = glm::dot(d, d), B = 2.0 * glm::dot(o, d), C = glm::dot(o, o) - 1.0;
  const double disc = B * B - 4.0 * A * C;
  if (disc < 0.0) return false;
  return (-B - std::sqrt(disc)) / (2.0 * A) > 0.0 || C < 0.0;
}

/** Frames until complete (or the limit); the pixels of the last frame. */
inline Rendered renderComplete(Renderer& r, const CameraPose& pose, double limitS = 60.0) {
  const auto start = std::chrono::steady_clock::now();
  Rendered out;
  for (;;) {
    r.frame(pose);
    if (r.complete()) break;
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() > limitS)
      break;
    if (!r.busy()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  out.complete = r.complete();
  out.pixels = r.readPixels();
  out.stats = r.stats();
  return out;
}

} // namespace tellus::planet::gltest

#define OPEN_RENDERER(var, source, geodesy, opts)                                                  \
  if (!tellus::planet::gltest::haveDisplay())                                                      \
    GTEST_SKIP() << "no DISPLAY: run the gl label under xvfb-run";                                 \
  auto var##Made = Renderer::create(source, geodesy, opts);                                        \
  ASSERT_TRUE(var##Made.has_value()) << var##Made.error();                                         \
  Renderer& var = **var##Made
