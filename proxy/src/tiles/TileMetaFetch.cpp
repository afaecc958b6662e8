// TileService: metatiles, several tiles of a WMS upstream fetched as one GetMap and split.

#include "tiles/TileServiceImpl.hpp"

#include <tellus/proxy/TileValidation.hpp>

#include <algorithm>

namespace tellus {

void TileService::Impl::getTiles(std::string_view layerName,
                                 std::string_view time,
                                 std::span<const TileKey> keys,
                                 TilesDone doneFn) {
  if (keys.empty()) return;
  const auto done = std::make_shared<TilesDone>(std::move(doneFn));
  auto waiter = [done](const TileKey& k) {
    return [done, k](TileAnswer&& a) { (*done)(k, std::move(a)); };
  };
  auto oneByOne = [&](std::span<const TileKey> ks) {
    for (const TileKey& k : ks)
      getTile(layerName, time, k, waiter(k));
  };
  const auto li = layerIndex.find(layerName);
  if (li == layerIndex.end()) return oneByOne(keys); // each answers "no layer"
  const LayerSpec& l = layers[li->second];
  const TileGrid& g = grids[li->second];
  const UpstreamSpec& u = upstreams.at(l.upstream);
  const bool oneLevel = std::all_of(
      keys.begin(), keys.end(), [&](const TileKey& k) { return k.level == keys[0].level; });
  if (keys.size() < 2 || !metaCapable(l, u) || !oneLevel || forcedOffline.load() ||
      !remoteReachable(u))
    return oneByOne(keys);
  std::pair<DatasetId, std::string> ds = defaultDatasets[li->second];
  if (!time.empty()) {
    auto found = dataset(l, time);
    if (!found) return oneByOne(keys); // each reports the error
    ds = std::move(*found);
  }
  const auto& [id, folder] = ds;
  std::vector<TileKey> owned = claimMissing(layerName, time, keys, g, id, folder, done);
  if (owned.empty()) return;
  fetchBlockUnderLease(std::move(owned), l, u, g, id, folder, std::string(time));
}

void TileService::Impl::missUnderMetaLease(const FlightKey& fk,
                                           const LayerSpec& l,
                                           const UpstreamSpec& u,
                                           const TileGrid& g,
                                           const std::string& folder,
                                           const std::string& time) {
  const TileBlock meta = metaTileOf(g, fk.key, u.metaTiles);
  const UnixMillis now = nowMillis();
  std::vector<TileKey> others;
  for (std::int64_t r = meta.row0; r < meta.row0 + meta.rows; ++r) {
    for (std::int64_t c = meta.col0; c < meta.col0 + meta.cols; ++c) {
      const TileKey k{fk.key.level, r, c};
      if (k != fk.key && g.isValid(k)) others.push_back(k);
    }
  }
  // One look at the index for the block's other tiles (peekMany), not one each.
  const auto known = cache.peekMany(fk.dataset, others);
  std::vector<TileKey> owned{fk.key};
  for (std::size_t i = 0; known && i < others.size(); ++i) {
    const TileKey& k = others[i];
    const CacheLookup& found = (*known)[i];
    const bool missing = found.kind != CacheLookup::Kind::Hit &&
                         !(found.kind == CacheLookup::Kind::Absent && found.retryAfter > now);
    if (!missing) continue;
    // Every missing tile is fetched, also one whose flight another request of this process
    // opened a moment ago: that request's own try waits for this lease, then finds its tile
    // stored (a tile left out would cost a second GetMap). A tile nobody asked for gets a flight
    // with no waiter, so that a request meanwhile joins it.
    (void)join(FlightKey{fk.dataset, k}, [](TileAnswer&&) {});
    owned.push_back(k);
  }
  fetchBlockUnderLease(std::move(owned), l, u, g, fk.dataset, folder, time);
}

void TileService::Impl::fetchBlockUnderLease(std::vector<TileKey> owned,
                                             const LayerSpec& l,
                                             const UpstreamSpec& u,
                                             const TileGrid& g,
                                             DatasetId id,
                                             const std::string& folder,
                                             const std::string& time) {
  if (!options.leases) return fetchBlock(std::move(owned), l, u, g, id, folder, time);
  const TileBlock meta = metaTileOf(g, owned.front(), u.metaTiles);
  const LeaseKey lease{folder, TileKey{meta.level, meta.row0, meta.col0}};
  auto hold = takeLease(lease, [owned, &l, &u, &g, id, folder, time](Impl& im) {
    std::vector<TileKey> left = owned;
    im.landCachedNow(left, id, folder);
    if (!left.empty()) im.fetchBlockUnderLease(std::move(left), l, u, g, id, folder, time);
  });
  if (!hold) return; // waiting
  if (*hold) {
    bool placed = false;
    {
      std::lock_guard lock(flightsMutex);
      for (const TileKey& k : owned) // a tile's own lease, if one is held, stays its flight's
        placed = heldLeases.try_emplace(FlightKey{id, k}, *hold).second || placed;
    }
    if (placed) hold->reset(); // its flights hold it: given back when the last of them lands
    // Another process may have stored some between our look and the lease.
    landCachedNow(owned, id, folder);
    if (owned.empty()) return;
  }
  fetchBlock(std::move(owned), l, u, g, id, folder, time);
}

std::vector<TileKey> TileService::Impl::claimMissing(std::string_view layerName,
                                                     std::string_view time,
                                                     std::span<const TileKey> keys,
                                                     const TileGrid& g,
                                                     DatasetId id,
                                                     const std::string& folder,
                                                     const std::shared_ptr<TilesDone>& done) {
  auto waiter = [done](const TileKey& k) {
    return [done, k](TileAnswer&& a) { (*done)(k, std::move(a)); };
  };
  const UnixMillis now = nowMillis();
  std::vector<TileKey> owned;
  for (const TileKey& k : keys) {
    if (k.level < 0 || k.level >= g.numLevels() || !g.isValid(k)) {
      getTile(layerName, time, k, waiter(k)); // answers "outside the layer's coverage"
      continue;
    }
    const auto known = cache.peek(id, k);
    const bool fromCache = !known || (known->kind == CacheLookup::Kind::Hit && !known->stale) ||
                           (known->kind == CacheLookup::Kind::Absent && known->retryAfter > now);
    if (fromCache) { // a hit, a remembered absence, or an index error: getTile answers
      getTile(layerName, time, k, waiter(k));
      continue;
    }
    // Missing or expired: ours to fetch unless a flight for it is already out (it answers).
    if (join(FlightKey{id, k}, waiter(k)) && !landIfCachedNow(FlightKey{id, k}, folder))
      owned.push_back(k);
  }
  return owned;
}

void TileService::Impl::fetchBlock(std::vector<TileKey> owned,
                                   const LayerSpec& l,
                                   const UpstreamSpec& u,
                                   const TileGrid& g,
                                   DatasetId id,
                                   const std::string& folder,
                                   std::string_view time) {
  const TileBlock block = boundingBlock(owned);
  const auto& spec = g.spec();
  const bool tooBig = static_cast<std::int64_t>(block.cols) * spec.tileWidth > 8192 ||
                      static_cast<std::int64_t>(block.rows) * spec.tileHeight > 8192;
  if (owned.size() == 1 || tooBig) {
    for (const TileKey& k : owned)
      fetchRemote(FlightKey{id, k}, l, u, g, folder, std::string(time), std::nullopt);
    return;
  }
  FetchRequest req;
  req.upstream = u.name;
  req.url = wmsUrl(
      u, l, blockSector(g, block), block.cols * spec.tileWidth, block.rows * spec.tileHeight, time);
  fetches.fetch_add(1);
  metaFetches.fetch_add(1);
  fetcher.fetch(std::move(req),
                [weak = weak_from_this(), owned = std::move(owned), block, &l, &g, id, folder](
                    FetchResult&& r) mutable {
                  const auto self = weak.lock();
                  if (!self) return;
                  self->workers->post([im = self.get(),
                                       owned = std::move(owned),
                                       block,
                                       &l,
                                       &g,
                                       id,
                                       folder,
                                       r = std::move(r)]() mutable {
                    im->onBlockFetched(owned, block, l, g, id, folder, std::move(r));
                  });
                });
}

void TileService::Impl::onBlockFetched(const std::vector<TileKey>& owned,
                                       const TileBlock& block,
                                       const LayerSpec& l,
                                       const TileGrid& g,
                                       DatasetId id,
                                       const std::string& folder,
                                       FetchResult&& r) {
  auto landAll = [&](const TileAnswer& a) {
    for (const TileKey& k : owned) {
      TileAnswer copy = a;
      land(FlightKey{id, k}, std::move(copy));
    }
  };
  if (!r) {
    landAll(fetchFailure(l.upstream, r.error()));
    return;
  }
  FetchResponse& resp = *r;
  if (noSuchTile(resp.status)) {
    for (const TileKey& k : owned)
      (void)cache.putAbsent(id, k, nowMillis() + options.absentRetry.count());
    landAll(absent(TileOrigin::Miss, "the upstream has no tile here"));
    return;
  }
  if (resp.status != 200) {
    landAll(error("the upstream answered HTTP " + std::to_string(resp.status)));
    return;
  }
  auto kind = validateImageResponse(resp, l.dataset.mimeType);
  if (!kind) {
    landAll(error("the upstream did not send a tile: " + kind.error()));
    return;
  }
  auto split = splitMetaTileLazily(
      resp.body, *kind, block.cols, block.rows, g.spec().tileWidth, g.spec().tileHeight);
  if (!split) {
    landAll(error("the upstream did not send a tile: " + split.error()));
    return;
  }
  resp.body = {}; // the metatile's bytes are no longer needed
  TileMeta m = freshMeta(l);
  // The metatile's ETag names another resource than any tile's GetMap: not kept. Its
  // Last-Modified is true of every tile in it.
  m.lastModified = resp.lastModified;
  // The first of `owned` is the tile a client asked for: stored first, it is answered, and under a
  // shared lease announced to the other instances (land), while the rest of its block is stored.
  // Tiles cut without decoding (JPEG): the rest on another task once the first is stored, their
  // files flushed together and their rows in one commit (storeMany), where a task each cost an
  // fsync each. Not before the first is stored: its fsync would then wait for their data in the
  // same journal commit (bench/RESULTS.md, issue 27).
  if (!split->decoded) {
    std::vector<FlightKey> rest;
    std::vector<std::vector<std::byte>> restBytes;
    for (std::size_t j = 1; j < owned.size(); ++j) {
      rest.push_back(FlightKey{id, owned[j]});
      restBytes.push_back(std::move(split->tiles[block.imageIndex(owned[j])]));
    }
    workers->post([this,
                   first = FlightKey{id, owned.front()},
                   bytes = std::move(split->tiles[block.imageIndex(owned.front())]),
                   rest = std::move(rest),
                   restBytes = std::move(restBytes),
                   folder,
                   m = std::move(m)]() mutable {
      auto notStored = put(first, bytes, m);
      workers->post(
          [this, rest = std::move(rest), restBytes = std::move(restBytes), folder, m]() mutable {
            storeMany(rest, folder, std::move(restBytes), m);
          });
      landStored(first, folder, std::move(bytes), std::move(m), std::move(notStored));
    });
    return;
  }
  // Decoded (PNG, a block not on JPEG blocks): each tile encoded and stored on its own task.
  for (const TileKey& k : owned) {
    workers->post([this,
                   fk = FlightKey{id, k},
                   folder,
                   m,
                   i = block.imageIndex(k),
                   decoded = split->decoded]() mutable {
      auto encoded = encodeMetaTilePart(*decoded, i);
      decoded.reset();
      if (!encoded)
        return land(fk, error("a tile of the metatile could not be encoded: " + encoded.error()));
      store(fk, folder, std::move(*encoded), std::move(m));
    });
  }
}

} // namespace tellus
