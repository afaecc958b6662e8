// Imagery layers drawn over an RGB(A) canvas (Compose.hpp's composeImagery): a fast path for the
// four texels of a pixel in one opaque RGB tile at full opacity (the vertical half of the filter
// once per row), else the four texels (or a coarser level's) sampled and drawn "over".
#include "compose/ComposeSampling.hpp"

namespace tellus {

using compose::Axis;
using compose::AxisSample;
using compose::Fallback;
using compose::LevelTiles;
using compose::over;
using compose::Quad;
using compose::quadAt;

namespace {

/** Bilinear RGBA of a quad (imagery tiles of 3 or 4 channels). */
void sampleRgba(const Quad& q, std::uint8_t out[4]) noexcept {
  const std::int32_t w[4] = {
      (256 - q.wx) * (256 - q.wy), q.wx * (256 - q.wy), (256 - q.wx) * q.wy, q.wx * q.wy};
  for (int ch = 0; ch < 4; ++ch) {
    std::int32_t acc = 0;
    for (int k = 0; k < 4; ++k) {
      const TileSamples* s = q.t[k];
      const std::int32_t v = ch < 3 || s->channels == 4
                                 ? s->rgb[q.index[k] * static_cast<std::size_t>(s->channels) +
                                          static_cast<std::size_t>(ch)]
                                 : 255;
      acc += v * w[k];
    }
    out[ch] = static_cast<std::uint8_t>((acc + 32768) >> 16);
  }
}

/** The fast path's columns, compact: the tile column slot when both texels lie in one tile (else
 * -1), the two texels' byte offsets in an RGB row, the second's weight. */
struct FastColumn {
  std::int32_t slot;
  std::uint32_t xa, xb;
  std::int32_t wx;
};

std::vector<FastColumn> fastColumns(const Axis& cols) {
  std::vector<FastColumn> fast(cols.samples.size());
  for (std::size_t i = 0; i < fast.size(); ++i) {
    const AxisSample& c = cols.samples[i];
    fast[i] = FastColumn{c.slotA >= 0 && c.slotA == c.slotB ? c.slotA : -1,
                         static_cast<std::uint32_t>(std::max(c.offA, 0)) * 3u,
                         static_cast<std::uint32_t>(std::max(c.offB, 0)) * 3u,
                         c.weightB};
  }
  return fast;
}

/** The fast path's vertical half of one output row: for each tile column whose four texels lie in
 * one opaque RGB tile, the two texel rows blended with the row's weight over the texels the row
 * samples (a plain loop over bytes, which the compiler vectorises), at `rowBlend[k]`; null for
 * the other tile columns (and for every one when the row is not `fastRow`). */
void blendFastRow(const LevelTiles& t,
                  const AxisSample& r,
                  bool fastRow,
                  std::size_t tileRowSamples,
                  std::vector<std::uint16_t>& blended,
                  std::vector<const std::uint16_t*>& rowBlend) {
  const auto wy = static_cast<std::uint32_t>(r.weightB);
  for (std::size_t k = 0; k < t.cols.tiles.size(); ++k) {
    const TileSamples* s = fastRow ? t.at(r.slotA, static_cast<std::int32_t>(k)) : nullptr;
    if (!s || s->channels != 3 || t.cols.hi[k] < 0) {
      rowBlend[k] = nullptr;
      continue;
    }
    const auto w = static_cast<std::size_t>(s->width);
    const std::uint8_t* a = s->rgb + static_cast<std::size_t>(r.offA) * w * 3;
    const std::uint8_t* b = s->rgb + static_cast<std::size_t>(r.offB) * w * 3;
    std::uint16_t* out = &blended[k * tileRowSamples];
    const std::size_t from = static_cast<std::size_t>(t.cols.lo[k]) * 3;
    const std::size_t to = static_cast<std::size_t>(t.cols.hi[k] + 1) * 3;
    for (std::size_t x = from; x < to; ++x)
      out[x] = static_cast<std::uint16_t>(a[x] * (256u - wy) + b[x] * wy);
    rowBlend[k] = out;
  }
}

/** One output row of an imagery layer drawn over the canvas row `out`: per pixel the fast path's
 * horizontal half, else the four texels (or the coarser level's) sampled and drawn "over" with
 * the layer's opacity (`scale`, 1/256). */
void drawImageryRow(const LevelTiles& t,
                    const AxisSample& r,
                    std::int32_t j,
                    const std::vector<FastColumn>& fast,
                    const std::vector<const std::uint16_t*>& rowBlend,
                    Fallback& fallback,
                    std::int32_t scale,
                    int cc,
                    std::uint8_t* out,
                    ComposeStats& stats) {
  Quad q{};
  const auto width = static_cast<std::int32_t>(fast.size());
  for (std::int32_t i = 0; i < width; ++i, out += cc) {
    // The common case: the four texels in one opaque RGB tile, drawn at full opacity.
    const FastColumn& f = fast[static_cast<std::size_t>(i)];
    if (f.slot >= 0) {
      const std::uint16_t* v = rowBlend[static_cast<std::size_t>(f.slot)];
      if (v) {
        const auto wx = static_cast<std::uint32_t>(f.wx);
        for (std::uint32_t ch = 0; ch < 3; ++ch)
          out[ch] = static_cast<std::uint8_t>(
              (v[f.xa + ch] * (256u - wx) + v[f.xb + ch] * wx + 32768u) >> 16);
        if (cc == 4) out[3] = 255;
        continue;
      }
    }
    const AxisSample& c = t.cols.samples[static_cast<std::size_t>(i)];
    if (c.slotA < 0) continue;
    bool found = quadAt(t, c, r, q);
    if (!found) {
      found = fallback.quad(i, j, q);
      if (found) {
        ++stats.fallbackPixels;
      } else {
        ++stats.missingPixels;
        continue;
      }
    }
    std::uint8_t px[4];
    sampleRgba(q, px);
    if (scale < 256) px[3] = static_cast<std::uint8_t>((px[3] * scale + 128) >> 8);
    over(px, out, cc);
  }
}

} // namespace

ComposeStats composeImagery(const TileGrid& grid,
                            const MapBox& box,
                            std::int32_t width,
                            std::int32_t height,
                            std::int32_t level,
                            std::int32_t firstLevel,
                            const TileLookup& tiles,
                            double opacity,
                            std::vector<std::uint8_t>& canvas,
                            std::int32_t canvasChannels) {
  if (canvasChannels == 1) {
    canvas.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
    return compose::composePlaneInto(
        grid, box, width, height, level, firstLevel, tiles, nullptr, canvas.data());
  }
  const int cc = canvasChannels == 3 ? 3 : 4;
  canvas.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) *
                static_cast<std::size_t>(cc));
  if (const std::int32_t s = compose::columnSamples(grid, box, width, level); s > 1) {
    return compose::composeWide(
        box,
        width,
        height,
        s,
        cc,
        true,
        canvas.data(),
        [&](const MapBox& b, std::int32_t w, std::int32_t h, std::vector<std::uint8_t>& wide) {
          return composeImagery(grid, b, w, h, level, firstLevel, tiles, opacity, wide, cc);
        });
  }
  const double o = std::isfinite(opacity) ? std::clamp(opacity, 0.0, 1.0) : 1.0;
  const auto scale = static_cast<std::int32_t>(std::lround(o * 256.0));
  ComposeStats stats;
  const LevelTiles t = compose::levelTiles(grid, box, width, height, level, tiles);
  Fallback fallback(grid, box, width, height, level, std::max(0, firstLevel), tiles);
  const std::vector<FastColumn> fast = fastColumns(t.cols);
  // Per output row, the fast path's vertical half first, then per pixel only the horizontal
  // half. Integer sums without intermediate rounding: the same values as blending horizontally
  // first.
  const std::size_t tileRowSamples = static_cast<std::size_t>(grid.spec().tileWidth) * 3;
  std::vector<std::uint16_t> blended(t.cols.tiles.size() * tileRowSamples);
  std::vector<const std::uint16_t*> rowBlend(t.cols.tiles.size());
  for (std::int32_t j = 0; j < height; ++j) {
    const AxisSample& r = t.rows.samples[static_cast<std::size_t>(j)];
    if (r.slotA < 0) continue;
    blendFastRow(t, r, scale == 256 && r.slotA == r.slotB, tileRowSamples, blended, rowBlend);
    std::uint8_t* out = &canvas[static_cast<std::size_t>(j) * static_cast<std::size_t>(width) *
                                static_cast<std::size_t>(cc)];
    drawImageryRow(t, r, j, fast, rowBlend, fallback, scale, cc, out, stats);
  }
  return stats;
}

} // namespace tellus
