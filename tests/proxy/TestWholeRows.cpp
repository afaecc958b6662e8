// Polar rows fetched whole (issue 29, docs/design/poles.md): `<layer>@caps` is the row's box at
// 8 x 1 tiles, asked for in kCapBands bands (CapBands.hpp), `<layer>@span<k>` ONE GetMap of k
// tiles' box at one tile's size, each cached as a tile of its own dataset; against a real
// loopback server.

#include "../../proxy/src/tiles/CapBands.hpp"
#include "../support/CacheFixtures.hpp"
#include "../support/SyntheticWms.hpp"
#include "../support/TempDir.hpp"

#include <tellus/cache/CacheMaintenance.hpp>
#include <tellus/cache/TileCache.hpp>
#include <tellus/cache/TilePath.hpp>
#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/HttpServer.hpp>
#include <tellus/proxy/ImageCodec.hpp>
#include <tellus/proxy/ProxyFrontEnd.hpp>
#include <tellus/proxy/RemoteTileSource.hpp>
#include <tellus/proxy/TileService.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <charconv>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <mutex>
#include <set>
#include <span>
#include <tuple>

using namespace tellus;
using namespace std::chrono_literals;

namespace {

constexpr int kLevels = 4;

/** A tile source's answer to one address (the in-process service or a remote one). */
TileResult awaitTile(ITileSource& src, const std::string& layer, const TileKey& key) {
  std::mutex m;
  std::condition_variable cv;
  std::optional<TileResult> got;
  src.request({layer, "", key}, 1.0, [&](TileResult&& r) {
    std::lock_guard lock(m);
    got = std::move(r);
    cv.notify_all();
  });
  std::unique_lock lock(m);
  EXPECT_TRUE(cv.wait_for(lock, 10s, [&] { return got.has_value(); }));
  return got ? std::move(*got) : TileResult{};
}

/** A tile service over one upstream: layer "sat" (global, 36-degree, 256-px JPEG, 4 levels) and
 * layer "band" (every longitude, latitudes -54..54: no pole). */
struct RowService {
  test::TempDir dir{"whole-rows"};
  std::unique_ptr<TileCache> cache = test::openTestCache(dir.path());
  Fetcher fetcher;
  std::unique_ptr<TileService> tiles;

  RowService(const std::string& url, UpstreamSpec::Type type) {
    UpstreamSpec u;
    u.name = "up";
    u.type = type;
    u.url = url;
    u.policy.retries = 0;
    u.policy.timeout = 5000ms;
    LayerSpec l;
    l.name = "sat";
    l.upstream = "up";
    l.dataset.grid = GridSpec{Sector{}, 36.0, 256, 256, kLevels};
    l.dataset.mimeType = "image/jpeg";
    LayerSpec band = l;
    band.name = "band";
    band.dataset.grid.sector = Sector{-180.0, -54.0, 180.0, 54.0};
    auto t = TileService::create(*cache, fetcher, {u}, {l, band}, {});
    EXPECT_TRUE(t) << (t ? "" : t.error());
    tiles = std::move(*t);
  }

  TileResult get(const std::string& layer, const TileKey& key) {
    return awaitTile(*tiles, layer, key);
  }

  /** The file a whole row is kept in: tile (level, row, 0) of dataset "sat@caps". */
  std::filesystem::path capFile(const TileKey& key) const {
    DatasetSpec s = tiles->layer("sat")->dataset;
    s.name = "sat@caps";
    s.grid.tileWidth *= kWholeRowWidthFactor;
    return dir.path() / datasetFolder(s) / tileRelativePath(key, "jpg");
  }
};

/** A RowService behind `tellus serve`'s front end on a loopback port. */
struct ServedRows {
  ServedRows(const std::string& url, UpstreamSpec::Type type)
      : rows(url, type), front(*rows.tiles, {}),
        http(oneThread(), [this](HttpRequest&& r, Responder respond) {
          front.handle(std::move(r), std::move(respond));
        }) {
    EXPECT_TRUE(http.start());
  }
  ~ServedRows() { http.stop(); }
  static HttpServerOptions oneThread() {
    HttpServerOptions so;
    so.threads = 1;
    return so;
  }
  std::string base() const { return "http://127.0.0.1:" + std::to_string(http.port()); }

  RowService rows;
  ProxyFrontEnd front;
  HttpServer http;
};

std::int64_t lastRow(int level) {
  return (std::int64_t{5} << level) - 1;
}

/** A number as a URL writes it: the shortest form that reads back the same. */
std::string shortest(double v) {
  char buf[32];
  return {buf, std::to_chars(buf, buf + sizeof buf, v).ptr};
}

/** PSNR of two decoded images of the same size. */
double rowPsnr(const DecodedImage& a, const DecodedImage& b) {
  double sum = 0.0;
  for (std::size_t i = 0; i < a.pixels.size(); ++i) {
    const double d = static_cast<double>(a.pixels[i]) - static_cast<double>(b.pixels[i]);
    sum += d * d;
  }
  return 10.0 * std::log10(255.0 * 255.0 * static_cast<double>(a.pixels.size()) / sum);
}

} // namespace

// Both poles at level 0 and at the deepest level: the row's whole box at 2048 x 256 (8 tiles of
// 256 px) asked for in its bands (capBands: boxes and sizes as that function makes them), the
// cap's picture the source's (PSNR >= 35 dB against one GetMap of the row), kept under the
// "sat@caps" dataset, served from the cache the second time.
TEST(WholeRows, ACapIsItsRowInBandsCachedUnderItsOwnKey) {
  test::FakeUpstream up([](const test::FakeRequest& r) { return test::syntheticReply(r); });
  RowService s(up.url("/wms"), UpstreamSpec::Type::Wms);
  EXPECT_TRUE(s.tiles->wholePolarRows("sat"));
  for (const int level : {0, kLevels - 1})
    for (const bool north : {true, false}) {
      SCOPED_TRACE(std::to_string(level) + (north ? " north" : " south"));
      const TileKey key{level, north ? lastRow(level) : 0, 0};
      const double d = std::ldexp(36.0, -level);
      const Sector row{-180.0, north ? 90.0 - d : -90.0, 180.0, north ? 90.0 : -90.0 + d};
      const auto bands = capBands(row, 2048, 256);
      ASSERT_EQ(bands.size(), static_cast<std::size_t>(kCapBands));
      const std::size_t before = up.requests();
      const TileResult first = s.get("sat@caps", key);
      ASSERT_EQ(first.status, TileStatus::Ok) << first.message;
      ASSERT_EQ(up.requests(), before + bands.size());
      std::multiset<std::string> asked, expected;
      for (std::size_t i = before; i < up.requests(); ++i) {
        const auto p = test::queryParams(up.received()[i].target);
        asked.insert(p.at("BBOX") + " " + p.at("WIDTH") + "x" + p.at("HEIGHT"));
      }
      for (const CapBand& b : bands)
        expected.insert(shortest(b.box.south) + ",-180," + shortest(b.box.north) + ",180 " +
                        std::to_string(b.width) + "x" + std::to_string(b.height));
      EXPECT_EQ(asked, expected);
      const auto img = decodeImagery(first.bytes, "image/jpeg", 2048, 256);
      ASSERT_TRUE(img) << img.error();
      const std::string ref =
          test::syntheticJpeg(row.west, row.south, row.east, row.north, 2048, 256);
      const auto want =
          decodeImagery(std::as_bytes(std::span(ref.data(), ref.size())), "image/jpeg", 2048, 256);
      ASSERT_TRUE(want);
      EXPECT_GE(rowPsnr(*img, *want), 35.0);
      EXPECT_TRUE(std::filesystem::exists(s.capFile(key))) << s.capFile(key);
      const TileResult again = s.get("sat@caps", key);
      ASSERT_EQ(again.status, TileStatus::Ok);
      EXPECT_EQ(up.requests(), before + bands.size()); // from the cache
      EXPECT_EQ(again.bytes, first.bytes);
    }
  // Its own dataset: verify finds the index and the tree in step, rebuild finds its tiles again,
  // a prune of it removes them.
  CacheMaintenance m(*s.cache);
  const auto report = m.verify();
  ASSERT_TRUE(report);
  EXPECT_TRUE(report->ok());
  const auto rebuilt = m.rebuild(); // the index refilled from the tree alone
  ASSERT_TRUE(rebuilt);
  EXPECT_EQ(*rebuilt, 4);
  const auto stats = m.stats();
  ASSERT_TRUE(stats);
  bool listed = false;
  for (const auto& d : *stats)
    if (d.dataset.spec.name == "sat@caps")
      listed = d.tiles == 4 && d.dataset.spec.grid.tileWidth == 2048;
  EXPECT_TRUE(listed);
  PruneOptions prune;
  prune.datasetName = "sat@caps";
  const auto removed = m.prune(prune);
  ASSERT_TRUE(removed);
  EXPECT_EQ(*removed, 4);
  EXPECT_FALSE(std::filesystem::exists(s.capFile({0, 0, 0})));
}

// Only rows on a pole, at column 0, exist; a layer without a pole has none.
TEST(WholeRows, OnlyPolarRowsOfLayersThatReachAPole) {
  test::FakeUpstream up([](const test::FakeRequest& r) { return test::syntheticReply(r); });
  RowService s(up.url("/wms"), UpstreamSpec::Type::Wms);
  EXPECT_FALSE(s.tiles->wholePolarRows("band"));
  EXPECT_EQ(s.get("band@caps", {0, 0, 0}).status, TileStatus::Failed);      // no such layer
  EXPECT_EQ(s.get("sat@caps", {0, 2, 0}).status, TileStatus::Absent);       // not a polar row
  EXPECT_EQ(s.get("sat@caps", {0, 4, 1}).status, TileStatus::Absent);       // not column 0
  EXPECT_EQ(s.get("sat@caps", {kLevels, 0, 0}).status, TileStatus::Absent); // below the deepest
  EXPECT_EQ(up.requests(), 0u);
  EXPECT_EQ(s.tiles->layers().size(), 2u); // no client sees "sat@caps"
  EXPECT_EQ(s.tiles->layer("sat@caps"), nullptr);
}

// A World Wind server serves only its grid: no whole rows, the renderer composes.
TEST(WholeRows, ATileOnlyUpstreamHasNone) {
  test::FakeUpstream up([](const test::FakeRequest& r) { return test::syntheticReply(r); });
  RowService s(up.url("/tiles"), UpstreamSpec::Type::WorldWind);
  EXPECT_FALSE(s.tiles->wholePolarRows("sat"));
  EXPECT_EQ(s.get("sat@caps", {0, 4, 0}).status, TileStatus::Failed);
  EXPECT_EQ(s.get("sat", {0, 4, 0}).status, TileStatus::Ok);
}

// A failing or hostile answer for a whole row is never kept: 500, an error page, a JPEG of the
// wrong size, bytes that are no image, or one band of eight failing (the band at the pole) while
// the others answer; the next request, all bands answering, stores the cap.
TEST(WholeRows, ABadAnswerIsRefusedAndNothingIsCached) {
  std::atomic<int> mode = 0;
  test::FakeUpstream up([&](const test::FakeRequest& r) {
    const bool pole = test::queryParams(r.target).at("BBOX").ends_with(",90,180");
    switch (mode) {
    case 4:
      return pole ? test::FakeReply::withStatus(500, "down") : test::syntheticReply(r);
    case 5:
      return test::syntheticReply(r);
    case 0:
      return test::FakeReply::withStatus(500, "down");
    case 1:
      return test::FakeReply::ok("<html>error</html>", "text/html");
    case 2:
      return test::FakeReply::ok(test::syntheticJpeg(-180, 72, 180, 90, 2048, 255), "image/jpeg");
    default:
      return test::FakeReply::ok("not a jpeg at all", "image/jpeg");
    }
  });
  for (int m = 0; m < 5; ++m) {
    mode = m;
    SCOPED_TRACE(m);
    // A service each: eight failed bands open the upstream's breaker (five failures in a row).
    RowService s(up.url("/wms"), UpstreamSpec::Type::Wms);
    const TileResult r = s.get("sat@caps", {0, 4, 0});
    EXPECT_EQ(r.status, TileStatus::Failed);
    EXPECT_NE(r.message.find(m == 0 || m == 4 ? "HTTP 500" : "did not send a tile"),
              std::string::npos)
        << r.message;
    EXPECT_FALSE(std::filesystem::exists(s.capFile({0, 4, 0})));
    const auto stats = CacheMaintenance(*s.cache).stats();
    ASSERT_TRUE(stats);
    for (const auto& d : *stats)
      EXPECT_EQ(d.tiles, 0) << d.dataset.spec.name;
    if (m != 4) continue;
    mode = 5;
    const TileResult ok = s.get("sat@caps", {0, 4, 0});
    EXPECT_EQ(ok.status, TileStatus::Ok) << ok.message;
    EXPECT_TRUE(std::filesystem::exists(s.capFile({0, 4, 0})));
  }
}

// Through `tellus serve`: a renderer's tile service whose WMS upstream is another tellus's /wms
// asks it for the whole row's bands; that server composes each from its own tiles, and the
// picture is the synthetic source's (PSNR >= 35 dB).
TEST(WholeRows, ThroughTellusServeTheSameBandsAreComposedThere) {
  test::FakeUpstream up([](const test::FakeRequest& r) { return test::syntheticReply(r); });
  ServedRows server(up.url("/wms"), UpstreamSpec::Type::Wms);
  RowService renderer(server.base() + "/wms", UpstreamSpec::Type::Wms);
  const TileResult r = renderer.get("sat@caps", {0, 4, 0});
  ASSERT_EQ(r.status, TileStatus::Ok) << r.message;
  EXPECT_EQ(renderer.tiles->upstreamFetches(), static_cast<std::size_t>(kCapBands));
  EXPECT_GE(up.requests(), 10u); // the server's own tiles of the row, from the synthetic WMS
  const auto got = decodeImagery(r.bytes, "image/jpeg", 2048, 256);
  ASSERT_TRUE(got) << got.error();
  const std::string ref = test::syntheticJpeg(-180, 54, 180, 90, 2048, 256); // row 4: 54..90
  const auto want =
      decodeImagery(std::as_bytes(std::span(ref.data(), ref.size())), "image/jpeg", 2048, 256);
  ASSERT_TRUE(want);
  const double psnr = rowPsnr(*got, *want);
  std::printf("through tellus serve: PSNR %.1f dB against the source\n", psnr);
  EXPECT_GE(psnr, 35.0);
}

// A merged row's node of k tiles (k = 2, 4, 8 at the deepest level, by both poles and at the
// row's east end): one GetMap of the k tiles' box, one tile tall and as wide as its equatorward
// parallel needs (wholeSpanTexelWidth: a tile's 256 where k is too wide for the row, 41 for two
// tiles by the pole), stretched to one tile's size (256 x 256), whose picture is the source's
// there; kept under "sat@span<k>" and served from the cache the second time. Keys that start no
// aligned run inside the row, spans wider than a level-zero column's widest row and layers
// without whole rows are refused without asking upstream.
TEST(WholeRows, AMergedNodeIsOneGetMapOfItsBoxAtItsOwnWidth) {
  test::FakeUpstream up([](const test::FakeRequest& r) { return test::syntheticReply(r); });
  RowService s(up.url("/wms"), UpstreamSpec::Type::Wms);
  const int level = kLevels - 1;
  const double d = std::ldexp(36.0, -level);
  const std::int64_t cols = std::int64_t{10} << level;
  std::set<int> widths;
  for (const std::int64_t k : {2, 4, 8})
    for (const std::int64_t row : {lastRow(level), std::int64_t{0}, lastRow(level) - 3})
      for (const std::int64_t col : {std::int64_t{0}, 2 * k, cols - k}) {
        SCOPED_TRACE(std::to_string(k) + " " + std::to_string(row) + " " + std::to_string(col));
        const std::string layer = wholeSpanLayer("sat", k);
        const TileKey key{level, row, col};
        const std::size_t before = up.requests();
        const TileResult first = s.get(layer, key);
        ASSERT_EQ(first.status, TileStatus::Ok) << first.message;
        ASSERT_EQ(up.requests(), before + 1);
        const double west = -180.0 + static_cast<double>(col) * d;
        const double east = west + static_cast<double>(k) * d;
        const double south = -90.0 + static_cast<double>(row) * d;
        char expected[128];
        std::snprintf(expected, sizeof expected, "%g,%g,%g,%g", south, west, south + d, east);
        const auto p = test::queryParams(up.received().back().target);
        EXPECT_EQ(p.at("BBOX"), expected);
        const int width = wholeSpanTexelWidth(Sector{west, south, east, south + d}, 256, 256);
        widths.insert(width);
        EXPECT_EQ(p.at("WIDTH"), std::to_string(width));
        EXPECT_EQ(p.at("HEIGHT"), "256");
        const auto got = decodeImagery(first.bytes, "image/jpeg", 256, 256);
        ASSERT_TRUE(got) << got.error();
        const std::string ref = test::syntheticJpeg(west, south, east, south + d, 256, 256);
        const auto want =
            decodeImagery(std::as_bytes(std::span(ref.data(), ref.size())), "image/jpeg", 256, 256);
        ASSERT_TRUE(want);
        EXPECT_GE(rowPsnr(*got, *want), 35.0);
        DatasetSpec spec = s.tiles->layer("sat")->dataset;
        spec.name = layer;
        EXPECT_TRUE(std::filesystem::exists(s.dir.path() / datasetFolder(spec) /
                                            tileRelativePath(key, "jpg")));
        const TileResult again = s.get(layer, key);
        ASSERT_EQ(again.status, TileStatus::Ok);
        EXPECT_EQ(up.requests(), before + 1); // from the cache
        EXPECT_EQ(again.bytes, first.bytes);
      }
  EXPECT_EQ(widths, (std::set<int>{41, 81, 159, 161, 256})); // by the pole, 2 tiles: 256 x 0.156
  const std::size_t asked = up.requests();
  EXPECT_EQ(s.get("sat@span4", {level, 0, 2}).status, TileStatus::Absent);    // unaligned
  EXPECT_EQ(s.get("sat@span4", {level, 0, cols}).status, TileStatus::Absent); // past the row
  EXPECT_EQ(s.get("sat@span2", {level, 40, 0}).status, TileStatus::Absent);   // past the pole
  EXPECT_EQ(s.get("sat@span2", {kLevels, 0, 0}).status, TileStatus::Absent);  // too deep
  EXPECT_EQ(s.get("sat@span16", {level, 0, 0}).status, TileStatus::Failed);   // wider than any
  EXPECT_EQ(s.get("sat@span3", {level, 0, 0}).status, TileStatus::Failed);    // not a power
  EXPECT_EQ(s.get("band@span2", {level, 10, 0}).status, TileStatus::Failed);  // no pole
  EXPECT_EQ(up.requests(), asked);
  EXPECT_EQ(s.tiles->layers().size(), 2u); // no client sees them
  EXPECT_EQ(s.tiles->layer("sat@span2"), nullptr);
  RowService ww(up.url("/tiles"), UpstreamSpec::Type::WorldWind);
  EXPECT_EQ(ww.get("sat@span2", {level, 0, 0}).status, TileStatus::Failed); // a grid only
}

// A renderer's `--server` source over `tellus serve`: /layers.json says which layers give whole
// rows and spans, and `/tiles/<layer>@caps/...` and `/tiles/<layer>@span<k>/...` fetch them
// through the server's tile service (a cap's bands, a span's one GetMap, the second time from its
// cache), the same bytes an in-process service makes. A server over a World Wind upstream offers
// none.
TEST(WholeRows, ARemoteSourceGetsThemFromTellusServe) {
  test::FakeUpstream up([](const test::FakeRequest& r) { return test::syntheticReply(r); });
  for (const auto type : {UpstreamSpec::Type::Wms, UpstreamSpec::Type::WorldWind}) {
    const bool wms = type == UpstreamSpec::Type::Wms;
    SCOPED_TRACE(wms ? "wms" : "world wind");
    ServedRows server(up.url(wms ? "/wms" : "/tiles"), type);
    auto src = RemoteTileSource::connect(server.base());
    ASSERT_TRUE(src) << src.error();
    EXPECT_EQ((*src)->wholePolarRows("sat"), wms);
    EXPECT_FALSE((*src)->wholePolarRows("band"));
    if (!wms) {
      EXPECT_EQ(awaitTile(**src, "sat@caps", {0, 4, 0}).status, TileStatus::Failed);
      EXPECT_EQ(awaitTile(**src, "sat", {0, 4, 0}).status, TileStatus::Ok);
      continue;
    }
    RowService local(up.url("/wms"), UpstreamSpec::Type::Wms); // in-process, for the bytes
    const auto caps = static_cast<std::size_t>(kCapBands);
    // What is asked for: a cap's bands, the rim's as wide as the cap; a merged node's box by the
    // pole at its own width (81 texels for 4 tiles at 85.5 degrees), stretched to 256.
    for (const auto& [layer, key, width, fetches, asked] :
         {std::tuple{std::string("sat@caps"), TileKey{0, 4, 0}, 2048, caps, 2048},
          std::tuple{std::string("sat@caps"), TileKey{kLevels - 1, 0, 0}, 2048, caps, 2048},
          std::tuple{wholeSpanLayer("sat", 4),
                     TileKey{kLevels - 1, lastRow(kLevels - 1), 8},
                     256,
                     std::size_t{1},
                     81}}) {
      SCOPED_TRACE(layer);
      const std::size_t before = up.requests();
      const TileResult r = awaitTile(**src, layer, key);
      ASSERT_EQ(r.status, TileStatus::Ok) << r.message;
      ASSERT_EQ(up.requests(), before + fetches);
      int widest = 0;
      for (std::size_t i = before; i < up.requests(); ++i)
        widest =
            std::max(widest, std::stoi(test::queryParams(up.received()[i].target).at("WIDTH")));
      EXPECT_EQ(widest, asked);
      EXPECT_TRUE(decodeImagery(r.bytes, "image/jpeg", width, 256));
      EXPECT_EQ(awaitTile(**src, layer, key).bytes, r.bytes); // from the server's cache
      EXPECT_EQ(up.requests(), before + fetches);
      EXPECT_EQ(local.get(layer, key).bytes, r.bytes);
    }
    const std::size_t asked = up.requests();
    EXPECT_EQ(awaitTile(**src, "sat@span3", {kLevels - 1, 0, 0}).status, TileStatus::Failed);
    EXPECT_EQ(awaitTile(**src, "band@caps", {0, 0, 0}).status, TileStatus::Failed);
    EXPECT_EQ(awaitTile(**src, "sat@caps", {0, 2, 0}).status, TileStatus::Absent); // no pole
    EXPECT_EQ(up.requests(), asked);
  }
}
