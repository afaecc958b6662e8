// TileService: one tile rendered from a local raster or fetched, revalidated and checked.

#include "tiles/TileServiceImpl.hpp"

#include <tellus/proxy/TileValidation.hpp>

namespace tellus {

void TileService::Impl::renderLocal(const FlightKey& fk,
                                    const LayerSpec& l,
                                    const TileGrid& g,
                                    const std::string& folder,
                                    std::optional<CacheLookup> stale) {
  workers->post([this, fk, &l, &g, folder, stale = std::move(stale)]() mutable {
    const auto& src = rasters.at(l.upstream);
    auto bytes = src.renderTile(requestSector(l, g, fk.key),
                                g.spec().tileWidth,
                                g.spec().tileHeight,
                                l.dataset.mimeType,
                                l.noData);
    if (!bytes) {
      if (stale) {
        land(fk, staleTile(std::move(*stale), folder, fk.key));
      } else {
        land(fk, error("cannot render the tile: " + bytes.error()));
      }
      return;
    }
    store(fk, folder, std::move(*bytes), freshMeta(l));
  });
}

void TileService::Impl::fetchRemote(const FlightKey& fk,
                                    const LayerSpec& l,
                                    const UpstreamSpec& u,
                                    const TileGrid& g,
                                    const std::string& folder,
                                    std::string time,
                                    std::optional<CacheLookup> stale) {
  if (l.wmts && wmtsComposed(*l.wmts, fk.key)) {
    composeRemote(fk, l, u, g, folder, time, std::move(stale));
    return;
  }
  if (u.type == UpstreamSpec::Type::Wms && isWholeBox(l)) {
    // A cap in bands, a merged node at the texels east-west it needs (CapBands.hpp): each
    // stretched back to the image's width.
    const Sector box = requestSector(l, g, fk.key);
    const int tw = g.spec().tileWidth, th = g.spec().tileHeight;
    auto bands = isWholeRow(l) ? capBands(box, tw, th)
                               : std::vector{CapBand{box, wholeSpanTexelWidth(box, tw, th), th, 0}};
    if (bands.size() > 1 || bands.front().width < tw) {
      fetchBands(fk, l, u, g, folder, time, std::move(stale), std::move(bands));
      return;
    }
  }
  FetchRequest req;
  req.upstream = u.name;
  req.url = upstreamUrl(u, l, requestSector(l, g, fk.key), fk.key, time);
  if (req.url.empty()) { // a WMTS tile outside the upstream's matrix: there is none to fetch
    land(fk, absent(TileOrigin::Miss, "the upstream has no tile here"));
    return;
  }
  if (stale) {
    req.ifNoneMatch = stale->meta.etag;
    req.ifModifiedSince = stale->meta.lastModified;
  }
  fetches.fetch_add(1);
  fetcher.fetch(std::move(req),
                [weak = weak_from_this(), fk, &l, &g, folder, stale = std::move(stale)](
                    FetchResult&& r) mutable {
                  // The fetcher thread only hands over: validation and the cache write run on a
                  // worker. A service already destroyed has no one left to answer.
                  const auto self = weak.lock();
                  if (!self) return;
                  self->workers->post([im = self.get(),
                                       fk,
                                       &l,
                                       &g,
                                       folder,
                                       stale = std::move(stale),
                                       r = std::move(r)]() mutable {
                    im->onFetched(fk, l, g, folder, std::move(stale), std::move(r));
                  });
                });
}

void TileService::Impl::onFetched(const FlightKey& fk,
                                  const LayerSpec& l,
                                  const TileGrid& g,
                                  const std::string& folder,
                                  std::optional<CacheLookup> stale,
                                  FetchResult&& r) {
  auto serveStale = [&] {
    if (!stale) return false;
    land(fk, staleTile(std::move(*stale), folder, fk.key));
    return true;
  };
  if (!r) {
    if (serveStale()) return;
    land(fk, fetchFailure(l.upstream, r.error()));
    return;
  }
  FetchResponse& resp = *r;
  if (resp.status == 304 && stale) {
    // The same bytes: a new expiry, the same version. Its fetched-at (the tile's Last-Modified
    // and part of its ETag, and what a local tier's copy is checked against) stays, so that the
    // clients, a CDN and the other instances' copies revalidating it find it unchanged.
    TileMeta m = freshMeta(l);
    if (stale->meta.fetchedAt != 0) m.fetchedAt = stale->meta.fetchedAt;
    m.etag = resp.etag.empty() ? stale->meta.etag : resp.etag;
    m.lastModified = resp.lastModified.empty() ? stale->meta.lastModified : resp.lastModified;
    (void)cache.revalidated(fk.dataset, fk.key, m);
    land(fk,
         tile(TileOrigin::Hit,
              std::move(stale->bytes),
              stale->meta.contentType,
              m.fetchedAt,
              folder,
              fk.key,
              std::move(stale->file)));
    return;
  }
  if (noSuchTile(resp.status)) {
    (void)cache.putAbsent(fk.dataset, fk.key, nowMillis() + options.absentRetry.count());
    land(fk, absent(TileOrigin::Miss, "the upstream has no tile here"));
    return;
  }
  if (resp.status != 200) {
    if (serveStale()) return;
    land(fk, error("the upstream answered HTTP " + std::to_string(resp.status)));
    return;
  }
  if (auto ok = validateTile(resp, l.dataset.mimeType, g.spec().tileWidth, g.spec().tileHeight);
      !ok) {
    // Never cached: an error page, a ServiceException, a truncated or wrong-sized image.
    if (serveStale()) return;
    land(fk, error("the upstream did not send a tile: " + ok.error()));
    return;
  }
  TileMeta m = freshMeta(l);
  m.etag = resp.etag;
  m.lastModified = resp.lastModified;
  store(fk, folder, std::move(resp.body), std::move(m));
}

} // namespace tellus
