#include "compose/MapComposer.hpp"

#include <tellus/cache/TilePath.hpp>
#include <tellus/proxy/Capabilities.hpp>
#include <tellus/proxy/ImageCodec.hpp>
#include <tellus/proxy/Log.hpp>
#include <tellus/proxy/OgcExceptionFormat.hpp>
#include <tellus/proxy/ProxyFrontEnd.hpp>
#include <tellus/proxy/Query.hpp>
#include <tellus/proxy/WebPage.hpp>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <mutex>

namespace tellus {

// ------------------------------------------------------------------------------- HTTP helpers

std::string formatHttpDate(std::int64_t unixMillis) {
  const std::time_t t = static_cast<std::time_t>(unixMillis / 1000);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[40];
  std::strftime(buf, sizeof buf, "%a, %d %b %Y %H:%M:%S GMT", &tm);
  return buf;
}

std::optional<std::int64_t> parseHttpDate(std::string_view text) {
  if (text.empty()) return std::nullopt;
  const std::string s(text);
  // IMF-fixdate, RFC 850, asctime (RFC 9110 section 5.6.7); strptime with the C locale's names.
  for (const char* fmt :
       {"%a, %d %b %Y %H:%M:%S GMT", "%A, %d-%b-%y %H:%M:%S GMT", "%a %b %e %H:%M:%S %Y"}) {
    std::tm tm{};
    const char* end = strptime(s.c_str(), fmt, &tm);
    if (end && *end == '\0') return static_cast<std::int64_t>(timegm(&tm)) * 1000;
  }
  return std::nullopt;
}

bool ifNoneMatchHits(std::string_view header, std::string_view etag) {
  auto opaque = [](std::string_view t) {
    if (t.starts_with("W/")) t.remove_prefix(2);
    return t;
  };
  const std::string_view mine = opaque(etag);
  std::size_t pos = 0;
  while (pos < header.size()) {
    const auto comma = header.find(',', pos);
    std::string_view item =
        header.substr(pos, comma == std::string_view::npos ? std::string_view::npos : comma - pos);
    while (!item.empty() && (item.front() == ' ' || item.front() == '\t'))
      item.remove_prefix(1);
    while (!item.empty() && (item.back() == ' ' || item.back() == '\t'))
      item.remove_suffix(1);
    if (item == "*" || (!item.empty() && opaque(item) == mine)) return true;
    if (comma == std::string_view::npos) break;
    pos = comma + 1;
  }
  return false;
}

// ------------------------------------------------------------------------------- front end

struct ProxyFrontEnd::Impl {
  TileService& tiles;
  FrontEndOptions options;
  ProxyMetrics metrics;
  std::string updateSequence;
  std::string lastUpdate;
  std::int64_t startedMillis = unixMillisNow();
  FetchBudget budget;   // upstream fetches per client address
  MapComposer composer; // last: its workers stop first

  static std::vector<std::string> layerNames(const TileService& t) {
    std::vector<std::string> names;
    for (const auto& l : t.layers())
      names.push_back(l.name);
    return names;
  }

  static TileOutcome outcomeOf(const TileAnswer& a) {
    if (a.kind == TileAnswer::Kind::Error) {
      if (a.failure == TileAnswer::Failure::OverBudget) return TileOutcome::Refused;
      return a.origin == TileOrigin::Offline ? TileOutcome::Offline : TileOutcome::Error;
    }
    if (a.kind == TileAnswer::Kind::Absent)
      return a.origin == TileOrigin::Offline ? TileOutcome::Offline : TileOutcome::Absent;
    switch (a.origin) {
    case TileOrigin::Hit:
      return TileOutcome::Hit;
    case TileOrigin::Miss:
      return TileOutcome::Miss;
    case TileOrigin::Stale:
      return TileOutcome::Stale;
    case TileOrigin::Offline:
      return TileOutcome::Offline;
    }
    return TileOutcome::Error;
  }

  void countTile(const LayerSpec* l, const TileAnswer& a) {
    metrics.tile(static_cast<std::size_t>(l - tiles.layers().data()), outcomeOf(a));
  }

  void metricsPage(const Responder& respond) const {
    auto r = HttpResponse::text(
        200,
        "text/plain; version=0.0.4; charset=utf-8",
        metrics.render(tiles.upstreamMetrics(),
                       tiles.cachedBytes(),
                       composer.decodedCacheBytes(),
                       FetchBudgetMetrics{budget.perMinute(), budget.refused(), budget.clients()},
                       tiles.cacheHealth()));
    r.setHeader("Cache-Control", "no-store");
    respond(std::move(r));
  }

  Impl(TileService& t, FrontEndOptions o)
      : tiles(t), options(std::move(o)), metrics(layerNames(t)),
        budget(options.fetchesPerClientPerMinute, options.clock ? *options.clock : Clock::system()),
        composer(t,
                 options.composeThreads,
                 options.maxTilesPerMap,
                 options.decodedTileCacheBytes,
                 options.jpegQuality) {
    const auto now = unixMillisNow();
    updateSequence =
        options.updateSequence.empty() ? std::to_string(now / 1000) : options.updateSequence;
    // The service's LastUpdate: the newest of its layers' (see capabilitiesModel).
    UnixMillis newest = 0;
    for (const auto& l : tiles.layers())
      newest = std::max(newest, tiles.layerSince(l.name));
    const std::time_t secs = static_cast<std::time_t>((newest > 0 ? newest : now) / 1000);
    std::tm tm{};
    gmtime_r(&secs, &tm);
    char buf[32];
    std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
    lastUpdate = buf;
  }

  void common(HttpResponse& r) const {
    if (!options.cors.empty()) r.setHeader("Access-Control-Allow-Origin", options.cors);
  }

  HttpResponse plain(int status, std::string_view text) const {
    auto r = HttpResponse::text(status, "text/plain; charset=utf-8", text);
    common(r);
    return r;
  }

  // ----------------------------------------------------------------------------- errors

  /** What a client may see of an error message: the one redaction (sanitizeForClient: URLs, file
   * paths, credentials in user:password@ and key=value form), cut to kMaxClientMessageBytes.
   * Every error any endpoint sends goes through here: the plain-text errors (errorText) and the
   * OGC exceptions, XML or drawn into an image (exception). */
  static std::string clientMessage(std::string_view message) {
    // Cut first as well: a message is at most kMaxClientMessageBytes once it is redacted.
    std::string m = sanitizeForClient(message.substr(0, 8 * kMaxClientMessageBytes));
    if (m.size() > kMaxClientMessageBytes) {
      std::size_t cut = kMaxClientMessageBytes;
      while (cut > 0 && (static_cast<unsigned char>(m[cut]) & 0xC0u) == 0x80u)
        --cut;
      m.resize(cut);
      m += "...";
    }
    return m;
  }

  /** A plain-text error: the status and the redacted message. */
  HttpResponse errorText(int status, std::string_view message) const {
    return plain(status, clientMessage(message) + "\n");
  }

  /** The HTTP status of a temporary failure and when to try again: the upstream is unavailable
   * (503) or the client's fetch budget is spent (429). */
  struct Temporary {
    int status = 503;
    std::int64_t retryAfterSeconds = 1;
  };
  static std::optional<Temporary> temporary(TileAnswer::Failure f, std::int64_t retryAfter) {
    if (f == TileAnswer::Failure::Bad) return std::nullopt;
    return Temporary{f == TileAnswer::Failure::OverBudget ? 429 : 503,
                     std::max<std::int64_t>(1, retryAfter)};
  }
  static void markTemporary(HttpResponse& r, const Temporary& t) {
    r.status = t.status;
    r.setHeader("Retry-After", std::to_string(t.retryAfterSeconds));
    r.setHeader("Cache-Control", "no-store");
  }

  /** A tile that could not be had, for the World Wind and static endpoints: 404 when there is no
   * such tile, 503 or 429 with Retry-After when it may come later, 502 when the upstream's answer
   * was not a tile. */
  HttpResponse tileError(const TileAnswer& a) const {
    if (a.kind == TileAnswer::Kind::Absent) {
      auto r = errorText(404, a.message);
      r.setHeader("X-Cache", toString(a.origin));
      r.setHeader("Cache-Control", "public, max-age=60");
      return r;
    }
    auto r = errorText(502, a.message);
    r.setHeader("X-Cache", toString(a.origin));
    if (const auto t = temporary(a.failure, a.retryAfterSeconds))
      markTemporary(r, *t);
    else
      r.setHeader("Cache-Control", "no-store");
    return r;
  }

  /** What the HTTP server refused (HttpRequest::refusal): answered here like any other request,
   * so that it is counted and logged. */
  HttpResponse refusalResponse(const HttpRequest& req) const {
    switch (req.refusal) {
    case HttpRefusal::BadRequest:
      return errorText(400, "bad request: malformed request line or header");
    case HttpRefusal::MethodNotAllowed: {
      auto r = errorText(405, "only GET, HEAD and OPTIONS");
      r.setHeader("Allow", kAllowedMethods);
      return r;
    }
    case HttpRefusal::BodyTooLarge:
      return errorText(413, "request body too large");
    case HttpRefusal::TooManyRequests: {
      auto r = errorText(429, "too many requests");
      markTemporary(r, Temporary{429, 1});
      return r;
    }
    case HttpRefusal::HeaderTooLarge:
      return errorText(431, "request header fields too large");
    case HttpRefusal::None:
      break;
    }
    return errorText(500, "internal error");
  }

  static constexpr const char* kAllowedMethods = "GET, HEAD, OPTIONS";

  /** A header list such as Access-Control-Request-Headers asks for: tokens (RFC 9110) separated
   * by commas and blanks, not too long. */
  static bool tokenList(std::string_view v) {
    if (v.empty() || v.size() > 1024) return false;
    return std::all_of(v.begin(), v.end(), [](char c) {
      return std::isalnum(static_cast<unsigned char>(c)) ||
             std::string_view("!#$%&'*+-.^_`|~, \t").find(c) != std::string_view::npos;
    });
  }

  /** OPTIONS: a CORS preflight (Origin and Access-Control-Request-Method) gets 204 with what a
   * browser needs to send the real request (the headers it asked for are allowed: tellus
   * ignores them, an Authorization or a Cesium Resource header included); a plain OPTIONS gets
   * 204 with Allow. */
  HttpResponse optionsResponse(const HttpRequest& req) const {
    HttpResponse r;
    r.status = 204;
    r.setHeader("Allow", kAllowedMethods);
    const bool preflight =
        !req.header("origin").empty() && !req.header("access-control-request-method").empty();
    if (!preflight || options.cors.empty()) return r;
    r.setHeader("Access-Control-Allow-Origin", options.cors);
    r.setHeader("Access-Control-Allow-Methods", kAllowedMethods);
    const std::string_view asked = req.header("access-control-request-headers");
    r.setHeader("Access-Control-Allow-Headers",
                tokenList(asked) ? std::string(asked)
                                 : std::string("Authorization, X-Requested-With, If-None-Match, "
                                               "If-Modified-Since, Cache-Control"));
    r.setHeader("Access-Control-Max-Age", "86400");
    r.setHeader("Vary", "Origin, Access-Control-Request-Method, Access-Control-Request-Headers");
    return r;
  }

  /** The budget the requests of this client are charged to (none when unlimited). */
  FetchGate gateFor(const HttpRequest& req) {
    return FetchGate{budget.unlimited() ? nullptr : &budget, req.remoteAddress};
  }

  static bool safeHost(std::string_view h) {
    return !h.empty() && h.size() < 256 && std::all_of(h.begin(), h.end(), [](char c) {
      return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == ':' ||
             c == '[' || c == ']';
    });
  }

  /** The URL clients reach us at: the configured one, else Host / X-Forwarded-* (checked). */
  std::string baseUrl(const HttpRequest& req) const {
    if (!options.publicUrl.empty()) {
      std::string u = options.publicUrl;
      while (!u.empty() && u.back() == '/')
        u.pop_back();
      return u;
    }
    std::string_view proto = req.header("x-forwarded-proto");
    if (proto != "https") proto = "http";
    std::string_view host = req.header("x-forwarded-host");
    if (const auto comma = host.find(','); comma != std::string_view::npos)
      host = host.substr(0, comma);
    if (!safeHost(host)) host = req.header("host");
    if (!safeHost(host)) host = "localhost";
    std::string prefix(req.header("x-forwarded-prefix"));
    const bool prefixOk = std::all_of(prefix.begin(), prefix.end(), [](char c) {
      return std::isalnum(static_cast<unsigned char>(c)) || c == '/' || c == '-' || c == '_' ||
             c == '.';
    });
    if (!prefixOk || (!prefix.empty() && prefix.front() != '/')) prefix.clear();
    while (!prefix.empty() && prefix.back() == '/')
      prefix.pop_back();
    return std::string(proto) + "://" + std::string(host) + prefix;
  }

  // ----------------------------------------------------------------------------- tiles

  /** What a tile answer needs of the request: its validators (not a copy of the request). */
  struct Validators {
    std::string ifNoneMatch;
    std::string ifModifiedSince;
    explicit Validators(const HttpRequest& req)
        : ifNoneMatch(req.header("if-none-match")),
          ifModifiedSince(req.header("if-modified-since")) {}
  };

  void sendTile(const Validators& req,
                TileAnswer&& a,
                const LayerSpec& l,
                const Responder& respond) const {
    HttpResponse r;
    r.headers.reserve(8);
    common(r);
    r.setHeader("ETag", a.etag);
    r.setHeader("Last-Modified", formatHttpDate(a.fetchedAt));
    r.setHeader("Cache-Control",
                a.origin == TileOrigin::Stale
                    ? std::string("public, max-age=60")
                    : "public, max-age=" + std::to_string(l.maxAge.count()));
    r.setHeader("X-Cache", toString(a.origin));
    const std::string_view inm = req.ifNoneMatch;
    bool notModified = false;
    if (!inm.empty()) {
      notModified = ifNoneMatchHits(inm, a.etag);
    } else if (const auto ims = parseHttpDate(req.ifModifiedSince)) {
      notModified = a.fetchedAt / 1000 <= *ims / 1000; // HTTP dates have whole seconds
    }
    if (notModified) {
      r.status = 304;
    } else {
      r.status = 200;
      r.setHeader("Content-Type", a.contentType);
      if (a.file) {
        const auto size = a.file->size();
        const int fd = a.file->fd();
        r.file = HttpFileBody{fd, size, std::move(a.file)};
      } else {
        r.body = std::move(a.bytes);
      }
    }
    respond(std::move(r));
  }

  /** World Wind and static requests: 404 when there is no tile, fast. */
  void serveTilePath(const HttpRequest& req,
                     const std::string& layerName,
                     const TileKey& key,
                     const Responder& respond,
                     const std::string* time = nullptr) {
    const LayerSpec* l = tiles.layer(layerName);
    if (!l) return respond(plain(404, "no such layer\n"));
    tiles.getTile(
        layerName,
        time ? *time : l->timeDefault,
        key,
        [this, v = Validators(req), l, respond](TileAnswer&& a) {
          countTile(l, a);
          if (a.kind == TileAnswer::Kind::Tile) return sendTile(v, std::move(a), *l, respond);
          respond(tileError(a));
        },
        gateFor(req));
  }

  void worldWind(const HttpRequest& req, const Responder& respond) {
    auto params = parseQuery(req.query, options.maxParamBytes, options.maxQueryBytes);
    if (!params) return respond(errorText(400, "bad query: " + params.error()));
    auto ww = parseWorldWindTile(*params);
    if (!ww) return respond(errorText(400, ww.error()));
    serveTilePath(req, ww->dataset, TileKey{ww->level, ww->row, ww->col}, respond);
  }

  void staticTile(const HttpRequest& req, const Responder& respond) {
    const auto parsed =
        parseStaticTilePath(std::string_view(req.path).substr(std::string_view("/tiles/").size()));
    if (!parsed)
      return respond(
          plain(404, "not a tile path: /tiles/<layer>/<level>/<row>/<row>_<col>.<ext>\n"));
    const LayerSpec* l = tiles.layer(parsed->layer);
    if (!l || parsed->extension != l->dataset.extension)
      return respond(plain(404, "no such layer\n"));
    // `?time=T` picks another time of a layer with a TIME dimension (the remote tile source of
    // the planet renderer uses it); validated as a WMS TIME is.
    std::string time;
    const std::string* timeOrDefault = nullptr; // the hot path (no query) allocates nothing
    if (!req.query.empty()) {
      auto params = parseQuery(req.query, options.maxParamBytes, options.maxQueryBytes);
      if (!params) return respond(errorText(400, "bad query: " + params.error()));
      if (const auto t = params->get("time")) {
        auto resolved = resolveTime(*l, *t);
        if (!resolved)
          return respond(errorText(400, resolved.error().code + ": " + resolved.error().message));
        time = std::move(*resolved);
        timeOrDefault = &time;
      }
    }
    serveTilePath(req, parsed->layer, parsed->key, respond, timeOrDefault);
  }

  // ----------------------------------------------------------------------------- WMS

  /** What a map of these layers is made of: heights (mapIsHeights) or a picture, and the
   * no-data value of heights (the first elevation layer's, else -32768). Unknown names count as
   * imagery. */
  struct MapKind {
    bool heights = false;
    std::int16_t noData = -32768;
  };
  MapKind mapKind(MapFormat format, const std::vector<std::string>& names) const {
    MapKind k;
    bool allElevation = !names.empty();
    bool noDataSet = false;
    for (const std::string& n : names) {
      const LayerSpec* l = tiles.layer(n);
      allElevation = allElevation && l && l->elevation;
      if (l && l->elevation && !noDataSet) {
        k.noData = l->noData;
        noDataSet = true;
      }
    }
    k.heights = mapIsHeights(format, allElevation);
    return k;
  }

  /** An OGC exception in the form the request asked for: XML, or for a GetMap with
   * EXCEPTIONS=BLANK/INIMAGE an image in its FORMAT (every format: see blankMap). */
  void
  exception(const WmsErrorContext& ctx, const OgcException& raw, const Responder& respond) const {
    const OgcException e{raw.code, clientMessage(raw.locator), clientMessage(raw.message)};
    if (ctx.exceptions != GetMapRequest::Exceptions::Xml && ctx.width > 0 && ctx.height > 0) {
      const std::string text = ctx.exceptions == GetMapRequest::Exceptions::InImage
                                   ? sanitizeForClient(e.code + ": " + e.message)
                                   : std::string();
      const MapKind kind = mapKind(ctx.mapFormat, ctx.layers);
      if (auto img = blankMap(ctx.mapFormat,
                              kind.heights,
                              ctx.width,
                              ctx.height,
                              ctx.bgcolor,
                              ctx.transparent,
                              text,
                              kind.noData)) {
        HttpResponse r;
        common(r);
        r.status = 200;
        r.setHeader("Content-Type", std::string(contentTypeOf(ctx.mapFormat)));
        r.setHeader("Cache-Control", "no-store"); // an error, drawn: never kept as the map
        r.body = std::move(*img);
        return respond(std::move(r));
      }
    }
    const FormattedResponse f = formatWmsException(ctx.version, e, options.exceptionsHttpStatus);
    auto r = HttpResponse::text(f.httpStatus, f.contentType, f.body);
    common(r);
    respond(std::move(r));
  }

  /** An exception for a tile or map that could not be had: a temporary failure (an upstream
   * unavailable, the client's fetch budget spent) has its own status (503, 429) and Retry-After
   * whatever exceptions_http_status says, so that no client keeps it; the body is what the
   * request's EXCEPTIONS asks for. */
  void exception(const WmsErrorContext& ctx,
                 const OgcException& e,
                 const Responder& respond,
                 std::optional<Temporary> temporaryFailure) const {
    if (!temporaryFailure) return exception(ctx, e, respond);
    // exception() answers before it returns: the references outlive the call.
    exception(ctx, e, [&](HttpResponse&& r) {
      markTemporary(r, *temporaryFailure);
      respond(std::move(r));
    });
  }

  /** A GetMap where there is no tile: the empty map in the request's format. */
  void emptyImage(const GetMapRequest& m,
                  const MapKind& kind,
                  std::string_view why,
                  TileOrigin origin,
                  const Responder& respond) const {
    auto img = blankMap(
        m.mapFormat, kind.heights, m.width, m.height, m.bgcolor, m.transparent, {}, kind.noData);
    if (!img) {
      WmsErrorContext ctx;
      ctx.version = m.version;
      return exception(
          ctx, OgcException{std::string(ogc::kNoApplicableCode), "", std::string(why)}, respond);
    }
    HttpResponse r;
    common(r);
    r.setHeader("Content-Type", std::string(contentTypeOf(m.mapFormat)));
    r.setHeader("X-Cache", toString(origin));
    r.setHeader("Cache-Control", "public, max-age=60");
    r.body = std::move(*img);
    respond(std::move(r));
  }

  static std::expected<std::string, OgcException> resolveTime(const LayerSpec& l,
                                                              std::string_view t) {
    return resolveTimeDimension(l.name, l.timeValues, l.timePeriod, l.timeDefault, t);
  }

  CapabilitiesModel capabilitiesModel(const HttpRequest& req) const {
    CapabilitiesModel m;
    m.title = options.title;
    m.abstract = "A WMS and NASA World Wind tile cache (tellus).";
    m.onlineResource = baseUrl(req) + "/wms?";
    std::vector<std::string> formats;
    const auto add = [&formats](std::string f) {
      if (std::find(formats.begin(), formats.end(), f) == formats.end())
        formats.push_back(std::move(f));
    };
    // The list is service-wide: every layer answers every format (heights as a grey picture,
    // imagery as its luminance in heights; docs/CONFIG.md, "WMS"). The layers' own formats first
    // (a client that takes the first one gets cached tiles as they are), then the rest.
    for (const auto& l : tiles.layers())
      add(l.dataset.mimeType);
    for (const MapFormat f :
         {MapFormat::Jpeg, MapFormat::Png, MapFormat::Png8, MapFormat::Bil16, MapFormat::Tiff})
      add(std::string(toString(f)));
    m.getMapFormats = formats;
    m.updateSequence = updateSequence;
    m.lastUpdate = lastUpdate;
    m.maxWidth = options.limits.maxWidth;
    m.maxHeight = options.limits.maxHeight;
    for (const auto& l : tiles.layers()) {
      CapabilitiesLayer c;
      c.name = l.name;
      c.title = l.title.empty() ? l.name : l.title;
      c.abstract = l.abstract;
      c.bbox = l.dataset.grid.sector;
      if (!l.dataset.style.empty()) c.styles.push_back(l.dataset.style);
      c.timeValues = l.timeValues;
      c.timePeriod = l.timePeriod;
      c.timeDefault = l.timeDefault;
      c.opaque = l.dataset.mimeType == "image/jpeg";
      // Since when this layer's tiles are what they are: World Wind Java drops its own cached
      // tiles older than this, so it must not move with every restart (only with a new definition).
      const UnixMillis since = tiles.layerSince(l.name);
      c.lastUpdateMillis = since > 0 ? since : startedMillis;
      m.layers.push_back(std::move(c));
    }
    return m;
  }

  void wms(const HttpRequest& req, const Responder& respond) {
    auto params = parseQuery(req.query, options.maxParamBytes, options.maxQueryBytes);
    if (!params) {
      return exception(WmsErrorContext{},
                       OgcException{std::string(ogc::kInvalidParameterValue), "", params.error()},
                       respond);
    }
    const WmsErrorContext ctx = wmsErrorContext(*params, options.limits);
    auto parsed = parseWms(*params, options.limits);
    if (!parsed) return exception(ctx, parsed.error(), respond);
    if (const auto* caps = std::get_if<GetCapabilitiesRequest>(&*parsed)) {
      if (auto e = checkUpdateSequence(caps->updateSequence, updateSequence))
        return exception(ctx, *e, respond);
      const std::string xml = capabilitiesXml(caps->version, capabilitiesModel(req));
      HttpResponse r = HttpResponse::text(
          200, caps->version == WmsVersion::V111 ? "application/vnd.ogc.wms_xml" : "text/xml", xml);
      common(r);
      char etag[24];
      std::snprintf(
          etag, sizeof etag, "\"%016llx\"", static_cast<unsigned long long>(stableHash64(xml)));
      r.setHeader("ETag", etag);
      r.setHeader("Cache-Control", "public, max-age=60");
      if (ifNoneMatchHits(req.header("if-none-match"), etag)) {
        r.status = 304;
        r.body.clear();
      }
      return respond(std::move(r));
    }
    auto& m = std::get<GetMapRequest>(*parsed);
    // Every layer first: known, style, time. Imagery and heights mix: the format says what the
    // map is (mapIsHeights), and each layer is drawn as that (MapComposer).
    std::vector<ComposeLayer> layers;
    for (std::size_t k = 0; k < m.layers.size(); ++k) {
      const LayerSpec* l = tiles.layer(m.layers[k]);
      if (!l) {
        return exception(ctx,
                         OgcException{std::string(ogc::kLayerNotDefined),
                                      "LAYERS",
                                      "no layer '" + m.layers[k] + "'"},
                         respond);
      }
      const std::string& style = m.styles[k];
      if (!style.empty() && style != "default" && style != l->dataset.style) {
        return exception(
            ctx,
            OgcException{std::string(ogc::kStyleNotDefined), "STYLES", "no style '" + style + "'"},
            respond);
      }
      auto time = resolveTime(*l, m.time);
      if (!time) return exception(ctx, time.error(), respond);
      layers.push_back(
          ComposeLayer{l, std::move(*time), m.opacities.empty() ? l->opacity : m.opacities[k]});
    }
    const LayerSpec* l = layers.front().layer;
    const MapKind kind = mapKind(m.mapFormat, m.layers);
    // One layer, its own format (as what it is: heights as heights), exactly one tile: the cached
    // file itself (the fast path).
    if (layers.size() == 1 && m.format == l->dataset.mimeType && kind.heights == l->elevation &&
        (m.opacities.empty() || m.opacities.front() >= 1.0)) {
      const TileGrid* g = tiles.grid(l->name);
      if (const auto key = g->keyForBbox(m.bbox, m.width, m.height)) {
        const FetchGate gate = gateFor(req);
        return tiles.getTile(
            l->name,
            layers.front().time,
            *key,
            [this, v = Validators(req), l, m = std::move(m), kind, ctx, respond](TileAnswer&& a) {
              countTile(l, a);
              if (a.kind == TileAnswer::Kind::Tile) return sendTile(v, std::move(a), *l, respond);
              if (a.kind == TileAnswer::Kind::Absent) {
                if (a.origin == TileOrigin::Offline &&
                    options.offlineResponse == FrontEndOptions::OfflineResponse::Exception) {
                  return exception(ctx,
                                   OgcException{std::string(ogc::kNoApplicableCode), "", a.message},
                                   respond);
                }
                // No tile there: an empty map, not an error.
                return emptyImage(m, kind, a.message, a.origin, respond);
              }
              exception(ctx,
                        OgcException{std::string(ogc::kNoApplicableCode), "", a.message},
                        respond,
                        temporary(a.failure, a.retryAfterSeconds));
            },
            gate);
      }
    }
    // Any other box, size, format or several layers: composed from the tiles.
    if (static_cast<std::int64_t>(m.width) * m.height > options.maxMapPixels) {
      return exception(
          ctx,
          OgcException{std::string(ogc::kInvalidParameterValue),
                       "WIDTH",
                       "the map has more than " + std::to_string(options.maxMapPixels) + " pixels"},
          respond);
    }
    ComposeRequest cr;
    cr.layers = std::move(layers);
    cr.bbox = m.bbox;
    cr.width = m.width;
    cr.height = m.height;
    cr.format = m.mapFormat;
    cr.heights = kind.heights;
    cr.noData = kind.noData;
    cr.transparent = m.transparent;
    cr.bgcolor = m.bgcolor;
    cr.ifNoneMatch = std::string(req.header("if-none-match"));
    cr.fetchBudget = gateFor(req).budget;
    cr.client = req.remoteAddress;
    auto started = composer.compose(
        std::move(cr),
        [this](const LayerSpec& layer, const TileAnswer& a) { countTile(&layer, a); },
        [this, ctx, respond](ComposedMap&& map) {
          metrics.composedTiles(map.decodedTiles,
                                map.tiles > map.decodedTiles ? map.tiles - map.decodedTiles : 0);
          if (map.kind == ComposedMap::Kind::Error) {
            return exception(ctx,
                             OgcException{std::string(ogc::kNoApplicableCode), "", map.message},
                             respond,
                             temporary(map.failure, map.retryAfterSeconds));
          }
          HttpResponse r;
          common(r);
          r.setHeader("ETag", map.etag);
          r.setHeader("Cache-Control", "public, max-age=" + std::to_string(map.maxAgeSeconds));
          r.setHeader("X-Cache", toString(map.origin));
          if (map.kind == ComposedMap::Kind::NotModified) {
            r.status = 304;
          } else {
            r.status = 200;
            r.setHeader("Content-Type", map.contentType);
            r.body = std::move(map.bytes);
          }
          respond(std::move(r));
        });
    if (!started) {
      return exception(
          ctx,
          OgcException{std::string(ogc::kInvalidParameterValue), "BBOX", started.error()},
          respond);
    }
  }

  /** The page (WebPage.hpp): `/` and its files, `/layers.json`, and the plain-text index at
   * `/index.txt` (also `/` when the page is not built in). */
  void index(const HttpRequest& req, const Responder& respond) const {
    if (req.path == "/layers.json") {
      auto r = layersJsonResponse(req, options.title, tiles.layers());
      common(r);
      return respond(std::move(r));
    }
    if (auto r = webAssetResponse(req)) {
      common(*r);
      return respond(std::move(*r));
    }
    const std::string base = baseUrl(req);
    std::string t = options.title + "\n\n";
    t += "WMS:        " + base + "/wms?SERVICE=WMS&REQUEST=GetCapabilities\n";
    t += "World Wind: " + base + "/wwtile?T=<layer>&L=<level>&X=<column>&Y=<row>\n";
    t += "Static:     " + base + "/tiles/<layer>/<level>/<row>/<row>_<column>.<ext>\n";
    if (webPageEmbedded()) t += "Map page:   " + base + "/  (layers: " + base + "/layers.json)\n";
    t += "\nlayers:\n";
    for (const auto& l : tiles.layers()) {
      t += "  " + l.name + "  " + l.dataset.mimeType + "  " +
           std::to_string(l.dataset.grid.levelZeroDeltaDeg) + " deg level 0, " +
           std::to_string(l.dataset.grid.numLevels) + " levels  e.g. " + base +
           "/wwtile?T=" + l.name + "&L=0&X=0&Y=0\n";
    }
    respond(plain(200, t));
  }
};

ProxyFrontEnd::ProxyFrontEnd(TileService& tiles, FrontEndOptions options)
    : impl_(std::make_unique<Impl>(tiles, std::move(options))) {}

ProxyFrontEnd::~ProxyFrontEnd() = default;

void ProxyFrontEnd::handle(HttpRequest&& req, Responder respond) {
  auto& im = *impl_;
  const bool wms =
      req.path == "/wms" || req.path == "/wms/" || (req.path == "/" && !req.query.empty());
  const Protocol protocol = wms                               ? Protocol::Wms
                            : req.path == "/wwtile"           ? Protocol::WorldWind
                            : req.path.starts_with("/tiles/") ? Protocol::Static
                            : isWebPagePath(req.path)         ? Protocol::Page
                            : req.path == "/metrics"          ? Protocol::Metrics
                                                              : Protocol::Other;
  im.metrics.requestStarted(protocol);
  // The access log's fields, only when it is on (it costs a few copies per request).
  struct Access {
    std::chrono::steady_clock::time_point start;
    std::string remote, method, target;
  };
  std::optional<Access> access;
  if (logger().accessLogEnabled())
    access = Access{std::chrono::steady_clock::now(), req.remoteAddress, req.method, req.target};
  Responder counted = [metrics = &im.metrics,
                       protocol,
                       access = std::move(access),
                       respond = std::move(respond)](HttpResponse&& r) {
    const auto bytes = r.file ? static_cast<std::uint64_t>(r.file->size) : r.body.size();
    metrics->requestFinished(protocol, r.status, bytes);
    if (access) {
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() -
                                                                  access->start)
                            .count();
      char msText[32];
      std::snprintf(msText, sizeof msText, "%.3f", ms);
      std::string_view cache = "-";
      for (const auto& [k, v] : r.headers) {
        if (k == "X-Cache") cache = v;
      }
      const std::string status = std::to_string(r.status);
      const std::string size = std::to_string(bytes);
      logger().access({{"remote", access->remote},
                       {"method", access->method},
                       {"target", access->target},
                       {"status", status},
                       {"bytes", size},
                       {"ms", msText},
                       {"cache", cache},
                       {"protocol", toString(protocol)}});
    }
    respond(std::move(r));
  };
  try {
    if (req.refusal != HttpRefusal::None) return counted(im.refusalResponse(req));
    if (req.method == "OPTIONS") return counted(im.optionsResponse(req));
    switch (protocol) {
    case Protocol::Wms:
      return im.wms(req, counted);
    case Protocol::WorldWind:
      return im.worldWind(req, counted);
    case Protocol::Static:
      return im.staticTile(req, counted);
    case Protocol::Page:
      return im.index(req, counted);
    case Protocol::Metrics:
      return im.metricsPage(counted);
    case Protocol::Other:
      break;
    }
    counted(im.plain(404, "not found\n"));
  } catch (const std::exception&) {
    // Last line of defence: nothing may escape an HTTP handler (this is a bug if it happens).
    counted(HttpResponse::text(500, "text/plain", "internal error\n"));
  }
}

} // namespace tellus
