// WMS for value layers (ValueLayer.hpp): the colour map of a STYLES entry, the styles and legends
// of the capabilities, GetLegendGraphic (the SLD profile's PNG legend) and GetFeatureInfo (the
// value at a pixel, sampled from the layer's tile through tellus::values).
#include "frontend/FrontEnd.hpp"

#include <tellus/cache/TilePath.hpp>
#include <tellus/codec/Png.hpp>
#include <tellus/proxy/Compose.hpp>
#include <tellus/proxy/FeatureInfo.hpp>
#include <tellus/values/Legend.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <mutex>

namespace tellus {

namespace {

constexpr std::int32_t kLegendWidth = 256; ///< the default legend (LegendURL's width x height)
constexpr std::int32_t kLegendHeight = 56;

OgcException ogcError(std::string_view code, std::string_view locator, std::string message) {
  return OgcException{std::string(code), std::string(locator), std::move(message)};
}

/** The pixel's centre in lon/lat, as the map samples it (the map's rows from the north; a Web
 * Mercator map's row at the inverse Mercator of its centre's y); `mapped` false past the Mercator
 * square (the map draws nothing there; the latitude is still the inverse Mercator's). */
struct PixelCentre {
  double lon, lat;
  bool mapped;
};
PixelCentre pixelCentre(const GetMapRequest& m, std::int32_t i, std::int32_t j) {
  const MapBox b = mapBoxOf(m);
  const double lon = b.west + (i + 0.5) * (b.east - b.west) / m.width;
  const double lat = b.rowLatitude(j, m.height);
  if (!std::isnan(lat)) return {lon, lat, true};
  return {
      lon, mercator::latitudeOfY(b.northY - (j + 0.5) * ((b.northY - b.southY) / m.height)), false};
}

/** The value at (lon, lat) of a tile's bytes: values::decode, then values::sample at the point's
 * place in the tile (bilinear between texel centres, clamped at the tile's edges). */
std::optional<float> valueInTile(const TileAnswer& a,
                                 const ValueLayerSpec& spec,
                                 const TileGrid& grid,
                                 const TileKey& key,
                                 double lon,
                                 double lat) {
  std::optional<std::vector<std::byte>> bytes = a.file ? a.file->readAll() : a.bytes;
  if (!bytes) return std::nullopt;
  const GridSpec& g = grid.spec();
  auto raster = values::decode(*bytes, spec.format, g.tileWidth, g.tileHeight);
  if (!raster) return std::nullopt;
  const Sector s = grid.sectorOf(key);
  const double x = (lon - s.west) / (s.east - s.west) * raster->width;
  const double y = (s.north - lat) / (s.north - s.south) * raster->height;
  const float v = values::sample(*raster, x, y);
  if (std::isnan(v)) return std::nullopt;
  return v;
}

/** The answers of one GetFeatureInfo as its tiles arrive (on any thread); `finish` answers
 * once the last one is in. */
struct FeatureInfoGather {
  std::mutex mutex;
  std::vector<FeatureInfoValue> values;
  std::size_t pending = 1; // the launching loop holds one until it is done
  std::optional<OgcException> failure;
  std::optional<FrontEnd::Temporary> temporary;
  /** Answers; given the gather (not holding it: no cycle that would keep it alive). */
  std::function<void(const FeatureInfoGather&)> finish;

  void start() {
    const std::lock_guard lock(mutex);
    ++pending;
  }
  /** One answer in: the value of layer k (and the failure of its tile, if any). */
  void arrive(std::size_t k, std::optional<float> v, const TileAnswer& a) {
    {
      const std::lock_guard lock(mutex);
      values[k].value = v;
      if (a.kind == TileAnswer::Kind::Error && !failure) {
        failure = ogcError(ogc::kNoApplicableCode, "", a.message);
        temporary = FrontEnd::temporary(a.failure, a.retryAfterSeconds);
      }
    }
    done();
  }
  void done() {
    bool last = false;
    {
      const std::lock_guard lock(mutex);
      last = --pending == 0;
    }
    if (last) finish(*this);
  }
};

/** Asks for the tile of queried layer k under the pixel (the level the map is drawn from) and
 * hands its value to `gather`; a pixel outside the layer is no data without asking. */
void fetchValue(FrontEnd& fe,
                const ComposeLayer& cl,
                const GetFeatureInfoRequest& f,
                std::size_t k,
                const std::shared_ptr<FeatureInfoGather>& gather,
                const FetchGate& gate) {
  const LayerSpec& l = *cl.layer;
  const TileGrid* grid = fe.tiles.grid(l.name);
  const auto [lon, lat, mapped] = pixelCentre(f.map, f.i, f.j);
  const Sector& sector = l.dataset.grid.sector;
  const bool global = sector.west <= -180.0 && sector.east >= 180.0;
  const double plon = global ? std::remainder(lon, 360.0) : lon;
  gather->values[k] = FeatureInfoValue{l.name, plon, lat, std::nullopt, l.values->format.unit};
  // The level the map draws the pixel's row from (a Web Mercator map's band of that row).
  std::int32_t level = 0;
  for (const ComposeBand& b : composeBands(*grid, mapBoxOf(f.map), f.map.width, f.map.height, 0)) {
    if (b.box.drawsRow(f.j)) level = b.level;
  }
  if (!mapped) return; // past the Mercator square: no data
  const auto key = grid->keyAt(lat, plon == 180.0 ? -180.0 : plon, level);
  if (!key) return;
  gather->start();
  fe.tiles.getTile(
      l.name,
      cl.time,
      *key,
      [&fe, gather, k, &l, grid, key = *key, plon, lat](TileAnswer&& a) {
        fe.countTile(&l, a);
        std::optional<float> v;
        if (a.kind == TileAnswer::Kind::Tile) v = valueInTile(a, *l.values, *grid, key, plon, lat);
        gather->arrive(k, v, a);
      },
      gate);
}

} // namespace

std::expected<const values::ColourMap*, OgcException>
WmsFrontEnd::styleOf(const LayerSpec& l, std::string_view style) const {
  const bool byDefault = style.empty() || style == "default";
  if (l.values) {
    if (byDefault) return values::findColourMap(l.values->defaultStyle); // null: as before
    if (l.values->offers(style)) return values::findColourMap(style);
  } else if (byDefault || style == l.dataset.style) {
    return nullptr;
  }
  return std::unexpected(
      ogcError(ogc::kStyleNotDefined,
               "STYLES",
               "layer '" + l.name + "' has no style '" + std::string(style) + "'"));
}

void WmsFrontEnd::describeStyles(const LayerSpec& l,
                                 const std::string& base,
                                 CapabilitiesLayer& c) const {
  if (!l.values) {
    if (!l.dataset.style.empty()) c.styles.push_back(l.dataset.style);
    return;
  }
  for (const std::string& name : l.values->styles) {
    const values::ColourMap* map = values::findColourMap(name);
    if (!map) continue;
    CapabilitiesStyle s;
    s.name = name;
    s.title = std::string(map->title) + (name == l.values->defaultStyle ? " (default)" : "");
    s.legendUrl = base + "SERVICE=WMS&REQUEST=GetLegendGraphic&VERSION=1.3.0&FORMAT=image/png" +
                  "&SLD_VERSION=1.1.0&LAYER=" + l.name + "&STYLE=" + name;
    s.legendWidth = kLegendWidth;
    s.legendHeight = kLegendHeight;
    // The default style first: clients that take the first style get the layer's default.
    if (name == l.values->defaultStyle)
      c.legendStyles.insert(c.legendStyles.begin(), std::move(s));
    else
      c.legendStyles.push_back(std::move(s));
  }
}

void WmsFrontEnd::legend(const GetLegendGraphicRequest& g,
                         std::string_view ifNoneMatch,
                         const WmsErrorContext& ctx,
                         const Responder& respond) const {
  WmsErrorContext c = ctx;
  c.version = g.version;
  const LayerSpec* l = fe_.tiles.layer(g.layer);
  if (!l)
    return exception(
        c, ogcError(ogc::kLayerNotDefined, "LAYER", "no layer '" + g.layer + "'"), respond);
  if (!l->values)
    return exception(c,
                     ogcError(ogc::kInvalidParameterValue,
                              "LAYER",
                              "layer '" + g.layer + "' has no legend (it is no value layer)"),
                     respond);
  auto map = styleOf(*l, g.style);
  if (map && *map == nullptr)
    map = std::unexpected(ogcError(ogc::kStyleNotDefined,
                                   "STYLE",
                                   "layer '" + g.layer +
                                       "' draws its default style without a "
                                       "colour map; name one of its styles in STYLE"));
  if (!map) {
    OgcException e = map.error();
    e.locator = "STYLE";
    return exception(c, e, respond);
  }
  const ValueLayerSpec& spec = *l->values;
  values::LegendOptions options;
  options.width = g.width > 0 ? g.width : kLegendWidth;
  options.height = g.height > 0 ? g.height : kLegendHeight;
  options.labels = !spec.rangeFromData;
  const std::string title = (l->title.empty() ? l->name : l->title) +
                            (spec.rangeFromData ? " (range from the data)" : "");
  auto image = values::renderLegend(spec.scale(**map), spec.format.unit, title, options);
  auto png = image ? codec::encodePng(image->width, image->height, 4, image->pixels.data())
                   : std::expected<codec::Bytes, std::string>(std::unexpected(image.error()));
  if (!png)
    return exception(
        c, ogcError(ogc::kNoApplicableCode, "", "cannot draw the legend: " + png.error()), respond);
  HttpResponse r;
  fe_.common(r);
  r.status = 200;
  r.setHeader("Content-Type", "image/png");
  fe_.cacheHeaders(r, l->maxAge, {}, false, layerKeys(l->name, {}));
  const std::string_view bytes(reinterpret_cast<const char*>(png->data()), png->size());
  char etag[24];
  std::snprintf(
      etag, sizeof etag, "\"%016llx\"", static_cast<unsigned long long>(stableHash64(bytes)));
  r.setHeader("ETag", etag);
  if (ifNoneMatchHits(ifNoneMatch, etag)) {
    r.status = 304;
  } else {
    r.body = std::move(*png);
  }
  respond(std::move(r));
}

void WmsFrontEnd::featureInfo(const HttpRequest& req,
                              const GetFeatureInfoRequest& f,
                              const WmsErrorContext& ctx,
                              const Responder& respond) {
  WmsErrorContext c = ctx;
  c.version = f.map.version;
  auto layers = mapLayers(f.map, c, respond); // known, style, time: as the map was asked
  if (!layers) return;
  std::vector<const ComposeLayer*> queried;
  for (const std::string& name : f.queryLayers) {
    const auto it = std::find_if(layers->begin(), layers->end(), [&](const ComposeLayer& cl) {
      return cl.layer->name == name;
    });
    if (!it->layer->values)
      return exception(c,
                       ogcError(ogc::kLayerNotQueryable,
                                "QUERY_LAYERS",
                                "layer '" + name + "' is not queryable (it is no value layer)"),
                       respond);
    if (std::find(queried.begin(), queried.end(), &*it) == queried.end()) queried.push_back(&*it);
  }
  auto gather = std::make_shared<FeatureInfoGather>();
  gather->values.resize(queried.size());
  gather->finish = [this, format = f.infoFormat, c, respond](const FeatureInfoGather& g) {
    if (g.failure) return exception(c, *g.failure, respond, g.temporary);
    auto r =
        HttpResponse::text(200, featureInfoContentType(format), featureInfoBody(format, g.values));
    fe_.common(r);
    r.setHeader("Cache-Control", "no-cache");
    respond(std::move(r));
  };
  const FetchGate gate = fe_.gateFor(req);
  for (std::size_t k = 0; k < queried.size(); ++k)
    fetchValue(fe_, *queried[k], f, k, gather, gate);
  gather->done(); // the launching loop's share
}

} // namespace tellus
