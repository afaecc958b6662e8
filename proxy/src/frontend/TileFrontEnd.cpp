// World Wind tiles (`/wwtile?T=&L=&X=&Y=`) and the static World Wind layout
// (`/tiles/<layer>/<level>/<row>/<row>_<col>.<ext>[?time=T]`): the cached file as it is, or 404
// when there is no such tile, 503/429 with Retry-After when it may come later, 502 when the
// upstream's answer was not a tile. `/tiles/` also serves a layer's whole polar rows and spans
// (`<layer>@caps`, `<layer>@span<k>`, issue 29) to a renderer's `--server` source; they are the
// layer's in everything but the tile (its time, counters and surrogate keys).
#include "frontend/FrontEnd.hpp"

#include <tellus/proxy/Query.hpp>

namespace tellus {

void TileFrontEnd::worldWind(const HttpRequest& req, const Responder& respond) {
  auto params = parseQuery(req.query, fe_.options.maxParamBytes, fe_.options.maxQueryBytes);
  if (!params) return respond(fe_.errorText(400, "bad query: " + params.error()));
  auto ww = parseWorldWindTile(*params);
  if (!ww) return respond(fe_.errorText(400, ww.error()));
  const LayerSpec* l = fe_.tiles.layer(ww->dataset);
  if (!l) return respond(fe_.plain(404, "no such layer\n"));
  serveTilePath(req, *l, ww->dataset, TileKey{ww->level, ww->row, ww->col}, respond);
}

void TileFrontEnd::staticTile(const HttpRequest& req, const Responder& respond) {
  const auto parsed =
      parseStaticTilePath(std::string_view(req.path).substr(std::string_view("/tiles/").size()));
  if (!parsed)
    return respond(
        fe_.plain(404, "not a tile path: /tiles/<layer>/<level>/<row>/<row>_<col>.<ext>\n"));
  const LayerSpec* l = fe_.tiles.layer(parsed->layer);
  if (!l) l = fe_.tiles.wholeBoxBase(parsed->layer);
  if (!l || parsed->extension != l->dataset.extension)
    return respond(fe_.plain(404, "no such layer\n"));
  // `?time=T` picks another time of a layer with a TIME dimension (the remote tile source of
  // the planet renderer uses it); validated as a WMS TIME is.
  std::string time;
  const std::string* timeOrDefault = nullptr; // the hot path (no query) allocates nothing
  if (!req.query.empty()) {
    auto params = parseQuery(req.query, fe_.options.maxParamBytes, fe_.options.maxQueryBytes);
    if (!params) return respond(fe_.errorText(400, "bad query: " + params.error()));
    if (const auto t = params->get("time")) {
      auto resolved = FrontEnd::resolveTime(*l, *t);
      if (!resolved) {
        return respond(fe_.errorText(400, resolved.error().code + ": " + resolved.error().message));
      }
      time = std::move(*resolved);
      timeOrDefault = &time;
    }
  }
  serveTilePath(req, *l, parsed->layer, parsed->key, respond, timeOrDefault);
}

void TileFrontEnd::serveTilePath(const HttpRequest& req,
                                 const LayerSpec& layer,
                                 const std::string& name,
                                 const TileKey& key,
                                 const Responder& respond,
                                 const std::string* time) {
  const std::string& t = time ? *time : layer.timeDefault;
  fe_.tiles.getTile(
      name,
      t,
      key,
      [this, v = FrontEnd::Validators(req), l = &layer, t, level = key.level, respond](
          TileAnswer&& a) {
        fe_.countTile(l, a);
        const std::string keys = layerKeys(l->name, t, level);
        if (a.kind == TileAnswer::Kind::Tile)
          return fe_.sendTile(v, std::move(a), *l, keys, respond);
        respond(tileError(a, keys));
      },
      fe_.gateFor(req));
}

HttpResponse TileFrontEnd::tileError(const TileAnswer& a, const std::string& keys) const {
  if (a.kind == TileAnswer::Kind::Absent) {
    auto r = fe_.errorText(404, a.message);
    r.setHeader("X-Cache", toString(a.origin));
    fe_.shortLived(r, keys);
    return r;
  }
  auto r = fe_.errorText(502, a.message);
  r.setHeader("X-Cache", toString(a.origin));
  if (const auto t = FrontEnd::temporary(a.failure, a.retryAfterSeconds))
    FrontEnd::markTemporary(r, *t);
  else
    r.setHeader("Cache-Control", "no-store");
  return r;
}

} // namespace tellus
