// WMTS tiles of the composed tile matrix sets, WorldCRS84Quad and GoogleMapsCompatible: composed
// from the layer's tiles by the WMS composition (MapComposer; a GoogleMapsCompatible tile's rows
// evenly in Mercator y, as an EPSG:3857 GetMap's) and kept in the cache as tiles of a dataset of
// their own (`<layer>.WorldCRS84Quad`, `<layer>.GoogleMapsCompatible`: composedCacheGrid), so the
// next request is a cached file.
#include "frontend/FrontEnd.hpp"

#include <tellus/cache/TileCache.hpp>
#include <tellus/cache/TilePath.hpp>
#include <tellus/proxy/MapBox.hpp>

#include <cstdio>

namespace tellus {

namespace {

std::string quotedHash(std::string_view text) {
  char etag[24];
  std::snprintf(
      etag, sizeof etag, "\"%016llx\"", static_cast<unsigned long long>(stableHash64(text)));
  return etag;
}

/** A composed tile's surrogate keys: its layer's (and time's), and its own dataset's (and time's,
 * which `tellus cache prune` of that dataset purges) and level's
 * (`layer:<layer>.WorldCRS84Quad/<level>`). */
std::string
composedKeys(const LayerSpec& l, WmtsSetKind kind, const std::string& time, std::int32_t level) {
  const std::string set =
      l.name + "." +
      std::string(kind == WmtsSetKind::GoogleMapsCompatible ? kGoogleMapsCompatible
                                                            : kWorldCrs84Quad);
  std::string k = layerKeys(l.name, time) + " " + layerKey(set);
  if (!time.empty()) k += " " + layerKey(set, time);
  return k + " " + layerKey(set) + "/" + std::to_string(level);
}

} // namespace

std::optional<std::pair<DatasetId, std::string>> WmtsFrontEnd::composedDataset(
    const LayerSpec& l, WmtsSetKind kind, const std::string& time, std::int32_t levels) {
  const std::string name =
      l.name + "." +
      std::string(kind == WmtsSetKind::GoogleMapsCompatible ? kGoogleMapsCompatible
                                                            : kWorldCrs84Quad);
  const std::lock_guard lock(datasetsMutex_);
  const auto k = std::pair{name, time};
  if (const auto it = datasets_.find(k); it != datasets_.end()) return it->second;
  DatasetSpec spec;
  spec.server = l.dataset.server;
  spec.name = name;
  spec.grid = composedCacheGrid(kind, levels);
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

void WmtsFrontEnd::composedTile(const HttpRequest& req,
                                const LayerSpec& l,
                                WmtsSetKind kind,
                                const WmtsTileMatrix& m,
                                std::int32_t level,
                                std::int64_t row,
                                std::int64_t col,
                                std::string time,
                                std::int32_t levels,
                                const Responder& respond) {
  // Exactly one tile of this layer or another of the same upstream data, on a grid that lines up
  // with WorldCRS84Quad (CesiumJS's geographic grid: 180-degree roots of 256 px): that tile, not
  // a composed copy of it (issue 29; WmsFrontEnd::sendOneTile does the same for GetMaps).
  if (kind == WmtsSetKind::WorldCRS84Quad) {
    const Sector box = wmtsTileBox(m, row, col);
    for (const LayerSpec& o : fe_.tiles.layers()) {
      if ((o.name != l.name && !sameUpstreamData(o, l)) || o.dataset.mimeType != l.dataset.mimeType)
        continue;
      if (const auto k = fe_.tiles.grid(o.name)->keyForBbox(box, m.tileWidth, m.tileHeight))
        return worldWindTile(req, o, *k, std::move(time), respond);
    }
  }
  const TileKey key = crs84QuadCacheKey(level, row, col);
  const auto ds = composedDataset(l, kind, time, levels);
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
      return fe_.sendTile(
          FrontEnd::Validators(req), std::move(a), l, composedKeys(l, kind, time, level), respond);
    }
  }
  const MapFormat format = *parseMapFormat(l.dataset.mimeType);
  ComposeRequest cr;
  cr.layers.push_back(ComposeLayer{&l, time, 1.0, nullptr});
  const Sector box = wmtsTileBox(m, row, col);
  cr.bbox = kind == WmtsSetKind::GoogleMapsCompatible ? mercatorBox(box) : MapBox(box);
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
      [this,
       v = FrontEnd::Validators(req),
       l = &l,
       ds,
       key,
       keys = composedKeys(l, kind, time, level),
       respond](ComposedMap&& map) {
        fe_.metrics.composedTiles(map.decodedTiles,
                                  map.tiles > map.decodedTiles ? map.tiles - map.decodedTiles : 0);
        fe_.metrics.composedTexels(
            map.outputTexels, map.upstreamTexels, map.cachedTexels, map.joinedTexels);
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
        if (!ds || !whole) return fe_.sendTile(v, std::move(a), *l, keys, respond, !whole);
        // Kept, then answered (a client that has the answer finds the tile kept), on a writer:
        // the composer's worker goes on to the next map while this one's fsync runs.
        fe_.writers.post([fe = &fe_, v, l, ds, key, keys, respond, a = std::move(a)]() mutable {
          TileMeta meta;
          meta.contentType = a.contentType;
          meta.etag = a.etag;
          meta.fetchedAt = a.fetchedAt;
          if (l->ttl.count() > 0) meta.expiresAt = a.fetchedAt + l->ttl.count();
          (void)fe->tiles.cache().put(ds->first, key, a.bytes, meta); // not kept: made again
          fe->sendTile(v, std::move(a), *l, keys, respond);
        });
      });
  if (!started)
    exception(OgcException{std::string(ogc::kNoApplicableCode), "", started.error()}, respond);
}

} // namespace tellus
