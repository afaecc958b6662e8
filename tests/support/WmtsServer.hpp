#pragma once
// A tellus serve of two PNG layers on a loopback port for the WMTS tests (TestWmtsIntegration,
// TestWmtsMercator): "sat" (36-degree grid, 256 px, 3 levels) and "daily" (the same with TIME),
// both from a fake WMS upstream whose tiles are gradients.
#include "CacheFixtures.hpp"
#include "FakeUpstream.hpp"
#include "HttpClient.hpp"
#include "ServedFrontEnd.hpp"
#include "TempDir.hpp"

#include <tellus/cache/TileCache.hpp>
#include <tellus/cache/TilePath.hpp>
#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/HttpServer.hpp>
#include <tellus/proxy/ImageCodec.hpp>
#include <tellus/proxy/ProxyFrontEnd.hpp>
#include <tellus/proxy/TileService.hpp>

#include <gtest/gtest.h>

namespace tellus::test {

using namespace std::chrono_literals;

/** A PNG tile with a gradient that depends on the request, so that sampling shows. */
inline FakeReply gradientTile(const FakeRequest& req) {
  const auto h = stableHash64(req.target);
  constexpr int n = 256;
  std::vector<std::uint8_t> px(n * n * 3);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      std::uint8_t* p = &px[static_cast<std::size_t>((y * n + x) * 3)];
      p[0] = static_cast<std::uint8_t>(x);
      p[1] = static_cast<std::uint8_t>(y);
      p[2] = static_cast<std::uint8_t>(h);
    }
  const auto bytes = *encodeImage("image/png", n, n, 3, px.data());
  auto r = FakeReply::ok(std::string(reinterpret_cast<const char*>(bytes.data()), bytes.size()),
                         "image/png");
  r.headers.emplace_back("ETag", "\"v1\"");
  return r;
}

/** Layer "sat" (36-degree grid, 256-px PNG, 3 levels) and "daily" (the same with a TIME). */
struct WmtsServer {
  TempDir dir{"wmts"};
  std::unique_ptr<TileCache> cache;
  std::unique_ptr<Fetcher> fetcher;
  std::unique_ptr<TileService> tiles;
  std::unique_ptr<ServedFrontEnd> web; ///< after the service: stopped before it goes

  /** `levels`: of both layers (1: every map is composed from level 0, whatever its scale). */
  /** `ttl`: of both layers (0: their tiles never expire). */
  explicit WmtsServer(const std::string& upstreamUrl,
                      std::int32_t levels = 3,
                      std::chrono::milliseconds ttl = 0ms) {
    cache = openTestCache(dir.path());
    fetcher = std::make_unique<Fetcher>();
    UpstreamSpec u;
    u.name = "up";
    u.type = UpstreamSpec::Type::Wms;
    u.url = upstreamUrl;
    u.policy.timeout = 2000ms;
    u.policy.retries = 0;
    LayerSpec l;
    l.name = "sat";
    l.title = "Satellite";
    l.upstream = "up";
    l.dataset.grid = GridSpec{Sector{}, 36.0, 256, 256, levels};
    l.dataset.mimeType = "image/png";
    l.maxAge = 3600s;
    l.ttl = ttl;
    LayerSpec d = l;
    d.name = "daily";
    d.timeValues = {"2024-03-01", "2024-03-02"};
    d.timeDefault = "2024-03-02";
    auto t = TileService::create(*cache, *fetcher, {u}, {l, d}, {});
    EXPECT_TRUE(t) << (t ? "" : t.error());
    tiles = std::move(*t);
    web = std::make_unique<ServedFrontEnd>(*tiles);
  }
  HttpResult get(const std::string& target) const { return web->get(target); }
};

inline std::vector<std::uint8_t> pixels(const HttpResult& r, int size = 256) {
  const auto* p = reinterpret_cast<const std::byte*>(r.body.data());
  auto img = decodeImagery({p, r.body.size()}, r.header("content-type"), size, size);
  EXPECT_TRUE(img) << (img ? "" : img.error());
  return img ? img->pixels : std::vector<std::uint8_t>{};
}

} // namespace tellus::test
