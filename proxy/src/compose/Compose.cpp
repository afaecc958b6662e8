#include <tellus/proxy/Compose.hpp>
#include <tellus/values/Sample.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define TELLUS_COMPOSE_AVX2 1
#endif

namespace tellus {

namespace {

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

bool globalInLongitude(const GridSpec& spec) noexcept {
  return spec.sector.west <= -180.0 && spec.sector.east >= 180.0;
}

/** Longitude into [-180, 180). */
double wrapLongitude(double lon) noexcept {
  const double x = lon + 180.0;
  // fmod's value without the call where it is a subtraction: fmod is exact, and so is x - 360
  // for x in [360, 720] (Sterbenz).
  double w = x >= 0.0 && x < 360.0 ? x : x >= 360.0 && x < 720.0 ? x - 360.0 : std::fmod(x, 360.0);
  if (w < 0.0) w += 360.0;
  if (w >= 360.0) w = 0.0;
  return w - 180.0;
}

/** `x` modulo `total` into [0, total): the division only for texels off the grid (the two
 * divisions per texel were most of the axes' cost). */
std::int64_t wrapIndex(std::int64_t x, std::int64_t total) noexcept {
  if (x >= 0 && x < total) return x;
  return (x % total + total) % total;
}

/** A texel index (>= 0) as a tile and the texel's offset in it. */
struct TexelInTile {
  std::int64_t tile;
  std::int32_t offset;
};

TexelInTile texelInTile(std::int64_t x, std::int32_t tileSize) noexcept {
  const std::int64_t tile = x / tileSize;
  return {tile, static_cast<std::int32_t>(x - tile * tileSize)};
}

/** texelInTile along an axis whose texels mostly grow: the last tile is kept, and a texel in it
 * needs no division. */
struct TileCursor {
  std::int32_t size;
  std::int64_t tile = 0, start = 0;

  TexelInTile operator()(std::int64_t x) noexcept {
    const std::int64_t d = x - start;
    if (d >= 0 && d < size) return {tile, static_cast<std::int32_t>(d)};
    const TexelInTile t = texelInTile(x, size);
    tile = t.tile;
    start = x - t.offset;
    return t;
  }
};

/** texelInTile(x1) knowing texelInTile(x0) = `a`: no division when x1 is x0 or its neighbour
 * inside the same tile (nearly every sample). */
TexelInTile nextTexelInTile(const TexelInTile& a,
                            std::int64_t x0,
                            std::int64_t x1,
                            std::int32_t tileSize) noexcept {
  if (x1 == x0) return a;
  if (x1 == x0 + 1 && a.offset + 1 < tileSize) return {a.tile, a.offset + 1};
  return texelInTile(x1, tileSize);
}

std::int32_t slotOf(std::vector<std::int64_t>& tiles, std::int64_t tile) {
  for (std::size_t k = 0; k < tiles.size(); ++k) {
    if (tiles[k] == tile) return static_cast<std::int32_t>(k);
  }
  tiles.push_back(tile);
  return static_cast<std::int32_t>(tiles.size() - 1);
}

/**
 * Columns: texel x counted from -180 (texel centres at x + 0.5), wrapped around a global layer,
 * clamped to the sector's texels otherwise.
 */
Axis computeColumns(const TileGrid& grid,
                    const Sector& box,
                    std::int32_t width,
                    std::int32_t level) {
  const GridSpec& spec = grid.spec();
  const double res = grid.deltaDeg(level) / spec.tileWidth;
  const std::int64_t total = grid.colCount(level) * spec.tileWidth;
  const bool wrap = globalInLongitude(spec);
  const auto first = static_cast<std::int64_t>(std::floor((spec.sector.west + 180.0) / res));
  const auto last = std::min<std::int64_t>(
      total - 1, static_cast<std::int64_t>(std::ceil((spec.sector.east + 180.0) / res)) - 1);
  const double dx = (box.east - box.west) / width;
  Axis a;
  a.samples.resize(static_cast<std::size_t>(width));
  TileCursor cursor{spec.tileWidth};
  for (std::int32_t i = 0; i < width; ++i) {
    double lon = box.west + (i + 0.5) * dx;
    if (wrap) {
      lon = wrapLongitude(lon);
    } else if (lon < spec.sector.west || lon > spec.sector.east) {
      continue; // outside the layer: slot -1
    }
    const double g = (lon + 180.0) / res - 0.5;
    const double fl = std::floor(g);
    const double f = g - fl;
    auto x0 = static_cast<std::int64_t>(fl);
    auto x1 = x0 + 1;
    if (wrap) {
      x0 = wrapIndex(x0, total);
      x1 = wrapIndex(x1, total);
    } else {
      x0 = std::clamp(x0, first, last);
      x1 = std::clamp(x1, first, last);
    }
    AxisSample& s = a.samples[static_cast<std::size_t>(i)];
    const TexelInTile ta = cursor(x0);
    const TexelInTile tb = nextTexelInTile(ta, x0, x1, spec.tileWidth);
    s.slotA = slotOf(a.tiles, ta.tile);
    s.slotB = ta.tile == tb.tile ? s.slotA : slotOf(a.tiles, tb.tile);
    s.offA = ta.offset;
    s.offB = tb.offset;
    a.use(s.slotA, s.offA);
    a.use(s.slotB, s.offB);
    s.exactWeightB = f;
    s.weightB = static_cast<std::int32_t>(std::lround(f * 256.0));
  }
  return a;
}

/** Rows: texel y counted from +90 down (tile rows are counted from the south), clamped at the
 * poles and at the sector's edges. */
Axis computeRows(const TileGrid& grid, const Sector& box, std::int32_t height, std::int32_t level) {
  const GridSpec& spec = grid.spec();
  const double res = grid.deltaDeg(level) / spec.tileHeight;
  const std::int64_t rowCount = grid.rowCount(level);
  const std::int64_t total = rowCount * spec.tileHeight;
  const double north = std::min(90.0, spec.sector.north);
  const double south = std::max(-90.0, spec.sector.south);
  const auto first = std::max<std::int64_t>(
      0, static_cast<std::int64_t>(std::floor((90.0 - spec.sector.north) / res)));
  const auto last = std::min<std::int64_t>(
      total - 1, static_cast<std::int64_t>(std::ceil((90.0 - spec.sector.south) / res)) - 1);
  const double dy = (box.north - box.south) / height;
  Axis a;
  a.samples.resize(static_cast<std::size_t>(height));
  TileCursor cursor{spec.tileHeight};
  for (std::int32_t j = 0; j < height; ++j) {
    const double lat = box.north - (j + 0.5) * dy;
    if (lat > north || lat < south) continue; // past a pole or outside the layer
    const double g = (90.0 - lat) / res - 0.5;
    const double fl = std::floor(g);
    const double f = g - fl;
    const auto y0 = std::clamp(static_cast<std::int64_t>(fl), first, last);
    const auto y1 = std::clamp(static_cast<std::int64_t>(fl) + 1, first, last);
    AxisSample& s = a.samples[static_cast<std::size_t>(j)];
    const TexelInTile ta = cursor(y0);
    const TexelInTile tb = nextTexelInTile(ta, y0, y1, spec.tileHeight);
    s.slotA = slotOf(a.tiles, rowCount - 1 - ta.tile);
    s.slotB = ta.tile == tb.tile ? s.slotA : slotOf(a.tiles, rowCount - 1 - tb.tile);
    s.offA = ta.offset;
    s.offB = tb.offset;
    a.use(s.slotA, s.offA);
    a.use(s.slotB, s.offB);
    s.exactWeightB = f;
    s.weightB = static_cast<std::int32_t>(std::lround(f * 256.0));
  }
  return a;
}

/**
 * The axes last computed, by what they depend on: a JPEG map composed on planes asks for its luma
 * axes twice (composeTilesYcc on the thread that takes the request, the Y plane on a composer
 * thread) and for its chroma axes three times (composeTilesYcc, Cb, Cr), and computing one costs
 * tens of nanoseconds per sample. Shared by all threads (under a lock, held only to look up and
 * to store a pointer); the axes are immutable once made.
 */
template <class Compute>
std::shared_ptr<const Axis> memoAxis(bool isColumns,
                                     const GridSpec& spec,
                                     double from,
                                     double to,
                                     std::int32_t samples,
                                     std::int32_t level,
                                     Compute&& compute) {
  struct Entry {
    bool isColumns;
    GridSpec spec;
    double from, to;
    std::int32_t samples, level;
    std::shared_ptr<const Axis> axis;
  };
  constexpr std::size_t kEntries = 16;    // the axes of four maps at a time
  constexpr std::int32_t kLargest = 4096; // larger maps' axes are not kept
  struct Memo {
    std::mutex lock;
    std::vector<Entry> entries;
    std::size_t next = 0;
  };
  // Never destroyed: a composer thread still running while statics are torn down at exit finds
  // it intact.
  static Memo& memo = *new Memo;
  std::shared_ptr<const Axis> found;
  {
    const std::lock_guard<std::mutex> guard(memo.lock);
    for (const Entry& e : memo.entries) {
      if (e.isColumns == isColumns && e.spec == spec && e.from == from && e.to == to &&
          e.samples == samples && e.level == level) {
        found = e.axis;
        break;
      }
    }
  }
  if (found) return found;
  auto a = std::make_shared<const Axis>(compute());
  if (samples <= kLargest) {
    Entry e{isColumns, spec, from, to, samples, level, a};
    const std::lock_guard<std::mutex> guard(memo.lock);
    if (memo.entries.size() < kEntries) {
      memo.entries.push_back(std::move(e));
    } else {
      memo.entries[memo.next] = std::move(e);
      memo.next = (memo.next + 1) % kEntries;
    }
  }
  return a;
}

std::shared_ptr<const Axis>
columns(const TileGrid& grid, const Sector& box, std::int32_t width, std::int32_t level) {
  return memoAxis(true, grid.spec(), box.west, box.east, width, level, [&] {
    return computeColumns(grid, box, width, level);
  });
}

std::shared_ptr<const Axis>
rows(const TileGrid& grid, const Sector& box, std::int32_t height, std::int32_t level) {
  return memoAxis(false, grid.spec(), box.north, box.south, height, level, [&] {
    return computeRows(grid, box, height, level);
  });
}

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

LevelTiles levelTiles(const TileGrid& grid,
                      const Sector& box,
                      std::int32_t width,
                      std::int32_t height,
                      std::int32_t level,
                      const TileLookup& lookup) {
  LevelTiles t(columns(grid, box, width, level), rows(grid, box, height, level));
  t.tiles.reserve(t.rows.tiles.size() * t.cols.tiles.size());
  for (const auto row : t.rows.tiles) {
    for (const auto col : t.cols.tiles) {
      const TileKey key{level, row, col};
      t.tiles.push_back(grid.isValid(key) ? lookup(key) : nullptr);
    }
  }
  return t;
}

/** The four texels of a pixel at one level, when all four tiles are there. */
struct Quad {
  const TileSamples* t[4];
  std::size_t index[4]; ///< texel index inside its tile (times channels for the caller)
  std::int32_t wx, wy;
  double fx, fy;
};

bool quadAt(const LevelTiles& t, const AxisSample& c, const AxisSample& r, Quad& q) noexcept {
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

/** Bilinear height of a quad; the nearest texel where one of the four is no-data. */
std::int16_t sampleHeight(const Quad& q, std::int16_t noData) noexcept {
  std::int16_t v[4];
  bool any = false;
  for (int k = 0; k < 4; ++k) {
    v[k] = q.t[k]->heights[q.index[k]];
    any = any || v[k] == noData;
  }
  if (any) { // the valid texel of the largest weight (no-data when none is valid)
    const double w[4] = {
        (1 - q.fx) * (1 - q.fy), q.fx * (1 - q.fy), (1 - q.fx) * q.fy, q.fx * q.fy};
    int best = -1;
    for (int k = 0; k < 4; ++k) {
      if (v[k] != noData && (best < 0 || w[k] > w[best])) best = k;
    }
    return best < 0 ? noData : v[best];
  }
  const double top = v[0] + (v[1] - v[0]) * q.fx;
  const double bottom = v[2] + (v[3] - v[2]) * q.fx;
  return static_cast<std::int16_t>(std::lround(top + (bottom - top) * q.fy));
}

/** Draws straight-alpha `src` (alpha already scaled) over canvas pixel `dst` (RGBA, or RGB when
 * `channels` is 3: an opaque canvas). */
void over(const std::uint8_t src[4], std::uint8_t* dst, int channels) noexcept {
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
           const Sector& box,
           std::int32_t width,
           std::int32_t height,
           std::int32_t level,
           std::int32_t firstLevel,
           const TileLookup& lookup)
      : grid_(grid), box_(box), width_(width), height_(height), level_(level), first_(firstLevel),
        lookup_(lookup) {}

  bool quad(std::int32_t i, std::int32_t j, Quad& q) {
    for (std::int32_t l = level_ - 1; l >= first_; --l) {
      const LevelTiles& t = tiles(l);
      if (quadAt(t,
                 t.cols.samples[static_cast<std::size_t>(i)],
                 t.rows.samples[static_cast<std::size_t>(j)],
                 q))
        return true;
    }
    return false;
  }

private:
  const LevelTiles& tiles(std::int32_t l) {
    const auto k = static_cast<std::size_t>(level_ - 1 - l);
    if (levels_.size() <= k) levels_.resize(k + 1);
    if (levels_[k].empty())
      levels_[k].push_back(levelTiles(grid_, box_, width_, height_, l, lookup_));
    return levels_[k].front();
  }

  const TileGrid& grid_;
  Sector box_;
  std::int32_t width_, height_, level_, first_;
  const TileLookup& lookup_;
  std::vector<std::vector<LevelTiles>> levels_; // index: levels above `level_` minus one
};

/** Runs `draw(pixel index, quad)` for every pixel inside the layer, falling back to coarser
 * levels per pixel. */
template <class Draw>
ComposeStats forEachPixel(const TileGrid& grid,
                          const Sector& box,
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

/** Bilinear value of a quad of one-plane tiles. */
std::uint8_t sampleOne(const Quad& q) noexcept {
  const std::int32_t w[4] = {
      (256 - q.wx) * (256 - q.wy), q.wx * (256 - q.wy), (256 - q.wx) * q.wy, q.wx * q.wy};
  std::int32_t acc = 0;
  for (int k = 0; k < 4; ++k)
    acc += q.t[k]->rgb[q.index[k]] * w[k];
  return static_cast<std::uint8_t>((acc + 32768) >> 16);
}

/**
 * The horizontal half of the planar filter, precomputed per output column: out[i] = (v[xa] * wa +
 * v[xb] * wb + 32768) >> 16 over the vertically blended row v. Columns are grouped in segments of
 * a run of columns inside the layer; a segment of 8 columns whose texel pairs are neighbours
 * (xb = xa + 1, or wb = 0) within 16 texels of `base` is done with AVX2 (when the CPU has it)
 * straight from v: two unaligned loads of 16 texels (v[base..] and v[base + 1..]) interleaved into
 * the 16 pairs (v[x], v[x + 1]), two in-register permutations and a blend that pick each column's
 * pair, and one multiply-add of 16-bit pairs (pmaddwd) for v[xa] * wa + v[xb] * wb. pmaddwd
 * multiplies signed 16-bit values and v reaches 65,280, so the texels go in less 32,768 (the sign
 * bit flipped) and 32,768 * (wa + wb) = 2^23 is added back: exact, the same integer arithmetic as
 * the plain loop.
 */
struct Horizontal {
  enum class Kind : std::uint8_t {
    Scalar,
    Avx2,   ///< 8 columns within 16 texels
    Avx512, ///< 16 columns within 32 texels (xa - base <= 30)
  };
  struct Segment {
    std::uint32_t begin, end; ///< output columns
    std::uint32_t base;       ///< for a SIMD segment: its first texel in v
    Kind kind;
  };
  std::vector<std::uint32_t> xa, xb, wa, wb;
  /// AVX2 segments, per column: the pair's 32-bit lane in the interleaved registers (bits 0-2)
  /// and which of the two (bit 31), from r = xa - base: (r & 3) | (r & 8) >> 1, r & 4.
  std::vector<std::uint32_t> lane;
  /// AVX-512 segments, per column: the 16-bit indices of v[xa] and v[xa + 1] from the base, so
  /// that one permutation of 32 texels (vpermw) gives the 16 pairs.
  std::vector<std::uint16_t> pairIndex;
  std::vector<std::uint32_t> weights; ///< SIMD segments, per column: wa | wb << 16
  std::vector<Segment> segments;

  /// How far past the last texel of v the SIMD loads read (v must have these elements).
  static constexpr std::size_t kPadding = 32;

  void scalar(const std::uint16_t* v, std::uint8_t* out, std::size_t b, std::size_t e) const {
    for (std::size_t i = b; i < e; ++i)
      out[i] = static_cast<std::uint8_t>((v[xa[i]] * wa[i] + v[xb[i]] * wb[i] + 32768u) >> 16);
  }
  void run(const std::uint16_t* v, std::uint8_t* out) const;
};

#ifdef TELLUS_COMPOSE_AVX2
// TELLUS_COMPOSE_NO_AVX2=1 takes the plain code on any CPU, TELLUS_COMPOSE_NO_AVX512=1 the AVX2
// code on a CPU with AVX-512 (the tests run all three).
const bool kHasAvx2 = __builtin_cpu_supports("avx2") && !std::getenv("TELLUS_COMPOSE_NO_AVX2");
const bool kHasAvx512 =
    kHasAvx2 && __builtin_cpu_supports("avx512bw") && !std::getenv("TELLUS_COMPOSE_NO_AVX512");

/** One AVX2 segment (8 columns). */
[[gnu::always_inline]] inline __attribute__((target("avx2"))) void segmentAvx2(
    const Horizontal& h, const Horizontal::Segment& s, const std::uint16_t* v, std::uint8_t* out) {
  const __m256i flip = _mm256_set1_epi16(static_cast<short>(0x8000));
  const __m256i offset = _mm256_set1_epi32((1 << 23) + 32768);
  // The low byte of each 32-bit lane to the first four bytes of each 128-bit half, then those two
  // words side by side.
  // clang-format off
  const __m256i bytes = _mm256_setr_epi8(0, 4, 8, 12, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1,
                                         0, 4, 8, 12, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1);
  // clang-format on
  const __m256i gather = _mm256_setr_epi32(0, 4, 1, 5, 2, 6, 3, 7);
  const __m256i v0 =
      _mm256_xor_si256(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(v + s.base)), flip);
  const __m256i v1 =
      _mm256_xor_si256(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(v + s.base + 1)), flip);
  // Pairs (v[x], v[x + 1]) for x = base + 0-3 | 8-11 (lo) and base + 4-7 | 12-15 (hi).
  const __m256i lo = _mm256_unpacklo_epi16(v0, v1);
  const __m256i hi = _mm256_unpackhi_epi16(v0, v1);
  const __m256i lane =
      _mm256_loadu_si256(reinterpret_cast<const __m256i*>(h.lane.data() + s.begin));
  const __m256 pick = _mm256_blendv_ps(_mm256_castsi256_ps(_mm256_permutevar8x32_epi32(lo, lane)),
                                       _mm256_castsi256_ps(_mm256_permutevar8x32_epi32(hi, lane)),
                                       _mm256_castsi256_ps(lane));
  const __m256i sum = _mm256_madd_epi16(
      _mm256_castps_si256(pick),
      _mm256_loadu_si256(reinterpret_cast<const __m256i*>(h.weights.data() + s.begin)));
  const __m256i r = _mm256_permutevar8x32_epi32(
      _mm256_shuffle_epi8(_mm256_srli_epi32(_mm256_add_epi32(sum, offset), 16), bytes), gather);
  _mm_storel_epi64(reinterpret_cast<__m128i*>(out + s.begin), _mm256_castsi256_si128(r));
}

__attribute__((target("avx2"))) void
horizontalAvx2(const Horizontal& h, const std::uint16_t* v, std::uint8_t* out) {
  for (const Horizontal::Segment& s : h.segments) {
    if (s.kind == Horizontal::Kind::Avx2) {
      segmentAvx2(h, s, v, out);
    } else {
      h.scalar(v, out, s.begin, s.end);
    }
  }
}

/** With AVX-512 (BW), 16 columns at a time: 32 texels from the base in one register, one vpermw
 * for the 16 pairs, the same multiply-add. */
__attribute__((target("avx2,avx512f,avx512bw"))) void
horizontalAvx512(const Horizontal& h, const std::uint16_t* v, std::uint8_t* out) {
  const __m512i flip = _mm512_set1_epi16(static_cast<short>(0x8000));
  const __m512i offset = _mm512_set1_epi32((1 << 23) + 32768);
  const __mmask16 all = 0xFFFF;
  for (const Horizontal::Segment& s : h.segments) {
    if (s.kind == Horizontal::Kind::Avx512) {
      const __m512i texels = _mm512_xor_si512(_mm512_loadu_si512(v + s.base), flip);
      const __m512i pairs = _mm512_permutexvar_epi16(
          _mm512_loadu_si512(h.pairIndex.data() + 2 * static_cast<std::size_t>(s.begin)), texels);
      const __m512i sum = _mm512_madd_epi16(pairs, _mm512_loadu_si512(h.weights.data() + s.begin));
      // The zero-masked forms: GCC 12's plain ones start from an "undefined" register that
      // -Wmaybe-uninitialized flags.
      const __m512i r = _mm512_maskz_srli_epi32(all, _mm512_add_epi32(sum, offset), 16);
      _mm_storeu_si128(reinterpret_cast<__m128i*>(out + s.begin),
                       _mm512_maskz_cvtepi32_epi8(all, r));
    } else if (s.kind == Horizontal::Kind::Avx2) {
      segmentAvx2(h, s, v, out);
    } else {
      h.scalar(v, out, s.begin, s.end);
    }
  }
}
#endif

void Horizontal::run(const std::uint16_t* v, std::uint8_t* out) const {
#ifdef TELLUS_COMPOSE_AVX2
  if (kHasAvx512) return horizontalAvx512(*this, v, out);
  if (kHasAvx2) return horizontalAvx2(*this, v, out);
#endif
  for (const Segment& s : segments)
    scalar(v, out, s.begin, s.end);
}

/** The vertical half of the filter over one texel row of a tile column: a plain loop that the
 * compiler vectorises, inlined once more into an AVX2 function used where the CPU has it
 * (dispatched at run time like the horizontal pass; not with target_clones, whose ifunc resolvers
 * run before ThreadSanitizer's runtime is up). */
[[gnu::always_inline]] inline void blendRowsLoop(const std::uint8_t* a,
                                                 const std::uint8_t* b,
                                                 std::uint32_t wy,
                                                 std::uint16_t* out,
                                                 std::size_t n) noexcept {
  for (std::size_t x = 0; x < n; ++x)
    out[x] = static_cast<std::uint16_t>(a[x] * (256u - wy) + b[x] * wy);
}

#ifdef TELLUS_COMPOSE_AVX2
__attribute__((target("avx2"))) void blendRowsAvx2(const std::uint8_t* a,
                                                   const std::uint8_t* b,
                                                   std::uint32_t wy,
                                                   std::uint16_t* out,
                                                   std::size_t n) noexcept {
  blendRowsLoop(a, b, wy, out, n);
}
#endif

void blendRows(const std::uint8_t* a,
               const std::uint8_t* b,
               std::uint32_t wy,
               std::uint16_t* out,
               std::size_t n) noexcept {
#ifdef TELLUS_COMPOSE_AVX2
  if (kHasAvx2) return blendRowsAvx2(a, b, wy, out, n);
#endif
  blendRowsLoop(a, b, wy, out, n);
}

/** Where each tile column's sampled texels [lo, hi] start in the blended row of a plane
 * (composePlaneInto), and (`span`) the row's length. */
std::vector<std::uint32_t> columnBases(const Axis& cols, std::uint32_t& span) {
  std::vector<std::uint32_t> base(cols.tiles.size(), 0);
  span = 0;
  for (std::size_t k = 0; k < cols.tiles.size(); ++k) {
    base[k] = span;
    if (cols.hi[k] >= cols.lo[k]) span += static_cast<std::uint32_t>(cols.hi[k] - cols.lo[k] + 1);
  }
  return base;
}

/** The horizontal half of a plane's filter per output column: the two texels in the blended
 * row and their weights; and the runs of columns inside the layer [begin, end). */
std::vector<std::pair<std::int32_t, std::int32_t>>
horizontalTexels(const Axis& cols, const std::vector<std::uint32_t>& base, Horizontal& hz) {
  const std::size_t w = cols.samples.size();
  hz.xa.assign(w, 0);
  hz.xb.assign(w, 0);
  hz.wa.assign(w, 0);
  hz.wb.assign(w, 0);
  hz.lane.assign(w, 0);
  hz.weights.assign(w, 0);
  std::vector<std::uint32_t>&xa = hz.xa, &xb = hz.xb, &wa = hz.wa, &wb = hz.wb;
  std::vector<std::pair<std::int32_t, std::int32_t>> runs;
  for (std::int32_t i = 0; i < static_cast<std::int32_t>(w); ++i) {
    const AxisSample& c = cols.samples[static_cast<std::size_t>(i)];
    if (c.slotA < 0) continue;
    const auto ka = static_cast<std::size_t>(c.slotA), kb = static_cast<std::size_t>(c.slotB);
    const auto ui = static_cast<std::size_t>(i);
    xa[ui] = base[ka] + static_cast<std::uint32_t>(c.offA - cols.lo[ka]);
    xb[ui] = base[kb] + static_cast<std::uint32_t>(c.offB - cols.lo[kb]);
    wb[ui] = static_cast<std::uint32_t>(c.weightB);
    if (xb[ui] == xa[ui]) wb[ui] = 0; // one texel (clamped at an edge): the same value
    wa[ui] = 256u - wb[ui];
    if (!runs.empty() && runs.back().second == i) {
      runs.back().second = i + 1;
    } else {
      runs.emplace_back(i, i + 1);
    }
  }
  return runs;
}

/** The runs of columns cut into segments: 16 columns by AVX-512 or 8 by AVX2 where their texel
 * pairs are neighbours close enough together, the rest scalar. */
void planSegments(const std::vector<std::pair<std::int32_t, std::int32_t>>& runs, Horizontal& hz) {
#ifdef TELLUS_COMPOSE_AVX2
  const bool wide = kHasAvx512;
#else
  const bool wide = false;
#endif
  const std::vector<std::uint32_t>&xa = hz.xa, &xb = hz.xb, &wa = hz.wa, &wb = hz.wb;
  if (wide) hz.pairIndex.assign(2 * xa.size(), 0);
  // Whether columns [i, i + n) can be one SIMD segment of n columns (texel pairs that are
  // neighbours within `reach` texels of the first); the first texel when they can.
  const auto fits = [&](std::uint32_t i, std::uint32_t n, std::uint32_t reach, std::uint32_t& lo) {
    std::uint32_t hi = xa[i];
    lo = xa[i];
    bool neighbours = true;
    for (std::uint32_t k = i; k < i + n; ++k) {
      lo = std::min(lo, xa[k]);
      hi = std::max(hi, xa[k]);
      neighbours = neighbours && (xb[k] == xa[k] + 1 || wb[k] == 0);
    }
    return neighbours && hi - lo < reach;
  };
  const auto add =
      [&](std::uint32_t begin, std::uint32_t end, std::uint32_t first, Horizontal::Kind kind) {
        if (kind == Horizontal::Kind::Scalar && !hz.segments.empty() &&
            hz.segments.back().kind == Horizontal::Kind::Scalar &&
            hz.segments.back().end == begin) {
          hz.segments.back().end = end;
        } else {
          hz.segments.push_back({begin, end, first, kind});
        }
      };
  for (const auto& [begin, end] : runs) {
    auto i = static_cast<std::uint32_t>(begin);
    const auto e = static_cast<std::uint32_t>(end);
    std::uint32_t lo = 0;
    while (i + 8 <= e) {
      if (wide && i + 16 <= e && fits(i, 16, 31, lo)) {
        for (std::uint32_t k = i; k < i + 16; ++k) {
          const std::uint32_t r = xa[k] - lo;
          hz.pairIndex[2 * k] = static_cast<std::uint16_t>(r);
          hz.pairIndex[2 * k + 1] = static_cast<std::uint16_t>(r + 1);
          hz.weights[k] = wa[k] | wb[k] << 16;
        }
        add(i, i + 16, lo, Horizontal::Kind::Avx512);
        i += 16;
        continue;
      }
      if (fits(i, 8, 16, lo)) {
        for (std::uint32_t k = i; k < i + 8; ++k) {
          const std::uint32_t r = xa[k] - lo;
          hz.lane[k] = (r & 3u) | (r & 8u) >> 1 | (r & 4u ? 0x80000000u : 0u);
          hz.weights[k] = wa[k] | wb[k] << 16;
        }
        add(i, i + 8, lo, Horizontal::Kind::Avx2);
      } else {
        add(i, i + 8, 0, Horizontal::Kind::Scalar);
      }
      i += 8;
    }
    if (i < e) add(i, e, 0, Horizontal::Kind::Scalar);
  }
}

/** The vertical half of one output row of a plane: each tile column's two texel rows blended
 * into `blended` at its base; `present` says which tile columns have both tiles. True when every
 * tile column the map samples has them. */
bool blendPlaneRow(const LevelTiles& t,
                   const AxisSample& r,
                   const std::vector<std::uint32_t>& base,
                   std::vector<std::uint16_t>& blended,
                   std::vector<char>& present) {
  const auto wy = static_cast<std::uint32_t>(r.weightB);
  bool all = true;
  for (std::size_t k = 0; k < t.cols.tiles.size(); ++k) {
    const TileSamples* sa = t.at(r.slotA, static_cast<std::int32_t>(k));
    const TileSamples* sb = t.at(r.slotB, static_cast<std::int32_t>(k));
    present[k] = sa && sb && t.cols.hi[k] >= 0;
    if (!present[k]) {
      all = all && t.cols.hi[k] < 0;
      continue;
    }
    const std::uint8_t* a =
        sa->rgb + static_cast<std::size_t>(r.offA) * static_cast<std::size_t>(sa->width);
    const std::uint8_t* b =
        sb->rgb + static_cast<std::size_t>(r.offB) * static_cast<std::size_t>(sb->width);
    const auto lo = static_cast<std::size_t>(t.cols.lo[k]);
    const std::size_t n = static_cast<std::size_t>(t.cols.hi[k]) + 1 - lo;
    blendRows(a + lo, b + lo, wy, blended.data() + base[k], n);
  }
  return all;
}

/** The horizontal half of a row of a plane where a tile is missing: pixel by pixel, the missing
 * ones from the coarser level (or the background, or left). */
void samplePlaneRowWithHoles(const LevelTiles& t,
                             const Horizontal& hz,
                             const std::uint16_t* v,
                             const std::vector<char>& present,
                             Fallback& fallback,
                             std::int32_t j,
                             const std::uint8_t* background,
                             std::uint8_t* out,
                             ComposeStats& stats) {
  Quad q{};
  for (std::int32_t i = 0; i < static_cast<std::int32_t>(t.cols.samples.size()); ++i) {
    const AxisSample& c = t.cols.samples[static_cast<std::size_t>(i)];
    if (c.slotA < 0) continue;
    const auto ui = static_cast<std::size_t>(i);
    if (present[static_cast<std::size_t>(c.slotA)] && present[static_cast<std::size_t>(c.slotB)]) {
      out[ui] = static_cast<std::uint8_t>(
          (v[hz.xa[ui]] * hz.wa[ui] + v[hz.xb[ui]] * hz.wb[ui] + 32768u) >> 16);
    } else if (fallback.quad(i, j, q)) { // a tile of the four is missing at this level
      ++stats.fallbackPixels;
      out[ui] = sampleOne(q);
    } else {
      ++stats.missingPixels;
      if (background) out[ui] = *background;
    }
  }
}

/**
 * composeImagery for one plane (tiles and canvas of one channel, opaque). Per output row, the
 * vertical half of the filter once per tile column into one row of the texels the map samples
 * (the tile columns side by side), then the horizontal half per pixel as two loads from that row:
 * no test per pixel while every tile of the row is there. The same integer arithmetic as the RGB
 * path's (weights in 1/256, one rounding), so the same values.
 */
ComposeStats composePlaneInto(const TileGrid& grid,
                              const Sector& box,
                              std::int32_t width,
                              std::int32_t height,
                              std::int32_t level,
                              std::int32_t firstLevel,
                              const TileLookup& tiles,
                              const std::uint8_t* background,
                              std::uint8_t* canvas) {
  ComposeStats stats;
  const LevelTiles t = levelTiles(grid, box, width, height, level, tiles);
  Fallback fallback(grid, box, width, height, level, std::max(0, firstLevel), tiles);
  std::uint32_t span = 0;
  const std::vector<std::uint32_t> base = columnBases(t.cols, span);
  Horizontal hz;
  planSegments(horizontalTexels(t.cols, base, hz), hz);
  // + 1: v[x + 1] of the last pair; the SIMD loads read up to 32 texels from a base <= span - 1.
  std::vector<std::uint16_t> blended(span + 1 + Horizontal::kPadding);
  std::vector<char> present(t.cols.tiles.size());
  // With a background, the columns outside the layer are filled in each row drawn.
  const bool outsideColumns =
      background && std::any_of(t.cols.samples.begin(),
                                t.cols.samples.end(),
                                [](const AxisSample& c) { return c.slotA < 0; });
  const auto w = static_cast<std::size_t>(width);
  for (std::int32_t j = 0; j < height; ++j) {
    const AxisSample& r = t.rows.samples[static_cast<std::size_t>(j)];
    std::uint8_t* out = canvas + static_cast<std::size_t>(j) * w;
    if (r.slotA < 0 || outsideColumns) {
      if (background) std::memset(out, *background, w);
      if (r.slotA < 0) continue;
    }
    if (blendPlaneRow(t, r, base, blended, present))
      hz.run(blended.data(), out);
    else
      samplePlaneRowWithHoles(t, hz, blended.data(), present, fallback, j, background, out, stats);
  }
  return stats;
}

} // namespace

std::optional<ChromaLayout>
chromaLayout(const TileGrid& grid, const Sector& box, std::int32_t width, std::int32_t height) {
  GridSpec spec = grid.spec();
  if (spec.tileWidth % 2 != 0 || spec.tileHeight % 2 != 0 || width <= 0 || height <= 0)
    return std::nullopt;
  spec.tileWidth /= 2;
  spec.tileHeight /= 2;
  auto half = TileGrid::create(spec);
  if (!half) return std::nullopt;
  const std::int32_t cw = (width + 1) / 2, ch = (height + 1) / 2;
  const double dx = (box.east - box.west) / width;
  const double dy = (box.north - box.south) / height;
  Sector b = box;
  // The odd pixel's chroma reaches half a chroma sample past the box (what JPEG's edge
  // replication would give it is as good; this keeps the sample spacing exact).
  if (cw * 2 != width) b.east = box.west + dx * (2 * cw);
  if (ch * 2 != height) b.south = box.north - dy * (2 * ch);
  return ChromaLayout{*half, b, cw, ch};
}

std::expected<std::vector<ComposeTile>, std::size_t> composeTilesYcc(const TileGrid& grid,
                                                                     const Sector& box,
                                                                     std::int32_t width,
                                                                     std::int32_t height,
                                                                     std::int32_t level,
                                                                     std::size_t maxTiles) {
  auto keys = composeTiles(grid, box, width, height, level, maxTiles);
  if (!keys) return keys;
  const auto chroma = chromaLayout(grid, box, width, height);
  if (!chroma) return keys;
  const auto more = composeTiles(chroma->grid,
                                 chroma->box,
                                 chroma->width,
                                 chroma->height,
                                 level,
                                 std::numeric_limits<std::size_t>::max());
  if (!more) return keys;
  for (const ComposeTile& c : *more) {
    const std::array<std::int32_t, 4> region{
        c.region[0] * 2, c.region[1] * 2, c.region[2] * 2, c.region[3] * 2};
    auto it = std::find_if(keys->begin(), keys->end(), [&](const ComposeTile& k) {
      return k.key.level == c.key.level && k.key.row == c.key.row && k.key.col == c.key.col;
    });
    if (it == keys->end()) {
      keys->push_back(ComposeTile{c.key, region});
    } else {
      it->region = {std::min(it->region[0], region[0]),
                    std::min(it->region[1], region[1]),
                    std::max(it->region[2], region[2]),
                    std::max(it->region[3], region[3])};
    }
  }
  return keys;
}

std::int32_t composeLevel(const TileGrid& grid,
                          const Sector& box,
                          std::int32_t width,
                          std::int32_t height,
                          std::int32_t firstLevel) {
  const GridSpec& spec = grid.spec();
  const double pixelX = (box.east - box.west) / width;
  const double pixelY = (box.north - box.south) / height;
  const std::int32_t first = std::clamp(firstLevel, 0, grid.numLevels() - 1);
  for (std::int32_t l = first; l < grid.numLevels(); ++l) {
    const double texelX = grid.deltaDeg(l) / spec.tileWidth;
    const double texelY = grid.deltaDeg(l) / spec.tileHeight;
    // A relative tolerance: a map of exactly the level's resolution takes that level.
    if (texelX <= pixelX * (1.0 + 1e-9) && texelY <= pixelY * (1.0 + 1e-9)) return l;
  }
  return grid.numLevels() - 1;
}

std::expected<std::vector<ComposeTile>, std::size_t> composeTiles(const TileGrid& grid,
                                                                  const Sector& box,
                                                                  std::int32_t width,
                                                                  std::int32_t height,
                                                                  std::int32_t level,
                                                                  std::size_t maxTiles) {
  const auto columnAxis = columns(grid, box, width, level);
  const auto rowAxis = rows(grid, box, height, level);
  const Axis& c = *columnAxis;
  const Axis& r = *rowAxis;
  const std::size_t count = c.tiles.size() * r.tiles.size();
  if (count > maxTiles) return std::unexpected(count);
  std::vector<ComposeTile> keys;
  keys.reserve(count);
  for (std::size_t rs = 0; rs < r.tiles.size(); ++rs) {
    for (std::size_t cs = 0; cs < c.tiles.size(); ++cs) {
      const TileKey key{level, r.tiles[rs], c.tiles[cs]};
      if (grid.isValid(key))
        keys.push_back(ComposeTile{key, {c.lo[cs], r.lo[rs], c.hi[cs] + 1, r.hi[rs] + 1}});
    }
  }
  return keys;
}

namespace {

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
                            const Sector& box,
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
    return composePlaneInto(
        grid, box, width, height, level, firstLevel, tiles, nullptr, canvas.data());
  }
  const int cc = canvasChannels == 3 ? 3 : 4;
  canvas.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) *
                static_cast<std::size_t>(cc));
  const double o = std::isfinite(opacity) ? std::clamp(opacity, 0.0, 1.0) : 1.0;
  const auto scale = static_cast<std::int32_t>(std::lround(o * 256.0));
  ComposeStats stats;
  const LevelTiles t = levelTiles(grid, box, width, height, level, tiles);
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

ComposeStats composePlane(const TileGrid& grid,
                          const Sector& box,
                          std::int32_t width,
                          std::int32_t height,
                          std::int32_t level,
                          std::int32_t firstLevel,
                          const TileLookup& tiles,
                          std::uint8_t background,
                          std::vector<std::uint8_t>& plane) {
  plane.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
  return composePlaneInto(
      grid, box, width, height, level, firstLevel, tiles, &background, plane.data());
}

ComposeStats composeHeights(const TileGrid& grid,
                            const Sector& box,
                            std::int32_t width,
                            std::int32_t height,
                            std::int32_t level,
                            std::int32_t firstLevel,
                            const TileLookup& tiles,
                            std::int16_t noData,
                            std::vector<std::int16_t>& heights) {
  heights.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height), noData);
  return forEachPixel(
      grid, box, width, height, level, firstLevel, tiles, [&](std::size_t pixel, const Quad& q) {
        const std::int16_t h = sampleHeight(q, noData);
        if (h != noData) heights[pixel] = h;
      });
}

namespace {

/** The value of a quad of value tiles by values/Sample.hpp's rule (bilinearValue, in double):
 * bilinear; the texel the point lies in where one of the four is NaN. */
float sampleValue(const Quad& q) noexcept {
  return static_cast<float>(values::bilinearValue(static_cast<double>(q.t[0]->values[q.index[0]]),
                                                  static_cast<double>(q.t[1]->values[q.index[1]]),
                                                  static_cast<double>(q.t[2]->values[q.index[2]]),
                                                  static_cast<double>(q.t[3]->values[q.index[3]]),
                                                  q.fx,
                                                  q.fy));
}

} // namespace

ComposeStats composeValues(const TileGrid& grid,
                           const Sector& box,
                           std::int32_t width,
                           std::int32_t height,
                           std::int32_t level,
                           std::int32_t firstLevel,
                           const TileLookup& tiles,
                           std::vector<float>& values) {
  values.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height),
                std::numeric_limits<float>::quiet_NaN());
  return forEachPixel(
      grid, box, width, height, level, firstLevel, tiles, [&](std::size_t pixel, const Quad& q) {
        const float v = sampleValue(q);
        if (!std::isnan(v)) values[pixel] = v;
      });
}

void drawValuesAsColours(const std::vector<float>& values,
                         const values::ColourScale& scale,
                         double opacity,
                         std::vector<std::uint8_t>& canvas,
                         std::int32_t canvasChannels) {
  const double alpha = std::clamp(opacity, 0.0, 1.0);
  const auto channels = static_cast<std::size_t>(canvasChannels);
  for (std::size_t p = 0; p < values.size() && (p + 1) * channels <= canvas.size(); ++p) {
    values::Rgba8 c = values::colourOf(scale, values[p]);
    if (c[3] == 0) continue;
    c[3] = static_cast<std::uint8_t>(std::lround(alpha * 255.0));
    over(c.data(), &canvas[p * channels], canvasChannels);
  }
}

std::uint8_t heightToGrey(std::int16_t raw) noexcept {
  const std::int32_t span = kGreyRampHigh - kGreyRampLow;
  const std::int32_t v = std::clamp<std::int32_t>(raw, kGreyRampLow, kGreyRampHigh) - kGreyRampLow;
  return static_cast<std::uint8_t>((v * 255 + span / 2) / span);
}

void drawHeightsAsGrey(const std::vector<std::int16_t>& heights,
                       std::int16_t noData,
                       double opacity,
                       std::vector<std::uint8_t>& canvas,
                       std::int32_t canvasChannels) {
  const auto alpha = static_cast<std::uint8_t>(std::lround(std::clamp(opacity, 0.0, 1.0) * 255.0));
  const auto channels = static_cast<std::size_t>(canvasChannels);
  for (std::size_t p = 0; p < heights.size() && (p + 1) * channels <= canvas.size(); ++p) {
    if (heights[p] == noData) continue;
    const std::uint8_t g = heightToGrey(heights[p]);
    const std::uint8_t src[4] = {g, g, g, alpha};
    over(src, &canvas[p * channels], canvasChannels);
  }
}

std::uint8_t luminance(std::uint8_t r, std::uint8_t g, std::uint8_t b) noexcept {
  return static_cast<std::uint8_t>((299 * r + 587 * g + 114 * b + 500) / 1000);
}

void drawLuminanceAsHeights(const std::vector<std::uint8_t>& rgba,
                            std::vector<std::int16_t>& heights) {
  for (std::size_t p = 0; p < heights.size() && (p + 1) * 4 <= rgba.size(); ++p) {
    const std::uint8_t* px = &rgba[p * 4];
    if (px[3] >= 128) heights[p] = luminance(px[0], px[1], px[2]);
  }
}

} // namespace tellus
