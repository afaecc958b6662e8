// A map's axes at one level and the tiles they name (ComposeSampling.hpp): which texels each
// output column and row samples, remembered between maps; the level a map is composed from and
// the tiles it needs (composeLevel, composeTiles, composeTilesYcc, chromaLayout: Compose.hpp); the
// fallback to coarser levels.
#include "compose/ComposeSampling.hpp"

#include <mutex>

namespace tellus {

namespace compose {

namespace {

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
                    const MapBox& box,
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
Axis computeRows(const TileGrid& grid, const MapBox& box, std::int32_t height, std::int32_t level) {
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
  Axis a;
  a.samples.resize(static_cast<std::size_t>(height));
  TileCursor cursor{spec.tileHeight};
  const std::int32_t begin = std::max(0, box.rowBegin), end = std::min(height, box.rowEnd);
  for (std::int32_t j = begin; j < end; ++j) {
    const double lat = box.rowLatitude(j, height);
    // Past a pole, outside the layer, or past the Mercator square (NaN).
    if (!(lat <= north && lat >= south)) continue;
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
/** What an axis depends on besides the grid, the samples and the level: its span (west and east;
 * north and south, or a Mercator map's y), how rows are spaced and the band of rows drawn. */
struct AxisSpan {
  double from, to;
  MapRows rows = MapRows::Latitude;
  std::int32_t begin = 0, end = 0;
  friend bool operator==(const AxisSpan&, const AxisSpan&) = default;
};

template <class Compute>
std::shared_ptr<const Axis> memoAxis(bool isColumns,
                                     const GridSpec& spec,
                                     const AxisSpan& span,
                                     std::int32_t samples,
                                     std::int32_t level,
                                     Compute&& compute) {
  struct Entry {
    bool isColumns;
    GridSpec spec;
    AxisSpan span;
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
      if (e.isColumns == isColumns && e.spec == spec && e.span == span && e.samples == samples &&
          e.level == level) {
        found = e.axis;
        break;
      }
    }
  }
  if (found) return found;
  auto a = std::make_shared<const Axis>(compute());
  if (samples <= kLargest) {
    Entry e{isColumns, spec, span, samples, level, a};
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

} // namespace

std::shared_ptr<const Axis>
columns(const TileGrid& grid, const MapBox& box, std::int32_t width, std::int32_t level) {
  return memoAxis(true, grid.spec(), AxisSpan{box.west, box.east}, width, level, [&] {
    return computeColumns(grid, box, width, level);
  });
}

std::shared_ptr<const Axis>
rows(const TileGrid& grid, const MapBox& box, std::int32_t height, std::int32_t level) {
  const bool mercator = box.rows == MapRows::Mercator;
  const AxisSpan span{mercator ? box.northY : box.north,
                      mercator ? box.southY : box.south,
                      box.rows,
                      std::max(0, box.rowBegin),
                      std::min(height, box.rowEnd)};
  return memoAxis(false, grid.spec(), span, height, level, [&] {
    return computeRows(grid, box, height, level);
  });
}

LevelTiles levelTiles(const TileGrid& grid,
                      const MapBox& box,
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

bool Fallback::quad(std::int32_t i, std::int32_t j, Quad& q) {
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

const LevelTiles& Fallback::tiles(std::int32_t l) {
  const auto k = static_cast<std::size_t>(level_ - 1 - l);
  if (levels_.size() <= k) levels_.resize(k + 1);
  if (levels_[k].empty())
    levels_[k].push_back(levelTiles(grid_, box_, width_, height_, l, lookup_));
  return levels_[k].front();
}

} // namespace compose

using compose::Axis;
using compose::columns;
using compose::rows;

std::optional<ChromaLayout>
chromaLayout(const TileGrid& grid, const MapBox& box, std::int32_t width, std::int32_t height) {
  GridSpec spec = grid.spec();
  if (spec.tileWidth % 2 != 0 || spec.tileHeight % 2 != 0 || width <= 0 || height <= 0)
    return std::nullopt;
  spec.tileWidth /= 2;
  spec.tileHeight /= 2;
  auto half = TileGrid::create(spec);
  if (!half) return std::nullopt;
  const std::int32_t cw = (width + 1) / 2, ch = (height + 1) / 2;
  const double dx = (box.east - box.west) / width;
  MapBox b = box;
  // The odd pixel's chroma reaches half a chroma sample past the box (what JPEG's edge
  // replication would give it is as good; this keeps the sample spacing exact).
  if (cw * 2 != width) b.east = box.west + dx * (2 * cw);
  if (ch * 2 != height) {
    if (box.rows == MapRows::Mercator) {
      b.southY = box.northY - (box.northY - box.southY) / height * (2 * ch);
      b.south = mercator::latitudeOfY(std::clamp(b.southY, -mercator::kMaxY, mercator::kMaxY));
    } else {
      const double dy = (box.north - box.south) / height;
      b.south = box.north - dy * (2 * ch);
    }
  }
  // The band's rows in chroma rows (a chroma row covers two of the map's).
  if (box.rowBegin > 0) b.rowBegin = box.rowBegin / 2;
  if (box.rowEnd < height) b.rowEnd = (box.rowEnd + 1) / 2;
  return ChromaLayout{*half, b, cw, ch};
}

std::expected<std::vector<ComposeTile>, std::size_t> composeTilesYcc(const TileGrid& grid,
                                                                     const MapBox& box,
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

std::optional<std::int32_t>
fineEnoughLevel(const TileGrid& grid, double pixelX, double pixelY, std::int32_t firstLevel) {
  const GridSpec& spec = grid.spec();
  const std::int32_t first = std::clamp(firstLevel, 0, grid.numLevels() - 1);
  // A relative tolerance: a map of exactly a level's resolution (times the bound) takes it.
  const double x = pixelX * kMaxUpsampling * (1.0 + 1e-9);
  const double y = pixelY * kMaxUpsampling * (1.0 + 1e-9);
  for (std::int32_t l = first; l < grid.numLevels(); ++l) {
    if (grid.deltaDeg(l) / spec.tileWidth <= x && grid.deltaDeg(l) / spec.tileHeight <= y) return l;
  }
  return std::nullopt;
}

namespace {

/** The level from `firstLevel` a pixel of pixelX x pixelY degrees is composed from
 * (composeLevel): fineEnoughLevel's, the deepest when none is fine enough. */
std::int32_t levelFor(const TileGrid& grid, double pixelX, double pixelY, std::int32_t firstLevel) {
  return fineEnoughLevel(grid, pixelX, pixelY, firstLevel).value_or(grid.numLevels() - 1);
}

} // namespace

std::vector<ComposeBand> composeBands(const TileGrid& grid,
                                      const MapBox& box,
                                      std::int32_t width,
                                      std::int32_t height,
                                      std::int32_t firstLevel) {
  const double pixelX = (box.east - box.west) / width;
  if (box.rows == MapRows::Latitude || height <= 0) {
    const double pixelY = (box.north - box.south) / height;
    return {ComposeBand{box, levelFor(grid, pixelX, pixelY, firstLevel)}};
  }
  std::vector<ComposeBand> bands;
  const auto add = [&](std::int32_t j, std::int32_t level) {
    if (!bands.empty() && bands.back().level == level) {
      bands.back().box.rowEnd = j + 1;
      return;
    }
    MapBox b = box;
    b.rowBegin = j;
    b.rowEnd = j + 1;
    bands.push_back(ComposeBand{b, level});
  };
  double top = box.rowEdgeLatitude(0, height);
  std::int32_t pending = 0; // rows past the square not yet in a band
  for (std::int32_t j = 0; j < height; ++j) {
    const double bottom = box.rowEdgeLatitude(j + 1, height);
    const double pixelY = top - bottom;
    top = bottom;
    if (!(pixelY > 0.0)) { // wholly past the square: in the band above, or the next one
      if (bands.empty()) {
        ++pending;
      } else {
        bands.back().box.rowEnd = j + 1;
      }
      continue;
    }
    add(j, levelFor(grid, pixelX, pixelY, firstLevel));
    if (pending > 0) {
      bands.front().box.rowBegin = 0;
      pending = 0;
    }
  }
  if (bands.empty()) { // nothing inside the square: one band that draws nothing
    MapBox b = box;
    b.rowBegin = 0;
    b.rowEnd = height;
    bands.push_back(ComposeBand{b, levelFor(grid, pixelX, pixelX, firstLevel)});
  }
  bands.back().box.rowEnd = height;
  return bands;
}

std::int32_t composeLevel(const TileGrid& grid,
                          const MapBox& box,
                          std::int32_t width,
                          std::int32_t height,
                          std::int32_t firstLevel) {
  std::int32_t level = 0;
  for (const ComposeBand& b : composeBands(grid, box, width, height, firstLevel))
    level = std::max(level, b.level);
  return level;
}

std::expected<std::vector<ComposeTile>, std::size_t> composeTiles(const TileGrid& grid,
                                                                  const MapBox& box,
                                                                  std::int32_t width,
                                                                  std::int32_t height,
                                                                  std::int32_t level,
                                                                  std::size_t maxTiles) {
  // The columns as drawn: with several samples across a pixel where one would alias (the
  // texels at either edge of the map are then those of the outer samples).
  const auto columnAxis =
      columns(grid, box, width * compose::columnSamples(grid, box, width, level), level);
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

} // namespace tellus
