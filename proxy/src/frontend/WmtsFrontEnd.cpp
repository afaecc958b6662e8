// WMTS 1.0.0 (`/wmts?SERVICE=WMTS&...`, `/wmts/1.0.0/...`): GetCapabilities, and GetTile checked
// (layer, style, format, tile matrix set, matrix, row and column, time) and answered by the kind
// of its tile matrix set: the layer's own World Wind grid as the cached file (what /wwtile sends,
// rows flipped), the composed sets in WmtsComposed.cpp. Errors are OWS 1.1 exception reports.
#include "frontend/FrontEnd.hpp"

#include <tellus/cache/TilePath.hpp>
#include <tellus/proxy/Query.hpp>

#include <algorithm>
#include <cstdio>

namespace tellus {

namespace {

OgcException invalid(std::string_view locator, std::string message) {
  return OgcException{std::string(ogc::kInvalidParameterValue), std::string(locator), message};
}

bool iequalsAscii(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           const auto lower = [](char c) { return c >= 'A' && c <= 'Z' ? char(c - 'A' + 'a') : c; };
           return lower(x) == lower(y);
         });
}

/** Whether a layer's tiles can be composed into the other sets: a picture or heights format the
 * WMS composition makes, and no value layer (whose maps need a style). */
bool composable(const LayerSpec& l) {
  return !l.values && parseMapFormat(l.dataset.mimeType).has_value();
}

} // namespace

WmtsFrontEnd::WmtsFrontEnd(FrontEnd& fe) : fe_(fe) {}

const std::vector<WmtsFrontEnd::LayerSets>& WmtsFrontEnd::layerSets() const {
  std::call_once(setsOnce_, [this] {
    std::int32_t quadLevels = 0, mercatorLevels = 0;
    for (const LayerSpec& l : fe_.tiles.layers()) {
      LayerSets ls;
      ls.layer = &l;
      const GridSpec& g = l.dataset.grid;
      if (!isEarthBody(l.dataset.body)) {
        // Another body: only its own grid, in its IAU CRS; one the table does not know has no
        // CRS to be named by and is not served here (World Wind tiles only).
        const auto body = bodyCrs(l.dataset.body);
        if (!body) continue;
        ls.sets.push_back(bodyWorldWindMatrixSet(l.name, g, l.firstLevel, *body));
        layers_.push_back(std::move(ls));
        continue;
      }
      ls.sets.push_back(worldWindMatrixSet(l.name, g, l.firstLevel));
      if (composable(l)) {
        for (const WmtsSetKind k :
             {WmtsSetKind::WorldCRS84Quad, WmtsSetKind::GoogleMapsCompatible}) {
          const std::int32_t n = composedLevels(k, g);
          ls.sets.push_back(composedMatrixSet(k, g.sector, n));
          auto& most = k == WmtsSetKind::WorldCRS84Quad ? quadLevels : mercatorLevels;
          most = std::max(most, n);
        }
      }
      layers_.push_back(std::move(ls));
    }
    if (quadLevels > 0)
      composedDefinitions_.push_back(
          composedMatrixSet(WmtsSetKind::WorldCRS84Quad, Sector{}, quadLevels));
    if (mercatorLevels > 0)
      composedDefinitions_.push_back(
          composedMatrixSet(WmtsSetKind::GoogleMapsCompatible, Sector{}, mercatorLevels));
  });
  return layers_;
}

void WmtsFrontEnd::handle(const HttpRequest& req, const Responder& respond) {
  std::expected<WmtsRequest, OgcException> parsed;
  if (req.path == "/wmts" || req.path == "/wmts/") {
    if (auto quick =
            parseWmtsKvpQuery(req.query, fe_.options.maxParamBytes, fe_.options.maxQueryBytes)) {
      parsed = std::move(*quick);
    } else {
      auto params = parseQuery(req.query, fe_.options.maxParamBytes, fe_.options.maxQueryBytes);
      if (!params) return exception(invalid("", params.error()), respond);
      parsed = parseWmtsKvp(*params);
    }
  } else if (req.path.starts_with("/wmts/1.0.0/")) {
    parsed =
        parseWmtsRest(std::string_view(req.path).substr(std::string_view("/wmts/1.0.0/").size()));
    if (!parsed) return exception(parsed.error(), respond, 404);
  } else {
    return exception(
        invalid("", "not a WMTS resource: /wmts? (KVP) or /wmts/1.0.0/ (RESTful)"), respond, 404);
  }
  if (!parsed) return exception(parsed.error(), respond);
  if (std::holds_alternative<WmtsGetCapabilitiesRequest>(*parsed))
    return capabilities(req, respond);
  getTile(req, std::get<WmtsGetTileRequest>(*parsed), respond);
}

void WmtsFrontEnd::capabilities(const HttpRequest& req, const Responder& respond) const {
  WmtsCapabilitiesModel m;
  m.title = fe_.options.title;
  m.abstract = "A WMTS of the layers of a WMS and NASA World Wind tile cache (tellus).";
  m.baseUrl = fe_.baseUrl(req);
  for (const LayerSets& ls : layerSets()) {
    const LayerSpec& l = *ls.layer;
    WmtsLayerInfo info;
    info.identifier = l.name;
    info.title = l.title.empty() ? l.name : l.title;
    info.abstract = l.abstract;
    info.bbox = l.dataset.grid.sector;
    info.format = l.dataset.mimeType;
    info.extension = l.dataset.extension.empty() ? extensionForMimeType(l.dataset.mimeType)
                                                 : l.dataset.extension;
    info.timeValues = l.timeValues;
    info.timePeriod = l.timePeriod;
    info.timeDefault = l.timeDefault;
    if (!isEarthBody(l.dataset.body)) info.bodyCrs = ls.sets.front().crs;
    for (const WmtsTileMatrixSet& s : ls.sets)
      info.sets.push_back(&s);
    m.sets.push_back(&ls.sets.front());
    m.layers.push_back(std::move(info));
  }
  for (const WmtsTileMatrixSet& s : composedDefinitions_)
    m.sets.push_back(&s);
  const std::string xml = wmtsCapabilitiesXml(m);
  HttpResponse r = HttpResponse::text(200, "application/xml", xml);
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

void WmtsFrontEnd::getTile(const HttpRequest& req,
                           const WmtsGetTileRequest& t,
                           const Responder& respond) {
  const auto& all = layerSets();
  const auto ls = std::find_if(
      all.begin(), all.end(), [&](const LayerSets& s) { return s.layer->name == t.layer; });
  if (ls == all.end()) return exception(invalid("Layer", "no layer '" + t.layer + "'"), respond);
  const LayerSpec& l = *ls->layer;
  if (!t.style.empty() && t.style != "default")
    return exception(invalid("Style", "the layer's one style is 'default'"), respond);
  const std::string ext =
      l.dataset.extension.empty() ? extensionForMimeType(l.dataset.mimeType) : l.dataset.extension;
  if (t.extension.empty() ? !iequalsAscii(t.format, l.dataset.mimeType) : t.extension != ext)
    return exception(
        invalid("Format", "the layer's tiles are " + l.dataset.mimeType + " (." + ext + ")"),
        respond);
  const auto set = std::find_if(ls->sets.begin(), ls->sets.end(), [&](const WmtsTileMatrixSet& s) {
    return s.identifier == t.tileMatrixSet;
  });
  if (set == ls->sets.end())
    return exception(invalid("TileMatrixSet",
                             "layer '" + l.name + "' has no tile matrix set '" +
                                 t.tileMatrixSet.substr(0, 64) + "'"),
                     respond);
  const auto matrix = checkWmtsTile(*set, t.tileMatrix, t.row, t.col);
  if (!matrix) return exception(matrix.error(), respond);
  auto time = FrontEnd::resolveTime(l, t.time ? std::string_view(*t.time) : std::string_view());
  if (!time) {
    // WMTS has no dimension exceptions: a missing or unknown time is a parameter's value.
    const bool missing = time.error().code == ogc::kMissingDimensionValue;
    return exception(OgcException{std::string(missing ? ogc::kMissingParameterValue
                                                      : ogc::kInvalidParameterValue),
                                  "Time",
                                  time.error().message},
                     respond);
  }
  const WmtsTileMatrix& m = set->matrices[*matrix];
  switch (set->kind) {
  case WmtsSetKind::WorldWind:
    return worldWindTile(
        req, l, worldWindKeyOf(*set, *matrix, t.row, t.col), std::move(*time), respond);
  case WmtsSetKind::WorldCRS84Quad:
  case WmtsSetKind::GoogleMapsCompatible:
    return composedTile(req,
                        l,
                        set->kind,
                        m,
                        static_cast<std::int32_t>(*matrix),
                        t.row,
                        t.col,
                        std::move(*time),
                        static_cast<std::int32_t>(set->matrices.size()),
                        respond);
  }
}

void WmtsFrontEnd::worldWindTile(const HttpRequest& req,
                                 const LayerSpec& l,
                                 const TileKey& key,
                                 std::string time,
                                 const Responder& respond) {
  fe_.tiles.getTile(
      l.name,
      time,
      key,
      [this, v = FrontEnd::Validators(req), l = &l, time, level = key.level, respond](
          TileAnswer&& a) {
        fe_.countTile(l, a);
        const std::string keys = layerKeys(l->name, time, level);
        if (a.kind == TileAnswer::Kind::Tile)
          return fe_.sendTile(v, std::move(a), *l, keys, respond);
        tileFailure(a, keys, respond);
      },
      fe_.gateFor(req));
}

void WmtsFrontEnd::tileFailure(const TileAnswer& a,
                               const std::string& keys,
                               const Responder& respond) const {
  const OgcException e{std::string(ogc::kNoApplicableCode), "", a.message};
  if (a.kind == TileAnswer::Kind::Absent) {
    // No tile there (the upstream has none): 404, which WMTS clients draw as empty.
    return exception(
        e,
        [&](HttpResponse&& r) {
          r.setHeader("X-Cache", toString(a.origin));
          fe_.shortLived(r, keys);
          respond(std::move(r));
        },
        404);
  }
  exception(e, respond, 502, FrontEnd::temporary(a.failure, a.retryAfterSeconds));
}

void WmtsFrontEnd::exception(const OgcException& raw,
                             const Responder& respond,
                             int status,
                             std::optional<FrontEnd::Temporary> temporary) const {
  const OgcException e{
      raw.code, FrontEnd::clientMessage(raw.locator), FrontEnd::clientMessage(raw.message)};
  auto r = HttpResponse::text(status != 0 ? status : wmtsExceptionHttpStatus(e.code),
                              "application/xml",
                              wmtsExceptionXml(e));
  fe_.common(r);
  if (temporary)
    FrontEnd::markTemporary(r, *temporary);
  else
    r.setHeader("Cache-Control", "no-store");
  respond(std::move(r));
}

} // namespace tellus
