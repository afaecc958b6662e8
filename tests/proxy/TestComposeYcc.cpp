// The composer's YCbCr path (tellus/codec/JpegYcc.hpp and Compose's planes): region decodes
// against whole decodes, the chroma planes' geometry, and JPEG maps made on Y, Cb and Cr planes
// against the same maps made on the RGB path, on tiles cut from the bundled Blue Marble and encoded
// as the seeder encodes them (quality 90, 4:2:0, restart markers), and as an upstream may (no
// markers).

#include "../support/JpegSampling.hpp"

#include <tellus/codec/JpegSplit.hpp>
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

std::vector<std::byte> readFile(const std::filesystem::path& p) {
  std::ifstream f(p, std::ios::binary);
  const std::vector<char> c{std::istreambuf_iterator<char>(f), {}};
  std::vector<std::byte> out(c.size());
  std::memcpy(out.data(), c.data(), c.size());
  return out;
}

/** The bundled 2048 x 1024 Blue Marble, decoded once. */
const DecodedImage& world() {
  static const DecodedImage image = [] {
    const auto bytes = readFile(std::filesystem::path(TELLUS_TEST_DATA_DIR) / "bmng_2048x1024.jpg");
    auto d = decodeImagery(bytes, "image/jpeg", 2048, 1024);
    EXPECT_TRUE(d.has_value());
    return d ? *d : DecodedImage{};
  }();
  return image;
}

constexpr int kTile = 512;

TileGrid grid() {
  return *TileGrid::create(GridSpec{Sector{}, 36.0, kTile, kTile, 3});
}

/** A tile of `g` sampled (nearest) from the Blue Marble, as RGB. */
std::vector<std::uint8_t> tileRgb(const TileGrid& g, const TileKey& k) {
  const DecodedImage& w = world();
  std::vector<std::uint8_t> px(static_cast<std::size_t>(kTile * kTile * 3));
  const Sector s = g.sectorOf(k);
  for (int y = 0; y < kTile; ++y)
    for (int x = 0; x < kTile; ++x) {
      const double lon = s.west + (x + 0.5) * (s.east - s.west) / kTile;
      const double lat = s.north - (y + 0.5) * (s.north - s.south) / kTile;
      const int sx = std::clamp(static_cast<int>((lon + 180.0) / 360.0 * w.width), 0, w.width - 1);
      const int sy = std::clamp(static_cast<int>((90.0 - lat) / 180.0 * w.height), 0, w.height - 1);
      std::memcpy(&px[static_cast<std::size_t>((y * kTile + x) * 3)],
                  &w.pixels[static_cast<std::size_t>((sy * w.width + sx) * 3)],
                  3);
    }
  return px;
}

/** The JPEG tiles of a grid, made on first use: as tellus writes its tiles (`restart`: with
 * restart markers, decoded from the segments around a region) or without markers. */
struct JpegTiles {
  bool restart = true;
  TileGrid g = grid();
  std::map<std::tuple<int, std::int64_t, std::int64_t>, std::vector<std::byte>> jpegs;
  const std::vector<std::byte>& at(const TileKey& k) {
    auto& j = jpegs[{k.level, k.row, k.col}];
    if (j.empty()) {
      const auto px = tileRgb(g, k);
      j = *encodeImage("image/jpeg", kTile, kTile, 3, px.data(), restart);
    }
    return j;
  }
};

/** The tiles of the current test: tellus's (restart markers) unless a test switches. */
JpegTiles* current = nullptr;
JpegTiles& tiles() {
  static JpegTiles withMarkers;
  return current ? *current : withMarkers;
}
JpegTiles& plainTiles() {
  static JpegTiles plain = [] {
    JpegTiles t;
    t.restart = false;
    return t;
  }();
  return plain;
}
/** Runs `f` on tellus's tiles and on tiles without restart markers. */
template <typename F> void forBothTileKinds(F&& f) {
  for (JpegTiles* t : {&tiles(), &plainTiles()}) {
    SCOPED_TRACE(t->restart ? "tiles with restart markers" : "tiles without restart markers");
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

TEST(JpegRaw, RegionDecodesMatchTheWholeDecode) {
  forBothTileKinds([] {
    const auto& jpeg = tiles().at(TileKey{2, 12, 21}); // Europe, level 2
    Planes whole;
    ASSERT_EQ(decode(jpeg, nullptr, whole), codec::YccDecode::Ok);
    const std::array<std::int32_t, 4> regions[] = {
        {0, 0, 512, 512},
        {0, 0, 1, 1},
        {511, 511, 512, 512},
        {17, 33, 18, 34},
        {200, 0, 512, 512},
        {0, 300, 512, 512},
        {100, 100, 300, 300},
        {0, 0, 100, 512},
        {15, 15, 17, 17},
        {496, 0, 512, 16},
        {63, 63, 65, 65},     // across segment corners
        {448, 496, 512, 512}, // the last segment
        {0, 496, 512, 512},   // the last row, all of it
        {130, 7, 131, 500},   // one column
        {-5, -5, 600, 3},     // clamped to the tile
    };
    for (const auto& r : regions) {
      Planes part(0x55);
      ASSERT_EQ(decode(jpeg, &r, part), codec::YccDecode::Ok);
      int bad = 0;
      for (int y = std::max(r[1], 0); y < std::min(r[3], kTile); ++y)
        for (int x = std::max(r[0], 0); x < std::min(r[2], kTile); ++x) {
          const auto k = static_cast<std::size_t>(y * kTile + x);
          const auto kc = static_cast<std::size_t>((y / 2) * (kTile / 2) + x / 2);
          bad += part.y[k] != whole.y[k];
          bad += part.cb[kc] != whole.cb[kc];
          bad += part.cr[kc] != whole.cr[kc];
        }
      EXPECT_EQ(bad, 0) << r[0] << "," << r[1] << " - " << r[2] << "," << r[3];
      // Below the region's last block row nothing is decoded.
      const int below = (r[3] + 15) / 16 * 16;
      if (below < kTile) {
        EXPECT_EQ(part.y[static_cast<std::size_t>(below * kTile)], 0x55);
      }
      // Tiles with restart markers: decoded from the segments around the region unless it needs
      // every segment from the top; without markers, never.
      const bool fromTop = r[1] < 16 && r[0] < 64 && r[2] > kTile - 64;
      EXPECT_EQ(codec::decodesFromSegments(jpeg, kTile, kTile, r), tiles().restart && !fromTop)
          << r[0] << "," << r[1] << " - " << r[2] << "," << r[3];
    }
    // The planes are the RGB decode's colours (JFIF) at the chroma's resolution.
    std::vector<std::uint8_t> rgb;
    ASSERT_TRUE(decodeImageryInto(jpeg, "image/jpeg", kTile, kTile, rgb, nullptr));
    double err = 0;
    for (std::size_t k = 0; k < whole.y.size(); ++k) {
      const auto y = codec::rgbToYcc(rgb[k * 3], rgb[k * 3 + 1], rgb[k * 3 + 2])[0];
      err += std::abs(int{y} - int{whole.y[k]});
    }
    EXPECT_LT(err / static_cast<double>(whole.y.size()), 1.0);
  });
}

TEST(JpegRaw, SegmentDecodesOfRandomRegionsMatchTheWholeDecode) {
  // Random regions of tiles with restart markers: exactly the whole decode's samples (the same
  // blocks), with the 64 x 16 segments' edges anywhere in the region.
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> at(0, kTile - 1);
  const TileKey keys[] = {{2, 12, 21}, {1, 6, 12}, {0, 2, 3}, {2, 0, 5}};
  for (const TileKey& key : keys) {
    const auto& jpeg = tiles().at(key);
    Planes whole;
    ASSERT_EQ(decode(jpeg, nullptr, whole), codec::YccDecode::Ok);
    for (int k = 0; k < 40; ++k) {
      int x0 = at(rng), x1 = at(rng), y0 = at(rng), y1 = at(rng);
      if (x0 > x1) std::swap(x0, x1);
      if (y0 > y1) std::swap(y0, y1);
      const std::array<std::int32_t, 4> r{x0, y0, x1 + 1, y1 + 1};
      Planes part(0x55);
      ASSERT_EQ(decode(jpeg, &r, part), codec::YccDecode::Ok);
      int bad = 0;
      for (int y = r[1]; y < r[3]; ++y)
        for (int x = r[0]; x < r[2]; ++x) {
          const auto i = static_cast<std::size_t>(y * kTile + x);
          const auto ic = static_cast<std::size_t>((y / 2) * (kTile / 2) + x / 2);
          bad += part.y[i] != whole.y[i];
          bad += part.cb[ic] != whole.cb[ic];
          bad += part.cr[ic] != whole.cr[ic];
        }
      EXPECT_EQ(bad, 0) << r[0] << "," << r[1] << " - " << r[2] << "," << r[3];
    }
  }
}

TEST(JpegRaw, TilesCutFromAMetatileAreDecodedFromSegments) {
  // The seeder's metatile split writes its tiles with restart markers too.
  const auto left = tileRgb(tiles().g, TileKey{2, 12, 20});
  const auto right = tileRgb(tiles().g, TileKey{2, 12, 21});
  std::vector<std::uint8_t> meta(static_cast<std::size_t>(2 * kTile * kTile * 3));
  for (std::size_t y = 0; y < kTile; ++y) {
    const std::size_t row = kTile * 3;
    std::memcpy(&meta[y * 2 * row], &left[y * row], row);
    std::memcpy(&meta[y * 2 * row + row], &right[y * row], row);
  }
  const auto jpeg = *encodeImage("image/jpeg", 2 * kTile, kTile, 3, meta.data());
  const auto cut = codec::splitJpegDct(jpeg, 2, 1, kTile, kTile, false);
  ASSERT_TRUE(cut.has_value());
  ASSERT_EQ(cut->size(), 2u);
  const std::array<std::int32_t, 4> r{300, 200, 420, 260};
  for (const auto& tile : *cut) {
    EXPECT_TRUE(codec::decodesFromSegments(tile, kTile, kTile, r));
    Planes whole, part(0x55);
    ASSERT_EQ(decode(tile, nullptr, whole), codec::YccDecode::Ok);
    ASSERT_EQ(decode(tile, &r, part), codec::YccDecode::Ok);
    int bad = 0;
    for (int y = r[1]; y < r[3]; ++y)
      for (int x = r[0]; x < r[2]; ++x)
        bad += part.y[static_cast<std::size_t>(y * kTile + x)] !=
               whole.y[static_cast<std::size_t>(y * kTile + x)];
    EXPECT_EQ(bad, 0);
  }
}

TEST(JpegRaw, DamagedTilesWithRestartMarkersAreDecodedAsAWhole) {
  // A stream whose markers are not all there (truncated) or not in order is decoded as a whole
  // (the damaged part grey, as on the RGB path), never spliced from the wrong segments.
  const auto& jpeg = tiles().at(TileKey{2, 12, 21});
  const std::array<std::int32_t, 4> lower{100, 400, 300, 500};
  ASSERT_TRUE(codec::decodesFromSegments(jpeg, kTile, kTile, lower));
  const std::vector<std::byte> truncated(
      jpeg.begin(), jpeg.begin() + static_cast<std::ptrdiff_t>(jpeg.size() / 2));
  EXPECT_FALSE(codec::decodesFromSegments(truncated, kTile, kTile, lower));
  Planes p;
  EXPECT_EQ(decode(truncated, &lower, p), codec::YccDecode::Ok);
  // Two restart markers swapped: out of order.
  std::vector<std::byte> swapped = jpeg;
  std::vector<std::size_t> markers;
  for (std::size_t i = 0; i + 1 < swapped.size(); ++i)
    if (swapped[i] == std::byte{0xFF} && (std::to_integer<int>(swapped[i + 1]) & 0xF8) == 0xD0)
      markers.push_back(i + 1);
  ASSERT_GE(markers.size(), 100u); // 8 x 32 segments of a 512-pixel tile
  std::swap(swapped[markers[10]], swapped[markers[11]]);
  EXPECT_FALSE(codec::decodesFromSegments(swapped, kTile, kTile, lower));
  EXPECT_EQ(decode(swapped, &lower, p), codec::YccDecode::Ok);
  // Not the tile's size.
  EXPECT_FALSE(codec::decodesFromSegments(jpeg, 256, 256, lower));
}

TEST(JpegRaw, OtherSamplingsAndShapesAreLeftToTheRgbPath) {
  const auto rgb = tileRgb(tiles().g, TileKey{1, 5, 10});
  Planes p;
  EXPECT_EQ(decode(test::jpegWithSampling(rgb, kTile, kTile, 1, 1), nullptr, p),
            codec::YccDecode::NotYcc420); // 4:4:4
  EXPECT_EQ(decode(test::jpegWithSampling(rgb, kTile, kTile, 2, 1), nullptr, p),
            codec::YccDecode::NotYcc420); // 4:2:2
  EXPECT_EQ(decode(test::jpegWithSampling(rgb, kTile, kTile, 2, 2), nullptr, p),
            codec::YccDecode::Ok);
  std::vector<std::uint8_t> grey(static_cast<std::size_t>(kTile * kTile), 128);
  EXPECT_EQ(decode(*encodeImage("image/jpeg", kTile, kTile, 1, grey.data()), nullptr, p),
            codec::YccDecode::NotYcc420);
  const auto& jpeg = tiles().at(TileKey{1, 5, 10});
  std::string message;
  EXPECT_EQ(
      codec::decodeJpegYcc(jpeg, 256, 256, nullptr, p.y.data(), p.cb.data(), p.cr.data(), message),
      codec::YccDecode::NotYcc420); // not the tile size
  const std::vector<std::byte> garbage(jpeg.begin(), jpeg.begin() + 40);
  EXPECT_EQ(decode(garbage, nullptr, p), codec::YccDecode::Failed);
  // A truncated stream decodes (with grey blocks), as on the RGB path.
  const std::vector<std::byte> truncated(
      jpeg.begin(), jpeg.begin() + static_cast<std::ptrdiff_t>(jpeg.size() / 2));
  EXPECT_EQ(decode(truncated, nullptr, p), codec::YccDecode::Ok);
}

TEST(JpegRaw, AlignedBoxGivesTheTilePlanesExactly) {
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

TEST(JpegRaw, YccMapsMatchTheRgbPath) {
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

TEST(JpegRaw, ChromaTilesAreFetchedWhereTheLumaDoesNotReach) {
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
