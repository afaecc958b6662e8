#pragma once
// Shared by the tests of the renderer's units (layers, update, intake, draw list, uploads): layers
// of the tests' one fake tile source (answered at once, every request recorded), a LayerSet over
// it, and cameras. GL-free: nothing here makes a GL object.

#include "../../planet/gl/src/LayerSet.hpp"
#include "../support/FakeTileSource.hpp"

#include <tellus/cache/TileSource.hpp>
#include <tellus/planet/Camera.hpp>
#include <tellus/planet/Geodesy.hpp>
#include <tellus/planet_gl/Renderer.hpp>

#include <gtest/gtest.h>

#include <map>
#include <memory>
#include <string>
#include <vector>

namespace tellus::planet::layertest {

using tellus::test::FakeTileSource;

/** A layer of the tests' source, answered at once: every tile Absent (the default), or Ok with a
 * few bytes of "image/png". Any time of a known layer exists. */
inline void addLayer(FakeTileSource& source,
                     const std::string& name,
                     GridSpec grid,
                     TileStatus answer = TileStatus::Absent) {
  source.addLayer(
      {name,
       grid,
       "image/png",
       answer == TileStatus::Ok
           ? FakeTileSource::bytes({std::byte{1}, std::byte{2}, std::byte{3}}, "image/png")
           : FakeTileSource::Answer(
                 [answer](const TileAddress&) { return FakeTileSource::result(answer); })});
}

inline GridSpec grid36(int levels, int tileSize = 256) {
  GridSpec g;
  g.levelZeroDeltaDeg = 36.0;
  g.tileWidth = g.tileHeight = tileSize;
  g.numLevels = levels;
  return g;
}

/** A LayerSet of the options' base and overlays over a source (opened; the test fails if it
 * cannot be). */
struct Layers {
  Layers(FakeTileSource& source, RendererOptions o) : opt(std::move(o)) {
    const auto spec = source.describe(opt.layer, opt.time);
    EXPECT_TRUE(spec.has_value());
    set = std::make_unique<LayerSet>(source, geodesy, opt, *TileGrid::create(spec->grid));
    const auto opened = set->open();
    EXPECT_TRUE(opened.has_value()) << (opened ? "" : opened.error());
  }
  Geodesy geodesy;
  RendererOptions opt;
  std::unique_ptr<LayerSet> set;
};

inline RendererOptions layerOptions(const std::string& base,
                                    const std::vector<std::string>& overlays = {}) {
  RendererOptions o;
  o.layer = base;
  o.width = 640;
  o.height = 480;
  for (const std::string& name : overlays) {
    LayerOptions l;
    l.layer = name;
    o.overlays.push_back(l);
  }
  return o;
}

/** The roots that are neither polar caps nor empty slots (a cap row has one root). */
inline std::vector<Node*> plainRoots(const Quadtree& tree) {
  std::vector<Node*> out;
  for (const auto& r : tree.roots())
    if (r && !r->isCap()) out.push_back(r.get());
  return out;
}

/** A camera looking straight down from altitudeM over (lat, lon), 640 x 480. */
inline Camera cameraAt(const Geodesy& g, double lat, double lon, double altitudeM) {
  return Camera(g, CameraPose{lat, lon, altitudeM, 0.0, 0.0}, Viewport{640, 480});
}

} // namespace tellus::planet::layertest
