// WMS 1.1.1 and 1.3.0 (`/wms`, and `/` with a query): GetCapabilities; GetMap answered with the
// cached file when it is exactly one tile of one layer in the layer's own format, else composed
// (MapComposer); every error as the OGC exception the request asked for (XML, or drawn into an
// image), a temporary failure with its own status (503, 429) and Retry-After.
#include "frontend/FrontEnd.hpp"

#include <tellus/cache/TilePath.hpp>
#include <tellus/proxy/BodyCrs.hpp>
#include <tellus/proxy/Capabilities.hpp>
#include <tellus/proxy/ImageCodec.hpp>
#include <tellus/proxy/Query.hpp>

#include <algorithm>
#include <cstdio>
#include <optional>

namespace tellus {

namespace {

/** The CRS and the layers of a map must lie on one body (docs/design/bodies-proxy.md): an Earth
 * layer takes no IAU code; another body's layer takes its own IAU code, or EPSG:4326 / CRS:84 read
 * as degrees on that body (what USGS Astrogeology's planetary servers advertise), never EPSG:3857
 * (the Earth's Web Mercator). Unknown layers are left to the layer check. */
std::optional<OgcException> bodyMismatch(const GetMapRequest& m, const TileService& tiles) {
  const std::string locator = m.version == WmsVersion::V130 ? "CRS" : "SRS";
  const auto invalidCrs = [&](std::string message) {
    return OgcException{std::string(invalidCrsCode(m.version)), locator, std::move(message)};
  };
  const LayerSpec* first = nullptr;
  for (const std::string& name : m.layers) {
    const LayerSpec* l = tiles.layer(name);
    if (!l) continue;
    const std::string& body = l->dataset.body;
    if (first && first->dataset.body != body) {
      return OgcException{std::string(ogc::kInvalidParameterValue),
                          "LAYERS",
                          "layers '" + first->name + "' (" + first->dataset.body + ") and '" +
                              l->name + "' (" + body + ") lie on different bodies"};
    }
    first = l;
    const bool iau = m.crs.starts_with("IAU:");
    if (isEarthBody(body)) {
      if (iau) return invalidCrs("layer '" + name + "' lies on the Earth, not in " + m.crs);
      continue;
    }
    const auto b = bodyCrs(body);
    if (!b) {
      return invalidCrs("layer '" + name + "' lies on '" + body +
                        "', which has no IAU code known to tellus (World Wind tiles only)");
    }
    if (m.crs == kWebMercator || (iau && m.crs != iauCrs130(b->iauCode))) {
      return invalidCrs(
          "layer '" + name + "' lies on " + body + ": " + m.crs + " is not its CRS (" +
          (m.version == WmsVersion::V130 ? iauCrs130(b->iauCode) : iauCrs111(b->iauCode)) + ")");
    }
  }
  return std::nullopt;
}

} // namespace

void WmsFrontEnd::handle(const HttpRequest& req, const Responder& respond) {
  auto params = parseQuery(req.query, fe_.options.maxParamBytes, fe_.options.maxQueryBytes);
  if (!params) {
    return exception(WmsErrorContext{},
                     OgcException{std::string(ogc::kInvalidParameterValue), "", params.error()},
                     respond);
  }
  const WmsErrorContext ctx = wmsErrorContext(*params, fe_.options.limits);
  auto parsed = parseWms(*params, fe_.options.limits);
  if (!parsed) return exception(ctx, parsed.error(), respond);
  const GetMapRequest* map = std::get_if<GetMapRequest>(&*parsed);
  if (const auto* f = std::get_if<GetFeatureInfoRequest>(&*parsed)) map = &f->map;
  if (map) {
    if (auto e = bodyMismatch(*map, fe_.tiles)) return exception(ctx, *e, respond);
  }
  if (const auto* caps = std::get_if<GetCapabilitiesRequest>(&*parsed))
    return capabilities(req, *caps, ctx, respond);
  if (const auto* g = std::get_if<GetLegendGraphicRequest>(&*parsed))
    return legend(*g, req.header("if-none-match"), ctx, respond);
  if (const auto* f = std::get_if<GetFeatureInfoRequest>(&*parsed))
    return featureInfo(req, *f, ctx, respond);
  getMap(req, std::move(std::get<GetMapRequest>(*parsed)), ctx, respond);
}

// ---- GetCapabilities ----------------------------------------------------------------------------

void WmsFrontEnd::capabilities(const HttpRequest& req,
                               const GetCapabilitiesRequest& caps,
                               const WmsErrorContext& ctx,
                               const Responder& respond) const {
  if (auto e = checkUpdateSequence(caps.updateSequence, fe_.updateSequence))
    return exception(ctx, *e, respond);
  const std::string xml = capabilitiesXml(caps.version, capabilitiesModel(req));
  HttpResponse r = HttpResponse::text(
      200, caps.version == WmsVersion::V111 ? "application/vnd.ogc.wms_xml" : "text/xml", xml);
  fe_.common(r);
  char etag[24];
  std::snprintf(
      etag, sizeof etag, "\"%016llx\"", static_cast<unsigned long long>(stableHash64(xml)));
  r.setHeader("ETag", etag);
  fe_.cacheHeaders(r, std::chrono::seconds(60), {}, false, capabilitiesKeys());
  if (ifNoneMatchHits(req.header("if-none-match"), etag)) {
    r.status = 304;
    r.body.clear();
  }
  respond(std::move(r));
}

CapabilitiesModel WmsFrontEnd::capabilitiesModel(const HttpRequest& req) const {
  CapabilitiesModel m;
  m.title = fe_.options.title;
  m.abstract = "A WMS and NASA World Wind tile cache (tellus).";
  m.onlineResource = fe_.baseUrl(req) + "/wms?";
  std::vector<std::string> formats;
  const auto add = [&formats](std::string f) {
    if (std::find(formats.begin(), formats.end(), f) == formats.end())
      formats.push_back(std::move(f));
  };
  // The list is service-wide: every layer answers every format (heights as a grey picture,
  // imagery as its luminance in heights; docs/CONFIG.md, "WMS"). The layers' own formats first
  // (a client that takes the first one gets cached tiles as they are), then the rest.
  for (const auto& l : fe_.tiles.layers())
    add(l.dataset.mimeType);
  for (const MapFormat f :
       {MapFormat::Jpeg, MapFormat::Png, MapFormat::Png8, MapFormat::Bil16, MapFormat::Tiff})
    add(std::string(toString(f)));
  // Values as Float32 BIL: offered when a layer's values are Float32 (only those layers answer it).
  const auto& layers = fe_.tiles.layers();
  if (std::any_of(layers.begin(), layers.end(), [](const LayerSpec& l) {
        return l.values && l.values->format.encoding == values::Encoding::Float32;
      }))
    add(std::string(toString(MapFormat::Bil32)));
  m.getMapFormats = formats;
  // GetFeatureInfo is offered when a layer is queryable (a value or elevation layer).
  const auto& all = fe_.tiles.layers();
  if (std::any_of(all.begin(), all.end(), [](const LayerSpec& l) { return l.values.has_value(); }))
    for (const InfoFormat f : {InfoFormat::Text,
                               InfoFormat::Html,
                               InfoFormat::Json,
                               InfoFormat::Gml,
                               InfoFormat::GmlXml})
      m.getFeatureInfoFormats.emplace_back(toString(f));
  // GetLegendGraphic (PNG) is declared when a layer has a style with a legend (a colour map).
  if (std::any_of(all.begin(), all.end(), [](const LayerSpec& l) {
        return l.values.has_value() && !l.values->styles.empty();
      }))
    m.getLegendGraphicFormats.emplace_back("image/png");
  m.updateSequence = fe_.updateSequence;
  m.lastUpdate = fe_.lastUpdate;
  m.maxWidth = fe_.options.limits.maxWidth;
  m.maxHeight = fe_.options.limits.maxHeight;
  for (const auto& l : fe_.tiles.layers()) {
    CapabilitiesLayer c;
    if (!isEarthBody(l.dataset.body)) {
      // A body without a known IAU code has no CRS to be named by: World Wind tiles only.
      const auto b = bodyCrs(l.dataset.body);
      if (!b) continue;
      c.iauCode = b->iauCode;
    }
    c.name = l.name;
    c.title = l.title.empty() ? l.name : l.title;
    c.abstract = l.abstract;
    c.bbox = l.dataset.grid.sector;
    describeStyles(l, m.onlineResource, c);
    c.queryable = l.values.has_value();
    c.timeValues = l.timeValues;
    c.timePeriod = l.timePeriod;
    c.timeDefault = l.timeDefault;
    c.opaque = l.dataset.mimeType == "image/jpeg";
    // Since when this layer's tiles are what they are: World Wind Java drops its own cached
    // tiles older than this, so it must not move with every restart (only with a new definition).
    const UnixMillis since = fe_.tiles.layerSince(l.name);
    c.lastUpdateMillis = since > 0 ? since : fe_.startedMillis;
    m.layers.push_back(std::move(c));
  }
  return m;
}

// ---- GetMap -------------------------------------------------------------------------------------

WmsFrontEnd::MapKind WmsFrontEnd::mapKind(MapFormat format,
                                          const std::vector<std::string>& names,
                                          const std::vector<std::string>& styles) const {
  MapKind k;
  bool allElevation = !names.empty();
  bool noDataSet = false;
  bool coloured = false;
  for (std::size_t i = 0; i < names.size(); ++i) {
    const LayerSpec* l = fe_.tiles.layer(names[i]);
    allElevation = allElevation && l && l->elevation;
    if (l && l->elevation && !noDataSet) {
      k.noData = l->noData;
      noDataSet = true;
    }
    if (l && drawnInColour(*l, i < styles.size() ? std::string_view(styles[i]) : ""))
      coloured = true;
  }
  // A layer drawn with a colour map is a picture: the map is heights only when no layer is,
  // except in BIL, which is only ever heights.
  k.heights = mapIsHeights(format, allElevation) && (!coloured || format == MapFormat::Bil16);
  k.values = format == MapFormat::Bil32;
  for (const std::string& n : names) {
    const LayerSpec* l = fe_.tiles.layer(n);
    if (!k.values || !l || !l->values || !l->values->format.noData) continue;
    const values::ValueFormat& f = l->values->format;
    k.valueNoData = static_cast<float>(*f.noData * f.scale + f.offset);
    break;
  }
  return k;
}

bool WmsFrontEnd::drawnInColour(const LayerSpec& l, std::string_view style) const {
  const auto map = styleOf(l, style);
  return map ? *map != nullptr : l.values.has_value();
}

void WmsFrontEnd::getMap(const HttpRequest& req,
                         GetMapRequest&& m,
                         const WmsErrorContext& ctx,
                         const Responder& respond) {
  // Every layer first: known, style, time. Imagery and heights mix: the format says what the
  // map is (mapIsHeights), and each layer is drawn as that (MapComposer).
  auto layers = mapLayers(m, ctx, respond);
  if (!layers) return;
  const MapKind kind = mapKind(m.mapFormat, m.layers, m.styles);
  // In a heights map (BIL) an elevation layer is its heights, whatever its style; in a map of
  // values (BIL32), every layer its values.
  for (ComposeLayer& l : *layers)
    if ((kind.heights && l.layer->elevation) || kind.values) l.colourMap = nullptr;
  if (sendOneTile(req, m, *layers, kind, ctx, respond)) return;
  // Any other box, size, format or several layers: composed from the tiles.
  if (static_cast<std::int64_t>(m.width) * m.height > fe_.options.maxMapPixels) {
    return exception(ctx,
                     OgcException{std::string(ogc::kInvalidParameterValue),
                                  "WIDTH",
                                  "the map has more than " +
                                      std::to_string(fe_.options.maxMapPixels) + " pixels"},
                     respond);
  }
  compose(req, m, std::move(*layers), kind, ctx, respond);
}

std::optional<std::vector<ComposeLayer>> WmsFrontEnd::mapLayers(const GetMapRequest& m,
                                                                const WmsErrorContext& ctx,
                                                                const Responder& respond) const {
  std::vector<ComposeLayer> layers;
  for (std::size_t k = 0; k < m.layers.size(); ++k) {
    const LayerSpec* l = fe_.tiles.layer(m.layers[k]);
    if (!l) {
      exception(ctx,
                OgcException{
                    std::string(ogc::kLayerNotDefined), "LAYERS", "no layer '" + m.layers[k] + "'"},
                respond);
      return std::nullopt;
    }
    const auto colourMap = styleOf(*l, m.styles[k]);
    if (!colourMap) {
      exception(ctx, colourMap.error(), respond);
      return std::nullopt;
    }
    if (m.mapFormat == MapFormat::Bil32 &&
        !(l->values && l->values->format.encoding == values::Encoding::Float32)) {
      exception(ctx,
                OgcException{std::string(ogc::kInvalidFormat),
                             "FORMAT",
                             "application/bil32 is a map of Float32 values: layer '" + l->name +
                                 "' has none"},
                respond);
      return std::nullopt;
    }
    auto time = FrontEnd::resolveTime(*l, m.time);
    if (!time) {
      exception(ctx, time.error(), respond);
      return std::nullopt;
    }
    layers.push_back(ComposeLayer{
        l, std::move(*time), m.opacities.empty() ? l->opacity : m.opacities[k], *colourMap});
  }
  return layers;
}

bool WmsFrontEnd::sendOneTile(const HttpRequest& req,
                              GetMapRequest& m,
                              const std::vector<ComposeLayer>& layers,
                              const MapKind& kind,
                              const WmsErrorContext& ctx,
                              const Responder& respond) {
  // One layer, its own format (as what it is: heights as heights), exactly one tile: the cached
  // file itself (the fast path).
  const LayerSpec* l = layers.front().layer;
  if (layers.size() != 1 || layers.front().colourMap != nullptr || kind.heights != l->elevation ||
      !(m.opacities.empty() || m.opacities.front() >= 1.0) || m.crs == kWebMercator)
    return false;
  std::optional<TileKey> key;
  if (m.format == l->dataset.mimeType && // a values format is a value layer's own
      !(kind.values && l->values->format.byteOrder != values::ByteOrder::Little))
    key = fe_.tiles.grid(l->name)->keyForBbox(m.bbox, m.width, m.height);
  // Else exactly one tile of another layer of the same upstream data in its own format: that tile
  // (a layer on CesiumJS's grid beside World Wind's serves CesiumJS's GetMaps of either name as
  // tiles, issue 29, whether the client asks for that layer's format or this one's), the first
  // such layer in the configuration's order. Never a value layer's.
  for (const LayerSpec& o : fe_.tiles.layers()) {
    if (key || kind.values) break;
    if (!sameUpstreamData(o, *l) || o.dataset.mimeType != m.format) continue;
    if ((key = fe_.tiles.grid(o.name)->keyForBbox(m.bbox, m.width, m.height))) l = &o;
  }
  if (!key) return false;
  const FetchGate gate = fe_.gateFor(req);
  fe_.tiles.getTile(
      l->name,
      layers.front().time,
      *key,
      [this,
       v = FrontEnd::Validators(req),
       l,
       m = std::move(m),
       kind,
       ctx,
       time = layers.front().time,
       level = key->level,
       respond](TileAnswer&& a) {
        fe_.countTile(l, a);
        const std::string keys = layerKeys(l->name, time, level);
        if (a.kind == TileAnswer::Kind::Tile)
          return fe_.sendTile(v, std::move(a), *l, keys, respond);
        if (a.kind == TileAnswer::Kind::Absent) {
          if (a.origin == TileOrigin::Offline &&
              fe_.options.offlineResponse == FrontEndOptions::OfflineResponse::Exception) {
            return exception(
                ctx, OgcException{std::string(ogc::kNoApplicableCode), "", a.message}, respond);
          }
          // No tile there: an empty map, not an error.
          return emptyImage(m, kind, a.message, a.origin, keys, respond);
        }
        exception(ctx,
                  OgcException{std::string(ogc::kNoApplicableCode), "", a.message},
                  respond,
                  FrontEnd::temporary(a.failure, a.retryAfterSeconds));
      },
      gate);
  return true;
}

void WmsFrontEnd::compose(const HttpRequest& req,
                          const GetMapRequest& m,
                          std::vector<ComposeLayer>&& layers,
                          const MapKind& kind,
                          const WmsErrorContext& ctx,
                          const Responder& respond) {
  ComposeRequest cr;
  cr.layers = std::move(layers);
  cr.bbox = mapBoxOf(m);
  cr.width = m.width;
  cr.height = m.height;
  cr.format = m.mapFormat;
  cr.heights = kind.heights;
  cr.noData = kind.noData;
  cr.values = kind.values;
  cr.valueNoData = kind.valueNoData;
  cr.transparent = m.transparent;
  cr.bgcolor = m.bgcolor;
  cr.ifNoneMatch = std::string(req.header("if-none-match"));
  // The map's surrogate keys (each layer, each time) and shared-cache lifetime (the shortest
  // ttl of its layers; 0 when none expires).
  std::string keys = "tellus";
  std::chrono::milliseconds ttl{0};
  std::chrono::seconds maxAge{86400 * 365};
  for (const ComposeLayer& l : cr.layers) {
    maxAge = std::min(maxAge, l.layer->maxAge);
    keys += " " + layerKey(l.layer->name);
    if (!l.time.empty()) keys += " " + layerKey(l.layer->name, l.time);
    if (l.layer->ttl.count() > 0 && (ttl.count() == 0 || l.layer->ttl < ttl)) ttl = l.layer->ttl;
  }
  cr.fetchBudget = fe_.gateFor(req).budget;
  cr.client = req.remoteAddress;
  auto started = fe_.composer.compose(
      std::move(cr),
      [this](const LayerSpec& layer, const TileAnswer& a) { fe_.countTile(&layer, a); },
      [this, ctx, keys = std::move(keys), ttl, maxAge, respond](ComposedMap&& map) {
        fe_.metrics.composedTiles(map.decodedTiles,
                                  map.tiles > map.decodedTiles ? map.tiles - map.decodedTiles : 0);
        fe_.metrics.composedTexels(
            map.outputTexels, map.upstreamTexels, map.cachedTexels, map.joinedTexels);
        if (map.kind == ComposedMap::Kind::Error) {
          return exception(ctx,
                           OgcException{std::string(ogc::kNoApplicableCode), "", map.message},
                           respond,
                           FrontEnd::temporary(map.failure, map.retryAfterSeconds));
        }
        HttpResponse r;
        fe_.common(r);
        r.setHeader("ETag", map.etag);
        // A map of stale tiles, or with stand-ins or holes (MapRender shortened its max-age), is
        // kept briefly.
        const bool provisional =
            (map.origin != TileOrigin::Hit && map.origin != TileOrigin::Miss) ||
            map.maxAgeSeconds < maxAge.count();
        fe_.cacheHeaders(r, std::chrono::seconds(map.maxAgeSeconds), ttl, provisional, keys);
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

// ---- exceptions ---------------------------------------------------------------------------------

void WmsFrontEnd::exception(const WmsErrorContext& ctx,
                            const OgcException& raw,
                            const Responder& respond) const {
  const OgcException e{
      raw.code, FrontEnd::clientMessage(raw.locator), FrontEnd::clientMessage(raw.message)};
  if (ctx.exceptions != GetMapRequest::Exceptions::Xml && ctx.width > 0 && ctx.height > 0) {
    const std::string text = ctx.exceptions == GetMapRequest::Exceptions::InImage
                                 ? sanitizeForClient(e.code + ": " + e.message)
                                 : std::string();
    // The image the map would have been: a styled value layer's is a picture (mapKind).
    const MapKind kind = mapKind(ctx.mapFormat, ctx.layers, ctx.styles);
    if (auto img = blankMap(ctx.mapFormat,
                            kind.heights,
                            ctx.width,
                            ctx.height,
                            ctx.bgcolor,
                            ctx.transparent,
                            text,
                            kind.noData,
                            kind.valueNoData)) {
      HttpResponse r;
      fe_.common(r);
      r.status = 200;
      r.setHeader("Content-Type", std::string(contentTypeOf(ctx.mapFormat)));
      r.setHeader("Cache-Control", "no-store"); // an error, drawn: never kept as the map
      r.body = std::move(*img);
      return respond(std::move(r));
    }
  }
  const FormattedResponse f = formatWmsException(ctx.version, e, fe_.options.exceptionsHttpStatus);
  auto r = HttpResponse::text(f.httpStatus, f.contentType, f.body);
  fe_.common(r);
  r.setHeader("Cache-Control", std::string(kNoStore)); // with status 200 too: never the answer
  respond(std::move(r));
}

void WmsFrontEnd::exception(const WmsErrorContext& ctx,
                            const OgcException& e,
                            const Responder& respond,
                            std::optional<FrontEnd::Temporary> temporaryFailure) const {
  if (!temporaryFailure) return exception(ctx, e, respond);
  // exception() answers before it returns: the references outlive the call.
  exception(ctx, e, [&](HttpResponse&& r) {
    FrontEnd::markTemporary(r, *temporaryFailure);
    respond(std::move(r));
  });
}

void WmsFrontEnd::emptyImage(const GetMapRequest& m,
                             const MapKind& kind,
                             std::string_view why,
                             TileOrigin origin,
                             const std::string& keys,
                             const Responder& respond) const {
  auto img = blankMap(m.mapFormat,
                      kind.heights,
                      m.width,
                      m.height,
                      m.bgcolor,
                      m.transparent,
                      {},
                      kind.noData,
                      kind.valueNoData);
  if (!img) {
    WmsErrorContext ctx;
    ctx.version = m.version;
    return exception(
        ctx, OgcException{std::string(ogc::kNoApplicableCode), "", std::string(why)}, respond);
  }
  HttpResponse r;
  fe_.common(r);
  r.setHeader("Content-Type", std::string(contentTypeOf(m.mapFormat)));
  r.setHeader("X-Cache", toString(origin));
  fe_.shortLived(r, keys);
  r.body = std::move(*img);
  respond(std::move(r));
}

} // namespace tellus
