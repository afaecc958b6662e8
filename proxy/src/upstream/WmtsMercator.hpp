#pragma once
/**
 * @file WmtsMercator.hpp
 * @brief Web Mercator (EPSG:3857) upstream matrix sets mapped onto a lat/long World Wind grid
 * (WmtsUpstream.hpp): how such a set is recognised, which of its zooms a grid level is composed
 * from, and which of its tiles a grid tile needs.
 *
 * Recognition is by the CRS (EPSG 3857, 900913, 3785, 102100, 102113 or OSGEO 41001, in any URN or
 * short form) and by every matrix's geometry: the top-left corner at (-20037508.34, 20037508.34)
 * within a metre, square tiles, and a tile span (scale denominator x 0.28 mm x tile width) that is
 * the square's side 2 pi R over a power of two (the zoom) within a thousandth of a tile. The
 * matrix's own corner and pixel size (as written) are what the composition uses, so the tolerance
 * decides only what is accepted, never where a pixel lands.
 *
 * Zoom choice: a grid level is composed from the coarsest zoom whose pixel is at least as fine as
 * the level's pixel along both axes at the tile's latitude. A Mercator pixel spans 360 / (tile
 * width x 2^z) degrees of longitude at every latitude and cos(latitude) times that in latitude, so
 * the east-west span decides and the choice is the same at every latitude: the finest zoom needed
 * anywhere, no coarser toward the poles. What the poles cost instead is rows: a grid tile at
 * latitude phi covers about 1 / cos(phi) times as many Mercator rows as one at the equator.
 */

#include <tellus/proxy/WmtsUpstream.hpp>

#include <cstdint>
#include <expected>
#include <string>
#include <string_view>
#include <vector>

namespace tellus::wmtsmercator {

/** Whether `crs` names spherical (Web) Mercator. */
bool isMercatorCrs(std::string_view crs) noexcept;

/** The matrices of a Web Mercator set (originX/Y and pixelMetres set; west, north and pixelDeg
 * their lat/long equivalents at the equator), or why the set is not one. */
std::expected<std::vector<WmtsMatrixGeometry>, std::string>
matrices(const UpstreamTileMatrixSet& set);

/** The Mercator zoom of a matrix: log2 of the square's side over its tile span. */
int zoomOf(const WmtsMatrixGeometry& m) noexcept;

/** The source tiles (WMTS rows and columns, inclusive) a grid tile of `sector`, width x height
 * pixels, needs from matrix `m`; empty (r0 > r1) when the tile lies wholly beyond the square. */
struct TileRange {
  std::int64_t r0 = 0, r1 = -1, c0 = 0, c1 = -1;
};
TileRange sourceRange(const WmtsMatrixGeometry& m, const Sector& sector, int width, int height);

/** The fractional source pixel (x across, y down; pixel centres at whole numbers) of a
 * longitude and of a latitude in `m`. */
double columnOf(const WmtsMatrixGeometry& m, double lon) noexcept;
double rowOf(const WmtsMatrixGeometry& m, double lat) noexcept;

} // namespace tellus::wmtsmercator
