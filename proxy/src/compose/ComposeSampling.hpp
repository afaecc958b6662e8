#pragma once
// What the composers of proxy/src/compose share (the public side is tellus/proxy/Compose.hpp): a
// map's axes at one level (per output column and row, the two texels sampled, in which tile and
// with what weight; computed in ComposeAxes.cpp and remembered between maps), the tiles of a level
// laid out by the axes' slots, a pixel's four texels (Quad), the per-pixel fallback to coarser
// levels, and "over". The samplers built on them: ComposePlane.cpp (one plane, SIMD),
// ComposeImagery.cpp (RGB(A) imagery) and Compose.cpp (heights and values, and pictures of them).
// Hot per-pixel helpers are inline here so that each sampler's loop keeps them inlined.

#include <tellus/proxy/Compose.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <vector>

namespace tellus::compose {

/** One output column's (or row's) two texels at a level: tile slots, offsets inside the tiles and
 * the weight of the second texel in 1/256. */
struct AxisSample {
  std::int32_t slotA = -1; ///< index into Axis::tiles; -1: this pixel is outside the layer
  std::int32_t slotB = -1;
  std::int32_t offA = 0;
  std::int32_t offB = 0;
  std::int32_t weightB = 0;
  double exactWeightB = 0.0;
};

/** An axis of the map at one level. */
struct Axis {
  std::vector<AxisSample> samples;  ///< per output column / row
  std::vector<std::int64_t> tiles;  ///< distinct tile columns (west to east) / rows (north first)
  std::vector<std::int32_t> lo, hi; ///< per tile: the first and last texel offset sampled

  /** Counts a texel at `offset` inside tile `slot`. */
  void use(std::int32_t slot, std::int32_t offset) {
    const auto k = static_cast<std::size_t>(slot);
    if (lo.size() <= k) {
      lo.resize(k + 1, std::numeric_limits<std::int32_t>::max());
      hi.resize(k + 1, -1);
    }
    lo[k] = std::min(lo[k], offset);
    hi[k] = std::max(hi[k], offset);
  }
};

/** The columns of a map `width` pixels wide over `box` at `level` (texel x counted from -180,
 * wrapped around a global layer, clamped to the sector otherwise), shared with other maps of the
 * same columns. */
std::shared_ptr<const Axis>
columns(const TileGrid& grid, const MapBox& box, std::int32_t width, std::int32_t level);

/** The rows (texel y counted from +90 down, clamped at the poles and the sector's edges), each
 * at the box's latitude of its centre (MapBox::rowLatitude); rows outside the box's band, past a
 * pole or past the Mercator square have slot -1. */
std::shared_ptr<const Axis>
rows(const TileGrid& grid, const MapBox& box, std::int32_t height, std::int32_t level);

/** The tiles of one level laid out by (row slot, column slot). */
struct LevelTiles {
  std::shared_ptr<const Axis> colsAxis, rowsAxis; ///< (shared with memoAxis)
  const Axis& cols;
  const Axis& rows;
  std::vector<const TileSamples*> tiles; ///< rows.tiles.size() x cols.tiles.size()

  LevelTiles(std::shared_ptr<const Axis> c, std::shared_ptr<const Axis> r)
      : colsAxis(std::move(c)), rowsAxis(std::move(r)), cols(*colsAxis), rows(*rowsAxis) {}

  const TileSamples* at(std::int32_t rowSlot, std::int32_t colSlot) const noexcept {
    return tiles[static_cast<std::size_t>(rowSlot) * cols.tiles.size() +
                 static_cast<std::size_t>(colSlot)];
  }
};

/** The tiles of `level` that the map's axes name, each looked up once (null where not there). */
LevelTiles levelTiles(const TileGrid& grid,
                      const MapBox& box,
                      std::int32_t width,
                      std::int32_t height,
                      std::int32_t level,
                      const TileLookup& lookup);

/** The four texels of a pixel at one level, when all four tiles are there. */
struct Quad {
  const TileSamples* t[4];
  std::size_t index[4]; ///< texel index inside its tile (times channels for the caller)
  std::int32_t wx, wy;
  double fx, fy;
};

inline bool
quadAt(const LevelTiles& t, const AxisSample& c, const AxisSample& r, Quad& q) noexcept {
  if (c.slotA < 0 || r.slotA < 0) return false;
  q.t[0] = t.at(r.slotA, c.slotA);
  q.t[1] = t.at(r.slotA, c.slotB);
  q.t[2] = t.at(r.slotB, c.slotA);
  q.t[3] = t.at(r.slotB, c.slotB);
  if (!q.t[0] || !q.t[1] || !q.t[2] || !q.t[3]) return false;
  const auto idx = [](const TileSamples* s, std::int32_t x, std::int32_t y) {
    return static_cast<std::size_t>(y) * static_cast<std::size_t>(s->width) +
           static_cast<std::size_t>(x);
  };
  q.index[0] = idx(q.t[0], c.offA, r.offA);
  q.index[1] = idx(q.t[1], c.offB, r.offA);
  q.index[2] = idx(q.t[2], c.offA, r.offB);
  q.index[3] = idx(q.t[3], c.offB, r.offB);
  q.wx = c.weightB;
  q.wy = r.weightB;
  q.fx = c.exactWeightB;
  q.fy = r.exactWeightB;
  return true;
}

/** Draws straight-alpha `src` (alpha already scaled) over canvas pixel `dst` (RGBA, or RGB when
 * `channels` is 3: an opaque canvas). */
inline void over(const std::uint8_t src[4], std::uint8_t* dst, int channels) noexcept {
  if (src[3] == 255) {
    dst[0] = src[0];
    dst[1] = src[1];
    dst[2] = src[2];
    if (channels == 4) dst[3] = 255;
    return;
  }
  if (src[3] == 0) return;
  if (channels == 3) {
    const std::int32_t a = src[3];
    for (int ch = 0; ch < 3; ++ch)
      dst[ch] = static_cast<std::uint8_t>((src[ch] * a + dst[ch] * (255 - a) + 127) / 255);
    return;
  }
  const double as = src[3] / 255.0;
  const double ad = dst[3] / 255.0;
  const double ao = as + ad * (1.0 - as);
  for (int ch = 0; ch < 3; ++ch) {
    const double c = (src[ch] * as + dst[ch] * ad * (1.0 - as)) / ao;
    dst[ch] = static_cast<std::uint8_t>(std::lround(std::clamp(c, 0.0, 255.0)));
  }
  dst[3] = static_cast<std::uint8_t>(std::lround(ao * 255.0));
}

/**
 * The coarser levels, built on first need: for pixels whose tiles at the chosen level are
 * missing, the nearest coarser level whose four texels are there.
 */
class Fallback {
public:
  Fallback(const TileGrid& grid,
           const MapBox& box,
           std::int32_t width,
           std::int32_t height,
           std::int32_t level,
           std::int32_t firstLevel,
           const TileLookup& lookup)
      : grid_(grid), box_(box), width_(width), height_(height), level_(level), first_(firstLevel),
        lookup_(lookup) {}

  /** The four texels of pixel (i, j) at the nearest coarser level that has them; false when
   * none has (out of line: the slow path, ComposeAxes.cpp). */
  bool quad(std::int32_t i, std::int32_t j, Quad& q);

private:
  const LevelTiles& tiles(std::int32_t l);

  const TileGrid& grid_;
  MapBox box_;
  std::int32_t width_, height_, level_, first_;
  const TileLookup& lookup_;
  std::vector<std::vector<LevelTiles>> levels_; // index: levels above `level_` minus one
};

/** Runs `draw(pixel index, quad)` for every pixel inside the layer, falling back to coarser
 * levels per pixel. */
template <class Draw>
ComposeStats forEachPixel(const TileGrid& grid,
                          const MapBox& box,
                          std::int32_t width,
                          std::int32_t height,
                          std::int32_t level,
                          std::int32_t firstLevel,
                          const TileLookup& lookup,
                          Draw&& draw) {
  ComposeStats stats;
  const LevelTiles t = levelTiles(grid, box, width, height, level, lookup);
  Fallback fallback(grid, box, width, height, level, std::max(0, firstLevel), lookup);
  Quad q{};
  for (std::int32_t j = 0; j < height; ++j) {
    const AxisSample& r = t.rows.samples[static_cast<std::size_t>(j)];
    if (r.slotA < 0) continue;
    for (std::int32_t i = 0; i < width; ++i) {
      const AxisSample& c = t.cols.samples[static_cast<std::size_t>(i)];
      if (c.slotA < 0) continue;
      const std::size_t pixel = static_cast<std::size_t>(j) * static_cast<std::size_t>(width) +
                                static_cast<std::size_t>(i);
      if (quadAt(t, c, r, q)) {
        draw(pixel, q);
      } else if (fallback.quad(i, j, q)) {
        ++stats.fallbackPixels;
        draw(pixel, q);
      } else {
        ++stats.missingPixels;
      }
    }
  }
  return stats;
}

/**
 * The one-plane sampler (ComposePlane.cpp) behind composePlane and composeImagery's one-channel
 * canvas: writes `canvas` (width * height), `background` where no tile covers a pixel when not
 * null, else leaves those pixels.
 */
ComposeStats composePlaneInto(const TileGrid& grid,
                              const MapBox& box,
                              std::int32_t width,
                              std::int32_t height,
                              std::int32_t level,
                              std::int32_t firstLevel,
                              const TileLookup& tiles,
                              const std::uint8_t* background,
                              std::uint8_t* canvas);

/** At most this many samples across a pixel (composeWide): up to 85.05 degrees a Mercator pixel
 * spans fewer than 2 / cos(85.05) = 23.2 texels of its level. */
inline constexpr std::int32_t kMaxColumnSamples = 24;

/**
 * How many samples across each pixel a Mercator map's columns need at `level` (ComposeWide.cpp):
 * 1 while a pixel spans at most two texels of its level, else one sample per texel the pixel
 * spans (up to kMaxColumnSamples): rows near the poles, whose level follows their extent in
 * latitude. Always 1 for a lat/long map.
 */
std::int32_t
columnSamples(const TileGrid& grid, const MapBox& box, std::int32_t width, std::int32_t level);

/** Draws the band of a map `samples` times as wide (box, width, height, canvas of that map). */
using WideDraw = std::function<ComposeStats(
    const MapBox&, std::int32_t, std::int32_t, std::vector<std::uint8_t>&)>;

/**
 * The band of rows of `box` drawn by `draw` as a map of those rows alone `samples` (> 1) times as
 * wide, then each pixel of `canvas` (width x height, `channels` bytes a pixel) the mean of its
 * samples. With `over` the wide canvas starts as `canvas`'s rows, each pixel repeated (a layer
 * drawn over what is there); else `draw` writes every sample. Stats in pixels of the map.
 */
ComposeStats composeWide(const MapBox& box,
                         std::int32_t width,
                         std::int32_t height,
                         std::int32_t samples,
                         std::int32_t channels,
                         bool over,
                         std::uint8_t* canvas,
                         const WideDraw& draw);

} // namespace tellus::compose
