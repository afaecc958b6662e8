#pragma once
/**
 * @file WmtsUpstream.hpp
 * @brief An OGC WMTS 1.0.0 server as an upstream (NASA GIBS above all): its capabilities read,
 * one of its layers chosen (style, format, tile matrix set, dimensions) and mapped onto a tellus
 * layer's World Wind grid.
 *
 * Mapping. A matrix lines up with a level of the grid when its tiles have the grid's pixel size
 * and span (scale denominator x 0.28 mm / 111319.49079327357 m per degree x tile width) and its
 * top-left corner lies on the level's tile edges. Alignment is decided by that arithmetic alone,
 * never by a set's name, with a tolerance of 0.01 pixel: the spans may differ by at most 0.01
 * pixel over the matrix's whole width, and the corner may lie at most 0.01 pixel off an edge.
 * Aligned tiles are fetched and cached byte for byte, only re-indexed: WMTS counts rows from the
 * top (row 0 at the corner's latitude), World Wind from the south pole. GIBS's EPSG:4326 sets
 * (512-pixel tiles, level 0 of 2 x 1 tiles of 288 degrees) line up from their level 3 on: GIBS
 * level n + 3 is World Wind level n (36-degree tiles). GIBS levels 0-2 (288, 144 and 72 degrees)
 * have no World Wind level and are never fetched; World Wind levels finer than the set's finest
 * matrix are refused at start (a layer's grid.levels must stop there: upsampling makes nothing).
 * A level that no matrix lines up with (another tile size, span or origin) is composed: from the
 * coarsest matrix at least as fine as the level, the upstream tiles covering the grid tile are
 * fetched, decoded, sampled bilinearly at the grid's pixel centres and encoded in the layer's
 * format (WmtsCompose.hpp). Web Mercator sets (EPSG:3857 and its aliases, recognised by CRS and
 * matrix geometry, never by name) are composed at every level: each output row's latitude taken
 * to Mercator y, from the coarsest zoom whose pixel is as fine as the level's (WmtsMercator.hpp);
 * rows beyond +-85.0511 degrees are left empty. Other projected sets are refused at start.
 * Another body's layer (WmtsChoice::bodyMetresPerDegree) also takes the body's planetocentric IAU
 * CRS (latitude first, as EPSG:4326), and a set none of whose matrices spans exactly 360 degrees
 * at the Earth's metres per degree but one does at the body's is read at the body's (a server may
 * count its scale denominators either way; NASA Trek's were not verified offline).
 *
 * Capabilities are fetched once at start through the upstream's fetcher and kept in a file
 * (WmtsCapabilitiesCache) so that a start without the network, or with `--offline`, reads the
 * last copy.
 */

#include <tellus/cache/TileGrid.hpp>
#include <tellus/cache/TileKey.hpp>

#include <cstdint>
#include <expected>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace tellus {

class Fetcher;

struct UpstreamTileMatrix {
  std::string identifier;
  double scaleDenominator = 0.0;
  double topLeftX = 0.0; ///< as written: the CRS's first axis
  double topLeftY = 0.0; ///< the second axis
  std::int32_t tileWidth = 0;
  std::int32_t tileHeight = 0;
  std::int64_t matrixWidth = 0;
  std::int64_t matrixHeight = 0;
};

struct UpstreamTileMatrixSet {
  std::string identifier;
  std::string crs; ///< ows:SupportedCRS as written
  std::vector<UpstreamTileMatrix> matrices;
};

struct WmtsDimension {
  std::string identifier; ///< as written ("Time", "time")
  std::string defaultValue;
  std::vector<std::string> values;
};

struct WmtsResourceUrl {
  std::string format;
  std::string resourceType; ///< "tile" for tiles
  std::string tmpl;         ///< the template, {TileMatrix} and so on in it
};

struct WmtsLayer {
  std::string identifier;
  std::string title;
  std::vector<std::string> styles; ///< identifiers; the default one first
  std::vector<std::string> formats;
  std::vector<std::string> tileMatrixSets; ///< linked sets
  std::vector<WmtsDimension> dimensions;
  std::vector<WmtsResourceUrl> resourceUrls;
};

struct WmtsCapabilities {
  std::string title;
  std::string getTileKvpUrl; ///< OperationsMetadata GetTile's KVP href ("" if none)
  std::vector<WmtsLayer> layers;
  std::vector<UpstreamTileMatrixSet> tileMatrixSets;

  const WmtsLayer* layer(std::string_view id) const noexcept;
  const UpstreamTileMatrixSet* tileMatrixSet(std::string_view id) const noexcept;
};

/** Parses a WMTS 1.0.0 Capabilities document. An error says what is missing or malformed (an
 * ows:ExceptionReport gives its text). Unknown elements are ignored. */
std::expected<WmtsCapabilities, std::string> parseWmtsCapabilities(std::string_view xml);

/** How tiles are asked for: RESTful (the layer's ResourceURL template), KVP (GetTile with query
 * parameters), or Auto: REST when the layer has a template for the format, else KVP. */
enum class WmtsEncoding { Auto, Rest, Kvp };

/** What a tellus layer takes from a WMTS layer ("" picks the default: the layer's default style,
 * its only linked set). */
struct WmtsChoice {
  std::string layer;
  std::string style;
  std::string format; ///< the tellus layer's format; the WMTS layer must offer it
  std::string tileMatrixSet;
  WmtsEncoding encoding = WmtsEncoding::Auto;
  std::string capabilitiesUrl; ///< where the KVP base comes from when the document names none
  /// A layer on another body (issue 26): metres per degree on that body (BodyCrs.hpp's mean
  /// radius), for a set whose scale denominators are counted on it; 0 = the Earth's only.
  double bodyMetresPerDegree = 0.0;
};

/** Where a matrix lies, in degrees (the corner as west and north whatever the CRS's axis order). */
struct WmtsMatrixGeometry {
  std::string identifier;
  double west = -180.0;
  double north = 90.0;
  double pixelDeg = 0.0; ///< one pixel's span
  std::int32_t tileWidth = 0;
  std::int32_t tileHeight = 0;
  std::int64_t matrixWidth = 0;
  std::int64_t matrixHeight = 0;
  /// Web Mercator sets (WmtsTiles::mercator): the corner and pixel size in metres as written
  /// (west, north and pixelDeg then give the longitude of the corner, 85.0511 and a pixel's
  /// longitude span).
  double originX = 0.0;
  double originY = 0.0;
  double pixelMetres = 0.0;
};

/** One World Wind level's matrix: WMTS row = rowBase - row, WMTS column = colBase + col; or, when
 * `composeFrom` >= 0, the index in WmtsTiles::matrices of the matrix it is composed from. */
struct WmtsLevel {
  int composeFrom = -1;
  std::string matrix;
  std::int64_t rowBase = 0;
  std::int64_t colBase = 0;
  std::int64_t matrixWidth = 0;
  std::int64_t matrixHeight = 0;
};

/** A tellus layer bound to a WMTS layer: everything a tile's URL needs. */
struct WmtsTiles {
  std::string layer;
  std::string style;
  std::string format;
  std::string tileMatrixSet;
  bool rest = true;
  std::string urlTemplate; ///< REST: the template; KVP: the GetTile base URL
  std::string timeName;    ///< the time dimension's identifier as written ("" = none)
  std::string timeDefault; ///< its default (used when a tile is asked for without a time)
  /// other dimensions, at their defaults
  std::vector<std::pair<std::string, std::string>> dimensions;
  std::vector<WmtsLevel> levels;            ///< one per level of the grid
  std::vector<WmtsMatrixGeometry> matrices; ///< the set's matrices (what composed levels use)
  bool mercator = false; ///< a Web Mercator set: every level composed (WmtsMercator.hpp)
};

/** One upstream tile of a composed level. */
struct WmtsSourceTile {
  std::int64_t row = 0; ///< WMTS row (from the top) and column of the source matrix
  std::int64_t col = 0;
  std::string url;
};

/** Whether the level of `key` is composed (not re-indexed). */
bool wmtsComposed(const WmtsTiles& tiles, const TileKey& key) noexcept;

/** The upstream tiles a composed tile of `sector`, `width` x `height` pixels, needs: those its
 * bilinear samples touch, inside the source matrix (empty when the tile lies outside it: there is
 * no such tile). */
std::vector<WmtsSourceTile> wmtsSourceTiles(const WmtsTiles& tiles,
                                            const TileKey& key,
                                            const Sector& sector,
                                            int width,
                                            int height,
                                            std::string_view time);

/** Chooses and checks (layer, style, format, set exist; clear errors naming what exists) and
 * maps every level of `grid` onto a matrix of the set (see the file comment). */
std::expected<WmtsTiles, std::string>
bindWmtsLayer(const WmtsCapabilities& caps, const WmtsChoice& choice, const GridSpec& grid);

/** The URL of one tile; std::nullopt when the tile lies outside the matrix (no such tile).
 * `time` "" asks for the dimension's default. */
std::optional<std::string>
wmtsTileUrl(const WmtsTiles& tiles, const TileKey& key, std::string_view time);

/** The GetCapabilities URL of a configured url: as given when it already asks for something
 * (REQUEST=) or names a document (.xml), else with SERVICE=WMTS&REQUEST=GetCapabilities added. */
std::string wmtsCapabilitiesUrl(const std::string& url);

/** Where the capabilities of upstream `name` are kept under the cache root. */
std::filesystem::path wmtsCapabilitiesFile(const std::filesystem::path& cacheRoot,
                                           std::string_view upstream);

/** The capabilities of a WMTS upstream: fetched (through `fetcher`, upstream `name`) and saved
 * to `file` when it parses, else (or when `offline`) the saved copy; an error when neither can be
 * had names both reasons. `note` (may be null) receives a line when the saved copy was used
 * because the fetch failed. Blocks until the fetch ends. */
std::expected<WmtsCapabilities, std::string> loadWmtsCapabilities(Fetcher& fetcher,
                                                                  const std::string& name,
                                                                  const std::string& url,
                                                                  const std::filesystem::path& file,
                                                                  bool offline,
                                                                  std::string* note = nullptr);

} // namespace tellus
