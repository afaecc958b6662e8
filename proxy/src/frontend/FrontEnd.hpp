#pragma once
// The front ends of `tellus serve` (ProxyFrontEnd.cpp routes to them): WMS (WmsFrontEnd.cpp), World
// Wind and the static tile layout (TileFrontEnd.cpp), the page, /layers.json, /index.txt and
// /metrics (PagesFrontEnd.cpp). What they share is FrontEnd: the tile service, the options, the
// metrics, the fetch budget, the composer, and the one way each kind of answer and error is made
// (statuses, caching headers, the redaction of every message a client sees).

#include "compose/MapComposer.hpp"
#include "tiles/WorkerPool.hpp"

#include <tellus/proxy/Capabilities.hpp>
#include <tellus/proxy/FetchBudget.hpp>
#include <tellus/proxy/HttpServer.hpp>
#include <tellus/proxy/Metrics.hpp>
#include <tellus/proxy/OgcExceptionFormat.hpp>
#include <tellus/proxy/ProxyFrontEnd.hpp>
#include <tellus/proxy/TileService.hpp>
#include <tellus/proxy/Wms.hpp>
#include <tellus/proxy/Wmts.hpp>

#include <chrono>
#include <cstdint>
#include <expected>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace tellus {

struct CapabilitiesModel;

/** The state and the answers every front end shares. */
struct FrontEnd {
  FrontEnd(TileService& tiles, FrontEndOptions options);

  TileService& tiles;
  FrontEndOptions options;
  ProxyMetrics metrics;
  std::string updateSequence;
  std::string lastUpdate;
  std::int64_t startedMillis;
  FetchBudget budget; // upstream fetches per client address
  /// Composed WMTS tiles written to the cache (and then answered) off the composer's workers:
  /// a write waits for its fsync, which would hold a worker that could be composing the next
  /// tile. Declared before the composer: its last maps still find it.
  WorkerPool writers{kComposedWriters};
  MapComposer composer; // last: its workers stop first

  static constexpr int kComposedWriters = 4;

  static constexpr const char* kAllowedMethods = "GET, HEAD, OPTIONS";

  void countTile(const LayerSpec* l, const TileAnswer& a);
  /** The headers of every answer (CORS). */
  void common(HttpResponse& r) const;
  HttpResponse plain(int status, std::string_view text) const;

  /** What a client may see of an error message: the one redaction (sanitizeForClient: URLs, file
   * paths, credentials in user:password@ and key=value form), cut to kMaxClientMessageBytes.
   * Every error any endpoint sends goes through here: the plain-text errors (errorText) and the
   * OGC exceptions, XML or drawn into an image (WmsFrontEnd::exception). */
  static std::string clientMessage(std::string_view message);
  /** A plain-text error: the status and the redacted message. */
  HttpResponse errorText(int status, std::string_view message) const;

  /** The HTTP status of a temporary failure and when to try again: the upstream is unavailable
   * (503) or the client's fetch budget is spent (429). */
  struct Temporary {
    int status = 503;
    std::int64_t retryAfterSeconds = 1;
  };
  static std::optional<Temporary> temporary(TileAnswer::Failure f, std::int64_t retryAfter);
  static void markTemporary(HttpResponse& r, const Temporary& t);

  /** The budget the requests of this client are charged to (none when unlimited). */
  FetchGate gateFor(const HttpRequest& req);
  /** The URL clients reach us at: the configured one, else Host / X-Forwarded-* (checked). */
  std::string baseUrl(const HttpRequest& req) const;
  static std::expected<std::string, OgcException> resolveTime(const LayerSpec& l,
                                                              std::string_view t);

  /** What a tile answer needs of the request: its validators (not a copy of the request). */
  struct Validators {
    std::string ifNoneMatch;
    std::string ifModifiedSince;
    explicit Validators(const HttpRequest& req)
        : ifNoneMatch(req.header("if-none-match")),
          ifModifiedSince(req.header("if-modified-since")) {}
  };
  /** A tile as it is cached (200, or 304 for the client's validators), with its caching headers
   * and its surrogate keys (`keys`: layerKeys; "" = none). A provisional tile (stale, or composed
   * with a coarser tile standing in) is kept briefly (shortCacheControl). */
  void sendTile(const Validators& req,
                TileAnswer&& a,
                const LayerSpec& l,
                const std::string& keys,
                const Responder& respond,
                bool provisional = false) const;
  /** Cache-Control of a fresh tile of these layers (the shortest max_age and ttl) or a stale one,
   * and the surrogate keys when they are on. */
  void cacheHeaders(HttpResponse& r,
                    std::chrono::seconds maxAge,
                    std::chrono::milliseconds ttl,
                    bool stale,
                    const std::string& keys) const;
  /** Cache-Control of an answer that says "no tile here" (404, an empty map), with its keys. */
  void shortLived(HttpResponse& r, const std::string& keys) const;
  /** The last word on every answer (ProxyFrontEnd): an error no cache may keep says no-store
   * (keepable) and loses its surrogate keys. */
  void finishCaching(HttpResponse& r) const;
};

/** GetCapabilities and GetMap (one tile as cached, or composed), their OGC exceptions. */
class WmsFrontEnd {
public:
  explicit WmsFrontEnd(FrontEnd& fe) : fe_(fe) {}
  void handle(const HttpRequest& req, const Responder& respond);

private:
  /** What a map of these layers is made of: heights (mapIsHeights) or a picture, and the
   * no-data value of heights (the first elevation layer's, else -32768). Unknown names count as
   * imagery. A layer drawn in colour (drawnInColour: its STYLES entry, `styles` parallel to
   * `names` or empty) makes a PNG or TIFF map a picture; BIL16 stays heights (BIL is data: a
   * style does not apply), and so does BIL32, values. One rule for the map and for the image an
   * exception is drawn in. */
  struct MapKind {
    bool heights = false;
    std::int16_t noData = -32768;
    /** A map of values (application/bil32), no data as the first value layer's (as a value:
     * raw no-data * scale + offset), NaN when it has none. */
    bool values = false;
    float valueNoData = kNoValue;
  };
  MapKind mapKind(MapFormat format,
                  const std::vector<std::string>& names,
                  const std::vector<std::string>& styles) const;
  /** Whether a layer with this STYLES entry is drawn with a colour map: its style's colour map
   * (styleOf), or, for a style it does not have, whether it is a value layer (whose styles are
   * colour maps: what the request asked for is a picture). */
  bool drawnInColour(const LayerSpec& l, std::string_view style) const;
  void capabilities(const HttpRequest& req,
                    const GetCapabilitiesRequest& caps,
                    const WmsErrorContext& ctx,
                    const Responder& respond) const;
  CapabilitiesModel capabilitiesModel(const HttpRequest& req) const;
  void getMap(const HttpRequest& req,
              GetMapRequest&& m,
              const WmsErrorContext& ctx,
              const Responder& respond);
  /** Every layer of a GetMap, checked (known, style, time; for a map of values, Float32 values);
   * nullopt when an exception was sent. */
  std::optional<std::vector<ComposeLayer>>
  mapLayers(const GetMapRequest& m, const WmsErrorContext& ctx, const Responder& respond) const;
  /** One layer in its own format, exactly one tile: the cached file itself. False when the map
   * is not such a tile. */
  bool sendOneTile(const HttpRequest& req,
                   GetMapRequest& m,
                   const std::vector<ComposeLayer>& layers,
                   const MapKind& kind,
                   const WmsErrorContext& ctx,
                   const Responder& respond);
  void compose(const HttpRequest& req,
               const GetMapRequest& m,
               std::vector<ComposeLayer>&& layers,
               const MapKind& kind,
               const WmsErrorContext& ctx,
               const Responder& respond);
  /** An OGC exception in the form the request asked for: XML, or for a GetMap with
   * EXCEPTIONS=BLANK/INIMAGE an image in its FORMAT (every format: see blankMap). */
  void
  exception(const WmsErrorContext& ctx, const OgcException& raw, const Responder& respond) const;
  /** An exception for a tile or map that could not be had: a temporary failure (an upstream
   * unavailable, the client's fetch budget spent) has its own status (503, 429) and Retry-After
   * whatever exceptions_http_status says, so that no client keeps it; the body is what the
   * request's EXCEPTIONS asks for. */
  void exception(const WmsErrorContext& ctx,
                 const OgcException& e,
                 const Responder& respond,
                 std::optional<FrontEnd::Temporary> temporaryFailure) const;
  /** The colour map of a layer's STYLES entry: nullptr for a layer drawn as before (imagery,
   * an elevation layer's default), the map for a value layer's default or named style; an
   * exception (StyleNotDefined) for a style the layer does not offer. */
  std::expected<const values::ColourMap*, OgcException> styleOf(const LayerSpec& l,
                                                                std::string_view style) const;
  /** The capabilities' styles of a layer: its upstream style, or a value layer's colour maps,
   * each with the LegendURL of its GetLegendGraphic (WmsValues.cpp). */
  void describeStyles(const LayerSpec& l, const std::string& base, CapabilitiesLayer& c) const;
  /** GetLegendGraphic: the PNG legend of a value layer's style (WmsValues.cpp). */
  void legend(const GetLegendGraphicRequest& g,
              std::string_view ifNoneMatch,
              const WmsErrorContext& ctx,
              const Responder& respond) const;
  /** GetFeatureInfo: the value of each queried value layer at the pixel (WmsValues.cpp). */
  void featureInfo(const HttpRequest& req,
                   const GetFeatureInfoRequest& f,
                   const WmsErrorContext& ctx,
                   const Responder& respond);
  /** A GetMap where there is no tile: the empty map in the request's format. */
  void emptyImage(const GetMapRequest& m,
                  const MapKind& kind,
                  std::string_view why,
                  TileOrigin origin,
                  const std::string& keys,
                  const Responder& respond) const;

  FrontEnd& fe_;
};

/** World Wind tiles (`/wwtile?T=&L=&X=&Y=`) and the static layout (`/tiles/...`): the cached
 * file, or 404 when there is no tile, fast. */
class TileFrontEnd {
public:
  explicit TileFrontEnd(FrontEnd& fe) : fe_(fe) {}
  void worldWind(const HttpRequest& req, const Responder& respond);
  void staticTile(const HttpRequest& req, const Responder& respond);

private:
  /** The tile `name` asks for (the layer's own, or its whole row's or span's) as the layer's. */
  void serveTilePath(const HttpRequest& req,
                     const LayerSpec& layer,
                     const std::string& name,
                     const TileKey& key,
                     const Responder& respond,
                     const std::string* time = nullptr);
  /** A tile that could not be had: 404 when there is no such tile, 503 or 429 with Retry-After
   * when it may come later, 502 when the upstream's answer was not a tile. */
  HttpResponse tileError(const TileAnswer& a, const std::string& keys) const;

  FrontEnd& fe_;
};

/** WMTS 1.0.0 (`/wmts?` KVP, `/wmts/1.0.0/...` RESTful; WmtsFrontEnd.cpp): GetCapabilities and
 * GetTile in three kinds of tile matrix sets (Wmts.hpp): the layer's own World Wind grid (the
 * cached file, as /wwtile sends it), WorldCRS84Quad (composed, then kept in the cache as a
 * dataset of its own: WmtsComposed.cpp) and GoogleMapsCompatible (composed in EPSG:3857 and kept
 * the same way). Errors are OWS 1.1 exception reports with WMTS's HTTP statuses. */
class WmtsFrontEnd {
public:
  explicit WmtsFrontEnd(FrontEnd& fe);
  void handle(const HttpRequest& req, const Responder& respond);

private:
  struct LayerSets {
    const LayerSpec* layer = nullptr;
    std::vector<WmtsTileMatrixSet> sets; ///< WorldWind, then the composed ones (if composable)
  };
  void capabilities(const HttpRequest& req, const Responder& respond) const;
  void getTile(const HttpRequest& req, const WmtsGetTileRequest& t, const Responder& respond);
  void worldWindTile(const HttpRequest& req,
                     const LayerSpec& l,
                     const TileKey& key,
                     std::string time,
                     const Responder& respond);
  /** WorldCRS84Quad and GoogleMapsCompatible: from the cache of the composed set, else composed
   * (a Mercator tile's rows evenly in Mercator y) and kept when made of fresh tiles of the right
   * level (WmtsComposed). */
  void composedTile(const HttpRequest& req,
                    const LayerSpec& l,
                    WmtsSetKind kind,
                    const WmtsTileMatrix& m,
                    std::int32_t level,
                    std::int64_t row,
                    std::int64_t col,
                    std::string time,
                    std::int32_t levels,
                    const Responder& respond);
  /** A layer's composed set (`<layer>.<set>`) at a time as a cache dataset: (id, folder), or
   * nullopt when the cache cannot register it (then nothing is kept). */
  std::optional<std::pair<DatasetId, std::string>> composedDataset(const LayerSpec& l,
                                                                   WmtsSetKind kind,
                                                                   const std::string& time,
                                                                   std::int32_t levels);
  void exception(const OgcException& e,
                 const Responder& respond,
                 int status = 0,
                 std::optional<FrontEnd::Temporary> temporary = std::nullopt) const;
  void tileFailure(const TileAnswer& a, const std::string& keys, const Responder& respond) const;

  /** The layers' sets, made on first use (the front ends are made before FrontEnd). */
  const std::vector<LayerSets>& layerSets() const;

  FrontEnd& fe_;
  mutable std::once_flag setsOnce_;
  mutable std::vector<LayerSets> layers_;
  mutable std::vector<WmtsTileMatrixSet> composedDefinitions_; ///< at the most levels of any layer
  std::mutex datasetsMutex_;
  /// (`<layer>.<set>`, time) -> (id, folder)
  std::map<std::pair<std::string, std::string>, std::pair<DatasetId, std::string>> datasets_;
};

/** The page (WebPage.hpp): `/` and its files, `/layers.json`, the plain-text index at
 * `/index.txt` (also `/` when the page is not built in); and `/metrics`. */
class PagesFrontEnd {
public:
  explicit PagesFrontEnd(FrontEnd& fe) : fe_(fe) {}
  void index(const HttpRequest& req, const Responder& respond) const;
  void metrics(const Responder& respond) const;

private:
  FrontEnd& fe_;
};

} // namespace tellus
