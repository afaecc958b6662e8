// TileService: WMTS tiles of levels no upstream matrix lines up with, composed of its tiles.

#include "tiles/TileServiceImpl.hpp"

#include <algorithm>

namespace tellus {

void TileService::Impl::composeRemote(const FlightKey& fk,
                                      const LayerSpec& l,
                                      const UpstreamSpec& u,
                                      const TileGrid& g,
                                      const std::string& folder,
                                      const std::string& time,
                                      std::optional<CacheLookup> stale) {
  const Sector sector = g.sectorOf(fk.key);
  const auto sources =
      wmtsSourceTiles(*l.wmts, fk.key, sector, g.spec().tileWidth, g.spec().tileHeight, time);
  if (sources.empty()) {
    land(fk, absent(TileOrigin::Miss, "the upstream has no tile here"));
    return;
  }
  auto gather = std::make_shared<WmtsGather>();
  gather->left = sources.size();
  gather->stale = std::move(stale);
  for (const auto& src : sources)
    gather->tiles.push_back(WmtsFetchedTile{src, {}});
  fetches.fetch_add(sources.size());
  for (std::size_t i = 0; i < sources.size(); ++i) {
    FetchRequest req;
    req.upstream = u.name;
    req.url = sources[i].url;
    fetcher.fetch(
        std::move(req),
        [weak = weak_from_this(), gather, i, fk, &l, &g, folder, sector](FetchResult&& r) {
          {
            std::lock_guard lock(gather->mutex);
            if (r && r->status == 200)
              gather->tiles[i].bytes = std::move(r->body);
            else if (!(r && noSuchTile(r->status)) && !gather->failure)
              gather->failure = std::move(r);
            if (--gather->left > 0) return;
          }
          const auto self = weak.lock();
          if (!self) return;
          self->workers->post([im = self.get(), gather, fk, &l, &g, folder, sector] {
            im->onComposedFetched(fk, l, g, folder, sector, *gather);
          });
        });
  }
}

void TileService::Impl::onComposedFetched(const FlightKey& fk,
                                          const LayerSpec& l,
                                          const TileGrid& g,
                                          const std::string& folder,
                                          const Sector& sector,
                                          WmtsGather& gather) {
  if (gather.failure)
    return onFetched(fk, l, g, folder, std::move(gather.stale), std::move(*gather.failure));
  FetchResponse resp;
  const bool none = std::all_of(
      gather.tiles.begin(), gather.tiles.end(), [](const auto& t) { return t.bytes.empty(); });
  if (none) {
    resp.status = 404;
    return onFetched(fk, l, g, folder, std::move(gather.stale), FetchResult(std::move(resp)));
  }
  auto composed = composeWmtsTile(*l.wmts,
                                  fk.key,
                                  sector,
                                  g.spec().tileWidth,
                                  g.spec().tileHeight,
                                  gather.tiles,
                                  l.dataset.mimeType);
  if (!composed) {
    land(fk, error("the upstream's tiles could not be composed: " + composed.error()));
    return;
  }
  resp.status = 200;
  resp.contentType = l.dataset.mimeType;
  resp.body = std::move(*composed);
  onFetched(fk, l, g, folder, std::move(gather.stale), FetchResult(std::move(resp)));
}

} // namespace tellus
