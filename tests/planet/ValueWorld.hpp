#pragma once
// A world for the renderer's layers of values (issue 24, label gl): a flat grey base (PNG) and a
// layer of values ("vals", BIL16 Int16 tiles, one level of 36-degree 32 x 32 tiles: each texel
// 1.125 degrees) whose raw samples say where they are, some of them no data. The CPU's colour of
// any point (values::decode, values::sample and values::colourOf over the same tile bytes) is
// what a render must show there (tests/planet/TestValuesGl.cpp).

#include "../support/FakeTileSource.hpp"

#include <tellus/planet_gl/Renderer.hpp>
#include <tellus/values/ColourScale.hpp>
#include <tellus/values/ValueFormat.hpp>

#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <mutex>
#include <optional>
#include <utility>
#include <vector>

namespace tellus::planet::valuetest {

inline constexpr GridSpec kBaseGrid{Sector{}, 36.0, 32, 32, 4};
inline constexpr GridSpec kValueGrid{Sector{}, 36.0, 32, 32, 1};
inline constexpr std::array<std::uint8_t, 4> kGrey{128, 128, 128, 255};
inline constexpr std::int16_t kNoData = -32768;

/** The raw sample of texel (x, y) (y from the tile's north edge) of tile (row, col): a ramp that
 * wraps every 640 steps (-120 .. 519; values -30 .. 129.75 at scale 0.25), no data on a
 * diagonal lattice. */
inline std::int16_t rawAt(std::int64_t row, std::int64_t col, int x, int y) {
  if ((x + 3 * y) % 17 == 0) return kNoData;
  const auto gx = col * 32 + x, gy = row * 32 + y;
  return static_cast<std::int16_t>((gx * 37 + gy * 101) % 640 - 120);
}

inline std::vector<std::byte> bilTile(std::int64_t row, std::int64_t col) {
  std::vector<std::byte> b;
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x) {
      const auto v = static_cast<std::uint16_t>(rawAt(row, col, x, y));
      b.push_back(static_cast<std::byte>(v & 0xFF)); // little-endian
      b.push_back(static_cast<std::byte>(v >> 8));
    }
  return b;
}

inline values::ValueFormat valueFormat() {
  values::ValueFormat f;
  f.container = values::Container::Bil;
  f.encoding = values::Encoding::Int16;
  f.scale = 0.25;
  f.noData = kNoData;
  f.unit = "K";
  return f;
}

inline std::vector<std::byte> solidPng(std::array<std::uint8_t, 4> c) {
  std::vector<std::uint8_t> px(32 * 32 * 4);
  for (std::size_t i = 0; i < px.size(); i += 4)
    std::copy(c.begin(), c.end(), px.begin() + static_cast<std::ptrdiff_t>(i));
  return encodePngRgba(32, 32, px);
}

struct ValueWorld {
  ValueWorld() {
    source.addLayer({"base",
                     kBaseGrid,
                     "image/png",
                     test::FakeTileSource::bytes(solidPng(kGrey), "image/png")});
    source.addLayer({"vals", kValueGrid, "application/bil16", [](const TileAddress& a) {
                       return test::FakeTileSource::result(
                           TileStatus::Ok, bilTile(a.key.row, a.key.col), "application/bil16");
                     }});
  }
  /** The value the renderer holds at (lat, lon): the texel of the level-0 tile there, with the
   * texel coordinates' distance to the nearest texel edge (in texels) in *edge. */
  struct Texel {
    std::int64_t row = 0, col = 0;
    int x = 0, y = 0;  ///< y from the tile's north edge
    double edge = 0.0; ///< distance to the nearest texel edge, in texels
  };
  static Texel texelAt(double latDeg, double lonDeg) {
    const double fx = (lonDeg + 180.0) / 36.0, fy = (latDeg + 90.0) / 36.0;
    Texel t;
    t.col = static_cast<std::int64_t>(std::floor(fx));
    t.row = static_cast<std::int64_t>(std::floor(fy));
    const double tx = (fx - static_cast<double>(t.col)) * 32.0;
    const double ty = (1.0 - (fy - static_cast<double>(t.row))) * 32.0; // from the north
    t.edge = std::min(
        {tx - std::floor(tx), std::ceil(tx) - tx, ty - std::floor(ty), std::ceil(ty) - ty});
    t.x = std::clamp(static_cast<int>(tx), 0, 31);
    t.y = std::clamp(static_cast<int>(ty), 0, 31);
    return t;
  }
  /** The proxy's colour of a texel: values::apply over the decoded tile (cached per tile). */
  std::array<std::uint8_t, 4> cpuColour(const values::ColourScale& scale, const Texel& t) {
    auto& img = applied[{t.row, t.col}];
    if (img.pixels.empty())
      img = *values::apply(*values::decode(bilTile(t.row, t.col), valueFormat(), 32, 32), scale);
    const auto i = static_cast<std::size_t>((t.y * 32 + t.x) * 4);
    return {img.pixels[i], img.pixels[i + 1], img.pixels[i + 2], img.pixels[i + 3]};
  }
  static float valueOf(const Texel& t) {
    return values::decode(bilTile(t.row, t.col), valueFormat(), 32, 32)->at(t.x, t.y);
  }
  std::map<std::pair<std::int64_t, std::int64_t>, codec::Image> applied;
  static float valueAt(double latDeg, double lonDeg, double* edge = nullptr) {
    const double fx = (lonDeg + 180.0) / 36.0, fy = (latDeg + 90.0) / 36.0;
    const auto col = static_cast<std::int64_t>(std::floor(fx));
    const auto row = static_cast<std::int64_t>(std::floor(fy));
    const double tx = (fx - static_cast<double>(col)) * 32.0;
    const double ty = (1.0 - (fy - static_cast<double>(row))) * 32.0; // from the north
    if (edge != nullptr)
      *edge = std::min(
          {tx - std::floor(tx), std::ceil(tx) - tx, ty - std::floor(ty), std::ceil(ty) - ty});
    const int x = std::clamp(static_cast<int>(tx), 0, 31),
              y = std::clamp(static_cast<int>(ty), 0, 31);
    const auto raster = values::decode(bilTile(row, col), valueFormat(), 32, 32);
    return raster->at(x, y);
  }
  test::FakeTileSource source;
};

} // namespace tellus::planet::valuetest
