#pragma once
/**
 * @file TileGrid.hpp
 * @brief The lat/long quadtree grid of one dataset (World Wind conventions).
 *
 * All tile addressing math of tellus lives here. Angles are degrees, latitude in [-90, 90],
 * longitude in [-180, 180]. The origin is fixed at (-90, -180): row 0 is the southernmost row,
 * column 0 the westernmost column. Level L has tile delta levelZeroDelta / 2^L.
 */

#include <tellus/cache/TileKey.hpp>

#include <array>
#include <cstdint>
#include <expected>
#include <optional>
#include <string>
#include <vector>

namespace tellus {

/** A lat/long rectangle in degrees. west > east means the box crosses the antimeridian. */
struct Sector {
  double west = -180.0;
  double south = -90.0;
  double east = 180.0;
  double north = 90.0;

  friend bool operator==(const Sector&, const Sector&) = default;
};

/** The four neighbour directions of a tile. */
enum class Direction { North, East, South, West };

/** The parameters that define a grid (also what the cache stores per dataset). */
struct GridSpec {
  Sector sector{};                 ///< coverage of the dataset; tiles outside it do not exist
  double levelZeroDeltaDeg = 36.0; ///< tile size at level 0 in degrees (36, 45, 20 ...)
  std::int32_t tileWidth = 512;    ///< pixels
  std::int32_t tileHeight = 512;   ///< pixels
  std::int32_t numLevels = 1;      ///< levels 0 .. numLevels-1 exist; 1 <= numLevels <= kMaxLevel+1

  friend bool operator==(const GridSpec&, const GridSpec&) = default;
};

/**
 * @brief A validated, immutable tile grid. Cheap to copy; all methods are const, noexcept and
 * thread safe.
 *
 * Exactness guarantees:
 * - tile edges are computed from integer indices (origin + index * delta, delta = delta0 * 2^-L,
 *   exact power-of-two scaling), so neighbours share bit-identical edges;
 * - a point on the north edge at lat 90 maps to the last row, lon 180 to the last column
 *   (World Wind's rule); the same closed-edge rule holds at the north/east edge of the sector;
 * - NaN, +-inf and positions outside the sector give no key; levels up to kMaxLevel never overflow.
 */
class TileGrid {
public:
  /** Validates the spec: delta > 0 and finite, 180/delta and 360/delta whole numbers, sector inside
   * the globe with south < north and west < east (a dataset sector does not cross the
   * antimeridian), tile sizes in [1, 65536], numLevels in [1, kMaxLevel+1]. Returns a message
   * naming the bad field. */
  static std::expected<TileGrid, std::string> create(const GridSpec& spec);

  const GridSpec& spec() const noexcept { return spec_; }
  std::int32_t numLevels() const noexcept { return spec_.numLevels; }

  /** Tile delta (degrees) at a level; exact (power-of-two scaling of the level-zero delta). */
  double deltaDeg(std::int32_t level) const noexcept;
  /** Rows / columns of the whole globe at a level (180/delta * 2^level, 360/delta * 2^level). */
  std::int64_t rowCount(std::int32_t level) const noexcept;
  std::int64_t colCount(std::int32_t level) const noexcept;

  /** True when the level is in range, row/col are inside the globe and the tile intersects the
   * sector with a non-zero area. */
  bool isValid(const TileKey& key) const noexcept;

  /** The tile's sector. Precondition: isValid(key) (asserted); edges from integer indices. */
  Sector sectorOf(const TileKey& key) const noexcept;

  /** Tile containing (lat, lon) at a level; lat 90 -> last row, lon 180 -> last column; -0.0 is 0.
   * std::nullopt for NaN, inf, out-of-range position or level, or a position outside the sector. */
  std::optional<TileKey> keyAt(double latDeg, double lonDeg, std::int32_t level) const noexcept;

  /** Keys of all valid tiles intersecting the box with non-zero area, row-major from the
   * south-west. A box with west > east crosses the antimeridian and is split in two. A box is
   * clipped to
   * [-90, 90]; NaN/inf or an empty box gives an empty vector. maxKeys caps the result: beyond it
   * returns std::nullopt (a caller must not allocate billions of keys). */
  std::optional<std::vector<TileKey>>
  keysCovering(const Sector& box, std::int32_t level, std::size_t maxKeys = 1u << 20) const;

  /** Parent tile; std::nullopt at level 0 or for an invalid key. */
  std::optional<TileKey> parent(const TileKey& key) const noexcept;
  /** The four children (SW, SE, NW, NE); std::nullopt at the deepest level or for an invalid key.
   * Children outside the sector are still returned (callers check isValid). */
  std::optional<std::array<TileKey, 4>> children(const TileKey& key) const noexcept;
  /** Same-level neighbour. East/West wrap across the antimeridian; North of the last row and South
   * of row 0 give std::nullopt. Only valid keys (inside the sector) are returned. */
  std::optional<TileKey> neighbour(const TileKey& key, Direction dir) const noexcept;

  /**
   * @brief Key of the tile whose sector equals the WMS bbox (lon/lat order: west, south, east,
   * north) and whose pixel size equals width x height, within a relative tolerance of the tile
   * span (default 1e-9). std::nullopt when not aligned (any level), when sizes differ, or for
   * NaN/inf input.
   */
  std::optional<TileKey> keyForBbox(const Sector& bbox,
                                    std::int32_t width,
                                    std::int32_t height,
                                    double relTolerance = 1e-9) const noexcept;

private:
  explicit TileGrid(const GridSpec& spec) : spec_(spec) {}
  GridSpec spec_;
};

} // namespace tellus
