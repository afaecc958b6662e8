// A render and a GetMap of the same area agree pixel by pixel (issue 24, label gl): one layer of
// values (a synthetic WMS upstream behind the proxy's TileService: BIL16 tiles of a smooth field
// with no-data discs, one of them across a tile edge) is drawn by the renderer looking straight
// down (viridis over 0 .. 100, over a grey base) and composed by the proxy's front end as a styled
// GetMap (STYLES=viridis) of the area, both from the same cached tiles. Every render pixel is
// traced to its point on the globe (planet/Pick.hpp) and compared with the GetMap pixel there,
// as colour-map indices (values/Sample.hpp's rule on both sides, ColourScale's index rule).
//
// Tolerance, inside tiles (farther than 0.6 texel from a tile edge): at least 99.5% of the pixels
// at most 1 index apart, none more than 2 (the GetMap pixel is up to 1/30 texel from the render
// pixel's point; the render's mesh and the pick's ellipsoid differ by a fraction of a pixel; float
// against double). No data identical but within kMargin texel of a texel edge (the same position
// error moves the edge). Beside no data the rule jumps (where a no-data texel enters the four,
// and between texels while one is among them): pixels within kMargin of a jump are counted apart,
// 97% of them within 1 index. Along tile edges (the outer half texel of a node's texture, which
// holds no neighbour texels) the renderer clamps where the proxy samples across the edge: the
// residual is measured (printed) and bounded by half the change across a texel (here up to ~4
// indices); there the render must follow the rule it states (the clamped rule computed on the
// CPU, within 1 index for 99%).
//
// The test can fail: the same figures for the renderer's former rule (the nearest texel, computed
// on the CPU from the field) break the tolerance, and this is asserted too.

#include "../support/CacheFixtures.hpp"
#include "../support/FakeTransport.hpp"
#include "../support/TempDir.hpp"
#include "GlTestSupport.hpp"

#include <tellus/codec/Png.hpp>
#include <tellus/planet/Pick.hpp>
#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/HttpServer.hpp>
#include <tellus/proxy/ImageCodec.hpp>
#include <tellus/proxy/ProxyFrontEnd.hpp>
#include <tellus/proxy/TileService.hpp>
#include <tellus/values/ColourMap.hpp>
#include <tellus/values/ColourScale.hpp>
#include <tellus/values/Sample.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <future>
#include <map>
#include <string>
#include <vector>

using namespace tellus;
using namespace tellus::planet;
using namespace std::chrono_literals;

namespace {

constexpr int kTile = 64;                  // texels a tile side (level 0, 36 degrees)
constexpr double kTexelDeg = 36.0 / kTile; // 0.5625 degrees
constexpr std::int16_t kNoData = -32768;
constexpr double kScale = 0.01;                      // value = raw * 0.01
const CameraPose kView{18.0, 36.0, 1.4e6, 0.0, 0.0}; // over the corner of four tiles, nadir
constexpr int kSize = 256;                           // the render, square
constexpr int kMapSize = 1024; // the GetMap, square (about 1/30 texel a pixel)
/** Texels: how far a render pixel's point may be from the GetMap pixel's (1/30 texel a map pixel,
 * the mesh against the ellipsoid): where the rule jumps (beside no data) pixels this close to a
 * jump are counted apart. */
constexpr double kMargin = 0.06;

/** The field: smooth (up to ~3 units a texel: ~8 colour indices), no data in two discs. */
double fieldAt(double lat, double lon) {
  const auto inDisc = [&](double clat, double clon, double r) {
    return (lat - clat) * (lat - clat) + (lon - clon) * (lon - clon) < r * r;
  };
  if (inDisc(15.5, 39.0, 1.4) || inDisc(18.2, 33.5, 1.1)) return std::nan("");
  return 50.0 + 42.0 * std::sin(0.12 * (lon - 20.0)) * std::cos(0.10 * (lat - 12.0)) +
         4.0 * std::sin(0.5 * lat);
}

/** The raw sample of a texel whose centre is (lat, lon), as the upstream sends it. */
std::int16_t rawAt(double lat, double lon) {
  const double v = fieldAt(lat, lon);
  return std::isnan(v) ? kNoData : static_cast<std::int16_t>(std::lround(v / kScale));
}

/** The value of global level-0 texel (i from -180, j from +90), as decoded (a float). */
float texelValue(std::int64_t i, std::int64_t j) {
  const std::int16_t raw = rawAt(90.0 - (static_cast<double>(j) + 0.5) * kTexelDeg,
                                 -180.0 + (static_cast<double>(i) + 0.5) * kTexelDeg);
  return raw == kNoData ? std::nanf("") : static_cast<float>(raw * kScale);
}

std::string paramOf(const std::string& url, const std::string& name) {
  const auto at = url.find(name + "=");
  if (at == std::string::npos) return {};
  const auto end = url.find('&', at);
  return url.substr(at + name.size() + 1,
                    end == std::string::npos ? std::string::npos : end - at - name.size() - 1);
}

/** The upstream (a WMS 1.3.0 server, EPSG:4326): "upvals" BIL16 of the field at texel centres,
 * "upbase" a grey PNG. */
std::optional<TransferResult> upstream(const TransferRequest& req) {
  const int w = std::atoi(paramOf(req.url, "WIDTH").c_str());
  const int h = std::atoi(paramOf(req.url, "HEIGHT").c_str());
  if (w <= 0 || h <= 0 || w > 1024 || h > 1024) return test::FakeTransport::status(400);
  const auto n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  TransferResult r;
  r.status = 200;
  if (paramOf(req.url, "LAYERS") == "upbase") {
    std::vector<std::uint8_t> px(n * 3, 128);
    r.contentType = "image/png";
    r.body = *encodeImage("image/png", w, h, 3, px.data());
    return r;
  }
  double b[4] = {}; // south, west, north, east
  std::sscanf(paramOf(req.url, "BBOX").c_str(), "%lf,%lf,%lf,%lf", &b[0], &b[1], &b[2], &b[3]);
  std::vector<std::int16_t> v(n);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      v[static_cast<std::size_t>(y * w + x)] =
          rawAt(b[2] - (y + 0.5) * (b[2] - b[0]) / h, b[1] + (x + 0.5) * (b[3] - b[1]) / w);
  r.contentType = "application/bil16";
  r.body = *encodeHeights("application/bil16", w, h, v.data());
  return r;
}

values::ValueFormat valueFormat() {
  values::ValueFormat f;
  f.container = values::Container::Bil;
  f.encoding = values::Encoding::Int16;
  f.scale = kScale;
  f.noData = kNoData;
  f.unit = "u";
  return f;
}

/** The proxy: cache, fetcher over the fake upstream, tile service, WMS front end. */
struct Proxy {
  test::TempDir dir{"values-getmap-gl"};
  std::unique_ptr<TileCache> cache = test::openTestCache(dir.path());
  Fetcher fetcher{std::make_unique<test::FakeTransport>(upstream), Clock::system()};
  std::unique_ptr<TileService> tiles;
  std::unique_ptr<ProxyFrontEnd> front;

  Proxy() {
    UpstreamSpec u;
    u.name = "up";
    u.type = UpstreamSpec::Type::Wms;
    u.url = "http://upstream.test/wms";
    u.policy.retries = 0;
    LayerSpec base;
    base.name = "base";
    base.upstream = "up";
    base.upstreamLayer = "upbase";
    base.dataset.grid = GridSpec{Sector{}, 36.0, 32, 32, 4};
    base.dataset.mimeType = "image/png";
    LayerSpec vals;
    vals.name = "vals";
    vals.upstream = "up";
    vals.upstreamLayer = "upvals";
    vals.dataset.grid = GridSpec{Sector{}, 36.0, kTile, kTile, 1};
    vals.dataset.mimeType = "application/bil16";
    ValueLayerSpec v;
    v.format = valueFormat();
    v.defaultStyle = "viridis";
    v.styles = {"viridis"};
    v.min = 0.0;
    v.max = 100.0;
    vals.values = v;
    auto t = TileService::create(*cache, fetcher, {u}, {base, vals}, TileServiceOptions{});
    EXPECT_TRUE(t) << (t ? "" : t.error());
    if (t) tiles = std::move(*t);
    if (tiles) front = std::make_unique<ProxyFrontEnd>(*tiles, FrontEndOptions{});
  }

  /** A GetMap through the front end (as the HTTP server hands it a request). */
  HttpResponse get(const std::string& query) {
    HttpRequest req;
    req.method = "GET";
    req.path = "/wms";
    req.query = query;
    req.target = "/wms?" + query;
    req.remoteAddress = "127.0.0.1";
    std::promise<HttpResponse> answer;
    auto done = answer.get_future();
    front->handle(std::move(req), [&](HttpResponse&& r) { answer.set_value(std::move(r)); });
    if (done.wait_for(60s) != std::future_status::ready) return HttpResponse::text(504, "", "");
    return done.get();
  }
};

/** Colour -> the viridis indices with that colour. */
std::map<std::uint32_t, std::vector<int>> indexOfColour() {
  std::map<std::uint32_t, std::vector<int>> m;
  const auto& table = *values::findColourMap("viridis")->table;
  for (int i = 0; i < 256; ++i) {
    const auto& c = table[static_cast<std::size_t>(i)];
    m[(std::uint32_t(c[0]) << 16) | (std::uint32_t(c[1]) << 8) | c[2]].push_back(i);
  }
  return m;
}

/** The distance in indices between two colours' index sets (-1: a colour of no index). */
int indexDistance(const std::map<std::uint32_t, std::vector<int>>& m, std::uint32_t a, int b) {
  const auto it = m.find(a);
  if (it == m.end()) return -1;
  int best = 1 << 20;
  for (const int i : it->second)
    best = std::min(best, std::abs(i - b));
  return best;
}

/** Agreement figures of one pairing of pictures. */
struct Agreement {
  int pixels = 0;   ///< compared (both with a value, or both no data)
  int interior = 0; ///< of those with values, farther than 0.6 texel from a tile edge
  std::array<int, 4> interiorOff{}; ///< 0, 1, 2, >2 indices apart
  int interiorMax = 0;
  int strip = 0;        ///< with values, within 0.6 texel of a tile edge
  int stripWithin1 = 0; ///< of those, at most 1 index apart
  int stripMax = 0;
  int switching = 0; ///< with values, within 0.15 texel of where no data enters the four
  int switchingWithin1 = 0;
  int switchingMax = 0;   ///< (the value jumps there: not held to the tolerance)
  int noData = 0;         ///< no data on both sides
  int noDataMismatch = 0; ///< one side no data, the other not, away from texel edges
  int noDataNearEdge = 0; ///< the same within 0.15 texel of a texel edge (tolerated)
  int foreign = 0;        ///< a colour not in the map (neither a value's nor the base's)

  void add(bool aNaN, bool bNaN, int off, double tileEdge, double texelEdge, bool nearJump) {
    if (off < 0) {
      ++foreign;
      return;
    }
    if (aNaN != bNaN) {
      (texelEdge < kMargin ? noDataNearEdge : noDataMismatch) += 1;
      return;
    }
    ++pixels;
    if (aNaN) {
      ++noData;
      return;
    }
    if (nearJump) {
      ++switching;
      switchingWithin1 += off <= 1 ? 1 : 0;
      switchingMax = std::max(switchingMax, off);
    } else if (tileEdge < 0.6) {
      ++strip;
      stripWithin1 += off <= 1 ? 1 : 0;
      stripMax = std::max(stripMax, off);
    } else {
      ++interior;
      ++interiorOff[static_cast<std::size_t>(std::min(off, 3))];
      interiorMax = std::max(interiorMax, off);
    }
  }
  double interiorWithin1() const {
    return interior == 0 ? 0.0 : double(interiorOff[0] + interiorOff[1]) / interior;
  }
  std::string text() const {
    char b[600];
    std::snprintf(
        b,
        sizeof b,
        "compared %d, no data %d; interior %d: %d exact, %d one, %d two, %d more "
        "(within 1: %.4f, max %d); tile-edge strip %d: within 1 %.4f, max %d; beside "
        "no data where the rule switches %d: within 1 %.4f, max %d; no-data mismatches %d (+%d at "
        "texel edges); foreign colours %d",
        pixels,
        noData,
        interior,
        interiorOff[0],
        interiorOff[1],
        interiorOff[2],
        interiorOff[3],
        interiorWithin1(),
        interiorMax,
        strip,
        strip == 0 ? 0.0 : double(stripWithin1) / strip,
        stripMax,
        switching,
        switching == 0 ? 0.0 : double(switchingWithin1) / switching,
        switchingMax,
        noDataMismatch,
        noDataNearEdge,
        foreign);
    return b;
  }
};

TEST(ValuesGetMapGl, ARenderAndAGetMapOfTheSameAreaAgreePixelByPixel) {
  if (!gltest::haveDisplay()) GTEST_SKIP() << "no DISPLAY: run the gl label under xvfb-run";
  Proxy proxy;
  ASSERT_TRUE(proxy.front);
  const Geodesy wgs;
  RendererOptions o;
  o.layer = "base";
  o.width = kSize;
  o.height = kSize;
  LayerOptions l;
  l.layer = "vals";
  ValueLayerOptions v;
  v.format = valueFormat();
  v.colourMap = "viridis";
  v.min = 0.0;
  v.max = 100.0;
  l.values = v;
  o.overlays.push_back(l);
  OPEN_RENDERER(r, *proxy.tiles, wgs, o);
  const auto done = gltest::renderComplete(r, kView);
  ASSERT_TRUE(done.complete);
  const Camera cam = r.camera(r.drawnPose());

  // The area: every pixel's point on the globe, and the box around them.
  std::vector<std::optional<Geodetic>> at(static_cast<std::size_t>(kSize * kSize));
  Sector box{180.0, 90.0, -180.0, -90.0}; // west, south, east, north: emptied
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      auto g = pickGlobe(cam, wgs, x + 0.5 - kSize / 2.0, kSize / 2.0 - (y + 0.5));
      if (!g) continue;
      box.west = std::min(box.west, g->lonDeg);
      box.east = std::max(box.east, g->lonDeg);
      box.south = std::min(box.south, g->latDeg);
      box.north = std::max(box.north, g->latDeg);
      at[static_cast<std::size_t>(y * kSize + x)] = g;
    }
  ASSERT_LT(box.west, 34.0); // the view holds the four tiles' corner (36 E, 18 N)
  ASSERT_GT(box.east, 38.0);
  ASSERT_LT(box.south, 16.0);
  ASSERT_GT(box.north, 20.0);
  char bbox[160];
  std::snprintf(
      bbox, sizeof bbox, "%.10f,%.10f,%.10f,%.10f", box.west, box.south, box.east, box.north);
  const HttpResponse map =
      proxy.get(std::string("SERVICE=WMS&VERSION=1.3.0&REQUEST=GetMap&LAYERS=vals&STYLES=viridis"
                            "&CRS=CRS:84&FORMAT=image/png&TRANSPARENT=TRUE&WIDTH=") +
                std::to_string(kMapSize) + "&HEIGHT=" + std::to_string(kMapSize) + "&BBOX=" + bbox);
  ASSERT_EQ(map.status, 200) << std::string(reinterpret_cast<const char*>(map.body.data()),
                                            std::min<std::size_t>(map.body.size(), 400));
  const auto im = codec::decodePng(map.body);
  ASSERT_TRUE(im) << im.error();
  ASSERT_EQ(im->channels, 4);

  const auto colours = indexOfColour();
  const values::ColourScale scale{values::findColourMap("viridis"), 0.0, 100.0};
  Agreement renderVsMap, clampedRuleVsRender, nearestVsMap;
  int reported = 0;
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      const auto& g = at[static_cast<std::size_t>(y * kSize + x)];
      if (!g) continue;
      const int mx = static_cast<int>((g->lonDeg - box.west) / (box.east - box.west) * kMapSize);
      const int my = static_cast<int>((box.north - g->latDeg) / (box.north - box.south) * kMapSize);
      if (mx < 0 || my < 0 || mx >= kMapSize || my >= kMapSize) continue;
      const auto* m = &im->pixels[static_cast<std::size_t>((my * kMapSize + mx) * 4)];
      const auto* p = &done.pixels[static_cast<std::size_t>((y * kSize + x) * 4)];
      const std::uint32_t mapRgb = (std::uint32_t(m[0]) << 16) | (std::uint32_t(m[1]) << 8) | m[2];
      const std::uint32_t renderRgb =
          (std::uint32_t(p[0]) << 16) | (std::uint32_t(p[1]) << 8) | p[2];
      const bool mapNaN = m[3] == 0;
      const bool renderNaN = renderRgb == 0x808080u; // the grey base shows through
      // The map's index (any of its colour's), the render's distance to it.
      const auto mi = colours.find(mapRgb);
      const int mapIndex = mapNaN || mi == colours.end() ? -1 : mi->second.front();
      // Texel coordinates in the level-0 grid, and the distances to tile and texel edges.
      const double gx = (g->lonDeg + 180.0) / kTexelDeg, gy = (90.0 - g->latDeg) / kTexelDeg;
      const auto edgeOf = [](double c, double period) {
        const double f = c / period - std::floor(c / period);
        return std::min(f, 1.0 - f) * period;
      };
      const double tileEdge = std::min(edgeOf(gx, kTile), edgeOf(gy, kTile));
      const double texelEdge = std::min(edgeOf(gx, 1.0), edgeOf(gy, 1.0));
      // Beside no data the value jumps: where a no-data texel enters the four around the point
      // (the centre lines of the texels next to it) and, while one is among them, where the
      // point's own texel changes (texel edges). Near a jump: the rule's choice (bilinear, or
      // which texel) is not the same within 0.15 texel of the point.
      std::array<std::int64_t, 4> choice{};
      int k = 0;
      for (const double dx : {-kMargin, kMargin})
        for (const double dy : {-kMargin, kMargin}) {
          const auto i = static_cast<std::int64_t>(std::floor(gx + dx - 0.5));
          const auto j = static_cast<std::int64_t>(std::floor(gy + dy - 0.5));
          const bool withNaN = std::isnan(texelValue(i, j)) || std::isnan(texelValue(i + 1, j)) ||
                               std::isnan(texelValue(i, j + 1)) ||
                               std::isnan(texelValue(i + 1, j + 1));
          choice[static_cast<std::size_t>(k++)] =
              withNaN ? static_cast<std::int64_t>(std::floor(gx + dx)) * 100000 +
                            static_cast<std::int64_t>(std::floor(gy + dy))
                      : -1;
        }
      const bool nearJump =
          choice[0] != choice[1] || choice[0] != choice[2] || choice[0] != choice[3];
      const bool foreign =
          (!renderNaN && !colours.contains(renderRgb)) || (!mapNaN && mapIndex < 0);
      const int off = foreign               ? -1
                      : renderNaN || mapNaN ? 0
                                            : indexDistance(colours, renderRgb, mapIndex);
      renderVsMap.add(renderNaN, mapNaN, off, tileEdge, texelEdge, nearJump);
      if (!nearJump && tileEdge >= 0.6 && off > 2 && reported++ < 5)
        std::printf("pixel %d,%d (%.4f N %.4f E, texel %.3f,%.3f): %d indices apart\n",
                    x,
                    y,
                    g->latDeg,
                    g->lonDeg,
                    gx,
                    gy,
                    off);

      // The rule the render states, on the CPU: values/Sample.hpp inside the point's own tile
      // (a node's texture holds no neighbour texels: clamped at its edges).
      const auto tileCol = static_cast<std::int64_t>(std::floor(gx / kTile));
      const auto tileRow = static_cast<std::int64_t>(std::floor(gy / kTile));
      const auto cx = values::axisTexels(gx - double(tileCol * kTile), kTile);
      const auto cy = values::axisTexels(gy - double(tileRow * kTile), kTile);
      const auto tv = [&](int i, int j) {
        return double(texelValue(tileCol * kTile + i, tileRow * kTile + j));
      };
      const double clamped = values::bilinearValue(
          tv(cx.i0, cy.i0), tv(cx.i1, cy.i0), tv(cx.i0, cy.i1), tv(cx.i1, cy.i1), cx.f, cy.f);
      const int clampedIndex = values::colourIndex(scale, static_cast<float>(clamped));
      clampedRuleVsRender.add(
          std::isnan(clamped),
          renderNaN,
          renderNaN || clampedIndex < 0 ? 0 : indexDistance(colours, renderRgb, clampedIndex),
          tileEdge,
          texelEdge,
          nearJump);
      // The former rule (the nearest texel) against the map: must break the tolerance.
      const float nearest = texelValue(static_cast<std::int64_t>(std::floor(gx)),
                                       static_cast<std::int64_t>(std::floor(gy)));
      const int nearestIndex = values::colourIndex(scale, nearest);
      nearestVsMap.add(std::isnan(nearest),
                       mapNaN,
                       mapNaN || nearestIndex < 0 ? 0 : std::abs(nearestIndex - mapIndex),
                       tileEdge,
                       texelEdge,
                       nearJump);
    }
  std::printf("render vs GetMap: %s\n", renderVsMap.text().c_str());
  std::printf("stated rule (CPU) vs render: %s\n", clampedRuleVsRender.text().c_str());
  std::printf("former nearest rule vs GetMap: %s\n", nearestVsMap.text().c_str());

  EXPECT_GT(renderVsMap.interior, kSize * kSize / 2);
  EXPECT_GT(renderVsMap.noData, 500);    // both discs in view
  EXPECT_GT(renderVsMap.strip, 1000);    // the tile edges in view
  EXPECT_GT(renderVsMap.switching, 500); // the discs' rims
  EXPECT_EQ(renderVsMap.foreign, 0);
  EXPECT_EQ(renderVsMap.noDataMismatch, 0);
  EXPECT_GE(renderVsMap.interiorWithin1(), 0.995) << renderVsMap.text();
  EXPECT_LE(renderVsMap.interiorMax, 2) << renderVsMap.text();
  EXPECT_GE(double(renderVsMap.switchingWithin1) / renderVsMap.switching, 0.97)
      << renderVsMap.text();
  // Along tile edges: the render follows its stated (clamped) rule; the residual against the
  // map is at most half the change across one texel (here up to ~4 indices) plus the above.
  EXPECT_LE(renderVsMap.stripMax, 6) << renderVsMap.text();
  EXPECT_EQ(clampedRuleVsRender.foreign, 0);
  EXPECT_EQ(clampedRuleVsRender.noDataMismatch, 0);
  EXPECT_GE(double(clampedRuleVsRender.stripWithin1) / clampedRuleVsRender.strip, 0.99)
      << clampedRuleVsRender.text();
  EXPECT_GE(clampedRuleVsRender.interiorWithin1(), 0.995) << clampedRuleVsRender.text();
  EXPECT_LE(clampedRuleVsRender.interiorMax, 2);
  // The tolerance tells the rules apart: the nearest texel is farther than 2 indices from the
  // map for a good share of the pixels.
  EXPECT_GT(nearestVsMap.interiorMax, 2) << nearestVsMap.text();
  EXPECT_LT(nearestVsMap.interiorWithin1(), 0.995) << nearestVsMap.text();
}

} // namespace
