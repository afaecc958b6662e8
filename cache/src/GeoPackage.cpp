#include "sqlite/Sqlite.hpp"

#include <tellus/cache/GeoPackage.hpp>
#include <tellus/cache/TileGrid.hpp>
#include <tellus/cache/TileSource.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <map>
#include <system_error>
#include <unistd.h>

namespace tellus {

namespace fs = std::filesystem;

namespace {

constexpr const char* kWgs84Wkt =
    "GEOGCS[\"WGS 84\",DATUM[\"WGS_1984\",SPHEROID[\"WGS 84\",6378137,298.257223563,"
    "AUTHORITY[\"EPSG\",\"7030\"]],AUTHORITY[\"EPSG\",\"6326\"]],PRIMEM[\"Greenwich\",0,"
    "AUTHORITY[\"EPSG\",\"8901\"]],UNIT[\"degree\",0.0174532925199433,AUTHORITY[\"EPSG\",\"9122\"]]"
    ","
    "AXIS[\"Latitude\",NORTH],AXIS[\"Longitude\",EAST],AUTHORITY[\"EPSG\",\"4326\"]]";

CacheError invalid(std::string m) {
  return CacheError{CacheErrc::InvalidArgument, std::move(m)};
}

/** A table name GeoPackage and SQL accept without quoting trouble. */
bool validTableName(const std::string& t) {
  if (t.empty() || t.size() > 64 || std::isdigit(static_cast<unsigned char>(t[0]))) return false;
  for (const char c : t) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') return false;
  }
  return !t.starts_with("gpkg_") && !t.starts_with("sqlite_");
}

std::string tableFor(const std::string& name) {
  std::string t;
  for (const char c : name)
    t += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
  if (t.empty() || std::isdigit(static_cast<unsigned char>(t[0]))) t = "t_" + t;
  return t;
}

/** The top edge and the row count at level 0 of the matrix set: whole level-0 tiles. */
struct MatrixOrigin {
  double minX, maxY;
  std::int64_t cols0, rows0;
};
MatrixOrigin originOf(const TileGrid& g) {
  const GridSpec& s = g.spec();
  return MatrixOrigin{s.sector.west,
                      s.sector.south + static_cast<double>(g.rowCount(0)) * s.levelZeroDeltaDeg,
                      g.colCount(0),
                      g.rowCount(0)};
}

bool close(double a, double b) {
  return std::fabs(a - b) <= 1e-9 * std::max({1.0, std::fabs(a), std::fabs(b)});
}

struct Db {
  sql::DbPtr db;
  std::expected<void, CacheError> exec(const std::string& text, std::string_view what) const {
    char* msg = nullptr;
    const int rc = sqlite3_exec(db.get(), text.c_str(), nullptr, nullptr, &msg);
    if (rc == SQLITE_OK) return {};
    std::string m = msg ? msg : sqlite3_errstr(rc);
    sqlite3_free(msg);
    auto e = sql::errorFrom(db.get(), rc, what);
    e.message += ": " + m;
    return std::unexpected(e);
  }
};

std::expected<Db, CacheError> openGpkg(const fs::path& file, bool create) {
  sqlite3* raw = nullptr;
  const int flags = create ? (SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE) : SQLITE_OPEN_READONLY;
  const int rc = sqlite3_open_v2(file.c_str(), &raw, flags, nullptr);
  Db d{sql::DbPtr(raw)};
  if (rc != SQLITE_OK) return std::unexpected(sql::errorFrom(raw, rc, "opening " + file.string()));
  return d;
}

/** The GeoPackage tables, the WGS 84 reference system and the contents row of `table`. */
std::string schemaSql(const std::string& table, const char* bounds) {
  return "PRAGMA application_id = 1196444487; PRAGMA user_version = 10300; BEGIN;"
         "CREATE TABLE gpkg_spatial_ref_sys (srs_name TEXT NOT NULL, srs_id INTEGER NOT NULL "
         "PRIMARY KEY, organization TEXT NOT NULL, organization_coordsys_id INTEGER NOT NULL, "
         "definition TEXT NOT NULL, description TEXT);"
         "INSERT INTO gpkg_spatial_ref_sys VALUES ('Undefined cartesian SRS', -1, 'NONE', -1, "
         "'undefined', 'undefined cartesian coordinate reference system');"
         "INSERT INTO gpkg_spatial_ref_sys VALUES ('Undefined geographic SRS', 0, 'NONE', 0, "
         "'undefined', 'undefined geographic coordinate reference system');"
         "INSERT INTO gpkg_spatial_ref_sys VALUES ('WGS 84 geodetic', 4326, 'EPSG', 4326, '" +
         std::string(kWgs84Wkt) +
         "', 'longitude/latitude coordinates in decimal degrees on the WGS 84 spheroid');"
         "CREATE TABLE gpkg_contents (table_name TEXT NOT NULL PRIMARY KEY, data_type TEXT NOT "
         "NULL, identifier TEXT UNIQUE, description TEXT DEFAULT '', last_change DATETIME NOT NULL "
         "DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ','now')), min_x DOUBLE, min_y DOUBLE, max_x "
         "DOUBLE, "
         "max_y DOUBLE, srs_id INTEGER, CONSTRAINT fk_gc_r_srs_id FOREIGN KEY (srs_id) REFERENCES "
         "gpkg_spatial_ref_sys(srs_id));"
         "CREATE TABLE gpkg_tile_matrix_set (table_name TEXT NOT NULL PRIMARY KEY, srs_id INTEGER "
         "NOT NULL, min_x DOUBLE NOT NULL, min_y DOUBLE NOT NULL, max_x DOUBLE NOT NULL, max_y "
         "DOUBLE NOT NULL, CONSTRAINT fk_gtms_table_name FOREIGN KEY (table_name) REFERENCES "
         "gpkg_contents(table_name), CONSTRAINT fk_gtms_srs FOREIGN KEY (srs_id) REFERENCES "
         "gpkg_spatial_ref_sys (srs_id));"
         "CREATE TABLE gpkg_tile_matrix (table_name TEXT NOT NULL, zoom_level INTEGER NOT NULL, "
         "matrix_width INTEGER NOT NULL, matrix_height INTEGER NOT NULL, tile_width INTEGER NOT "
         "NULL, tile_height INTEGER NOT NULL, pixel_x_size DOUBLE NOT NULL, pixel_y_size DOUBLE "
         "NOT "
         "NULL, CONSTRAINT pk_ttm PRIMARY KEY (table_name, zoom_level), CONSTRAINT "
         "fk_tmm_table_name "
         "FOREIGN KEY (table_name) REFERENCES gpkg_contents(table_name));"
         "CREATE TABLE \"" +
         table +
         "\" (id INTEGER PRIMARY KEY AUTOINCREMENT, zoom_level INTEGER "
         "NOT NULL, tile_column INTEGER NOT NULL, tile_row INTEGER NOT NULL, tile_data BLOB NOT "
         "NULL, UNIQUE (zoom_level, tile_column, tile_row));"
         "INSERT INTO gpkg_contents (table_name, data_type, identifier, description, min_x, min_y, "
         "max_x, max_y, srs_id) VALUES ('" +
         table + "', 'tiles', '" + table +
         "', 'exported by "
         "tellus', " +
         bounds +
         ", 4326);"
         "INSERT INTO gpkg_tile_matrix_set VALUES ('" +
         table + "', 4326, " + bounds + ");";
}

/** What an export writes: a dataset's levels [fromLevel, toLevel] into `table`. */
struct ExportJob {
  TileCache& cache;
  DatasetId dataset;
  const DatasetSpec& spec;
  const TileGrid& grid;
  std::int32_t fromLevel;
  std::int32_t toLevel;
  std::string table;
};

/** One gpkg_tile_matrix row per level. */
std::expected<void, CacheError>
writeTileMatrix(const Db& db, const ExportJob& job, const MatrixOrigin& o) {
  sql::Stmt matrix(db.db.get(),
                   "INSERT INTO gpkg_tile_matrix VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)");
  const GridSpec& g = job.spec.grid;
  for (std::int32_t level = job.fromLevel; level <= job.toLevel; ++level) {
    sql::Stmt::Use u(matrix);
    const double d = job.grid.deltaDeg(level);
    u.bind(1, std::string_view(job.table)).bind(2, std::int64_t{level});
    u.bind(3, o.cols0 << level).bind(4, o.rows0 << level);
    u.bind(5, std::int64_t{g.tileWidth}).bind(6, std::int64_t{g.tileHeight});
    u.bind(7, d / g.tileWidth).bind(8, d / g.tileHeight);
    if (const int rc = u.step(); rc != SQLITE_DONE)
      return std::unexpected(sql::errorFrom(db.db.get(), rc, "writing the tile matrix"));
  }
  return {};
}

void count(GpkgReport& report, std::int32_t level, std::size_t bytes) {
  ++report.tiles;
  report.bytes += static_cast<std::int64_t>(bytes);
  report.minLevel = report.minLevel < 0 ? level : std::min(report.minLevel, level);
  report.maxLevel = std::max(report.maxLevel, level);
}

/** Every cached tile of the levels into the tiles table (GeoPackage rows start at the top). */
std::expected<void, CacheError>
copyTiles(const Db& db, const ExportJob& job, const MatrixOrigin& o, GpkgReport& report) {
  sql::Stmt insert(db.db.get(),
                   ("INSERT INTO \"" + job.table +
                    "\" (zoom_level, tile_column, tile_row, tile_data) VALUES (?1, ?2, ?3, ?4)")
                       .c_str());
  std::optional<CacheError> failure;
  TileCache& cache = job.cache;
  auto listed = cache.forEachTile(
      job.dataset, job.fromLevel, job.toLevel, [&](const TileKey& k, std::int64_t) {
        auto got = cache.get(job.dataset, k);
        if (!got) {
          failure = got.error();
          return false;
        }
        if (got->kind != CacheLookup::Kind::Hit) return true; // went away meanwhile
        sql::Stmt::Use u(insert);
        u.bind(1, std::int64_t{k.level}).bind(2, k.col);
        u.bind(3, (o.rows0 << k.level) - 1 - k.row);
        u.bindBlob(4, got->bytes.data(), got->bytes.size());
        if (const int rc = u.step(); rc != SQLITE_DONE) {
          failure = sql::errorFrom(db.db.get(), rc, "writing a tile");
          return false;
        }
        count(report, k.level, got->bytes.size());
        return true;
      });
  if (!listed) return std::unexpected(listed.error());
  if (failure) return std::unexpected(*failure);
  return {};
}

/** Writes the whole GeoPackage into `temp`. */
std::expected<void, CacheError>
writeGeoPackage(const fs::path& temp, const ExportJob& job, GpkgReport& report) {
  auto opened = openGpkg(temp, true);
  if (!opened) return std::unexpected(opened.error());
  const Db& db = *opened;
  const MatrixOrigin o = originOf(job.grid);
  const double delta = job.spec.grid.levelZeroDeltaDeg;
  const double maxX = o.minX + static_cast<double>(o.cols0) * delta;
  const double minY = o.maxY - static_cast<double>(o.rows0) * delta;
  char bounds[256];
  std::snprintf(bounds, sizeof bounds, "%.17g, %.17g, %.17g, %.17g", o.minX, minY, maxX, o.maxY);
  if (auto r = db.exec(schemaSql(job.table, bounds), "creating the GeoPackage"); !r) return r;
  if (auto r = writeTileMatrix(db, job, o); !r) return r;
  if (auto r = copyTiles(db, job, o, report); !r) return r;
  return db.exec("COMMIT;", "committing the GeoPackage");
}

/** The tiles table to import: `table`, or the first one gpkg_contents names. */
std::expected<std::string, CacheError>
tilesTable(sqlite3* db, const std::string& where, std::string table) {
  if (table.empty()) {
    sql::Stmt s(db, "SELECT table_name FROM gpkg_contents WHERE data_type = 'tiles' LIMIT 1");
    if (!s.ok()) return std::unexpected(invalid(where + " is not a GeoPackage (no gpkg_contents)"));
    sql::Stmt::Use u(s);
    if (u.step() != SQLITE_ROW) return std::unexpected(invalid(where + " has no tiles table"));
    table = u.text(0);
  }
  if (!validTableName(table)) return std::unexpected(invalid("bad table name '" + table + "'"));
  return table;
}

/** The matrix set must be EPSG:4326 with the grid's origin. */
std::expected<void, CacheError> checkMatrixSet(sqlite3* db,
                                               const std::string& where,
                                               const std::string& table,
                                               const MatrixOrigin& o) {
  sql::Stmt s(db, "SELECT srs_id, min_x, max_y FROM gpkg_tile_matrix_set WHERE table_name = ?1");
  if (!s.ok()) return std::unexpected(invalid(where + " has no gpkg_tile_matrix_set"));
  sql::Stmt::Use u(s);
  u.bind(1, std::string_view(table));
  if (u.step() != SQLITE_ROW)
    return std::unexpected(invalid(where + ": no tile matrix set for '" + table + "'"));
  if (u.i64(0) != 4326)
    return std::unexpected(
        invalid(where + ": tiles must be in EPSG:4326, got srs " + std::to_string(u.i64(0))));
  if (!close(u.f64(1), o.minX) || !close(u.f64(2), o.maxY))
    return std::unexpected(invalid(where + ": the matrix set's origin is not the grid's"));
  return {};
}

/** zoom level -> grid level (same pixel size and tile size). */
std::expected<std::map<std::int64_t, std::int32_t>, CacheError> gridLevels(sqlite3* db,
                                                                           const std::string& where,
                                                                           const std::string& table,
                                                                           const DatasetSpec& spec,
                                                                           const TileGrid& grid) {
  std::map<std::int64_t, std::int32_t> levelOf;
  sql::Stmt s(db,
              "SELECT zoom_level, tile_width, tile_height, pixel_x_size, pixel_y_size FROM "
              "gpkg_tile_matrix WHERE table_name = ?1");
  sql::Stmt::Use u(s);
  u.bind(1, std::string_view(table));
  while (u.step() == SQLITE_ROW) {
    if (u.i64(1) != spec.grid.tileWidth || u.i64(2) != spec.grid.tileHeight)
      return std::unexpected(invalid(where + ": tiles are " + std::to_string(u.i64(1)) + "x" +
                                     std::to_string(u.i64(2)) + " px, the layer's " +
                                     std::to_string(spec.grid.tileWidth) + "x" +
                                     std::to_string(spec.grid.tileHeight)));
    for (std::int32_t level = 0; level < grid.numLevels(); ++level) {
      const double d = grid.deltaDeg(level);
      if (close(u.f64(3), d / spec.grid.tileWidth) && close(u.f64(4), d / spec.grid.tileHeight))
        levelOf[u.i64(0)] = level;
    }
  }
  return levelOf;
}

/** A GeoPackage's tiles are in EPSG:4326 here, the Earth's CRS: a dataset on another body
 * (issue 26) would be mislabelled, and is refused rather than written as if on the Earth. */
std::expected<void, CacheError> earthOnly(const DatasetSpec& spec, const char* what) {
  if (isEarthBody(spec.body)) return {};
  return std::unexpected(invalid("dataset '" + spec.name + "' lies on " + spec.body +
                                 ": only the Earth's datasets are " + what +
                                 " as GeoPackages (EPSG:4326)"));
}

/** A renderer's whole polar rows or spans (`<layer>@caps`, `<layer>@span<k>`, TileSource.hpp)
 * are images of boxes no tile of their grid is: written as tiles they would lie. */
std::expected<void, CacheError> gridTiles(const DatasetSpec& spec, const char* what) {
  if (!wholeBoxLayer(spec.name)) return {};
  return std::unexpected(invalid("dataset '" + spec.name +
                                 "' holds a renderer's whole polar rows or spans, not a tile "
                                 "pyramid: it is not " +
                                 what + " as a GeoPackage (export its layer)"));
}

} // namespace

std::expected<GpkgReport, CacheError> exportGeoPackage(TileCache& cache,
                                                       DatasetId dataset,
                                                       const fs::path& file,
                                                       std::int32_t fromLevel,
                                                       std::int32_t toLevel,
                                                       std::string table) {
  const auto info = cache.dataset(dataset);
  if (!info) return std::unexpected(invalid("unknown dataset id " + std::to_string(dataset)));
  const DatasetSpec& spec = info->spec;
  if (auto b = earthOnly(spec, "exported"); !b) return std::unexpected(b.error());
  if (auto g = gridTiles(spec, "exported"); !g) return std::unexpected(g.error());
  if (spec.mimeType != "image/jpeg" && spec.mimeType != "image/png")
    return std::unexpected(invalid("a GeoPackage tile pyramid holds JPEG or PNG tiles; '" +
                                   spec.name + "' is " + spec.mimeType));
  auto grid = TileGrid::create(spec.grid);
  if (!grid) return std::unexpected(invalid(grid.error()));
  if (table.empty()) table = tableFor(spec.name);
  if (!validTableName(table)) return std::unexpected(invalid("bad table name '" + table + "'"));
  fromLevel = std::max(fromLevel, 0);
  toLevel = std::min(toLevel, grid->numLevels() - 1);
  if (fromLevel > toLevel) return std::unexpected(invalid("no level in the range"));

  const fs::path temp = file.string() + ".tmp-" + std::to_string(::getpid());
  std::error_code ec;
  fs::remove(temp, ec);
  GpkgReport report;
  const ExportJob job{cache, dataset, spec, *grid, fromLevel, toLevel, std::move(table)};
  if (auto written = writeGeoPackage(temp, job, report); !written) {
    fs::remove(temp, ec);
    return std::unexpected(written.error());
  }
  fs::rename(temp, file, ec);
  if (ec) {
    fs::remove(temp, ec);
    return std::unexpected(CacheError{CacheErrc::Io, "cannot write " + file.string()});
  }
  return report;
}

std::expected<GpkgReport, CacheError>
importGeoPackage(TileCache& cache, DatasetId dataset, const fs::path& file, std::string table) {
  const auto info = cache.dataset(dataset);
  if (!info) return std::unexpected(invalid("unknown dataset id " + std::to_string(dataset)));
  const DatasetSpec& spec = info->spec;
  if (auto b = earthOnly(spec, "imported"); !b) return std::unexpected(b.error());
  if (auto g = gridTiles(spec, "imported"); !g) return std::unexpected(g.error());
  auto grid = TileGrid::create(spec.grid);
  if (!grid) return std::unexpected(invalid(grid.error()));
  auto opened = openGpkg(file, false);
  if (!opened) return std::unexpected(opened.error());
  sqlite3* db = opened->db.get();
  const std::string where = file.string();
  auto name = tilesTable(db, where, std::move(table));
  if (!name) return std::unexpected(name.error());
  const MatrixOrigin o = originOf(*grid);
  if (auto r = checkMatrixSet(db, where, *name, o); !r) return std::unexpected(r.error());
  const auto levelOf = gridLevels(db, where, *name, spec, *grid);
  if (!levelOf) return std::unexpected(levelOf.error());
  GpkgReport report;
  sql::Stmt tiles(
      db, ("SELECT zoom_level, tile_column, tile_row, tile_data FROM \"" + *name + "\"").c_str());
  if (!tiles.ok()) return std::unexpected(invalid(where + ": cannot read table '" + *name + "'"));
  sql::Stmt::Use u(tiles);
  int rc = 0;
  while ((rc = u.step()) == SQLITE_ROW) {
    const auto it = levelOf->find(u.i64(0));
    if (it == levelOf->end())
      return std::unexpected(invalid(where + ": zoom level " + std::to_string(u.i64(0)) +
                                     " matches no level of the layer's grid"));
    const std::int32_t level = it->second;
    const TileKey key{level, (o.rows0 << level) - 1 - u.i64(2), u.i64(1)};
    if (!grid->isValid(key)) continue; // outside the layer's coverage
    const auto [data, size] = u.blob(3);
    TileMeta meta;
    meta.contentType = size >= 3 && data[0] == std::byte{0xFF} && data[1] == std::byte{0xD8}
                           ? "image/jpeg"
                           : "image/png";
    if (meta.contentType != spec.mimeType)
      return std::unexpected(
          invalid(where + ": a " + meta.contentType + " tile for a " + spec.mimeType + " layer"));
    if (auto put = cache.put(dataset, key, std::span(data, size), meta); !put)
      return std::unexpected(put.error());
    count(report, level, size);
  }
  if (rc != SQLITE_DONE) return std::unexpected(sql::errorFrom(db, rc, "reading " + where));
  return report;
}

} // namespace tellus
