// TileService: polar rows fetched whole (issue 29, docs/design/poles.md). A renderer's polar cap
// is a whole row of its level, 8 tiles wide in texels; where the upstream can make any box (a WMS,
// a local raster) the row is ONE request of its box at that size, kept as the tile (level, row, 0)
// of the dataset `<layer>@caps`, instead of up to 80 of the row's tiles. Likewise a merged row's
// node of k tiles is ONE request of its box at one tile's size, kept as the tile (level, row, col)
// of `<layer>@span<k>`, instead of up to 16 tiles shrunk into one. From a WMS, a cap is asked for
// in bands and a merged node at its own width, each only as wide as its parallels need
// (CapBands.hpp), and stretched back.

#include "tiles/TileServiceImpl.hpp"

#include <tellus/proxy/TileValidation.hpp>

namespace tellus {

std::optional<LayerSpec> TileService::Impl::wholeRowLayer(const LayerSpec& l,
                                                          const UpstreamSpec& u) {
  const bool anyBox = u.type == UpstreamSpec::Type::Wms || u.type == UpstreamSpec::Type::Local;
  const bool imagery = !l.elevation && !l.values &&
                       (l.dataset.mimeType == "image/jpeg" || l.dataset.mimeType == "image/png");
  const Sector& s = l.dataset.grid.sector;
  const bool polar = s.west == -180.0 && s.east == 180.0 && (s.north == 90.0 || s.south == -90.0);
  if (!anyBox || !imagery || !polar || l.wmts) return std::nullopt;
  LayerSpec c = l;
  c.name += kWholeRowLayerSuffix;
  c.dataset.name = c.name;
  c.dataset.grid.tileWidth *= kWholeRowWidthFactor;
  if (!TileGrid::create(c.dataset.grid)) return std::nullopt; // wider than any grid may be
  return c;
}

void TileService::Impl::fetchBands(const FlightKey& fk,
                                   const LayerSpec& l,
                                   const UpstreamSpec& u,
                                   const TileGrid& g,
                                   const std::string& folder,
                                   const std::string& time,
                                   std::optional<CacheLookup> stale,
                                   std::vector<CapBand> bands) {
  auto gather = std::make_shared<BandGather>();
  gather->bands = std::move(bands);
  gather->answers.resize(gather->bands.size());
  gather->left = gather->bands.size();
  gather->stale = std::move(stale);
  fetches.fetch_add(gather->bands.size());
  for (std::size_t i = 0; i < gather->bands.size(); ++i) {
    const CapBand& b = gather->bands[i];
    FetchRequest req;
    req.upstream = u.name;
    req.url = wmsUrl(u, l, b.box, b.width, b.height, time);
    fetcher.fetch(std::move(req),
                  [weak = weak_from_this(), gather, i, fk, &l, &g, folder](FetchResult&& r) {
                    {
                      std::lock_guard lock(gather->mutex);
                      gather->answers[i] = std::move(r);
                      if (--gather->left > 0) return;
                    }
                    const auto self = weak.lock();
                    if (!self) return;
                    self->workers->post([im = self.get(), gather, fk, &l, &g, folder] {
                      im->onBandsFetched(fk, l, g, folder, *gather);
                    });
                  });
  }
}

void TileService::Impl::onBandsFetched(const FlightKey& fk,
                                       const LayerSpec& l,
                                       const TileGrid& g,
                                       const std::string& folder,
                                       BandGather& gather) {
  std::vector<std::vector<std::byte>> images;
  images.reserve(gather.bands.size());
  for (std::size_t i = 0; i < gather.bands.size(); ++i) {
    FetchResult& r = *gather.answers[i];
    // A failure, an absence or an answer that is no image: the tile's answer. The image's size
    // is checked where it is decoded, once (composeBands), as a metatile's.
    if (!r || r->status != 200)
      return onFetched(fk, l, g, folder, std::move(gather.stale), std::move(r));
    if (auto ok = validateImageResponse(*r, l.dataset.mimeType); !ok) {
      if (gather.stale) return land(fk, staleTile(std::move(*gather.stale), folder, fk.key));
      return land(fk, error("the upstream did not send a tile: " + ok.error()));
    }
    images.push_back(std::move(r->body));
  }
  auto cap = composeBands(gather.bands,
                          images,
                          g.spec().tileWidth,
                          g.spec().tileHeight,
                          l.dataset.mimeType,
                          /*wrap=*/isWholeRow(l));
  if (!cap) { // a band of another size, or that does not decode
    if (gather.stale) return land(fk, staleTile(std::move(*gather.stale), folder, fk.key));
    return land(fk, error("the upstream did not send a tile: " + cap.error()));
  }
  store(fk, folder, std::move(*cap), freshMeta(l));
}

bool TileService::Impl::isPolarRowKey(const TileGrid& g, const TileKey& k) noexcept {
  if (k.level < 0 || k.level >= g.numLevels() || k.col != 0 || !g.isValid(k)) return false;
  const Sector s = g.sectorOf(k);
  return (k.row == 0 && s.south == -90.0) || (k.row == g.rowCount(k.level) - 1 && s.north == 90.0);
}

bool TileService::Impl::isSpanKey(const TileGrid& g, const TileKey& k, std::int64_t span) noexcept {
  if (k.level < 0 || k.level >= g.numLevels() || k.col < 0 || k.col % span != 0) return false;
  if (span >= g.colCount(k.level) || k.col + span > g.colCount(k.level)) return false;
  return g.isValid(k) && g.isValid({k.level, k.row, k.col + span - 1});
}

const LayerSpec* TileService::wholeBoxBase(std::string_view name) const noexcept {
  if (!impl_->capIndex.contains(name)) return nullptr;
  const auto base = wholeBoxLayer(name);
  return base ? layer(*base) : nullptr;
}

bool TileService::wholePolarRows(std::string_view layer) const {
  return impl_->capIndex.contains(std::string(layer) + std::string(kWholeRowLayerSuffix));
}

} // namespace tellus
