#pragma once
/**
 * @file GeoPackage.hpp
 * @brief A cached layer as an OGC GeoPackage 1.3 tile pyramid (EPSG:4326), which GDAL and QGIS
 * open, and back.
 *
 * Zoom level n is the grid's level n: the level-zero matrix is the grid's level-zero tiles (10 x 5
 * for 36-degree tiles), each level halves the pixel size. GeoPackage counts rows from the top
 * (north) where World Wind counts from the bottom: gpkg_row = matrix_height - 1 - row. Only JPEG
 * and PNG tiles can be stored (the tiles of the core GeoPackage standard). Only the Earth's
 * datasets: one on another body (DatasetSpec::body) is refused both ways, since its tiles would
 * be labelled EPSG:4326.
 */

#include <tellus/cache/CacheError.hpp>
#include <tellus/cache/TileCache.hpp>

#include <cstdint>
#include <expected>
#include <filesystem>
#include <limits>
#include <string>

namespace tellus {

struct GpkgReport {
  std::int64_t tiles = 0;
  std::int64_t bytes = 0;
  std::int32_t minLevel = -1; ///< -1 when no tile was copied
  std::int32_t maxLevel = -1;
};

/** Writes the dataset's cached tiles of levels [fromLevel, toLevel] to a new GeoPackage (`table`,
 * default the dataset's name). The file appears whole or not at all (written beside it, renamed);
 * an existing file is replaced. */
std::expected<GpkgReport, CacheError>
exportGeoPackage(TileCache& cache,
                 DatasetId dataset,
                 const std::filesystem::path& file,
                 std::int32_t fromLevel = 0,
                 std::int32_t toLevel = std::numeric_limits<std::int32_t>::max(),
                 std::string table = {});

/** Reads a GeoPackage tile pyramid into the dataset: its matrix set must be EPSG:4326 with the
 * dataset's origin, tile size and pixel sizes (each zoom level is matched to the grid level of the
 * same pixel size). `table` "" = the first tiles table. Tiles already cached are replaced. */
std::expected<GpkgReport, CacheError> importGeoPackage(TileCache& cache,
                                                       DatasetId dataset,
                                                       const std::filesystem::path& file,
                                                       std::string table = {});

} // namespace tellus
