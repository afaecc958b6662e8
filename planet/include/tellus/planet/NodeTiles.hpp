#pragma once
/**
 * @file NodeTiles.hpp
 * @brief Which tiles a node's texture is made of, for one layer's source.
 *
 * Normally textureTileCount(key) tiles of the node's own dataset (Quadtree.hpp): one, a merged
 * row's up to 16, a polar cap's up to 80. Where the source gives a polar row whole
 * (ITileSource::wholePolarRows, issue 29), a cap is ONE tile instead: (level, row, wholeRowColumn)
 * here, asked for as the layer `<layer>@caps` at (level, row, 0) (TileSource.hpp). The column, one
 * past the level's last, is no tile of the grid, so the streamer's and intake's maps keyed by tile
 * keep it apart from the row's own tiles. See docs/design/poles.md.
 */

#include <tellus/cache/TileSource.hpp>
#include <tellus/planet/Quadtree.hpp>

#include <cstdint>
#include <string>

namespace tellus::planet {

static_assert(kCapTextureWidthFactor == kWholeRowWidthFactor, "a cap is a whole row's image");

struct NodeTiles {
  /// Level zero's columns when the source gives polar rows whole; 0: caps are composed.
  std::int64_t wholeRowRootCols = 0;

  /** Whether the node (key) is a cap whose texture is one whole-row tile. */
  bool wholeCap(const NodeKey& k) const noexcept {
    return wholeRowRootCols >= 2 && k.col == 0 && k.span == (wholeRowRootCols << k.level);
  }
  std::int64_t count(const NodeKey& k) const noexcept {
    return wholeCap(k) ? 1 : textureTileCount(k);
  }
  /** The i-th of them, west to east; a whole cap's one tile has the reserved column. */
  TileKey tile(const NodeKey& k, std::int64_t i) const noexcept {
    return wholeCap(k) ? TileKey{k.level, k.row, k.span} : textureTile(k, i);
  }
  /** Whether a tile key is a whole row's (the reserved column). */
  bool isWholeRow(const TileKey& t) const noexcept {
    return wholeRowRootCols >= 2 && t.col == (wholeRowRootCols << t.level);
  }
  /** What the source is asked for: `<layer>@caps` at column 0 for a whole row. */
  TileAddress address(const std::string& layer, const std::string& time, const TileKey& t) const {
    if (!isWholeRow(t)) return {layer, time, t};
    return {layer + std::string(kWholeRowLayerSuffix), time, TileKey{t.level, t.row, 0}};
  }
};

} // namespace tellus::planet
