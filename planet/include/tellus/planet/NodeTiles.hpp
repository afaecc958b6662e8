#pragma once
/**
 * @file NodeTiles.hpp
 * @brief Which tiles a node's texture is made of, for one layer's source.
 *
 * Normally textureTileCount(key) tiles of the node's own dataset (Quadtree.hpp): one, a merged
 * row's up to 16, a polar cap's up to 80. Where the source gives polar rows whole
 * (ITileSource::wholePolarRows, issue 29) a node is ONE tile instead:
 * - a cap: (level, row, cols), cols the level's columns, asked for as `<layer>@caps` at
 *   (level, row, 0);
 * - a merged row's node of span k (aligned: col a multiple of k): (level, row, cols + 2 col + k),
 *   asked for as wholeSpanLayer(layer, k) at (level, row, col). 2 col + k - 1 numbers the aligned
 *   power-of-two runs of a row in order (k - 1 in binary is the run's trailing ones), so each has
 *   a column of its own past the cap's.
 * These columns are no tile of the grid, so the streamer's and intake's maps keyed by tile keep
 * them apart from the row's own tiles. A failure turns caps or spans off for the layer; an absence
 * (offline, not cached) that one node's only, which is then composed of its tiles (refused). See
 * docs/design/poles.md.
 */

#include <tellus/cache/TileSource.hpp>
#include <tellus/planet/Quadtree.hpp>

#include <bit>
#include <cstdint>
#include <string>
#include <unordered_set>

namespace tellus::planet {

static_assert(kCapTextureWidthFactor == kWholeRowWidthFactor, "a cap is a whole row's image");

struct NodeTiles {
  std::int64_t rootCols = 0; ///< level zero's columns; below 2: every node is composed
  bool caps = false;         ///< a cap is one whole row
  bool spans = false;        ///< a merged row's node is one image of its box
  /** Whole rows and spans the source lacks: their nodes are composed (refused). */
  std::unordered_set<TileKey, TileKeyHash> absent;

  /** Caps (where the tree has them) and spans whole, on a grid of rootCols level-zero columns. */
  static NodeTiles whole(std::int64_t rootCols, bool caps) { return {rootCols, caps, true, {}}; }

  std::int64_t cols(std::int32_t level) const noexcept { return rootCols << level; }
  /** Whether the node (key) is a cap whose texture is one whole-row tile. */
  bool wholeCap(const NodeKey& k) const noexcept {
    return caps && rootCols >= 2 && k.col == 0 && k.span == cols(k.level) &&
           !absent.contains(capTile(k));
  }
  /** Whether the node is a merged row's whose texture is one image of its box. */
  bool wholeSpan(const NodeKey& k) const noexcept {
    return spans && rootCols >= 2 && k.span >= 2 && k.span < cols(k.level) &&
           k.span <= kMaxWholeSpan && std::has_single_bit(static_cast<std::uint64_t>(k.span)) &&
           k.col % k.span == 0 && !absent.contains(spanTile(k));
  }
  std::int64_t count(const NodeKey& k) const noexcept {
    return wholeCap(k) || wholeSpan(k) ? 1 : textureTileCount(k);
  }
  /** The i-th of them, west to east; a whole cap's or span's one tile has a reserved column. */
  TileKey tile(const NodeKey& k, std::int64_t i) const noexcept {
    if (wholeCap(k)) return capTile(k);
    if (wholeSpan(k)) return spanTile(k);
    return textureTile(k, i);
  }
  TileKey capTile(const NodeKey& k) const noexcept { return {k.level, k.row, cols(k.level)}; }
  TileKey spanTile(const NodeKey& k) const noexcept {
    return {k.level, k.row, cols(k.level) + 2 * k.col + k.span};
  }
  /** Whether a tile key is a whole row's (the reserved column). */
  bool isWholeRow(const TileKey& t) const noexcept {
    return rootCols >= 2 && t.col == cols(t.level);
  }
  /** Whether a tile key is a whole span's (a reserved column past the row's). */
  bool isWholeSpan(const TileKey& t) const noexcept {
    return rootCols >= 2 && t.col > cols(t.level);
  }
  /** A whole span's node (isWholeSpan(t)). */
  NodeKey spanNode(const TileKey& t) const noexcept {
    const auto run = static_cast<std::uint64_t>(t.col - cols(t.level) - 1); // 2 col + span - 1
    const std::int64_t span = std::int64_t{1} << std::countr_one(run);
    return {t.level, t.row, (static_cast<std::int64_t>(run) - span + 1) / 2, span};
  }
  /** What the source is asked for: `<layer>@caps` at column 0 for a whole row, `<layer>@span<k>`
   * at the node's first column for a whole span. */
  TileAddress address(const std::string& layer, const std::string& time, const TileKey& t) const {
    if (isWholeRow(t))
      return {layer + std::string(kWholeRowLayerSuffix), time, TileKey{t.level, t.row, 0}};
    if (isWholeSpan(t)) {
      const NodeKey n = spanNode(t);
      return {wholeSpanLayer(layer, n.span), time, n.firstTile()};
    }
    return {layer, time, t};
  }
  /** The source failed (`failed`) or lacks the tile t. If it is a whole row (span): failed, the
   * layer's caps (merged nodes) are composed of their rows' tiles from now on (a WMS refusing the
   * size, an error); lacking, only this one's node is (offline, not cached). True when the layer's
   * caps or spans were turned off. */
  bool refused(const TileKey& t, bool failed) {
    if (!(isWholeRow(t) || isWholeSpan(t))) return false;
    if (!failed) {
      absent.insert(t);
      return false;
    }
    bool& flag = isWholeRow(t) ? caps : spans;
    if (!flag) return false;
    flag = false;
    return true;
  }
  /** What `other` turned off is off here too (a prefetcher following its streamer). */
  void narrowTo(const NodeTiles& other) noexcept {
    caps = caps && other.caps;
    spans = spans && other.spans;
  }
};

} // namespace tellus::planet
