#pragma once
/**
 * @file Wms.hpp
 * @brief The WMS 1.1.1 / 1.3.0 and World Wind front ends' request parsing: from decoded query
 * parameters to typed requests or an OGC exception. Pure functions, no sockets; the server looks
 * layers and formats up and renders the answers.
 */

#include <tellus/cache/TileGrid.hpp>
#include <tellus/cache/TileKey.hpp>
#include <tellus/proxy/MapBox.hpp>
#include <tellus/proxy/Query.hpp>

#include <cstdint>
#include <expected>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace tellus {

/** The WMS exception codes (WMS 1.1.1 and 1.3.0, section 6.11 / annex A) plus OWS'
 * NoApplicableCode for everything else. */
namespace ogc {
inline constexpr std::string_view kLayerNotDefined = "LayerNotDefined";
inline constexpr std::string_view kInvalidCrs = "InvalidCRS"; ///< WMS 1.3.0
inline constexpr std::string_view kInvalidSrs = "InvalidSRS"; ///< WMS 1.1.1
inline constexpr std::string_view kInvalidFormat = "InvalidFormat";
inline constexpr std::string_view kStyleNotDefined = "StyleNotDefined";
inline constexpr std::string_view kLayerNotQueryable = "LayerNotQueryable";
inline constexpr std::string_view kInvalidPoint = "InvalidPoint";
inline constexpr std::string_view kMissingDimensionValue = "MissingDimensionValue";
inline constexpr std::string_view kInvalidDimensionValue = "InvalidDimensionValue";
inline constexpr std::string_view kOperationNotSupported = "OperationNotSupported";
inline constexpr std::string_view kMissingParameterValue = "MissingParameterValue";
inline constexpr std::string_view kInvalidParameterValue = "InvalidParameterValue";
inline constexpr std::string_view kInvalidUpdateSequence = "InvalidUpdateSequence";
inline constexpr std::string_view kCurrentUpdateSequence = "CurrentUpdateSequence";
inline constexpr std::string_view kNoApplicableCode = "NoApplicableCode";
} // namespace ogc

/** One OGC service exception: code (one of ogc::k...), locator (usually the parameter name, may
 * be empty) and a human-readable message. */
struct OgcException {
  std::string code;
  std::string locator;
  std::string message;

  friend bool operator==(const OgcException&, const OgcException&) = default;
};

enum class WmsVersion { V111, V130 };

/** "1.1.1" or "1.3.0". */
std::string_view toString(WmsVersion version) noexcept;
/** The invalid-CRS code of a version: InvalidSRS for 1.1.1, InvalidCRS for 1.3.0. */
std::string_view invalidCrsCode(WmsVersion version) noexcept;

/** Limits the server enforces on GetMap (also advertised as MaxWidth/MaxHeight in 1.3.0). */
struct WmsLimits {
  std::int32_t maxWidth = 4096;
  std::int32_t maxHeight = 4096;
};

/** Largest |coordinate| accepted in a BBOX (degrees). Boxes past +-180/+-90 are legal WMS
 * requests (the outside is drawn empty), but a box of 1e300 degrees is an attack, not a map. */
inline constexpr double kMaxBboxMagnitudeDeg = 1.0e6;
/// The same for an EPSG:3857 BBOX (metres; the Mercator square's half side is about 2.0e7).
inline constexpr double kMaxBboxMagnitudeMetres = 1.0e12;
/// Web Mercator's normalised name (EPSG:900913, EPSG:102100 and EPSG:102113 are read as it).
inline constexpr std::string_view kWebMercator = "EPSG:3857";
/** Whether a CRS/SRS names Web Mercator: EPSG:3857 or one of its aliases (any case). */
bool isWebMercator(std::string_view crs) noexcept;

/**
 * The GetMap output formats tellus serves, for every layer (docs/CONFIG.md, "WMS"): pictures
 * (JPEG; PNG 24-bit, or 32-bit with TRANSPARENT=TRUE; PNG 8-bit paletted, 24-bit and 32-bit;
 * 8-bit RGB(A) TIFF) and heights (BIL16; PNG is 16-bit and TIFF Int16 heights when every layer
 * of the map is an elevation layer). Which a map is made as: mapIsHeights().
 */
/** GetMap formats. Bil32: a map of values (Float32, little-endian, as World Wind reads BIL), for
 * value layers whose samples are Float32 only. */
enum class MapFormat { Jpeg, Png, Png8, Png24, Png32, Bil16, Tiff, Bil32 };

/** The no-data value of a map of values (application/bil32) whose layers do not name one. */
inline constexpr float kNoValue = std::numeric_limits<float>::quiet_NaN();

/**
 * A FORMAT value as a MapFormat. A MIME type is case-insensitive in its type, subtype and
 * parameter names and values (RFC 2045), and spaces around ';' and '=' do not count:
 * "IMAGE/PNG; Mode=8BIT" is "image/png; mode=8bit". Also accepted: "image/png8" (GeoServer's
 * 8-bit PNG). std::nullopt for anything else.
 */
std::optional<MapFormat> parseMapFormat(std::string_view format) noexcept;
/** The canonical spelling: "image/jpeg", "image/png", "image/png; mode=8bit",
 * "image/png; mode=24bit", "image/png; mode=32bit", "application/bil16", "image/tiff",
 * "application/bil32". */
std::string_view toString(MapFormat format) noexcept;
/** The Content-Type of a map in that format ("image/png" for every PNG). */
std::string_view contentTypeOf(MapFormat format) noexcept;
/** Whether a map in `format` carries heights (16-bit values) rather than a picture: BIL16
 * always, PNG and TIFF when every layer of the map is an elevation layer (a TIFF of imagery is
 * a picture: an imagery layer whose tiles are TIFF is served as it is cached). */
bool mapIsHeights(MapFormat format, bool everyLayerIsElevation) noexcept;

struct GetMapRequest;
/** The box a map of this request is composed over (Compose.hpp): lon/lat rows, or for EPSG:3857
 * the bbox's metres as longitudes and Web Mercator rows (mercatorBox). */
MapBox mapBoxOf(const GetMapRequest& m) noexcept;

struct GetCapabilitiesRequest {
  WmsVersion version = WmsVersion::V130; ///< after version negotiation
  std::string updateSequence;            ///< UPDATESEQUENCE, empty when absent
  std::string format;                    ///< FORMAT verbatim, empty when absent

  friend bool operator==(const GetCapabilitiesRequest&, const GetCapabilitiesRequest&) = default;
};

struct GetMapRequest {
  WmsVersion version = WmsVersion::V130;
  std::vector<std::string> layers; ///< non-empty, names verbatim (case-sensitive), none empty
  /** Always exactly one entry per layer; "" is the layer's default style. */
  std::vector<std::string> styles;
  /// normalised: "EPSG:4326", "CRS:84", "EPSG:3857" (kWebMercator) or a body's "IAU:<code>"
  std::string crs;
  /** ALWAYS lon/lat (west, south, east, north) after the axis-order handling; west < east and
   * south < north; may extend past +-180 / +-90; -0 is normalised to 0. For EPSG:3857: metres,
   * west/east the easting (x) and south/north the northing (y) under both versions, and may
   * extend past the Mercator square (mapBoxOf gives the map's box in degrees). */
  Sector bbox{};
  std::int32_t width = 0;  ///< 1 .. WmsLimits::maxWidth
  std::int32_t height = 0; ///< 1 .. WmsLimits::maxHeight
  std::string format;      ///< FORMAT in its canonical spelling (toString(mapFormat))
  MapFormat mapFormat = MapFormat::Png;
  bool transparent = false;
  std::optional<std::uint32_t> bgcolor; ///< 0xRRGGBB; std::nullopt = not given (white)
  std::string time;                     ///< TIME verbatim, empty when absent
  /** OPACITIES (vendor): one value in [0, 1] per layer; empty when absent (the layers' own). */
  std::vector<double> opacities;
  enum class Exceptions { Xml, InImage, Blank } exceptions = Exceptions::Xml;

  friend bool operator==(const GetMapRequest&, const GetMapRequest&) = default;
};

/** GetLegendGraphic (the SLD 1.1 profile of WMS, as MapServer and GeoServer serve it):
 * SERVICE=WMS, REQUEST=GetLegendGraphic, LAYER, FORMAT (image/png), optional STYLE, WIDTH,
 * HEIGHT, SLD_VERSION (1.1.0) and VERSION. */
struct GetLegendGraphicRequest {
  WmsVersion version = WmsVersion::V130; ///< VERSION when given (for the exception's format)
  std::string layer;
  std::string style;       ///< "" = the layer's default style
  std::int32_t width = 0;  ///< 0 = the default size; else 32 .. 4096
  std::int32_t height = 0; ///< 0 = the default size; else 32 .. 4096

  friend bool operator==(const GetLegendGraphicRequest&, const GetLegendGraphicRequest&) = default;
};

/** What GetFeatureInfo answers in (INFO_FORMAT, canonical). */
enum class InfoFormat { Text, Html, Json, Gml, GmlXml };

/** "text/plain", "text/html", "application/json", "application/vnd.ogc.gml", "text/xml". */
std::string_view toString(InfoFormat format) noexcept;

/** GetFeatureInfo (WMS 1.3.0 7.4, 1.1.1 7.3): the map request part (a GetMap without REQUEST;
 * FORMAT may be left out), QUERY_LAYERS, INFO_FORMAT (required in 1.3.0; text/plain when absent
 * in 1.1.1), the pixel I/J (1.3.0) or X/Y (1.1.1), FEATURE_COUNT. */
struct GetFeatureInfoRequest {
  GetMapRequest map;
  std::vector<std::string> queryLayers; ///< each one of map.layers
  InfoFormat infoFormat = InfoFormat::Text;
  std::int32_t i = 0; ///< column, 0 .. map.width - 1
  std::int32_t j = 0; ///< row from the top, 0 .. map.height - 1
  std::int32_t featureCount = 1;

  friend bool operator==(const GetFeatureInfoRequest&, const GetFeatureInfoRequest&) = default;
};

using WmsRequest = std::
    variant<GetCapabilitiesRequest, GetMapRequest, GetLegendGraphicRequest, GetFeatureInfoRequest>;

/** GetLegendGraphic's parameters (called by parseWms): LAYER and FORMAT required
 * (MissingParameterValue), FORMAT other than image/png -> InvalidFormat, SERVICE other than WMS
 * -> InvalidParameterValue, WIDTH/HEIGHT outside 32 .. 4096 or SLD_VERSION other than 1.1.0 ->
 * InvalidParameterValue. */
std::expected<WmsRequest, OgcException> parseGetLegendGraphic(const QueryParams& params);

/** GetFeatureInfo's parameters (called by parseWms): the map part as parseWms reads a GetMap
 * (its errors as GetMap's), then QUERY_LAYERS (required; a name not in LAYERS ->
 * LayerNotDefined), INFO_FORMAT (unknown -> InvalidFormat), I/J or X/Y (required; not a whole
 * number -> InvalidParameterValue; outside the map -> InvalidPoint in 1.3.0,
 * InvalidParameterValue in 1.1.1), FEATURE_COUNT (a whole number >= 1). */
std::expected<WmsRequest, OgcException> parseGetFeatureInfo(const QueryParams& params,
                                                            const WmsLimits& limits);

/**
 * @brief Parses a WMS request (keys as parseQuery stores them).
 *
 * Each version's request tables are followed (OGC 06-042 Tables 3 and 8 for 1.3.0, 01-068r3
 * 7.1.2 and 7.2.2 for 1.1.1); parameter names are case-insensitive (parseQuery), values
 * case-sensitive except REQUEST, SERVICE, CRS/SRS, FORMAT (a MIME type), TRANSPARENT and
 * EXCEPTIONS, which clients spell in any case.
 * - REQUEST missing -> MissingParameterValue (locator REQUEST); GetCapabilities (also WMS 1.0's
 *   "capabilities"), GetMap ("map"), GetFeatureInfo ("feature_info") and GetLegendGraphic are
 *   served (the last two: parseGetFeatureInfo, parseGetLegendGraphic); anything else ->
 *   OperationNotSupported (locator REQUEST).
 * - SERVICE=WMS is required for GetCapabilities only; GetMap's tables have no SERVICE (either
 *   version), so it may be absent or empty. A SERVICE other than WMS -> InvalidParameterValue.
 * - A parameter of the request's table given twice with different values -> InvalidParameterValue
 *   (locator: the parameter); the same value repeated is accepted.
 * - GetCapabilities negotiates VERSION (or WMTVER): none or above 1.3.0 -> 1.3.0, 1.3.0 ->
 *   1.3.0, anything below -> 1.1.1; an unparseable version -> InvalidParameterValue.
 * - GetMap needs VERSION 1.1.1 or 1.3.0 (missing -> MissingParameterValue, other ->
 *   InvalidParameterValue); 1.1.1 reads SRS, 1.3.0 reads CRS, each with the other as fallback.
 *   EPSG:4326 under 1.3.0 has a lat/lon BBOX; CRS:84 and EPSG:4326 under 1.1.1 are lon/lat;
 *   EPSG:3857 (and its aliases EPSG:900913, EPSG:102100, EPSG:102113, normalised to EPSG:3857)
 *   is easting/northing in metres under both; a body's geographic IAU code (BodyCrs.hpp:
 *   IAU:n, IAU2000:n, IAU_2015:n, IAU:2015:n with n a multiple of 100, normalised to IAU:n) is
 *   lat/lon under 1.3.0 and lon/lat under 1.1.1; any other CRS -> InvalidCRS (1.3.0) /
 *   InvalidSRS (1.1.1). Whether the layers lie on the CRS's body is the front end's check.
 * - BBOX: four finite numbers with min < max on both axes and |value| <= kMaxBboxMagnitudeDeg
 *   (kMaxBboxMagnitudeMetres for EPSG:3857), else InvalidParameterValue (locator BBOX). A
 *   Web Mercator BBOX past the Mercator square is valid (the part outside it is empty).
 * - WIDTH/HEIGHT: whole numbers in [1, limits], else InvalidParameterValue.
 * - FORMAT, LAYERS (non-empty) and STYLES (both versions; `STYLES=` selects the default styles)
 *   are required (MissingParameterValue); a FORMAT that parseMapFormat does not know ->
 *   InvalidFormat; an empty layer name in LAYERS -> LayerNotDefined; a STYLES list whose count
 *   differs from LAYERS -> InvalidParameterValue (locator STYLES).
 * - TRANSPARENT TRUE/FALSE, BGCOLOR 0xRRGGBB, EXCEPTIONS in either version's spelling, else
 *   InvalidParameterValue. Unknown parameters are ignored.
 * Messages quote client values only shortened; format them with formatWmsException.
 */
std::expected<WmsRequest, OgcException> parseWms(const QueryParams& params,
                                                 const WmsLimits& limits = {});

/**
 * @brief How to report an error for a request that may not have parsed: the version (from
 * VERSION/WMTVER, 1.3.0 when absent or unreadable), and the EXCEPTIONS mode with the image
 * parameters needed to honour INIMAGE/BLANK. When any of those (FORMAT, WIDTH, HEIGHT,
 * TRANSPARENT, BGCOLOR) is missing, invalid or given twice with different values, or the request
 * is no GetMap, exceptions is Xml.
 */
struct WmsErrorContext {
  WmsVersion version = WmsVersion::V130;
  GetMapRequest::Exceptions exceptions = GetMapRequest::Exceptions::Xml;
  std::string format; ///< canonical (toString(mapFormat))
  MapFormat mapFormat = MapFormat::Png;
  std::vector<std::string>
      layers; ///< LAYERS as given (to tell heights from pictures), may be empty
  /// STYLES as given (a styled value layer is a picture), may be empty or of another length
  std::vector<std::string> styles;
  std::int32_t width = 0;
  std::int32_t height = 0;
  bool transparent = false;
  std::optional<std::uint32_t> bgcolor;
};
WmsErrorContext wmsErrorContext(const QueryParams& params, const WmsLimits& limits = {});

/**
 * @brief The UPDATESEQUENCE rule of GetCapabilities: equal to the server's ->
 * CurrentUpdateSequence, greater -> InvalidUpdateSequence, lower or absent (either side empty) ->
 * std::nullopt (send the document). When both are decimal numbers in any lexical form
 * (`1796151274`, `1.796151274E9`, `01796151274`, `+1796151274.0`) they compare as numbers,
 * exactly (no rounding through a double); anything else compares as strings (ISO 8601 times
 * compare correctly that way).
 */
std::optional<OgcException> checkUpdateSequence(std::string_view requested,
                                                std::string_view current);

/**
 * @brief The TIME of a request for a layer with a TIME dimension (`values` listed, and/or a
 * `period` "start/end/step", kept as such when too long to list), in the layer's own spelling.
 *
 * TIME is read as one ISO 8601 instant: `YYYY-MM-DD`, or `YYYY-MM-DDThh:mm[:ss[.000]]` with `Z`,
 * an offset (`+01:00`) or nothing (UTC). It must be one of the values (the same string, or the
 * same instant spelt otherwise) or lie on the period's grid: start + k * step for a whole k >= 0,
 * not after the end, months and years added on the calendar (P1D, PT6H, P1M, P1Y, P1W...). The
 * answer is the matching value as listed, or the instant written as the period's start is
 * (`2024-03-01`, `2024-03-01T06:00Z`, `2024-03-01T06:00:00Z`), so that every spelling of one
 * instant names one dataset. Anything else, lists (`a,b`) and ranges (`a/b`, `a/b/P1D`) included,
 * is InvalidDimensionValue: a map is made for one time, and a time a layer does not have must not
 * create a dataset or an upstream request. No TIME: the default (in the same spelling), or
 * MissingDimensionValue when there is none. A layer without a dimension ignores TIME ("").
 */
std::expected<std::string, OgcException>
resolveTimeDimension(std::string_view layer,
                     const std::vector<std::string>& values,
                     std::string_view period,
                     std::string_view defaultValue,
                     std::string_view requested);

/** A World Wind tile-service request `?T=<dataset>&L=<level>&X=<column>&Y=<row>` (row 0 in the
 * south, column 0 at -180). */
struct WorldWindTileRequest {
  std::string dataset; ///< T, verbatim, non-empty
  std::int32_t level = 0;
  std::int64_t col = 0; ///< X
  std::int64_t row = 0; ///< Y

  friend bool operator==(const WorldWindTileRequest&, const WorldWindTileRequest&) = default;
};

/** Parses T, L, X, Y: T non-empty; L, X, Y non-negative decimal integers without sign or junk;
 * L <= kMaxLevel; X, Y fit in 64 bits. Whether the tile exists is the caller's (TileGrid). */
std::expected<WorldWindTileRequest, std::string> parseWorldWindTile(const QueryParams& params);

/** Longest layer name in a static tile path. */
inline constexpr std::size_t kMaxStaticLayerName = 128;

/** A static tile path `<layer>/<level>/<row>/<row>_<col>.<ext>` (WebWorldWind's
 * LevelRowColumnUrlBuilder, World Wind Java's cache layout). */
struct StaticTilePath {
  std::string layer;
  TileKey key{};
  std::string extension; ///< without the dot

  friend bool operator==(const StaticTilePath&, const StaticTilePath&) = default;
};

/** Parses the path after the service prefix. The layer is [A-Za-z0-9_.-]{1,128} and never "."
 * or "..", optionally followed by `@caps` or `@span<k>` (a layer's whole polar rows or spans,
 * TileSource.hpp: k a power of two, canonical); the rest follows parseTileRelativePath (no padding,
 * no signs, level <= kMaxLevel) with an extension of 1 to 16 ASCII letters and digits. No
 * percent-decoding: '%' is not a layer character. std::nullopt for anything else. */
std::optional<StaticTilePath> parseStaticTilePath(std::string_view pathAfterPrefix);

} // namespace tellus
