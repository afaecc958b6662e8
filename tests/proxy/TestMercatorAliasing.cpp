// East-west aliasing of Web Mercator maps near the poles: a Mercator row takes its level from its
// extent in latitude, cos(latitude) times its extent in longitude, so at 84 degrees a pixel spans
// about 10-20 texels of its row. Tiles of a fine graticule (a one-texel line every 8 texels of
// longitude, at every level) composed near 84 N, on the RGB path and on one plane, are compared
// with the graticule box-filtered over each pixel's extent at the level its band was composed
// from: one bilinear sample per pixel (before) is off by up to the line's full contrast (RMS 61 of
// 255, worst 212), the mean of samples a texel apart matches it.

#include <tellus/proxy/Compose.hpp>
#include <tellus/proxy/MapBox.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <tuple>

using namespace tellus;

namespace {

constexpr std::int32_t kTile = 256;
constexpr std::int64_t kPeriod = 8; // texels between the graticule's lines

std::uint8_t graticule(std::int64_t gx) {
  return gx % kPeriod == 0 ? 0 : 255;
}

/** Tiles whose texel column gx (counted from -180 at its level) is graticule(gx), `cc` channels. */
struct GraticuleTiles {
  const TileGrid& g;
  int cc;
  mutable std::map<std::tuple<int, std::int64_t, std::int64_t>, std::unique_ptr<TileSamples>> tiles;
  mutable std::vector<std::unique_ptr<std::vector<std::uint8_t>>> data;

  TileLookup lookup() const {
    return [this](const TileKey& k) -> const TileSamples* {
      if (!g.isValid(k)) return nullptr;
      auto& slot = tiles[{k.level, k.row, k.col}];
      if (!slot) {
        auto v = std::make_unique<std::vector<std::uint8_t>>(
            static_cast<std::size_t>(kTile * kTile * cc));
        for (int y = 0; y < kTile; ++y)
          for (int x = 0; x < kTile; ++x)
            for (int c = 0; c < cc; ++c)
              (*v)[static_cast<std::size_t>((y * kTile + x) * cc + c)] =
                  graticule(k.col * kTile + x);
        slot = std::make_unique<TileSamples>();
        slot->width = slot->height = kTile;
        slot->channels = cc;
        slot->rgb = v->data();
        data.push_back(std::move(v));
      }
      return slot.get();
    };
  }
};

/** The graticule's mean over longitudes [w, e] at `level`'s texels. */
double boxFiltered(const TileGrid& g, std::int32_t level, double w, double e) {
  const double res = g.deltaDeg(level) / kTile;
  const double a = (w + 180.0) / res, b = (e + 180.0) / res;
  double sum = 0.0;
  for (auto t = static_cast<std::int64_t>(std::floor(a)); static_cast<double>(t) < b; ++t) {
    const double from = std::max(a, static_cast<double>(t)),
                 to = std::min(b, static_cast<double>(t + 1));
    sum += graticule(t) * (to - from);
  }
  return sum / (b - a);
}

/** A 256 x 256 Mercator map of square pixels 0.02 degrees of longitude wide around 84 N. */
MapBox boxNear84(std::int32_t size) {
  const double west = 10.0, east = west + 0.02 * size;
  const double yc = mercator::yOfLatitude(84.0);
  const double half = (mercator::xOfLongitude(east) - mercator::xOfLongitude(west)) / 2.0;
  return mercatorBox(
      Sector{mercator::xOfLongitude(west), yc - half, mercator::xOfLongitude(east), yc + half});
}

struct Errors {
  double rms = 0.0, worst = 0.0;
};

/** The map's first channel against the box-filtered graticule, per band's level. */
Errors against(const TileGrid& g,
               const MapBox& box,
               std::int32_t size,
               const std::vector<std::uint8_t>& map,
               int cc) {
  Errors e;
  double sum = 0.0;
  std::size_t n = 0;
  const double dx = (box.east - box.west) / size;
  for (const ComposeBand& b : composeBands(g, box, size, size, 0)) {
    for (std::int32_t j = std::max(0, b.box.rowBegin); j < std::min(size, b.box.rowEnd); ++j) {
      for (std::int32_t i = 0; i < size; ++i) {
        const double want = boxFiltered(g, b.level, box.west + i * dx, box.west + (i + 1) * dx);
        const double d = map[static_cast<std::size_t>((j * size + i) * cc)] - want;
        sum += d * d;
        e.worst = std::max(e.worst, std::fabs(d));
        ++n;
      }
    }
  }
  e.rms = std::sqrt(sum / static_cast<double>(n));
  return e;
}

} // namespace

TEST(MercatorAliasing, RowsNear84DegreesAreBoxFilteredEastWest) {
  const TileGrid g = *TileGrid::create(GridSpec{Sector{}, 36.0, kTile, kTile, 10});
  constexpr std::int32_t size = 256;
  const MapBox box = boxNear84(size);
  const auto bands = composeBands(g, box, size, size, 0);
  ASSERT_FALSE(bands.empty());
  // The premise: the rows' levels are fine enough in latitude that a pixel spans many texels of
  // its row (about 1 / cos(84) = 9.6 to twice that).
  for (const ComposeBand& b : bands) {
    const double texels = (box.east - box.west) / size / (g.deltaDeg(b.level) / kTile);
    EXPECT_GT(texels, 8.0) << "level " << b.level;
  }
  // RGB, as a map of several bands is drawn.
  const GraticuleTiles rgb{g, 3, {}, {}};
  std::vector<std::uint8_t> canvas(static_cast<std::size_t>(size * size * 3), 128);
  for (const ComposeBand& b : bands) {
    const auto stats =
        composeImagery(g, b.box, size, size, b.level, 0, rgb.lookup(), 1.0, canvas, 3);
    EXPECT_EQ(stats.missingPixels, 0u);
    EXPECT_EQ(stats.fallbackPixels, 0u);
  }
  const Errors e = against(g, box, size, canvas, 3);
  std::printf(
      "[ aliasing ] RGB: RMS %.2f, worst %.2f of 255 against the box filter\n", e.rms, e.worst);
  EXPECT_LT(e.rms, 1.0);
  EXPECT_LT(e.worst, 4.0);
  // One plane (a JPEG map of one band, on the YCbCr planes).
  const GraticuleTiles grey{g, 1, {}, {}};
  std::vector<std::uint8_t> plane;
  for (const ComposeBand& b : bands) {
    const auto stats = composePlane(g, b.box, size, size, b.level, 0, grey.lookup(), 0, plane);
    EXPECT_EQ(stats.missingPixels, 0u);
  }
  const Errors p = against(g, box, size, plane, 1);
  std::printf("[ aliasing ] plane: RMS %.2f, worst %.2f\n", p.rms, p.worst);
  EXPECT_LT(p.rms, 1.0);
  EXPECT_LT(p.worst, 4.0);
  // The same colour in a row as in the RGB map (the same samples on both paths).
  for (std::size_t k = 0; k < plane.size(); ++k)
    ASSERT_EQ(plane[k], canvas[k * 3]) << "pixel " << k;
}

TEST(MercatorAliasing, SquarePixelsOfLatLongMapsAreSampledOnce) {
  // Drawn as before: a lat/long map of square pixels never spans more than two texels of its
  // level, so its pixels are one bilinear sample each (the same as a map one pixel wide at a
  // time).
  const TileGrid g = *TileGrid::create(GridSpec{Sector{}, 36.0, kTile, kTile, 10});
  const GraticuleTiles grey{g, 1, {}, {}};
  const MapBox box(Sector{10.0, 40.0, 10.0 + 0.03 * 64, 40.0 + 0.03 * 64});
  const auto bands = composeBands(g, box, 64, 64, 0);
  ASSERT_EQ(bands.size(), 1u);
  std::vector<std::uint8_t> whole, column;
  composePlane(g, box, 64, 64, bands[0].level, 0, grey.lookup(), 0, whole);
  for (std::int32_t i = 0; i < 64; i += 9) {
    MapBox one = box;
    one.west = box.west + 0.03 * i;
    one.east = one.west + 0.03;
    composePlane(g, one, 1, 64, bands[0].level, 0, grey.lookup(), 0, column);
    for (std::int32_t j = 0; j < 64; ++j)
      EXPECT_NEAR(
          column[static_cast<std::size_t>(j)], whole[static_cast<std::size_t>(j * 64 + i)], 1)
          << i << "," << j;
  }
}
