// WMTS GoogleMapsCompatible GetTile: composed by the WMS GetMap composition in EPSG:3857 (issue
// 25's Web Mercator part) and kept as a tile of the set's own dataset. The set in the capabilities,
// its scales and ranges and TileOutOfRange are tested in TestWmts and TestWmtsIntegration.
#include "../support/WmsSchemas.hpp"
#include "../support/WmtsServer.hpp"

#include <tellus/proxy/Capabilities.hpp>
#include <tellus/proxy/Wmts.hpp>

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <numbers>

using namespace tellus;
using test::WmtsServer;

namespace {

std::string mercatorTile(int z, int row, int col) {
  return "/wmts?SERVICE=WMTS&REQUEST=GetTile&VERSION=1.0.0&LAYER=sat&STYLE=default"
         "&FORMAT=image/png&TILEMATRIXSET=GoogleMapsCompatible&TILEMATRIX=" +
         std::to_string(z) + "&TILEROW=" + std::to_string(row) + "&TILECOL=" + std::to_string(col);
}

} // namespace

TEST(WmtsMercator, GetTileIsTheWmsMapInEpsg3857) {
  test::FakeUpstream up(test::gradientTile);
  WmtsServer s(up.url("/wms"));
  const auto tile = s.get(mercatorTile(2, 1, 2));
  ASSERT_EQ(tile.status, 200) << tile.body;
  EXPECT_EQ(tile.header("content-type"), "image/png");
  const double h = kWebMercatorHalf;
  const auto wms = s.get("/wms?SERVICE=WMS&VERSION=1.3.0&REQUEST=GetMap&LAYERS=sat&STYLES="
                         "&CRS=EPSG:3857&BBOX=0,0," +
                         formatCoordinate(h / 2) + "," + formatCoordinate(h / 2) +
                         "&WIDTH=256&HEIGHT=256&FORMAT=image/png&TRANSPARENT=TRUE");
  ASSERT_EQ(wms.status, 200) << wms.body;
  EXPECT_EQ(test::pixels(tile), test::pixels(wms));
}

TEST(WmtsMercator, RowsFollowMercatorLatitudes) {
  // Each row of a Mercator tile is the lat/long map at that row's latitude: compare a few rows
  // with one-pixel-high CRS:84 maps whose pixel centres are the row's (bilinear sampling on both
  // sides: within 2 levels of each channel). One level, so that both sample the same tiles. A
  // Mercator pixel here spans 2.5 texels of level 0 (90 / 256 degrees against 36 / 256), so it
  // is the mean of 3 samples (ComposeWide.cpp): the strip is 3 times as wide, each 3 of its
  // pixels averaged.
  test::FakeUpstream up(test::gradientTile);
  WmtsServer s(up.url("/wms"), 1);
  const auto tile = test::pixels(s.get(mercatorTile(2, 1, 2)));
  ASSERT_EQ(tile.size(), 256u * 256u * 4u);
  const double span = kWebMercatorHalf / 2; // tile z=2 row 1 col 2: x 0..span, y 0..span
  for (const int j : {0, 37, 128, 200, 255}) {
    const double y = span - (j + 0.5) * span / 256; // the row's centre
    const auto lat = [](double v) {
      return (2 * std::atan(std::exp(v / 6378137.0)) - std::numbers::pi / 2) * 180 /
             std::numbers::pi;
    };
    const auto strip =
        s.get("/wms?SERVICE=WMS&VERSION=1.3.0&REQUEST=GetMap&LAYERS=sat&STYLES="
              "&CRS=CRS:84&BBOX=0," +
              formatCoordinate(lat(y) - 0.1) + ",90," + formatCoordinate(lat(y) + 0.1) +
              "&WIDTH=768&HEIGHT=1&FORMAT=image/png&TRANSPARENT=TRUE");
    ASSERT_EQ(strip.status, 200) << strip.body;
    const auto* p = reinterpret_cast<const std::byte*>(strip.body.data());
    const auto row = decodeImagery({p, strip.body.size()}, "image/png", 768, 1);
    ASSERT_TRUE(row);
    for (int i = 0; i < 256; i += 17)
      for (int c = 0; c < 3; ++c) {
        int sum = 0;
        for (int k = 0; k < 3; ++k)
          sum += row->pixels[static_cast<std::size_t>((i * 3 + k) * row->channels + c)];
        EXPECT_NEAR(tile[static_cast<std::size_t>((j * 256 + i) * 4 + c)], sum / 3.0, 2)
            << "row " << j << " column " << i;
      }
  }
}

TEST(WmtsMercator, RestTilesAndTimeAreComposedToo) {
  test::FakeUpstream up(test::gradientTile);
  WmtsServer s(up.url("/wms"));
  const auto rest = s.get("/wmts/1.0.0/sat/default/GoogleMapsCompatible/2/1/2.png");
  ASSERT_EQ(rest.status, 200) << rest.body;
  EXPECT_EQ(rest.body, s.get(mercatorTile(2, 1, 2)).body);
  const auto first = s.get("/wmts/1.0.0/daily/default/2024-03-01/GoogleMapsCompatible/1/0/0.png");
  const auto second = s.get("/wmts/1.0.0/daily/default/2024-03-02/GoogleMapsCompatible/1/0/0.png");
  ASSERT_EQ(first.status, 200) << first.body;
  ASSERT_EQ(second.status, 200) << second.body;
  EXPECT_NE(first.body, second.body);
}

namespace {

/** The dataset of a layer's GoogleMapsCompatible tiles, if registered. */
std::optional<DatasetInfo> mercatorDataset(const TileCache& cache, std::string_view layer) {
  for (const auto& d : cache.datasets())
    if (d.spec.name == std::string(layer) + ".GoogleMapsCompatible") return d;
  return std::nullopt;
}

} // namespace

TEST(WmtsMercator, TilesAreKeptInTheirOwnSet) {
  test::FakeUpstream up(test::gradientTile);
  WmtsServer s(up.url("/wms"));
  const auto first = s.get("/wmts/1.0.0/sat/default/GoogleMapsCompatible/2/1/2.png");
  ASSERT_EQ(first.status, 200) << first.body;
  const std::size_t fetched = up.requests();
  EXPECT_GT(fetched, 0u);
  const auto d = mercatorDataset(*s.cache, "sat");
  ASSERT_TRUE(d);
  // 2^z x 2^z tiles at each matrix, as many as the layer's set has (0-6 for 9-degree tiles of
  // 256 px: z = 6's pixels are the first no larger than theirs).
  EXPECT_EQ(d->spec.grid, composedCacheGrid(WmtsSetKind::GoogleMapsCompatible, 7));
  const auto kept = s.cache->peek(d->id, TileKey{2, 4 - 1 - 1, 2});
  ASSERT_TRUE(kept);
  EXPECT_EQ(kept->kind, CacheLookup::Kind::Hit);
  EXPECT_FALSE(kept->meta.expiresAt); // the layer has no ttl: kept until pruned
  // The second request, KVP or REST, is the kept file: nothing fetched, the same validator.
  for (const std::string& path :
       {mercatorTile(2, 1, 2),
        std::string("/wmts/1.0.0/sat/default/GoogleMapsCompatible/2/1/2.png")}) {
    const auto again = s.get(path);
    ASSERT_EQ(again.status, 200) << again.body;
    EXPECT_EQ(again.body, first.body);
    EXPECT_EQ(again.header("etag"), first.header("etag"));
    EXPECT_EQ(again.header("x-cache"), "HIT");
  }
  EXPECT_EQ(up.requests(), fetched);
  // A time's tiles are a dataset of their own; the cache's own check finds all of it in order.
  ASSERT_EQ(s.get("/wmts/1.0.0/daily/default/2024-03-01/GoogleMapsCompatible/1/0/0.png").status,
            200);
  const auto verify = s.cache->verify();
  ASSERT_TRUE(verify);
  EXPECT_TRUE(verify->ok());
}

TEST(WmtsMercator, TilesFromACoarserFallbackAreNotKept) {
  // Level 0 cached (a world map drawn from it), then the upstream fails: a z = 4 tile (22.5-45 E,
  // 41-56 N) is drawn from level 1, whose tiles cannot be had, so its pixels come from level 0. It
  // is served, and not kept.
  std::atomic<bool> failing{false};
  test::FakeUpstream up([&failing](const test::FakeRequest& r) {
    return failing ? test::FakeReply::withStatus(500, "down") : test::gradientTile(r);
  });
  WmtsServer s(up.url("/wms"));
  const auto world = s.get("/wms?SERVICE=WMS&VERSION=1.3.0&REQUEST=GetMap&LAYERS=sat&STYLES="
                           "&CRS=CRS:84&BBOX=-180,-90,180,90&WIDTH=1280&HEIGHT=640"
                           "&FORMAT=image/png");
  ASSERT_EQ(world.status, 200) << world.body;
  EXPECT_EQ(up.requests(), 50u); // level 0's 10 x 5 tiles
  failing = true;
  for (int i = 0; i < 2; ++i) {
    const auto tile = s.get("/wmts/1.0.0/sat/default/GoogleMapsCompatible/4/5/9.png");
    ASSERT_EQ(tile.status, 200) << tile.body;
    EXPECT_NE(tile.header("x-cache"), "HIT");
    const auto d = mercatorDataset(*s.cache, "sat");
    ASSERT_TRUE(d);
    const auto kept = s.cache->peek(d->id, TileKey{4, 16 - 1 - 5, 9});
    ASSERT_TRUE(kept);
    EXPECT_NE(kept->kind, CacheLookup::Kind::Hit);
  }
  EXPECT_GT(up.requests(), 50u);
}

TEST(WmtsMercator, KeptTilesExpireWithTheLayersTtl) {
  test::FakeUpstream up(test::gradientTile);
  WmtsServer s(up.url("/wms"), 3, std::chrono::hours(2));
  ASSERT_EQ(s.get("/wmts/1.0.0/sat/default/GoogleMapsCompatible/2/1/2.png").status, 200);
  const auto d = mercatorDataset(*s.cache, "sat");
  ASSERT_TRUE(d);
  const auto kept = s.cache->peek(d->id, TileKey{2, 2, 2});
  ASSERT_TRUE(kept);
  ASSERT_EQ(kept->kind, CacheLookup::Kind::Hit);
  ASSERT_TRUE(kept->meta.expiresAt);
  EXPECT_EQ(*kept->meta.expiresAt - kept->meta.fetchedAt, 2 * 3600 * 1000);
}
