#pragma once
// Metatiles: up to n x n tiles of one level fetched from a WMS upstream with one GetMap, then split
// into tiles (MapProxy's meta_size, MapCache's metatile). The block arithmetic is pure; the split
// cuts a JPEG in the DCT domain when the tile edges fall on its iMCU boundaries (no generation
// loss, no pixel work), and otherwise decodes the image once and encodes each tile.

#include <tellus/cache/TileGrid.hpp>
#include <tellus/proxy/TileValidation.hpp>

#include <cstddef>
#include <cstdint>
#include <expected>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace tellus {

/** A rectangle of tiles of one level: rows row0 .. row0 + rows - 1 (row 0 in the south), columns
 * col0 .. col0 + cols - 1. */
struct TileBlock {
  std::int32_t level = 0;
  std::int64_t row0 = 0;
  std::int64_t col0 = 0;
  std::int32_t rows = 0;
  std::int32_t cols = 0;

  bool contains(const TileKey& k) const noexcept {
    return k.level == level && k.row >= row0 && k.row < row0 + rows && k.col >= col0 &&
           k.col < col0 + cols;
  }
  /** Index of a contained key in a split image's tiles (row-major from the top-left: the image's
   * first row of tiles is the block's northernmost). */
  std::size_t imageIndex(const TileKey& k) const noexcept {
    return static_cast<std::size_t>((row0 + rows - 1 - k.row) * cols + (k.col - col0));
  }
  friend bool operator==(const TileBlock&, const TileBlock&) = default;
};

/** The metatile of size n x n that holds `key`: aligned to multiples of n from the grid's origin
 * (row 0 at the south pole, column 0 at the antimeridian), clipped to the globe's rows and
 * columns at that level (level 0 of a 36-degree grid is 10 x 5 tiles: blocks of 4 x 4, 4 x 1,
 * 2 x 4, 2 x 1) and to the grid's valid tiles (a partial dataset's sector). n = 1 gives the key. */
TileBlock metaTileOf(const TileGrid& grid, const TileKey& key, std::int32_t n) noexcept;

/** The smallest block that holds every key (all of one level; `keys` not empty). */
TileBlock boundingBlock(std::span<const TileKey> keys) noexcept;

/** The block's sector: its south-west tile's south and west edges, its north-east tile's north and
 * east edges (computed from integer indices like every tile edge, so they are the tiles' own). */
Sector blockSector(const TileGrid& grid, const TileBlock& block) noexcept;

enum class MetaSplit { Dct, Decoded };

/** A metatile decoded once, whose tiles are encoded one by one (on any thread, each on its own):
 * so that the tile a client waits for is encoded and stored first, not after all of its block. */
struct DecodedMetaTile {
  ImageKind kind = ImageKind::Png; ///< Png: RGBA pixels; Jpeg: RGB
  int cols = 0, rows = 0, tileWidth = 0, tileHeight = 0;
  std::vector<std::uint8_t> pixels; ///< cols x tileWidth by rows x tileHeight, from the top
};

struct SplitTiles {
  std::vector<std::vector<std::byte>>
      tiles; ///< row-major from the top-left (TileBlock::imageIndex); empty when `decoded`
  MetaSplit how = MetaSplit::Dct;
  /** Decoded, from splitMetaTileLazily: the tiles are encodeMetaTilePart's to make. */
  std::shared_ptr<const DecodedMetaTile> decoded;
};

/**
 * Splits a metatile answer whose envelope was validated (validateImageResponse: status, content
 * type, magic, JPEG end marker) into cols x rows tiles of tileWidth x tileHeight. The image is
 * checked whole here, once: it must have exactly the block's pixel size and decode without even a
 * warning; otherwise no tile is returned. JPEG: cut in the DCT domain when aligned
 * (MetaSplit::Dct), else decoded once and each tile encoded (quality 90); PNG: decoded once, each
 * tile encoded (RGB when the tile is opaque, else RGBA). Other kinds are refused (the caller
 * fetches them per tile).
 */
std::expected<SplitTiles, std::string> splitMetaTile(std::span<const std::byte> body,
                                                     ImageKind kind,
                                                     int cols,
                                                     int rows,
                                                     int tileWidth,
                                                     int tileHeight);

/** splitMetaTile, but an image that must be decoded is returned decoded (SplitTiles::decoded),
 * checked the same way, its tiles left to encodeMetaTilePart; a JPEG cut in the DCT domain is
 * returned cut, as splitMetaTile does. */
std::expected<SplitTiles, std::string> splitMetaTileLazily(std::span<const std::byte> body,
                                                           ImageKind kind,
                                                           int cols,
                                                           int rows,
                                                           int tileWidth,
                                                           int tileHeight);

/** Tile `index` (TileBlock::imageIndex) of a decoded metatile, encoded: JPEG quality 90 with the
 * tiles' restart interval; PNG RGB when the tile is opaque, else RGBA. */
std::expected<std::vector<std::byte>, std::string> encodeMetaTilePart(const DecodedMetaTile& meta,
                                                                      std::size_t index);

} // namespace tellus
