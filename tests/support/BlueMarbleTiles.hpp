#pragma once
// JPEG tiles of the bundled Blue Marble on World Wind's 36-degree grid, 512 pixels a side (levels
// 0-2), made on first use: encoded as tellus writes its tiles (quality 90, 4:2:0, restart markers
// every codec::kTileRestartInterval MCUs) or as an upstream may (no markers). The fixtures of the
// codec's YCbCr tests (tests/codec/TestJpegYcc.cpp) and of the composer's (TestComposeYcc.cpp).

#include <tellus/codec/Jpeg.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <tuple>
#include <vector>

namespace tellus::test {

inline constexpr int kBlueMarbleTile = 512;

/** The bundled 2048 x 1024 Blue Marble, decoded once (RGB). */
inline const codec::Image& blueMarble() {
  static const codec::Image image = [] {
    std::ifstream f(std::filesystem::path(TELLUS_TEST_DATA_DIR) / "bmng_2048x1024.jpg",
                    std::ios::binary);
    const std::vector<char> c{std::istreambuf_iterator<char>(f), {}};
    auto d = codec::decodeJpeg(std::as_bytes(std::span(c)));
    EXPECT_TRUE(d.has_value());
    return d ? *d : codec::Image{};
  }();
  return image;
}

/** Tile (level, row, col) of the 36-degree grid (row 0 in the south) sampled nearest from the
 * Blue Marble, as RGB. */
inline std::vector<std::uint8_t> blueMarbleTileRgb(int level, std::int64_t row, std::int64_t col) {
  const codec::Image& w = blueMarble();
  constexpr int n = kBlueMarbleTile;
  const double delta = 36.0 / static_cast<double>(1 << level);
  const double west = -180.0 + static_cast<double>(col) * delta, east = west + delta;
  const double south = -90.0 + static_cast<double>(row) * delta, north = south + delta;
  std::vector<std::uint8_t> px(static_cast<std::size_t>(n * n * 3));
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const double lon = west + (x + 0.5) * (east - west) / n;
      const double lat = north - (y + 0.5) * (north - south) / n;
      const int sx = std::clamp(static_cast<int>((lon + 180.0) / 360.0 * w.width), 0, w.width - 1);
      const int sy = std::clamp(static_cast<int>((90.0 - lat) / 180.0 * w.height), 0, w.height - 1);
      std::memcpy(&px[static_cast<std::size_t>((y * n + x) * 3)],
                  &w.pixels[static_cast<std::size_t>((sy * w.width + sx) * 3)],
                  3);
    }
  return px;
}

/** The JPEG tiles, made on first use: as tellus writes its tiles (`restart`: with restart markers,
 * decoded from the segments around a region) or without markers. */
struct BlueMarbleJpegTiles {
  bool restart = true;
  std::map<std::tuple<int, std::int64_t, std::int64_t>, std::vector<std::byte>> jpegs;

  const std::vector<std::byte>& at(int level, std::int64_t row, std::int64_t col) {
    auto& j = jpegs[{level, row, col}];
    if (j.empty()) {
      const auto px = blueMarbleTileRgb(level, row, col);
      j = *codec::encodeJpeg(kBlueMarbleTile,
                             kBlueMarbleTile,
                             3,
                             px.data(),
                             {.restartInterval = restart ? codec::kTileRestartInterval : 0});
    }
    return j;
  }

  /** Tellus's tiles (restart markers), shared by the tests of one executable. */
  static BlueMarbleJpegTiles& withMarkers() {
    static BlueMarbleJpegTiles t;
    return t;
  }
  /** Tiles without restart markers. */
  static BlueMarbleJpegTiles& plain() {
    static BlueMarbleJpegTiles t = [] {
      BlueMarbleJpegTiles p;
      p.restart = false;
      return p;
    }();
    return t;
  }
};

/** Runs `f(tiles)` on tellus's tiles and on tiles without restart markers. */
template <typename F> void forBothTileKinds(F&& f) {
  for (BlueMarbleJpegTiles* t :
       {&BlueMarbleJpegTiles::withMarkers(), &BlueMarbleJpegTiles::plain()}) {
    SCOPED_TRACE(t->restart ? "tiles with restart markers" : "tiles without restart markers");
    f(*t);
  }
}

} // namespace tellus::test
