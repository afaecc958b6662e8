#pragma once
/**
 * @file Wmts.hpp
 * @brief WMTS 1.0.0 (OGC 07-057r7): request parsing (KVP and the RESTful binding), the tile
 * matrix sets tellus serves and their arithmetic, the capabilities document and the OWS 1.1
 * exception reports. Pure functions, no sockets (the front end is WmtsFrontEnd).
 *
 * Tile matrix sets (docs/CONFIG.md, "WMTS"):
 * - `WorldWind_<layer>`: the layer's own World Wind grid, in CRS84; tile matrix `n` is World Wind
 *   level n (from the layer's first level), rows counted from the north (World Wind counts them
 *   from the south: wmtsRow = rows - 1 - worldWindRow). Tiles are served as cached.
 * - `WorldCRS84Quad` (OGC 17-083r2, Two Dimensional Tile Matrix Set, annex D): CRS84, 256 px,
 *   level 0 two tiles of 180 degrees. Composed from the layer's tiles (not GoogleCRS84Quad of WMTS
 *   1.0.0 annex E, whose level 0 is one tile of 360 degrees with its south half empty).
 * - `GoogleMapsCompatible` (WMTS 1.0.0 annex E.4, EPSG:3857): composed by the WMS GetMap
 *   composition in EPSG:3857.
 */

#include <tellus/cache/TileGrid.hpp>
#include <tellus/cache/TileKey.hpp>
#include <tellus/proxy/BodyCrs.hpp>
#include <tellus/proxy/Query.hpp>
#include <tellus/proxy/Wms.hpp>

#include <cstdint>
#include <expected>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace tellus {

namespace ogc {
inline constexpr std::string_view kTileOutOfRange = "TileOutOfRange"; ///< WMTS 1.0.0 table 28
} // namespace ogc

/** The HTTP status WMTS 1.0.0 table 28 gives an exception code: 400 for MissingParameterValue,
 * InvalidParameterValue, TileOutOfRange (and the update-sequence codes), 501 for
 * OperationNotSupported, 500 for NoApplicableCode and anything else. */
int wmtsExceptionHttpStatus(std::string_view code) noexcept;

/** An OWS 1.1 ExceptionReport (version 1.0.0, xml:lang en), valid against
 * owsExceptionReport.xsd; locator omitted when empty; message and locator through
 * sanitizeForClient and escaped. */
std::string wmtsExceptionXml(const OgcException& e);

enum class WmtsSetKind { WorldWind, WorldCRS84Quad, GoogleMapsCompatible };

inline constexpr std::string_view kWorldCrs84Quad = "WorldCRS84Quad";
inline constexpr std::string_view kGoogleMapsCompatible = "GoogleMapsCompatible";
/** Half the Web Mercator world (metres): 20037508.3427892. */
inline constexpr double kWebMercatorHalf = 20037508.342789244;
/** The Web Mercator latitude limit (degrees). */
inline constexpr double kWebMercatorMaxLat = 85.0511287798066;

/** One tile matrix: its identifier, the tile grid in the set's CRS units (x east, y north), and
 * the tiles a layer has (its TileMatrixSetLimits, inclusive). */
struct WmtsTileMatrix {
  std::string identifier;
  double scaleDenominator = 0;
  double left = 0;     ///< top-left corner, x
  double top = 0;      ///< top-left corner, y
  double tileSpan = 0; ///< CRS units per tile (square tiles in units)
  std::int32_t tileWidth = 256;
  std::int32_t tileHeight = 256;
  std::int64_t matrixWidth = 1;
  std::int64_t matrixHeight = 1;
  std::int64_t minRow = 0, maxRow = 0, minCol = 0, maxCol = 0; ///< the layer's tiles
};

struct WmtsTileMatrixSet {
  std::string identifier;
  WmtsSetKind kind = WmtsSetKind::WorldWind;
  /// urn:ogc:def:crs:OGC:1.3:CRS84, urn:ogc:def:crs:EPSG::3857 or a body's IAU URN (BodyCrs.hpp)
  std::string crs;
  bool latFirst = false; ///< TopLeftCorner written "top left" (a body's IAU CRS: latitude first)
  std::string wellKnownScaleSet; ///< "" = none
  std::int32_t firstLevel = 0;   ///< WorldWind: the World Wind level of matrices[0]
  std::vector<WmtsTileMatrix> matrices;
};

/** The layer's own grid as a set (`WorldWind_<layer>`), levels firstLevel .. numLevels - 1. */
WmtsTileMatrixSet
worldWindMatrixSet(std::string_view layer, const GridSpec& grid, std::int32_t firstLevel);
/** The same set for a layer on another body (issue 26): in the body's IAU CRS (latitude first),
 * scale denominators counted on the body's mean radius. A body's layer has no composed sets
 * (WorldCRS84Quad and GoogleMapsCompatible are the Earth's). */
WmtsTileMatrixSet bodyWorldWindMatrixSet(std::string_view layer,
                                         const GridSpec& grid,
                                         std::int32_t firstLevel,
                                         const BodyCrs& body);
/** How many levels a composed set needs for a grid: down to the first whose pixels are no
 * larger than the grid's finest (at the equator for GoogleMapsCompatible), at most 25. */
std::int32_t composedLevels(WmtsSetKind kind, const GridSpec& grid);
/** WorldCRS84Quad or GoogleMapsCompatible with `levels` matrices, limited to `coverage`. */
WmtsTileMatrixSet composedMatrixSet(WmtsSetKind kind, const Sector& coverage, std::int32_t levels);

/** The bounding box of a tile in the set's CRS units (x: west/east, y: south/north). */
Sector wmtsTileBox(const WmtsTileMatrix& m, std::int64_t row, std::int64_t col);
/** The World Wind key of a WorldWind set's tile (rows flipped). */
TileKey worldWindKeyOf(const WmtsTileMatrixSet& set,
                       std::size_t matrix,
                       std::int64_t row,
                       std::int64_t col);
/** The key of a composed set's tile (WorldCRS84Quad or GoogleMapsCompatible) in its own cache
 * grid (composedCacheGrid): the matrix as the level, rows counted from the south as in every
 * cache grid. */
TileKey crs84QuadCacheKey(std::int32_t level, std::int64_t row, std::int64_t col);
/** The grid a composed set's tiles are kept in as a cache dataset, `levels` levels of 256 px:
 * WorldCRS84Quad its own (180-degree level zero, 2^(z+1) x 2^z tiles); GoogleMapsCompatible one
 * with its matrices' sizes, 2^z x 2^z (the western half of a 180-degree grid: the cache only
 * counts tiles, a Mercator tile's box is not the lat/long box that grid gives its key). */
GridSpec composedCacheGrid(WmtsSetKind kind, std::int32_t levels);

/** The matrix named `id` and the tile's range check: InvalidParameterValue (locator
 * TileMatrix) for an unknown matrix, TileOutOfRange (TileRow / TileCol) outside the layer's
 * limits. The index of the matrix. */
std::expected<std::size_t, OgcException> checkWmtsTile(const WmtsTileMatrixSet& set,
                                                       std::string_view id,
                                                       std::int64_t row,
                                                       std::int64_t col);

struct WmtsGetCapabilitiesRequest {
  std::string updateSequence;
  friend bool operator==(const WmtsGetCapabilitiesRequest&,
                         const WmtsGetCapabilitiesRequest&) = default;
};

struct WmtsGetTileRequest {
  std::string layer;
  std::string style;
  std::string format;    ///< KVP: FORMAT verbatim; REST: empty
  std::string extension; ///< REST: the extension of the path; KVP: empty
  std::string tileMatrixSet;
  std::string tileMatrix;
  std::int64_t row = 0;
  std::int64_t col = 0;
  std::optional<std::string> time; ///< the Time dimension, when given
  friend bool operator==(const WmtsGetTileRequest&, const WmtsGetTileRequest&) = default;
};

using WmtsRequest = std::variant<WmtsGetCapabilitiesRequest, WmtsGetTileRequest>;

/**
 * @brief A KVP request (`/wmts?SERVICE=WMTS&REQUEST=...`), names case-insensitive.
 * SERVICE must be WMTS (missing -> MissingParameterValue, other -> InvalidParameterValue);
 * REQUEST GetCapabilities or GetTile (missing -> MissingParameterValue, GetFeatureInfo and
 * anything else -> OperationNotSupported). GetTile: VERSION 1.0.0 (missing ->
 * MissingParameterValue, other -> InvalidParameterValue), LAYER, STYLE, FORMAT, TILEMATRIXSET,
 * TILEMATRIX, TILEROW, TILECOL required (MissingParameterValue; STYLE may be empty); TILEROW and
 * TILECOL decimal whole numbers >= 0 (InvalidParameterValue); TIME optional; a parameter given
 * twice with different values -> InvalidParameterValue. GetCapabilities: ACCEPTVERSIONS, when
 * given, must list 1.0.0 (else VersionNegotiationFailed).
 */
std::expected<WmtsRequest, OgcException> parseWmtsKvp(const QueryParams& params);

/**
 * @brief parseQuery and parseWmtsKvp in one pass, without copying the parameters: the same answer
 * for the queries it takes, those without percent escapes, '+', NUL bytes or a WMTS parameter
 * given twice, within the limits (parseQuery's arguments). Any other query -> std::nullopt: the
 * caller takes parseQuery and parseWmtsKvp. (A GetTile's cost beside /wwtile: bench/RESULTS.md.)
 */
std::optional<std::expected<WmtsRequest, OgcException>>
parseWmtsKvpQuery(std::string_view query, std::size_t maxParamBytes, std::size_t maxQueryBytes);

/**
 * @brief A RESTful path after `/wmts/1.0.0/`: `WMTSCapabilities.xml`, or
 * `<layer>/<style>/[<time>/]<set>/<matrix>/<row>/<col>.<ext>` (the ResourceURL templates of the
 * capabilities), each segment percent-decoded. Anything else -> InvalidParameterValue (locator
 * the part at fault); the front end answers unknown paths with 404.
 */
std::expected<WmtsRequest, OgcException> parseWmtsRest(std::string_view path);

/** What the capabilities say of one layer. */
struct WmtsLayerInfo {
  std::string identifier;
  std::string title;
  std::string abstract;
  Sector bbox{};
  std::string format;    ///< MIME type
  std::string extension; ///< of the RESTful tiles
  std::vector<std::string> timeValues;
  std::string timePeriod;
  std::string timeDefault;
  std::vector<const WmtsTileMatrixSet*> sets; ///< with the layer's limits
  /// "" = the Earth (ows:WGS84BoundingBox); a body's CRS URN: ows:BoundingBox in it, lat/lon
  std::string bodyCrs;
};

struct WmtsCapabilitiesModel {
  std::string title;
  std::string abstract;
  std::string baseUrl; ///< without a trailing '/': KVP at baseUrl + "/wmts?"
  std::string updateSequence;
  std::vector<WmtsLayerInfo> layers;
  /** Every set once: the WorldWind sets and the composed sets at the most levels of any layer
   * (each layer's own levels and tiles are its TileMatrixSetLimits). */
  std::vector<const WmtsTileMatrixSet*> sets;
};

/** The Capabilities document (valid against wmtsGetCapabilities_response.xsd): KVP and RESTful
 * GetTile and GetCapabilities, a Style "default", the Time dimension (Default, the values and a
 * period as `start/end/step`), the ResourceURL templates with {Time} where a layer has it. */
std::string wmtsCapabilitiesXml(const WmtsCapabilitiesModel& model);

} // namespace tellus
