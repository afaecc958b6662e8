#pragma once
/**
 * @file MapBox.hpp
 * @brief A map's box and how its pixel rows are spaced, and spherical (Web) Mercator's formulas.
 *
 * A map in EPSG:4326 or CRS:84 has its rows evenly spaced in latitude; one in EPSG:3857 (Web
 * Mercator: spherical Mercator on a sphere of radius 6378137 m, as EPSG:3857 defines it) has
 * them evenly spaced in Mercator y, so each row's latitude is the inverse Mercator of its
 * centre's y. Columns are evenly spaced in longitude in both (x = R * longitude). The composers
 * (Compose.hpp) read each row's latitude from the box, so a Mercator map is sampled straight from
 * the lat/long tiles (no intermediate picture), and rows past the Mercator square (|y| > pi R,
 * latitudes beyond +-85.0511287798 degrees) are left empty (the background).
 */

#include <tellus/cache/TileGrid.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>

namespace tellus {

namespace mercator {

inline constexpr double kRadius = 6378137.0; ///< EPSG:3857's sphere (WGS 84's semi-major axis)
inline constexpr double kMaxY = std::numbers::pi * kRadius; ///< the square's half side (metres)
/// The latitude of y = kMaxY: atan(sinh(pi)) in degrees (the square's north edge).
inline constexpr double kMaxLatitude = 85.05112877980659;

inline double xOfLongitude(double lon) noexcept {
  return lon * (std::numbers::pi / 180.0) * kRadius;
}
inline double longitudeOfX(double x) noexcept {
  return x / kRadius * (180.0 / std::numbers::pi);
}
/** y of a latitude (degrees, inside +-90): R ln tan(pi/4 + phi/2), written as R asinh(tan phi). */
inline double yOfLatitude(double lat) noexcept {
  return kRadius * std::asinh(std::tan(lat * (std::numbers::pi / 180.0)));
}
/** The latitude (degrees) of y: atan(sinh(y / R)) (the inverse; beyond the square it still
 * answers, between kMaxLatitude and 90). */
inline double latitudeOfY(double y) noexcept {
  return std::atan(std::sinh(y / kRadius)) * (180.0 / std::numbers::pi);
}

} // namespace mercator

/** How a map's pixel rows are spaced. */
enum class MapRows : std::uint8_t {
  Latitude, ///< evenly in latitude (EPSG:4326, CRS:84)
  Mercator, ///< evenly in spherical Mercator y (EPSG:3857)
};

/**
 * The box of a map: west and east in degrees of longitude (columns evenly spaced between them in
 * both spacings), south and north in degrees of latitude (for a Mercator map the latitudes of
 * southY and northY clamped to the square, for what needs a latitude range), and the band of rows
 * [rowBegin, rowEnd) a composer draws (the rows outside it are left as they are: a Mercator map
 * is composed in bands, each from its own level; composeBands).
 *
 * A plain Sector converts to a box of latitude rows (every row drawn).
 */
struct MapBox : Sector {
  MapRows rows = MapRows::Latitude;
  double northY = 0.0; ///< Mercator: the y of the map's top edge (metres)
  double southY = 0.0; ///< Mercator: the y of its bottom edge (metres), < northY
  std::int32_t rowBegin = 0;
  std::int32_t rowEnd = std::numeric_limits<std::int32_t>::max();

  MapBox() = default;
  MapBox(const Sector& s) : Sector(s) {} // NOLINT(google-explicit-constructor): a Sector is one

  friend bool operator==(const MapBox&, const MapBox&) = default;

  bool drawsRow(std::int32_t j) const noexcept { return j >= rowBegin && j < rowEnd; }

  /** The latitude of row j's centre in a map `height` rows high; NaN for a Mercator row whose
   * centre lies past the square (drawn as nothing). */
  double rowLatitude(std::int32_t j, std::int32_t height) const noexcept {
    if (rows == MapRows::Latitude) {
      const double dy = (north - south) / height;
      return north - (j + 0.5) * dy;
    }
    const double y = northY - (j + 0.5) * ((northY - southY) / height);
    if (!(std::fabs(y) <= mercator::kMaxY)) return std::numeric_limits<double>::quiet_NaN();
    return mercator::latitudeOfY(y);
  }

  /** The latitude of a row edge (j = 0 the top edge, `height` the bottom one), clamped to the
   * Mercator square. */
  double rowEdgeLatitude(std::int32_t j, std::int32_t height) const noexcept {
    if (rows == MapRows::Latitude) return north - j * ((north - south) / height);
    const double y = northY - j * ((northY - southY) / height);
    return mercator::latitudeOfY(std::clamp(y, -mercator::kMaxY, mercator::kMaxY));
  }
};

/** The box of an EPSG:3857 map whose bbox is `metres` (west/east: x, south/north: y, metres). */
inline MapBox mercatorBox(const Sector& metres) noexcept {
  MapBox b;
  b.rows = MapRows::Mercator;
  b.west = mercator::longitudeOfX(metres.west);
  b.east = mercator::longitudeOfX(metres.east);
  b.northY = metres.north;
  b.southY = metres.south;
  b.north = mercator::latitudeOfY(std::clamp(metres.north, -mercator::kMaxY, mercator::kMaxY));
  b.south = mercator::latitudeOfY(std::clamp(metres.south, -mercator::kMaxY, mercator::kMaxY));
  return b;
}

} // namespace tellus
