// The composer's YCbCr path (Compose's planes over tellus/codec/JpegYcc.hpp): the chroma planes'
// geometry, and JPEG maps made on Y, Cb and Cr planes against the same maps made on the RGB path,
// on tiles cut from the bundled Blue Marble and encoded as the seeder encodes them (quality 90,
// 4:2:0, restart markers), and as an upstream may (no markers). The planes' decoding itself is
// tested with the codec (tests/codec/TestJpegYcc.cpp).

#include "../support/BlueMarbleTiles.hpp"

#include <tellus/codec/JpegYcc.hpp>
#include <tellus/proxy/Compose.hpp>
#include <tellus/proxy/ImageCodec.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <random>
#include <tuple>

using namespace tellus;

namespace {

constexpr int kTile = test::kBlueMarbleTile;

TileGrid grid() {
  return *TileGrid::create(GridSpec{Sector{}, 36.0, kTile, kTile, 3});
}

/** The Blue Marble's JPEG tiles (tests/support/BlueMarbleTiles.hpp) and the grid the composer
 * reads them on. */
struct JpegTiles {
  test::BlueMarbleJpegTiles& jpegs;
  TileGrid g = grid();
  const std::vector<std::byte>& at(const TileKey& k) { return jpegs.at(k.level, k.row, k.col); }
};

/** The tiles of the current test: tellus's (restart markers) unless a test switches. */
JpegTiles* current = nullptr;
JpegTiles& tiles() {
  static JpegTiles withMarkers{test::BlueMarbleJpegTiles::withMarkers()};
  return current ? *current : withMarkers;
}
JpegTiles& plainTiles() {
  static JpegTiles plain{test::BlueMarbleJpegTiles::plain()};
  return plain;
}
/** Runs `f` on tellus's tiles and on tiles without restart markers. */
template <typename F> void forBothTileKinds(F&& f) {
  for (JpegTiles* t : {&tiles(), &plainTiles()}) {
    SCOPED_TRACE(t->jpegs.restart ? "tiles with restart markers" : "tiles without restart markers");
    current = t;
    f();
  }
  current = nullptr;
}

struct Planes {
  std::vector<std::uint8_t> y, cb, cr;
  explicit Planes(std::uint8_t fill = 0)
      : y(kTile * kTile, fill), cb(kTile * kTile / 4, fill), cr(kTile * kTile / 4, fill) {}
};

codec::YccDecode
decode(const std::vector<std::byte>& jpeg, const std::array<std::int32_t, 4>* region, Planes& p) {
  std::string message;
  return codec::decodeJpegYcc(
      jpeg, kTile, kTile, region, p.y.data(), p.cb.data(), p.cr.data(), message);
}

/** A map composed as the composer does on the RGB path: decoded JPEG (RGB). */
DecodedImage rgbMap(const Sector& box, int width, int height) {
  JpegTiles& t = tiles();
  const int level = composeLevel(t.g, box, width, height, 0);
  const auto keys = *composeTiles(t.g, box, width, height, level, 1000);
  std::map<std::tuple<std::int64_t, std::int64_t>, std::vector<std::uint8_t>> pixels;
  std::map<std::tuple<std::int64_t, std::int64_t>, TileSamples> views;
  for (const auto& k : keys) {
    auto& px = pixels[{k.key.row, k.key.col}];
    const auto ch = decodeImageryInto(t.at(k.key), "image/jpeg", kTile, kTile, px, &k.region);
    EXPECT_TRUE(ch.has_value());
    views[{k.key.row, k.key.col}] = TileSamples{kTile, kTile, 3, px.data(), nullptr};
  }
  const TileLookup lookup = [&](const TileKey& k) -> const TileSamples* {
    const auto it = views.find({k.row, k.col});
    return k.level == level && it != views.end() ? &it->second : nullptr;
  };
  std::vector<std::uint8_t> canvas(static_cast<std::size_t>(width * height * 3), 255);
  composeImagery(t.g, box, width, height, level, 0, lookup, 1.0, canvas, 3);
  const auto jpeg = *encodeImage("image/jpeg", width, height, 3, canvas.data());
  return *decodeImagery(jpeg, "image/jpeg", width, height);
}

/** The same map composed on Y, Cb and Cr planes (background white). */
DecodedImage yccMap(const Sector& box, int width, int height, std::size_t* tileCount = nullptr) {
  JpegTiles& t = tiles();
  const int level = composeLevel(t.g, box, width, height, 0);
  const auto keys = *composeTilesYcc(t.g, box, width, height, level, 1000);
  if (tileCount) *tileCount = keys.size();
  std::map<std::tuple<std::int64_t, std::int64_t>, std::unique_ptr<Planes>> planes;
  for (const auto& k : keys) {
    auto& p = planes[{k.key.row, k.key.col}];
    p = std::make_unique<Planes>();
    EXPECT_EQ(decode(t.at(k.key), &k.region, *p), codec::YccDecode::Ok);
  }
  const auto chroma = *chromaLayout(t.g, box, width, height);
  std::vector<std::uint8_t> out[3];
  const auto white = codec::rgbToYcc(255, 255, 255);
  out[0].assign(static_cast<std::size_t>(width * height), white[0]);
  out[1].assign(static_cast<std::size_t>(chroma.width * chroma.height), white[1]);
  out[2].assign(static_cast<std::size_t>(chroma.width * chroma.height), white[2]);
  for (int plane = 0; plane < 3; ++plane) {
    std::map<std::tuple<std::int64_t, std::int64_t>, TileSamples> views;
    for (const auto& [rc, p] : planes) {
      views[rc] = plane == 0   ? TileSamples{kTile, kTile, 1, p->y.data(), nullptr}
                  : plane == 1 ? TileSamples{kTile / 2, kTile / 2, 1, p->cb.data(), nullptr}
                               : TileSamples{kTile / 2, kTile / 2, 1, p->cr.data(), nullptr};
    }
    const TileLookup lookup = [&](const TileKey& k) -> const TileSamples* {
      const auto it = views.find({k.row, k.col});
      return k.level == level && it != views.end() ? &it->second : nullptr;
    };
    if (plane == 0) {
      composeImagery(t.g, box, width, height, level, 0, lookup, 1.0, out[0], 1);
    } else {
      composeImagery(chroma.grid,
                     chroma.box,
                     chroma.width,
                     chroma.height,
                     level,
                     0,
                     lookup,
                     1.0,
                     out[plane],
                     1);
    }
  }
  const auto jpeg =
      codec::encodeJpegYcc(width, height, out[0].data(), out[1].data(), out[2].data());
  EXPECT_TRUE(jpeg.has_value());
  return *decodeImagery(*jpeg, "image/jpeg", width, height);
}

/** PSNR (dB) and the largest difference of two RGB images of the same size. */
std::pair<double, int> compare(const DecodedImage& a, const DecodedImage& b) {
  EXPECT_EQ(a.pixels.size(), b.pixels.size());
  double sum = 0;
  int worst = 0;
  for (std::size_t k = 0; k < a.pixels.size(); ++k) {
    const int d = std::abs(int{a.pixels[k]} - int{b.pixels[k]});
    sum += double(d) * d;
    worst = std::max(worst, d);
  }
  const double mse = sum / static_cast<double>(a.pixels.size());
  return {mse == 0 ? 99.0 : 10 * std::log10(255.0 * 255.0 / mse), worst};
}

} // namespace

TEST(ComposeYcc, AlignedBoxGivesTheTilePlanesExactly) {
  // A map that is exactly one tile at its resolution: the luma and the chroma planes (centred
  // siting, half the tile size) are the tile's own, so the chroma geometry is JPEG's.
  JpegTiles& t = tiles();
  const TileKey key{1, 6, 12};
  // The tile and its neighbours (the filter's quads reach one texel past the tile, with weight 0).
  std::map<TileKey, std::unique_ptr<Planes>> planes;
  for (std::int64_t dr = -1; dr <= 1; ++dr)
    for (std::int64_t dc = -1; dc <= 1; ++dc) {
      const TileKey k{1, key.row + dr, key.col + dc};
      auto& p = planes[k];
      p = std::make_unique<Planes>();
      ASSERT_EQ(decode(t.at(k), nullptr, *p), codec::YccDecode::Ok);
    }
  const Sector box = t.g.sectorOf(key);
  const auto chroma = *chromaLayout(t.g, box, kTile, kTile);
  EXPECT_EQ(chroma.width, kTile / 2);
  for (int plane = 0; plane < 3; ++plane) {
    std::map<TileKey, TileSamples> views;
    for (const auto& [k, p] : planes) {
      views[k] = plane == 0   ? TileSamples{kTile, kTile, 1, p->y.data(), nullptr}
                 : plane == 1 ? TileSamples{kTile / 2, kTile / 2, 1, p->cb.data(), nullptr}
                              : TileSamples{kTile / 2, kTile / 2, 1, p->cr.data(), nullptr};
    }
    const TileLookup lookup = [&](const TileKey& k) -> const TileSamples* {
      const auto it = views.find(k);
      return it == views.end() ? nullptr : &it->second;
    };
    std::vector<std::uint8_t> out;
    const ComposeStats stats =
        plane == 0 ? composeImagery(t.g, box, kTile, kTile, 1, 0, lookup, 1.0, out, 1)
                   : composeImagery(
                         chroma.grid, chroma.box, kTile / 2, kTile / 2, 1, 0, lookup, 1.0, out, 1);
    EXPECT_EQ(stats.missingPixels, 0u);
    const auto& p = *planes[key];
    const auto& expected = plane == 0 ? p.y : plane == 1 ? p.cb : p.cr;
    EXPECT_TRUE(out == expected) << "plane " << plane;
  }
}

TEST(ComposeYcc, YccMapsMatchTheRgbPath) {
  struct Case {
    Sector box;
    int width, height;
  };
  std::vector<Case> cases = {
      {{-100.3, 10.2, -40.3, 55.2}, 1024, 768},  // the benchmark's box
      {{-10.0, 35.0, 30.0, 65.0}, 1001, 767},    // odd sizes
      {{-9.99, 35.01, 0.01, 42.51}, 1023, 769},  // magnified, odd
      {{170.0, -20.0, 190.0, -5.0}, 800, 600},   // across the antimeridian
      {{-30.0, 60.0, 30.0, 100.0}, 640, 427},    // past the north pole (white above 90)
      {{100.0, -100.0, 140.0, -70.0}, 512, 384}, // past the south pole
  };
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int k = 0; k < 6; ++k) { // the peers' random boxes
    const double span = 10 + u(rng) * 80;
    const double w = -180 + u(rng) * (360 - span);
    const double hs = span * 0.75;
    const double s = -90 + u(rng) * (180 - hs);
    cases.push_back({{w, s, w + span, s + hs}, 1024, 768});
  }
  forBothTileKinds([&] {
    for (const Case& c : cases) {
      SCOPED_TRACE(::testing::Message() << c.box.west << "," << c.box.south << "," << c.box.east
                                        << "," << c.box.north << " " << c.width << "x" << c.height);
      const DecodedImage rgb = rgbMap(c.box, c.width, c.height);
      const DecodedImage ycc = yccMap(c.box, c.width, c.height);
      ASSERT_EQ(ycc.width, c.width);
      ASSERT_EQ(ycc.height, c.height);
      const auto [psnr, worst] = compare(rgb, ycc);
      // Both are quality 90 JPEGs of the same map; they differ by rounding in different places
      // and by the second JPEG quantisation noise.
      EXPECT_GT(psnr, 44.0) << "worst " << worst;
      // Past a pole: the background, white.
      if (c.box.north > 90) {
        const auto* p = &ycc.pixels[static_cast<std::size_t>((2 * c.width + c.width / 2) * 3)];
        EXPECT_GE(p[0], 250);
        EXPECT_GE(p[1], 250);
        EXPECT_GE(p[2], 250);
      }
    }
  });
}

TEST(ComposeYcc, ChromaTilesAreFetchedWhereTheLumaDoesNotReach) {
  // A chroma sample at the map's edge may reach one texel into a tile (or a part of it) that the
  // luma does not touch: composeTilesYcc asks for the union, so every chroma sample finds its
  // tiles. Over random boxes of random sizes, some need that.
  const TileGrid g = grid();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int widened = 0;
  for (int k = 0; k < 400; ++k) {
    const double span = 2 + u(rng) * 60;
    const double w = -180 + u(rng) * 360;
    const double hs = span * (0.3 + u(rng));
    const double s = -95 + u(rng) * (185 - hs);
    const int width = 16 + static_cast<int>(u(rng) * 1000);
    const int height = 16 + static_cast<int>(u(rng) * 1000);
    const Sector box{w, s, w + span, s + hs};
    const int level = composeLevel(g, box, width, height, 0);
    const auto luma = *composeTiles(g, box, width, height, level, 1000);
    const auto all = *composeTilesYcc(g, box, width, height, level, 1000);
    const auto chroma = *chromaLayout(g, box, width, height);
    const auto needed =
        *composeTiles(chroma.grid, chroma.box, chroma.width, chroma.height, level, 1000);
    for (const auto& n : needed) {
      const auto a = std::find_if(all.begin(), all.end(), [&](const ComposeTile& t) {
        return t.key.level == n.key.level && t.key.row == n.key.row && t.key.col == n.key.col;
      });
      ASSERT_NE(a, all.end()) << n.key.row << "_" << n.key.col;
      EXPECT_LE(a->region[0], n.region[0] * 2);
      EXPECT_LE(a->region[1], n.region[1] * 2);
      EXPECT_GE(a->region[2], n.region[2] * 2);
      EXPECT_GE(a->region[3], n.region[3] * 2);
      const auto l = std::find_if(luma.begin(), luma.end(), [&](const ComposeTile& t) {
        return t.key.level == n.key.level && t.key.row == n.key.row && t.key.col == n.key.col;
      });
      if (l == luma.end() || l->region[0] > n.region[0] * 2 || l->region[1] > n.region[1] * 2 ||
          l->region[2] < n.region[2] * 2 || l->region[3] < n.region[3] * 2)
        ++widened;
    }
  }
  EXPECT_GT(widened, 0); // the case exists (else this test tests nothing)
}
