// Polar caps from whole-row GetMaps and merged nodes from one GetMap of their box (issue 29,
// docs/design/poles.md): the renderer over a real loopback WMS asks for each drawn cap as its
// row's box at 8 x 1 tiles, in bands (proxy/src/tiles/CapBands.hpp), and for each merged node
// with ONE GetMap of its k tiles' box at its own width, and the picture is the one a World Wind
// server's tiles make when caps and merged nodes are composed of their rows' tiles.

#include "../../proxy/src/tiles/CapBands.hpp"
#include "../support/CacheFixtures.hpp"
#include "../support/SyntheticWms.hpp"
#include "../support/TempDir.hpp"
#include "GlTestSupport.hpp"

#include <tellus/planet/Camera.hpp>
#include <tellus/planet_gl/Renderer.hpp>
#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/TileService.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <set>

using namespace tellus;
using namespace tellus::planet;
using namespace tellus::planet::gltest;

namespace {

/** Layer "sat" (global, 36-degree, 256-px JPEG, 4 levels) over the synthetic server. */
struct SyntheticService {
  SyntheticService(const std::string& url, UpstreamSpec::Type type) {
    UpstreamSpec u;
    u.name = "up";
    u.type = type;
    u.url = url;
    LayerSpec l;
    l.name = "sat";
    l.upstream = "up";
    l.dataset.grid = GridSpec{Sector{}, 36.0, 256, 256, 4};
    l.dataset.mimeType = "image/jpeg";
    auto s = TileService::create(*cache, fetcher, {u}, {l}, TileServiceOptions{});
    EXPECT_TRUE(s) << (s ? "" : s.error());
    if (s) service = std::move(*s);
  }
  test::TempDir dir{"whole-rows-gl"};
  std::unique_ptr<TileCache> cache = test::openTestCache(dir.path());
  Fetcher fetcher;
  std::unique_ptr<TileService> service;
};

/** PSNR over the pixels whose ray meets the Earth (the sky is the same in both). */
double globePsnr(const std::vector<std::uint8_t>& a,
                 const std::vector<std::uint8_t>& b,
                 const Camera& cam,
                 const Geodesy& g) {
  double sum = 0.0;
  std::size_t n = 0;
  const auto vp = cam.viewport();
  for (int y = 0; y < vp.height; ++y)
    for (int x = 0; x < vp.width; ++x) {
      if (!rayHitsEarth(cam, g, x, y, 0.001)) continue;
      const auto i = static_cast<std::size_t>((y * vp.width + x) * 4);
      for (std::size_t c = 0; c < 3; ++c) {
        const double d = static_cast<double>(a[i + c]) - static_cast<double>(b[i + c]);
        sum += d * d;
        ++n;
      }
    }
  if (n == 0) return 0.0;
  const double mse = sum / static_cast<double>(n);
  return mse == 0.0 ? 99.0 : 10.0 * std::log10(255.0 * 255.0 / mse);
}

} // namespace

// Both poles, from 3,000 km and from 300 km (the deepest cap level, 3, drawn): the WMS view asks
// for each cap once, as the bands of its whole row (every longitude, 2048 x 256 in all); the World
// Wind view composes it from up to 80 of its row's tiles; the two pictures agree (PSNR >= 35 dB)
// and the WMS view makes fewer requests. The merged nodes of the ring around the caps are one
// GetMap each too (at most 256 x 256 of a box wider than tall).
TEST(WholeRowsGl, ACapFromItsRowsBandsLooksAsTheComposedCap) {
  const Geodesy geodesy;
  test::FakeUpstream up([](const test::FakeRequest& r) { return test::syntheticReply(r); });
  SyntheticService wms(up.url("/wms"), UpstreamSpec::Type::Wms);
  SyntheticService ww(up.url("/tiles"), UpstreamSpec::Type::WorldWind);
  ASSERT_TRUE(wms.service && ww.service);
  ASSERT_TRUE(wms.service->wholePolarRows("sat"));
  ASSERT_FALSE(ww.service->wholePolarRows("sat"));
  const auto o = options("sat", 512, 384);
  OPEN_RENDERER(rw, *wms.service, geodesy, o);
  OPEN_RENDERER(rc, *ww.service, geodesy, o);
  std::set<int> capLevels;
  std::size_t spanGets = 0;
  for (const double lat : {90.0, -90.0})
    for (const double altitude : {3.0e6, 3.0e5}) {
      SCOPED_TRACE(std::to_string(lat) + " " + std::to_string(altitude));
      const CameraPose pose{lat, 0.0, altitude, 0.0, 0.0};
      const std::size_t before = up.requests();
      const Rendered wholeRows = renderComplete(rw, pose);
      ASSERT_TRUE(wholeRows.complete);
      const auto wmsRequests = up.received();
      const std::size_t mid = up.requests();
      const Rendered composed = renderComplete(rc, pose);
      ASSERT_TRUE(composed.complete);
      const std::size_t after = up.requests();
      std::size_t capGets = 0;
      for (std::size_t i = before; i < mid; ++i) {
        const auto p = test::queryParams(wmsRequests[i].target);
        double b[4] = {}; // south, west, north, east
        const char* at = p.at("BBOX").c_str();
        for (double& v : b) {
          char* end = nullptr;
          v = std::strtod(at, &end);
          at = *end == ',' ? end + 1 : end;
        }
        if (b[1] != -180.0 || b[3] != 180.0) { // not every longitude: a tile or a merged node
          // (a merged node at the texels east-west its parallels need, wholeSpanTexelWidth)
          EXPECT_LE(std::stoi(p.at("WIDTH")), 256);
          EXPECT_EQ(p.at("HEIGHT"), "256");
          spanGets += b[3] - b[1] > 1.5 * (b[2] - b[0]); // a merged node's box: 2^k tiles wide
          continue;
        }
        // A band of a cap: an eighth of its rows, at most the cap's width.
        EXPECT_EQ(p.at("HEIGHT"), std::to_string(256 / kCapBands));
        EXPECT_LE(std::stoi(p.at("WIDTH")), 2048);
        if ((lat > 0 ? b[2] : b[0]) != lat) continue; // one band a cap touches the pole
        ++capGets;
        const double span = (b[2] - b[0]) * kCapBands;
        capLevels.insert(static_cast<int>(std::lround(std::log2(36.0 / span))));
      }
      EXPECT_GE(capGets, 1u);
      std::printf("pole %+.0f altitude %.0f km: whole rows %zu requests (%zu caps), composed %zu\n",
                  lat,
                  altitude / 1000.0,
                  mid - before,
                  capGets,
                  after - mid);
      EXPECT_LT(mid - before, after - mid);
      const double psnr = globePsnr(wholeRows.pixels, composed.pixels, rw.camera(pose), geodesy);
      std::printf("  PSNR whole rows against composed: %.1f dB\n", psnr);
      EXPECT_GE(psnr, 35.0);
    }
  EXPECT_TRUE(capLevels.contains(3)) << "the deepest level's cap was not drawn";
  std::printf("merged nodes from one GetMap: %zu\n", spanGets);
  EXPECT_GE(spanGets, 8u);
}
