// WMTS tiles of the composed tile matrix sets. WorldCRS84Quad: composed from the layer's tiles by
// the WMS composition (MapComposer) and kept in the cache as tiles of a dataset of their own
// (`<layer>.WorldCRS84Quad`, a 180-degree, 256-px lat/long grid), so the next request is a cached
// file. GoogleMapsCompatible: a WMS GetMap of the tile's box in EPSG:3857 through WmsFrontEnd,
// its WMS exceptions turned into OWS ones.
#include "frontend/FrontEnd.hpp"

#include <tellus/cache/TileCache.hpp>
#include <tellus/cache/TilePath.hpp>
#include <tellus/proxy/Query.hpp>

#include <cstdio>

namespace tellus {

namespace {

std::string quotedHash(std::string_view text) {
  char etag[24];
  std::snprintf(
      etag, sizeof etag, "\"%016llx\"", static_cast<unsigned long long>(stableHash64(text)));
  return etag;
}

/** A query value: unreserved characters as they are, the rest %XX. */
std::string queryValue(std::string_view s) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string out;
  for (const char c : s) {
    const auto u = static_cast<unsigned char>(c);
    if ((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
        std::string_view("-._~:,").find(c) != std::string_view::npos) {
      out += c;
    } else {
      out += '%';
      out += kHex[u >> 4];
      out += kHex[u & 15];
    }
  }
  return out;
}

std::string unescapeXml(std::string_view s) {
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '&') {
      for (const auto& [entity, c] : {std::pair{"&amp;", '&'},
                                      std::pair{"&lt;", '<'},
                                      std::pair{"&gt;", '>'},
                                      std::pair{"&quot;", '"'},
                                      std::pair{"&apos;", '\''}}) {
        if (s.substr(i).starts_with(entity)) {
          out += c;
          i += std::string_view(entity).size() - 1;
          goto next;
        }
      }
    }
    out += s[i];
  next:;
  }
  return out;
}

/** The code and message of a WMS 1.3.0 ServiceExceptionReport (formatWmsException's). */
OgcException fromWmsException(std::string_view body) {
  OgcException e{std::string(ogc::kNoApplicableCode), "", "the map could not be made"};
  const auto at = body.find("<ServiceException");
  if (at == std::string_view::npos) return e;
  const auto open = body.find('>', at);
  const auto close = body.find("</ServiceException>", at);
  const auto code = body.find("code=\"", at);
  if (code != std::string_view::npos && code < open) {
    const auto end = body.find('"', code + 6);
    e.code = unescapeXml(body.substr(code + 6, end - code - 6));
  }
  if (open != std::string_view::npos && close != std::string_view::npos && open < close)
    e.message = unescapeXml(body.substr(open + 1, close - open - 1));
  // WMTS's codes pass; a WMS code (InvalidCRS, LayerNotDefined ...) says the composition could
  // not make this tile.
  if (e.code != ogc::kMissingParameterValue && e.code != ogc::kInvalidParameterValue &&
      e.code != ogc::kOperationNotSupported)
    e.code = ogc::kNoApplicableCode;
  return e;
}

} // namespace

std::optional<std::pair<DatasetId, std::string>>
WmtsFrontEnd::crs84QuadDataset(const LayerSpec& l, const std::string& time, std::int32_t levels) {
  const std::lock_guard lock(datasetsMutex_);
  const auto k = std::pair{l.name, time};
  if (const auto it = datasets_.find(k); it != datasets_.end()) return it->second;
  DatasetSpec spec;
  spec.server = l.dataset.server;
  spec.name = l.name + "." + std::string(kWorldCrs84Quad);
  spec.grid = GridSpec{Sector{}, 180.0, 256, 256, levels};
  spec.mimeType = l.dataset.mimeType;
  spec.extension =
      l.dataset.extension.empty() ? extensionForMimeType(l.dataset.mimeType) : l.dataset.extension;
  spec.time = time;
  TileCache& cache = fe_.tiles.cache();
  const auto id = cache.registerDataset(spec);
  if (!id) return std::nullopt; // a full disk: composed every time, not kept
  const auto info = cache.dataset(*id);
  if (!info) return std::nullopt;
  return datasets_.emplace(k, std::pair{*id, info->folder}).first->second;
}

void WmtsFrontEnd::crs84QuadTile(const HttpRequest& req,
                                 const LayerSpec& l,
                                 const WmtsTileMatrix& m,
                                 std::int32_t level,
                                 std::int64_t row,
                                 std::int64_t col,
                                 std::string time,
                                 std::int32_t levels,
                                 const Responder& respond) {
  const TileKey key = crs84QuadCacheKey(level, row, col);
  const auto ds = crs84QuadDataset(l, time, levels);
  TileCache& cache = fe_.tiles.cache();
  if (ds) {
    auto found = cache.openTile(ds->first, key);
    if (found && found->kind == CacheLookup::Kind::Hit && !found->stale) {
      TileAnswer a;
      a.kind = TileAnswer::Kind::Tile;
      a.origin = TileOrigin::Hit;
      a.file = std::move(found->file);
      a.contentType = std::move(found->meta.contentType);
      a.fetchedAt = found->meta.fetchedAt;
      a.etag = std::move(found->meta.etag);
      return fe_.sendTile(FrontEnd::Validators(req), std::move(a), l, respond);
    }
  }
  const MapFormat format = *parseMapFormat(l.dataset.mimeType);
  ComposeRequest cr;
  cr.layers.push_back(ComposeLayer{&l, time, 1.0, nullptr});
  cr.bbox = wmtsTileBox(m, row, col);
  cr.width = m.tileWidth;
  cr.height = m.tileHeight;
  cr.format = format;
  cr.heights = l.elevation && mapIsHeights(format, true);
  cr.noData = l.noData;
  cr.transparent = format != MapFormat::Jpeg; // outside the layer: transparent where it can be
  cr.fetchBudget = fe_.gateFor(req).budget;
  cr.client = req.remoteAddress;
  auto started = fe_.composer.compose(
      std::move(cr),
      [this](const LayerSpec& layer, const TileAnswer& a) { fe_.countTile(&layer, a); },
      [this, v = FrontEnd::Validators(req), l = &l, ds, key, respond](ComposedMap&& map) {
        fe_.metrics.composedTiles(map.decodedTiles,
                                  map.tiles > map.decodedTiles ? map.tiles - map.decodedTiles : 0);
        if (map.kind != ComposedMap::Kind::Map) {
          return exception(OgcException{std::string(ogc::kNoApplicableCode), "", map.message},
                           respond,
                           502,
                           FrontEnd::temporary(map.failure, map.retryAfterSeconds));
        }
        TileAnswer a;
        a.kind = TileAnswer::Kind::Tile;
        a.origin = map.origin;
        a.contentType = std::move(map.contentType);
        a.fetchedAt = Clock::system().now();
        a.bytes = std::move(map.bytes);
        const std::string folder = ds ? ds->second : std::string("-");
        a.etag = quotedHash(folder + "/" + std::to_string(key.level) + "/" +
                            std::to_string(key.row) + "/" + std::to_string(key.col) + "/" +
                            std::to_string(a.fetchedAt) + "/" + std::to_string(a.bytes.size()));
        // Kept only when made of tiles as they are: not stale, not offline, no coarser tile
        // standing in for a missing one.
        const bool whole = (a.origin == TileOrigin::Hit || a.origin == TileOrigin::Miss) &&
                           map.fallbackPixels == 0;
        if (ds && whole) {
          TileMeta meta;
          meta.contentType = a.contentType;
          meta.etag = a.etag;
          meta.fetchedAt = a.fetchedAt;
          if (l->ttl.count() > 0) meta.expiresAt = a.fetchedAt + l->ttl.count();
          (void)fe_.tiles.cache().put(ds->first, key, a.bytes, meta); // not kept: made again
        }
        fe_.sendTile(v, std::move(a), *l, respond);
      });
  if (!started)
    exception(OgcException{std::string(ogc::kNoApplicableCode), "", started.error()}, respond);
}

void WmtsFrontEnd::mercatorTile(const HttpRequest& req,
                                const LayerSpec& l,
                                const WmtsTileMatrix& m,
                                std::int64_t row,
                                std::int64_t col,
                                const std::string& time,
                                const Responder& respond) {
  const Sector box = wmtsTileBox(m, row, col);
  const auto format = parseMapFormat(l.dataset.mimeType);
  std::string query =
      "SERVICE=WMS&VERSION=1.3.0&REQUEST=GetMap&LAYERS=" + queryValue(l.name) +
      "&STYLES=&CRS=EPSG:3857&BBOX=" + formatCoordinate(box.west) + "," +
      formatCoordinate(box.south) + "," + formatCoordinate(box.east) + "," +
      formatCoordinate(box.north) + "&WIDTH=" + std::to_string(m.tileWidth) +
      "&HEIGHT=" + std::to_string(m.tileHeight) + "&FORMAT=" + queryValue(l.dataset.mimeType) +
      "&TRANSPARENT=" + (format == MapFormat::Jpeg ? "FALSE" : "TRUE") + "&EXCEPTIONS=XML";
  if (!time.empty()) query += "&TIME=" + queryValue(time);
  // Refused here as the WMS would refuse it (EPSG:3857 unknown to it: InvalidCRS), said in WMTS.
  const auto params = parseQuery(query, fe_.options.maxParamBytes, fe_.options.maxQueryBytes);
  if (params) {
    if (auto parsed = parseWms(*params, fe_.options.limits); !parsed) {
      return exception(OgcException{std::string(ogc::kNoApplicableCode),
                                    "TileMatrixSet",
                                    "GoogleMapsCompatible tiles are not composed here: " +
                                        parsed.error().message},
                       respond);
    }
  }
  HttpRequest wmsReq = req;
  wmsReq.path = "/wms";
  wmsReq.query = std::move(query);
  wmsReq.target = "/wms?" + wmsReq.query;
  wms_.handle(wmsReq, [this, respond](HttpResponse&& r) {
    std::string_view type;
    for (const auto& [k, v] : r.headers)
      if (k == "Content-Type") type = v;
    const bool xml = type.find("xml") != std::string_view::npos;
    if (r.status == 304 || (!xml && r.status == 200)) return respond(std::move(r));
    const std::string body(reinterpret_cast<const char*>(r.body.data()), r.body.size());
    std::optional<FrontEnd::Temporary> temporary;
    if (r.status == 503 || r.status == 429) {
      std::int64_t after = 1;
      for (const auto& [k, v] : r.headers)
        if (k == "Retry-After") after = std::max<std::int64_t>(1, std::atoll(v.c_str()));
      temporary = FrontEnd::Temporary{r.status, after};
    }
    exception(fromWmsException(body), respond, 0, temporary);
  });
}

} // namespace tellus
