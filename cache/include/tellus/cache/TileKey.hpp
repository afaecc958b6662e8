#pragma once
/**
 * @file TileKey.hpp
 * @brief The address of one tile in a lat/long quadtree: level, row (from the south), column (from
 * the antimeridian at -180 degrees).
 */

#include <compare>
#include <cstdint>
#include <functional>

namespace tellus {

/** Deepest level any grid supports. At level 30 a 20-degree grid has 9 * 2^30 rows, so rows and
 * columns are 64-bit. */
inline constexpr std::int32_t kMaxLevel = 30;

/**
 * @brief One tile of a World Wind style lat/long grid.
 *
 * Row 0 is the southernmost row (its south edge is -90), column 0 the westernmost (west edge -180),
 * exactly as World Wind numbers them. Integers are the source of truth: tile edges are derived from
 * them, never the other way round.
 */
struct TileKey {
  std::int32_t level = 0;
  std::int64_t row = 0;
  std::int64_t col = 0;

  friend constexpr auto operator<=>(const TileKey&, const TileKey&) = default;
};

/** Hash for unordered containers. */
struct TileKeyHash {
  std::size_t operator()(const TileKey& k) const noexcept {
    constexpr std::uint64_t kGolden = 0x9E3779B97F4A7C15u;
    std::uint64_t h = static_cast<std::uint64_t>(k.level) * kGolden;
    h ^= static_cast<std::uint64_t>(k.row) + kGolden + (h << 6) + (h >> 2);
    h ^= static_cast<std::uint64_t>(k.col) + kGolden + (h << 6) + (h >> 2);
    return static_cast<std::size_t>(h);
  }
};

} // namespace tellus
