// Metatiles: the DCT-domain split of a JPEG (tellus/codec/JpegSplit.hpp), the block arithmetic
// (MetaTile), and seeding through the tile service with one GetMap per metatile against a fake WMS
// that draws georeferenced pixels (so every tile can be checked against where it is on the globe).

#include "../../proxy/src/tiles/MetaTile.hpp"
#include "../support/CacheFixtures.hpp"
#include "../support/FakeUpstream.hpp"
#include "../support/HttpClient.hpp"
#include "../support/TempDir.hpp"

#include <tellus/cache/TileCache.hpp>
#include <tellus/codec/Jpeg.hpp>
#include <tellus/codec/JpegSplit.hpp>
#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/HttpServer.hpp>
#include <tellus/proxy/ImageCodec.hpp>
#include <tellus/proxy/ProxyFrontEnd.hpp>
#include <tellus/proxy/Seeder.hpp>
#include <tellus/proxy/TileService.hpp>

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <future>
#include <mutex>
#include <thread>

using namespace tellus;
using namespace std::chrono_literals;

namespace {

constexpr std::size_t sz(int v) {
  return static_cast<std::size_t>(v);
}

/** Smooth but not flat colours with some texture: what a JPEG encoder meets in imagery. */
std::vector<std::uint8_t> testPixels(int w, int h, int channels) {
  std::vector<std::uint8_t> px(sz(w) * sz(h) * sz(channels));
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      for (int c = 0; c < channels; ++c) {
        const double v = 128 + 60 * std::sin(x * 0.031 * (c + 1) + y * 0.017) +
                         40 * std::cos(y * 0.043 * (c + 2) - x * 0.011) + ((x * 7 + y * 13) % 17);
        px[(sz(y) * sz(w) + sz(x)) * sz(channels) + sz(c)] =
            static_cast<std::uint8_t>(std::clamp(v, 0.0, 255.0));
      }
    }
  }
  return px;
}

/** Encodes grey or RGB pixels with libjpeg's defaults (4:2:0 for colour) at quality 90. */
std::vector<std::byte> encodeTestJpeg(int w, int h, int channels, const std::uint8_t* px) {
  auto e = codec::encodeJpeg(w, h, channels, px);
  EXPECT_TRUE(e) << (e ? "" : e.error());
  return e ? *e : std::vector<std::byte>{};
}

double meanAbsDiff(const std::vector<std::uint8_t>& a, const std::vector<std::uint8_t>& b) {
  EXPECT_EQ(a.size(), b.size());
  double sum = 0;
  for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i)
    sum += std::abs(static_cast<int>(a[i]) - static_cast<int>(b[i]));
  return a.empty() ? 0 : sum / static_cast<double>(a.size());
}

} // namespace

// ------------------------------------------------------------------------------ splitting

TEST(MetaTile, MisalignedJpegTilesAreDecodedOnceAndEncoded) {
  // 200 px tiles do not fall on 4:2:0's 16-px iMCUs.
  const auto px = testPixels(400, 200, 3);
  const auto whole = encodeTestJpeg(400, 200, 3, px.data());
  auto dct = codec::splitJpegDct(whole, 2, 1, 200, 200);
  ASSERT_FALSE(dct);
  EXPECT_EQ(dct.error().code, codec::JpegSplitErrc::NotAligned);
  auto split = splitMetaTile(whole, ImageKind::Jpeg, 2, 1, 200, 200);
  ASSERT_TRUE(split) << split.error();
  EXPECT_EQ(split->how, MetaSplit::Decoded);
  ASSERT_EQ(split->tiles.size(), 2u);
  std::vector<std::uint8_t> all;
  ASSERT_TRUE(codec::decodeJpegInto(whole, 400, 200, all, nullptr));
  for (int t = 0; t < 2; ++t) {
    std::vector<std::uint8_t> got;
    ASSERT_TRUE(codec::decodeJpegInto(split->tiles[sz(t)], 200, 200, got, nullptr));
    std::vector<std::uint8_t> want;
    for (int y = 0; y < 200; ++y)
      want.insert(want.end(),
                  all.begin() + (y * 400 + t * 200) * 3,
                  all.begin() + (y * 400 + t * 200 + 200) * 3); // int offsets: small
    EXPECT_LT(meanAbsDiff(got, want), 2.5) << "one more JPEG generation";
  }
  // Aligned ones take the DCT path.
  const auto aligned = encodeTestJpeg(512, 256, 3, testPixels(512, 256, 3).data());
  auto fast = splitMetaTile(aligned, ImageKind::Jpeg, 2, 1, 256, 256);
  ASSERT_TRUE(fast) << fast.error();
  EXPECT_EQ(fast->how, MetaSplit::Dct);
}

TEST(MetaTile, APngMetaTileIsSplitLosslessly) {
  const auto png = *encodeImage("image/png", 512, 256, 3, testPixels(512, 256, 3).data());
  auto p = splitMetaTile(png, ImageKind::Png, 2, 1, 256, 256);
  ASSERT_TRUE(p) << p.error();
  const auto right = *decodeImagery(p->tiles[1], "image/png", 256, 256);
  const auto src = testPixels(512, 256, 3);
  ASSERT_EQ(right.channels, 3); // opaque: written as RGB
  for (int y = 0; y < 256; ++y)
    ASSERT_TRUE(std::equal(right.pixels.begin() + y * 256 * 3,
                           right.pixels.begin() + (y + 1) * 256 * 3,
                           src.begin() + (y * 512 + 256) * 3))
        << "row " << y;
}

TEST(MetaTile, ALazySplitEncodesEachTileOnItsOwnAsTheEagerSplitDoes) {
  // The service encodes a decoded metatile's tiles one task each, the asked-for tile first.
  for (const ImageKind kind : {ImageKind::Png, ImageKind::Jpeg}) {
    const auto px = testPixels(400, 400, 3);
    const auto body = kind == ImageKind::Png ? *encodeImage("image/png", 400, 400, 3, px.data())
                                             : encodeTestJpeg(400, 400, 3, px.data());
    auto eager = splitMetaTile(body, kind, 2, 2, 200, 200);
    auto lazy = splitMetaTileLazily(body, kind, 2, 2, 200, 200);
    ASSERT_TRUE(eager && lazy);
    EXPECT_EQ(lazy->how, MetaSplit::Decoded);
    EXPECT_TRUE(lazy->tiles.empty());
    ASSERT_TRUE(lazy->decoded);
    ASSERT_EQ(eager->tiles.size(), 4u);
    for (std::size_t i : {3U, 0U, 2U, 1U}) { // any order
      auto part = encodeMetaTilePart(*lazy->decoded, i);
      ASSERT_TRUE(part) << part.error();
      EXPECT_EQ(*part, eager->tiles[i]) << "tile " << i;
    }
  }
  // An aligned JPEG is cut at once (no pixels), a broken image refused before any tile.
  const auto aligned = encodeTestJpeg(512, 256, 3, testPixels(512, 256, 3).data());
  auto cut = splitMetaTileLazily(aligned, ImageKind::Jpeg, 2, 1, 256, 256);
  ASSERT_TRUE(cut);
  EXPECT_EQ(cut->how, MetaSplit::Dct);
  EXPECT_EQ(cut->tiles.size(), 2u);
  EXPECT_FALSE(cut->decoded);
  auto png = *encodeImage("image/png", 512, 256, 3, testPixels(512, 256, 3).data());
  png.resize(png.size() / 2);
  EXPECT_FALSE(splitMetaTileLazily(png, ImageKind::Png, 2, 1, 256, 256));
}

// ------------------------------------------------------------------------------ block arithmetic

TEST(MetaTile, BlocksAreAlignedAndClippedAtTheGridsEdges) {
  const auto grid = *TileGrid::create(GridSpec{Sector{}, 36.0, 512, 512, 5});
  // Level 0 is 10 x 5 tiles: blocks 4x4, 4x4, 2x4 and 4x1, 4x1, 2x1.
  EXPECT_EQ(metaTileOf(grid, TileKey{0, 0, 0}, 4), (TileBlock{0, 0, 0, 4, 4}));
  EXPECT_EQ(metaTileOf(grid, TileKey{0, 3, 5}, 4), (TileBlock{0, 0, 4, 4, 4}));
  EXPECT_EQ(metaTileOf(grid, TileKey{0, 2, 9}, 4), (TileBlock{0, 0, 8, 4, 2}));
  EXPECT_EQ(metaTileOf(grid, TileKey{0, 4, 9}, 4), (TileBlock{0, 4, 8, 1, 2}));
  EXPECT_EQ(metaTileOf(grid, TileKey{1, 9, 19}, 4), (TileBlock{1, 8, 16, 2, 4}));
  EXPECT_EQ(metaTileOf(grid, TileKey{1, 9, 19}, 1), (TileBlock{1, 9, 19, 1, 1}));
  // Its sector ends exactly at the antimeridian and the pole; the first starts at -180, -90.
  const Sector ne = blockSector(grid, metaTileOf(grid, TileKey{0, 4, 9}, 4));
  EXPECT_EQ(ne.east, 180.0);
  EXPECT_EQ(ne.north, 90.0);
  EXPECT_EQ(ne.west, 108.0);
  EXPECT_EQ(ne.south, 54.0);
  const Sector sw = blockSector(grid, metaTileOf(grid, TileKey{0, 0, 0}, 4));
  EXPECT_EQ(sw, (Sector{-180.0, -90.0, -36.0, 54.0}));
  // Image order: the top-left tile (north-west) first.
  const TileBlock b{0, 0, 8, 4, 2};
  EXPECT_EQ(b.imageIndex(TileKey{0, 3, 8}), 0u);
  EXPECT_EQ(b.imageIndex(TileKey{0, 3, 9}), 1u);
  EXPECT_EQ(b.imageIndex(TileKey{0, 0, 8}), 6u);
  EXPECT_EQ(boundingBlock(std::vector<TileKey>{{2, 5, 7}, {2, 3, 9}, {2, 4, 8}}),
            (TileBlock{2, 3, 7, 3, 3}));
  // A partial dataset: only the tiles inside its sector (level 1: 18-degree tiles).
  const auto part = *TileGrid::create(GridSpec{Sector{0, 0, 54, 36}, 36.0, 512, 512, 5});
  EXPECT_EQ(metaTileOf(part, TileKey{1, 5, 10}, 4), (TileBlock{1, 5, 10, 2, 2}));
  EXPECT_EQ(metaTileOf(part, TileKey{1, 6, 12}, 4), (TileBlock{1, 5, 12, 2, 1}));
}

// ------------------------------------------------------------------------------ through the
// service

namespace {

/** A query parameter of a request target ("" when absent). */
std::string param(const std::string& target, const std::string& name) {
  const auto q = target.find('?');
  std::size_t pos = q == std::string::npos ? 0 : q + 1;
  while (pos < target.size()) {
    auto amp = target.find('&', pos);
    if (amp == std::string::npos) amp = target.size();
    const std::string kv = target.substr(pos, amp - pos);
    const auto eq = kv.find('=');
    if (eq != std::string::npos && kv.substr(0, eq) == name) return kv.substr(eq + 1);
    pos = amp + 1;
  }
  return {};
}

/** The colour of a place on the globe: smooth, so JPEG keeps it well. */
std::array<double, 3> colourAt(double lon, double lat) {
  return {(lon + 180) / 360 * 255,
          (lat + 90) / 180 * 255,
          128 + 90 * std::sin(lon * 0.2) * std::cos(lat * 0.15)};
}

/** A WMS 1.3.0 (EPSG:4326: BBOX south,west,north,east) GetMap answered with colourAt() at each
 * pixel's centre, as JPEG or PNG: a tile and a metatile that hold it agree where they overlap. */
test::FakeReply drawMap(const test::FakeRequest& req) {
  const int w = std::atoi(param(req.target, "WIDTH").c_str());
  const int h = std::atoi(param(req.target, "HEIGHT").c_str());
  double s = 0, west = 0, n = 0, e = 0;
  if (w <= 0 || h <= 0 || w > 4096 || h > 4096 ||
      std::sscanf(param(req.target, "BBOX").c_str(), "%lf,%lf,%lf,%lf", &s, &west, &n, &e) != 4)
    return test::FakeReply::withStatus(400, "bad request");
  std::vector<std::uint8_t> px(sz(w) * sz(h) * 3);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const auto c = colourAt(west + (x + 0.5) * (e - west) / w, n - (y + 0.5) * (n - s) / h);
      for (int k = 0; k < 3; ++k)
        px[(sz(y) * sz(w) + sz(x)) * 3 + sz(k)] =
            static_cast<std::uint8_t>(std::lround(std::clamp(c[sz(k)], 0.0, 255.0)));
    }
  }
  const std::string mime =
      param(req.target, "FORMAT") == "image%2Fpng" ? "image/png" : "image/jpeg";
  const auto bytes = *encodeImage(mime, w, h, 3, px.data());
  return test::FakeReply::ok(std::string(reinterpret_cast<const char*>(bytes.data()), bytes.size()),
                             mime);
}

bool isMetaTileRequest(const test::FakeRequest& r) {
  return param(r.target, "WIDTH") != "256" || param(r.target, "HEIGHT") != "256";
}

/** tellus serve's pieces on one WMS layer "sat" (36-degree grid, 256 px tiles, 4 levels) whose
 * upstream asks for metaTiles x metaTiles tiles per GetMap. */
struct MetaProxy {
  test::TempDir dir{"metatile"};
  std::unique_ptr<TileCache> cache;
  std::unique_ptr<Fetcher> fetcher;
  std::unique_ptr<TileService> tiles;
  std::unique_ptr<ProxyFrontEnd> front;
  std::unique_ptr<HttpServer> server;

  MetaProxy(const std::string& url, int metaTiles, const std::string& mime = "image/jpeg") {
    cache = test::openTestCache(dir.path());
    fetcher = std::make_unique<Fetcher>();
    UpstreamSpec u;
    u.name = "up";
    u.type = UpstreamSpec::Type::Wms;
    u.url = url;
    u.metaTiles = metaTiles;
    u.policy.timeout = 5000ms;
    u.policy.retries = 0;
    u.policy.failureThreshold = 1000;
    LayerSpec l;
    l.name = "sat";
    l.upstream = "up";
    l.dataset.grid = GridSpec{Sector{}, 36.0, 256, 256, 4};
    l.dataset.mimeType = mime;
    TileServiceOptions o;
    o.renderThreads = 4;
    auto t = TileService::create(*cache, *fetcher, {u}, {l}, o);
    EXPECT_TRUE(t) << (t ? "" : t.error());
    tiles = std::move(*t);
    front = std::make_unique<ProxyFrontEnd>(*tiles, FrontEndOptions{});
    HttpServerOptions so;
    so.threads = 2;
    server = std::make_unique<HttpServer>(so, [this](HttpRequest&& r, Responder respond) {
      front->handle(std::move(r), std::move(respond));
    });
    EXPECT_TRUE(server->start());
  }
  ~MetaProxy() {
    server->stop();
    front.reset();
    tiles.reset();
    fetcher.reset();
  }
  DatasetId dataset() { return *cache->registerDataset(*tiles->describe("sat")); }
  std::optional<std::vector<std::byte>> cached(const TileKey& k) {
    auto got = cache->get(dataset(), k);
    if (!got || got->kind != CacheLookup::Kind::Hit) return std::nullopt;
    return got->bytes;
  }
  std::string url(const std::string& target) const {
    return "http://127.0.0.1:" + std::to_string(server->port()) + target;
  }
};

ServiceSeedOptions seedRange(int from, int to, Sector box) {
  ServiceSeedOptions o;
  o.range.fromLevel = from;
  o.range.toLevel = to;
  o.range.box = box;
  o.concurrency = 4;
  return o;
}

} // namespace

TEST(MetaTileIntegration, SeedingAsksOneGetMapPerMetaTileAndTheTilesAreWhereTheyBelong) {
  for (const std::string mime : {"image/jpeg", "image/png"}) {
    SCOPED_TRACE(mime);
    test::FakeUpstream up(drawMap);
    MetaProxy meta(up.url("/wms"), 4, mime);
    MetaProxy single(up.url("/wms"), 1, mime);
    // Level 0, the north-east corner of the globe: columns 6-9 (to the antimeridian), rows 2-4
    // (to the pole): 12 tiles in four metatiles (2x2, 2x2, 2x1, 2x1); level 1 below it: columns
    // 12-19, rows 4-9, 48 tiles in four (4x4, 4x4, 4x2, 4x2; the globe has 10 rows there).
    const Sector box{36, -18, 180, 90};
    auto r = seedThroughService(*meta.tiles, *meta.cache, "sat", seedRange(0, 1, box));
    ASSERT_TRUE(r) << r.error();
    EXPECT_EQ(r->planned, 12 + 48);
    EXPECT_EQ(r->written, 60);
    EXPECT_EQ(r->failed, 0) << (r->failures.empty() ? "" : r->failures[0]);
    EXPECT_EQ(up.requests(), 4u + 4u);
    EXPECT_EQ(meta.tiles->metaTileFetches(), 8u);
    EXPECT_EQ(meta.tiles->metaTileSize("sat"), 4);
    EXPECT_EQ(single.tiles->metaTileSize("sat"), 1);
    const std::size_t before = up.requests();
    auto s = seedThroughService(*single.tiles, *single.cache, "sat", seedRange(0, 1, box));
    ASSERT_TRUE(s) << s.error();
    EXPECT_EQ(s->written, 60);
    EXPECT_EQ(up.requests() - before, 60u);
    const auto grid = *meta.tiles->grid("sat");
    const auto level0 = *grid.keysCovering(box, 0);
    for (const auto& k : level0) {
      for (const TileKey key :
           {k, TileKey{1, k.row * 2, k.col * 2}, TileKey{1, k.row * 2 + 1, k.col * 2 + 1}}) {
        SCOPED_TRACE(::testing::Message()
                     << "L" << key.level << " R" << key.row << " C" << key.col);
        const auto a = meta.cached(key);
        const auto b = single.cached(key);
        ASSERT_TRUE(a && b);
        auto pa = decodeImagery(*a, mime, 256, 256); // a valid tile of the grid's size
        auto pb = decodeImagery(*b, mime, 256, 256);
        ASSERT_TRUE(pa && pb);
        ASSERT_EQ(pa->channels, 3);
        // The same place: the per-tile fetch and the metatile agree (PNG exactly).
        const double diff = meanAbsDiff(pa->pixels, pb->pixels);
        if (mime == "image/png") {
          EXPECT_EQ(diff, 0.0);
        } else {
          EXPECT_LT(diff, 1.5);
        }
        // And where the tile is on the globe: its pixels are colourAt() of their centres.
        const Sector sec = grid.sectorOf(key);
        double err = 0;
        for (int y = 8; y < 256; y += 16) {
          for (int x = 8; x < 256; x += 16) {
            const auto c = colourAt(sec.west + (x + 0.5) * (sec.east - sec.west) / 256,
                                    sec.north - (y + 0.5) * (sec.north - sec.south) / 256);
            for (int ch = 0; ch < 3; ++ch)
              err += std::abs(pa->pixels[(sz(y) * 256 + sz(x)) * 3 + sz(ch)] - c[sz(ch)]);
          }
        }
        EXPECT_LT(err / (16 * 16 * 3), 3.0);
      }
    }
  }
}

TEST(MetaTileIntegration, AFailingMetaTileStoresNothingAndItsTilesAreRetriedOneByOne) {
  // Every way a metatile answer can be wrong; tiles asked one by one are fine.
  const std::vector<std::function<test::FakeReply(const test::FakeRequest&)>> faults{
      [](const test::FakeRequest&) { return test::FakeReply::withStatus(500, "down"); },
      [](const test::FakeRequest&) {
        return test::FakeReply::ok(
            "<?xml version=\"1.0\"?><ServiceExceptionReport><ServiceException>"
            "Image size out of range, WIDTH and HEIGHT must be 2048 or "
            "less</ServiceException></ServiceExceptionReport>",
            "image/jpeg");
      },
      [](const test::FakeRequest& r) { // a JPEG cut in the middle, with an end marker
        auto good = drawMap(r);
        good.body.resize(good.body.size() / 2);
        good.body += "\xFF\xD9";
        return good;
      },
      [](const test::FakeRequest& r) { // half the size asked for
        test::FakeRequest smaller = r;
        const auto w = param(r.target, "WIDTH");
        smaller.target.replace(smaller.target.find("WIDTH=" + w), 6 + w.size(), "WIDTH=256");
        return drawMap(smaller);
      },
  };
  for (std::size_t f = 0; f < faults.size(); ++f) {
    SCOPED_TRACE(f);
    test::FakeUpstream up([&](const test::FakeRequest& r) {
      return isMetaTileRequest(r) ? faults[f](r) : drawMap(r);
    });
    MetaProxy p(up.url("/wms"), 4);
    auto o = seedRange(0, 0, Sector{-180, -90, -108, -18}); // a 2x2 block at level 0
    o.retries = 0;
    auto r = seedThroughService(*p.tiles, *p.cache, "sat", o);
    ASSERT_TRUE(r) << r.error();
    EXPECT_EQ(r->written, 0);
    EXPECT_EQ(r->failed, 4);
    ASSERT_FALSE(r->failures.empty());
    EXPECT_EQ(up.requests(), 1u);
    for (std::int64_t row = 0; row < 2; ++row)
      for (std::int64_t col = 0; col < 2; ++col)
        EXPECT_EQ(p.cache->peek(p.dataset(), TileKey{0, row, col})->kind, CacheLookup::Kind::Miss);
    // With a retry, each tile is asked for alone and stored.
    o.retries = 1;
    auto again = seedThroughService(*p.tiles, *p.cache, "sat", o);
    ASSERT_TRUE(again) << again.error();
    EXPECT_EQ(again->written, 4);
    EXPECT_EQ(again->retried, 4);
    EXPECT_EQ(again->failed, 0);
    EXPECT_EQ(up.requests(), 1u + 1u + 4u);
    if (f == 1) {
      EXPECT_NE(r->failures[0].find("Image size out of range"), std::string::npos)
          << r->failures[0];
    }
  }
}

// The clients ask the tile service as the front end does (getTile): by the time their calls have
// returned they wait on the metatile's flights or have started fetches of their own (which the
// upstream would see), so the metatile's answer is held exactly until then, not for an interval.
TEST(MetaTileIntegration, ServeRequestsForTilesOfAMetaTileInFlightWaitForIt) {
  const auto clientsAsked = std::make_shared<test::Gate>();
  test::FakeUpstream up([&](const test::FakeRequest& r) {
    auto reply = drawMap(r);
    if (isMetaTileRequest(r)) reply.holdUntilOpen = clientsAsked;
    return reply;
  });
  MetaProxy p(up.url("/wms"), 4);
  auto seeding = std::async(std::launch::async, [&] {
    return seedThroughService(
        *p.tiles, *p.cache, "sat", seedRange(1, 1, Sector{-180, -90, -108, -18})); // 4x4 at L1
  });
  ASSERT_TRUE(up.waitForRequests(1)); // the metatile's GetMap is out (and held)
  ASSERT_TRUE(isMetaTileRequest(up.received().at(0)));
  // Three clients ask for tiles of that metatile while it is out (World Wind: X = column).
  std::mutex m;
  std::condition_variable cv;
  std::vector<TileAnswer> answers;
  for (const TileKey key : {TileKey{1, 0, 0}, TileKey{1, 3, 3}, TileKey{1, 1, 2}}) {
    p.tiles->getTile("sat", "", key, [&](TileAnswer&& a) {
      std::lock_guard lock(m);
      answers.push_back(std::move(a));
      cv.notify_all();
    });
  }
  {
    std::lock_guard lock(m);
    EXPECT_TRUE(answers.empty()) << "answered before the metatile came";
  }
  clientsAsked->open();
  {
    std::unique_lock lock(m);
    ASSERT_TRUE(cv.wait_for(lock, 10s, [&] { return answers.size() == 3; }));
    for (const TileAnswer& a : answers) {
      EXPECT_EQ(a.kind, TileAnswer::Kind::Tile) << a.message;
      EXPECT_EQ(a.contentType, "image/jpeg");
    }
  }
  const auto r = seeding.get();
  ASSERT_TRUE(r) << r.error();
  EXPECT_EQ(r->written, 16);
  EXPECT_EQ(up.requests(), 1u) << "one GetMap for the metatile, none for the clients";
}

TEST(MetaTileIntegration, APartlyCachedMetaTileAsksOnlyForTheBlockOfItsMissingTiles) {
  test::FakeUpstream up(drawMap);
  MetaProxy p(up.url("/wms"), 4);
  // Two tiles of the level-1 block rows 0-3, columns 0-3 are cached already (the west column's
  // south half: column 0, rows 0 and 1).
  auto first =
      seedThroughService(*p.tiles, *p.cache, "sat", seedRange(1, 1, Sector{-180, -90, -162, -54}));
  ASSERT_TRUE(first) << first.error();
  EXPECT_EQ(first->written, 2);
  const auto kept = *p.cache->get(p.dataset(), TileKey{1, 0, 0});
  const std::size_t before = up.requests();
  auto r =
      seedThroughService(*p.tiles, *p.cache, "sat", seedRange(1, 1, Sector{-180, -90, -108, -18}));
  ASSERT_TRUE(r) << r.error();
  EXPECT_EQ(r->skipped, 2);
  EXPECT_EQ(r->written, 14);
  ASSERT_EQ(up.requests(), before + 1);
  // The block of the missing tiles is still the whole 4x4 (they span every row and column): one
  // GetMap, and the cached tiles are not rewritten.
  const auto last = up.received().back();
  EXPECT_EQ(param(last.target, "WIDTH"), "1024");
  EXPECT_EQ(param(last.target, "HEIGHT"), "1024");
  const auto after = *p.cache->get(p.dataset(), TileKey{1, 0, 0});
  EXPECT_EQ(after.meta.fetchedAt, kept.meta.fetchedAt);
  EXPECT_EQ(after.bytes, kept.bytes);
  // Missing tiles only in the block's east half: a 2-column GetMap.
  for (std::int64_t row = 4; row < 8; ++row)
    for (std::int64_t col = 4; col < 6; ++col)
      (void)p.cache->put(
          p.dataset(), TileKey{1, row, col}, *p.cached(TileKey{1, 0, 0}), TileMeta{});
  auto east =
      seedThroughService(*p.tiles, *p.cache, "sat", seedRange(1, 1, Sector{-108, -18, -36, 54}));
  ASSERT_TRUE(east) << east.error();
  EXPECT_EQ(east->skipped, 8);
  EXPECT_EQ(east->written, 8);
  EXPECT_EQ(param(up.received().back().target, "WIDTH"), "512");
  EXPECT_EQ(param(up.received().back().target, "HEIGHT"), "1024");
}
