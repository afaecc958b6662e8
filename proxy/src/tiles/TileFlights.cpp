// TileService: the cache-through lookup, single flight, the answers and the stores.

#include "tiles/TileServiceImpl.hpp"

#include <tellus/proxy/Log.hpp>

#include <cstdio>

namespace tellus {

namespace {

std::string
strongEtag(const std::string& folder, const TileKey& k, UnixMillis fetchedAt, std::size_t size) {
  char buf[80];
  std::snprintf(
      buf,
      sizeof buf,
      "\"%016llx-%llx-%zx\"",
      static_cast<unsigned long long>(stableHash64(folder + "/" + tileRelativePath(k, ""))),
      static_cast<unsigned long long>(fetchedAt),
      size);
  return buf;
}

} // namespace

std::expected<std::pair<DatasetId, std::string>, std::string>
TileService::Impl::dataset(const LayerSpec& l, std::string_view time) {
  std::lock_guard lock(datasetsMutex);
  const auto key = std::make_pair(l.name, std::string(time));
  if (const auto it = datasets.find(key); it != datasets.end()) return it->second;
  DatasetSpec spec = l.dataset;
  spec.time = std::string(time);
  auto id = cache.registerDataset(spec);
  if (!id && id.error().code == CacheErrc::DiskFull) {
    // Served from the upstream, not stored; registered by a later request once there is room.
    noticeStoreState(&id.error());
    const std::string folder = datasetFolder(spec);
    return std::make_pair(unregisteredId(folder), folder);
  }
  if (!id) return std::unexpected("cache: " + id.error().message);
  const auto value = std::make_pair(*id, datasetFolder(spec));
  datasets.emplace(key, value);
  return value;
}

void TileService::Impl::noticeStoreState(const CacheError* refusal) {
  const bool writable = refusal == nullptr && cache.storeStatus().writable;
  if (storingLogged.exchange(writable) == writable) return;
  const std::string root = cache.root().string();
  const auto space = cache.diskSpace();
  const std::string freeBytes = space ? std::to_string(space->freeBytes) : "?";
  const std::string freeInodes = space ? std::to_string(space->freeInodes) : "?";
  if (!writable) {
    logger().log(LogLevel::Error,
                 "cache",
                 "the cache is full: tiles are served but not stored until there is room",
                 {{"root", root},
                  {"free_bytes", freeBytes},
                  {"free_inodes", freeInodes},
                  {"error", refusal ? std::string_view(refusal->message) : "disk full"}});
  } else {
    logger().log(LogLevel::Warn,
                 "cache",
                 "the cache stores tiles again",
                 {{"root", root}, {"free_bytes", freeBytes}, {"free_inodes", freeInodes}});
  }
}

bool TileService::Impl::join(const FlightKey& k, Done done) {
  std::lock_guard lock(flightsMutex);
  auto [it, inserted] = flights.try_emplace(k);
  it->second.push_back(std::move(done));
  if (inserted) openFlights.fetch_add(1, std::memory_order_relaxed);
  return inserted;
}

bool TileService::Impl::joinUnderWay(const FlightKey& k, Done& done) {
  // A stale count only sends the caller the long way (a lookup, then joinGated).
  if (openFlights.load(std::memory_order_relaxed) == 0) return false;
  std::lock_guard lock(flightsMutex);
  const auto it = flights.find(k);
  if (it == flights.end()) return false;
  it->second.push_back(std::move(done));
  return true;
}

TileService::Impl::Joined
TileService::Impl::joinGated(const FlightKey& k, Done& done, FetchGate gate) {
  std::lock_guard lock(flightsMutex);
  if (const auto it = flights.find(k); it != flights.end()) {
    it->second.push_back(std::move(done));
    return {};
  }
  if (gate.budget) {
    if (auto wait = gate.budget->take(gate.client)) return {false, wait};
  }
  flights[k].push_back(std::move(done));
  openFlights.fetch_add(1, std::memory_order_relaxed);
  return {true, std::nullopt};
}

bool TileService::Impl::landIfCachedNow(const FlightKey& fk, const std::string& folder) {
  std::vector<TileKey> one{fk.key};
  landCachedNow(one, fk.dataset, folder);
  return one.empty();
}

void TileService::Impl::landCachedNow(std::vector<TileKey>& keys,
                                      DatasetId id,
                                      const std::string& folder) {
  if (id < 0 || keys.empty()) return;
  auto found = cache.openTiles(id, keys);
  if (!found) return; // the index did not answer: none is known to be stored
  auto fresh = [](const CacheLookup& f) { return f.kind == CacheLookup::Kind::Hit && !f.stale; };
  std::vector<FlightKey> stored;
  for (std::size_t i = 0; i < keys.size(); ++i)
    if (fresh((*found)[i])) stored.push_back(FlightKey{id, keys[i]});
  releaseLeasesOf(stored); // before their clients are answered, as storeMany does
  std::erase_if(keys, [&, i = std::size_t{0}](const TileKey& k) mutable {
    CacheLookup& f = (*found)[i++];
    if (!fresh(f)) return false;
    land(FlightKey{id, k},
         tile(TileOrigin::Hit,
              {},
              std::move(f.meta.contentType),
              f.meta.fetchedAt,
              folder,
              k,
              std::move(f.file)));
    return true;
  });
}

void TileService::Impl::releaseLeasesOf(std::span<const FlightKey> fks) {
  if (fks.empty()) return; // a miss's look at the cache, most often: no lock taken
  std::vector<std::shared_ptr<LeaseHold>> holds;
  {
    std::lock_guard lock(flightsMutex);
    for (const FlightKey& fk : fks) {
      if (const auto h = heldLeases.find(fk); h != heldLeases.end()) {
        holds.push_back(std::move(h->second));
        heldLeases.erase(h);
      }
    }
  }
  holds.clear(); // a lease no other flight holds is given back here
}

void TileService::Impl::land(const FlightKey& k, TileAnswer&& answer) {
  std::vector<Done> waiters;
  std::shared_ptr<LeaseHold> lease;
  {
    std::lock_guard lock(flightsMutex);
    if (const auto h = heldLeases.find(k); h != heldLeases.end()) {
      lease = std::move(h->second);
      heldLeases.erase(h);
    }
    if (const auto it = flights.find(k); it != flights.end()) {
      waiters = std::move(it->second);
      flights.erase(it);
      openFlights.fetch_sub(1, std::memory_order_relaxed);
    }
  }
  // A metatile's lease is shared by its tiles' flights: while others still hold it, the first tile
  // stored (the one a client asked for: it is stored first) is announced, so that other processes
  // waiting for it need not wait for the whole block. Only the first: each announcement wakes every
  // waiter to look up all of its tiles again, which cost more than it saved when every tile was
  // announced (bench/RESULTS.md, issue 27).
  if (lease && lease.use_count() > 1 && answer.kind == TileAnswer::Kind::Tile &&
      !answer.notStored && !lease->announced.exchange(true))
    lease->leases->progress(lease->key);
  lease.reset(); // the last flight holding it: released (the tile is stored), waiters wake
  // The first waiter started the fetch; the others joined it in flight.
  for (std::size_t i = 0; i + 1 < waiters.size(); ++i) {
    TileAnswer copy = answer;
    copy.joinedInFlight = i > 0;
    waiters[i](std::move(copy));
  }
  answer.joinedInFlight = waiters.size() > 1;
  if (!waiters.empty()) waiters.back()(std::move(answer));
}

TileAnswer TileService::Impl::unavailable(const std::string& upstream, std::string message) const {
  TileAnswer a = error(std::move(message));
  a.failure = TileAnswer::Failure::Unavailable;
  const auto wait = std::chrono::ceil<std::chrono::seconds>(fetcher.unavailableFor(upstream));
  a.retryAfterSeconds = std::max<std::int64_t>(kMinRetryAfterSeconds, wait.count());
  return a;
}

TileAnswer TileService::Impl::fetchFailure(const std::string& upstream, const FetchError& e) const {
  const std::string what = e.code == FetchErrc::HttpError && e.httpStatus > 0
                               ? "HTTP " + std::to_string(e.httpStatus)
                               : std::string(toString(e.code));
  switch (e.code) {
  case FetchErrc::Timeout:
  case FetchErrc::Connect:
  case FetchErrc::CircuitOpen:
  case FetchErrc::Truncated:
  case FetchErrc::Throttled:
  case FetchErrc::Cancelled:
    return unavailable(upstream, "the upstream is unavailable (" + what + ")");
  case FetchErrc::HttpError:
    if (e.httpStatus >= 500 || e.httpStatus == 429)
      return unavailable(upstream, "the upstream is unavailable (" + what + ")");
    break;
  default:
    break;
  }
  return error("the upstream failed (" + what + ")");
}

TileAnswer TileService::Impl::tile(TileOrigin origin,
                                   std::vector<std::byte> bytes,
                                   std::string contentType,
                                   UnixMillis fetchedAt,
                                   const std::string& folder,
                                   const TileKey& key,
                                   std::shared_ptr<const TileFile> file) {
  TileAnswer a;
  a.kind = TileAnswer::Kind::Tile;
  a.origin = origin;
  a.etag = strongEtag(
      folder, key, fetchedAt, file ? static_cast<std::size_t>(file->size()) : bytes.size());
  a.bytes = std::move(bytes);
  a.file = std::move(file);
  a.contentType = std::move(contentType);
  a.fetchedAt = fetchedAt;
  return a;
}

TileAnswer
TileService::Impl::staleTile(CacheLookup&& old, const std::string& folder, const TileKey& key) {
  return tile(TileOrigin::Stale,
              std::move(old.bytes),
              std::move(old.meta.contentType),
              old.meta.fetchedAt,
              folder,
              key,
              std::move(old.file));
}

namespace {

CacheError unregisteredDataset() {
  return CacheError{CacheErrc::DiskFull,
                    "the cache is full: the layer's dataset could not be registered"};
}

} // namespace

void TileService::Impl::store(const FlightKey& fk,
                              const std::string& folder,
                              std::vector<std::byte> bytes,
                              TileMeta meta) {
  std::optional<CacheError> notStored = put(fk, bytes, meta);
  landStored(fk, folder, std::move(bytes), std::move(meta), std::move(notStored));
}

std::optional<CacheError> TileService::Impl::put(const FlightKey& fk,
                                                 std::span<const std::byte> bytes,
                                                 const TileMeta& meta) {
  if (fk.dataset < 0) return unregisteredDataset();
  if (auto stored = cache.put(fk.dataset, fk.key, bytes, meta); !stored)
    return std::move(stored.error());
  return std::nullopt;
}

void TileService::Impl::storeMany(const std::vector<FlightKey>& fks,
                                  const std::string& folder,
                                  std::vector<std::vector<std::byte>> bytes,
                                  const TileMeta& meta) {
  if (fks.empty()) return;
  std::optional<CacheError> notStored;
  if (fks.front().dataset < 0) {
    notStored = unregisteredDataset();
  } else {
    std::vector<TileCache::TileBytes> tiles;
    tiles.reserve(fks.size());
    for (std::size_t i = 0; i < fks.size(); ++i)
      tiles.push_back(TileCache::TileBytes{fks[i].key, bytes[i]});
    if (auto stored = cache.putMany(fks.front().dataset, tiles, meta); !stored)
      notStored = std::move(stored.error());
  }
  // Their lease back before their clients here are answered: most of a burst's clients wait in
  // other instances, woken by the release (bench/RESULTS.md, issue 27).
  releaseLeasesOf(fks);
  for (std::size_t i = 0; i < fks.size(); ++i)
    landStored(fks[i], folder, std::move(bytes[i]), meta, notStored);
}

void TileService::Impl::landStored(const FlightKey& fk,
                                   const std::string& folder,
                                   std::vector<std::byte> bytes,
                                   TileMeta meta,
                                   std::optional<CacheError> notStored) {
  if (notStored && notStored->code == CacheErrc::DiskFull) {
    refusedStores.fetch_add(1, std::memory_order_relaxed);
    noticeStoreState(&*notStored); // logged once per change, not once per tile
  } else if (notStored) {
    logger().log(LogLevel::Error,
                 "cache",
                 "cannot cache a tile; it is served but not kept",
                 {{"error", notStored->message}});
  } else {
    noticeStoreState(nullptr);
  }
  if (notStored) {
    const UnixMillis now = nowMillis();
    if (meta.fetchedAt == 0) meta.fetchedAt = now;
    unstored.keep(folder, fk.key, bytes, meta, now);
  } else {
    unstored.stored(folder, fk.key, false);
  }
  TileAnswer a =
      tile(TileOrigin::Miss, std::move(bytes), meta.contentType, meta.fetchedAt, folder, fk.key);
  a.notStored = std::move(notStored);
  land(fk, std::move(a));
}

void TileService::Impl::serveKept(DatasetId id,
                                  const std::string& folder,
                                  const TileKey& key,
                                  UnstoredTiles::Kept& kept,
                                  const Done& done) {
  // Fetched before but not stored: answered from memory, and stored now if the cache takes it
  // (on a worker; once per retry interval), without asking the upstream again.
  if (kept.storeNow && id >= 0) {
    // `this`, not a shared_ptr: the workers finish their jobs before Impl's other members go, and
    // a job must never hold the last reference (its pool would join itself).
    workers->post([this, id, folder, key, bytes = kept.bytes, meta = kept.meta] {
      if (cache.put(id, key, bytes, meta)) {
        unstored.stored(folder, key, true);
        noticeStoreState(nullptr);
      }
    });
  }
  const UnixMillis fetchedAt = kept.meta.fetchedAt;
  done(tile(TileOrigin::Hit,
            std::move(kept.bytes),
            std::move(kept.meta.contentType),
            fetchedAt,
            folder,
            key));
}

void TileService::Impl::getTile(std::string_view layerName,
                                std::string_view time,
                                const TileKey& key,
                                Done done,
                                FetchGate gate) {
  const auto li = layerIndex.find(layerName);
  const auto ci = li == layerIndex.end() ? capIndex.find(layerName) : capIndex.end();
  if (li == layerIndex.end() && ci == capIndex.end())
    return done(error("no layer '" + std::string(layerName) + "'"));
  const bool whole = ci != capIndex.end(); // a polar row fetched whole (TileWholeRows.cpp)
  const LayerSpec& l = whole ? capLayers[ci->second] : layers[li->second];
  const TileGrid& g = whole ? capGrids[ci->second] : grids[li->second];
  const std::int64_t span = whole ? wholeSpanOf(l) : 0;
  if (span > 0 ? !isSpanKey(g, key, span)
      : whole  ? !isPolarRowKey(g, key)
               : key.level < 0 || key.level >= g.numLevels() || !g.isValid(key)) {
    return done(absent(TileOrigin::Hit, "outside the layer's coverage"));
  }
  // Layers without TIME (most requests) use the dataset registered at start: no lock, no copy.
  std::pair<DatasetId, std::string> timed;
  const std::pair<DatasetId, std::string>* ds = whole ? nullptr : &defaultDatasets[li->second];
  if (!time.empty() || whole) {
    auto found = dataset(l, time);
    if (!found) return done(error(found.error()));
    timed = std::move(*found);
    ds = &timed;
  }
  if (time.empty() && ds->first < 0) { // not registered for lack of space: room now?
    auto again = dataset(l, time);
    if (!again) return done(error(again.error()));
    timed = std::move(*again);
    ds = &timed;
  }
  const auto& [id, folder] = *ds;
  // A tile this process is fetching, or waiting for under another's lease, is joined without a
  // look at the index: a burst of requests for one missing tile looked it up once each, and on a
  // shared index the fetch's own lookups waited behind theirs (bench/RESULTS.md, issue 27).
  if (id >= 0 && joinUnderWay(FlightKey{id, key}, done)) return;
  // The file held open, not read: the HTTP server sends it with sendfile(2). A dataset the
  // cache could not register has nothing cached.
  auto found =
      id < 0 ? std::expected<CacheLookup, CacheError>(CacheLookup{}) : cache.openTile(id, key);
  if (!found && options.leases) return serveWithoutIndex(id, folder, key, std::move(done));
  if (found && options.leases) indexDown.store(false, std::memory_order_relaxed);
  if (!found) return done(error("cache: " + std::string(toString(found.error().code))));
  const UnixMillis now = nowMillis();
  if (found->kind == CacheLookup::Kind::Hit && !found->stale) {
    return done(tile(TileOrigin::Hit,
                     {},
                     std::move(found->meta.contentType),
                     found->meta.fetchedAt,
                     folder,
                     key,
                     std::move(found->file)));
  }
  if (found->kind == CacheLookup::Kind::Absent && found->retryAfter > now) {
    return done(absent(TileOrigin::Hit, "the upstream has no tile here"));
  }
  // Nothing cached, or an expired tile whose refresh could not be stored: a copy kept since
  // (newer than the row: a store of the tile drops it) is answered without another fetch.
  if (found->kind == CacheLookup::Kind::Miss || found->kind == CacheLookup::Kind::Hit) {
    if (auto kept = unstored.find(folder, key, now)) return serveKept(id, folder, key, *kept, done);
  }
  const UpstreamSpec& u = upstreams.at(l.upstream);
  const bool forced = forcedOffline.load();
  std::optional<CacheLookup> stale;
  if (found->kind == CacheLookup::Kind::Hit) stale = std::move(*found);
  if (forced || !remoteReachable(u)) {
    if (stale) {
      return done(staleTile(std::move(*stale), folder, key));
    }
    // Offline by choice: there is no tile to be had. An open breaker is a temporary failure.
    if (forced) return done(absent(TileOrigin::Offline, "offline: the tile is not cached"));
    TileAnswer a = unavailable(
        u.name, "the upstream is unreachable (circuit open) and the tile is not cached");
    a.origin = TileOrigin::Offline;
    return done(std::move(a));
  }
  const FlightKey fk{id, key};
  // Local rasters are rendered here, not fetched: the budget counts upstream fetches.
  const auto joined = joinGated(fk, done, u.type == UpstreamSpec::Type::Local ? FetchGate{} : gate);
  if (joined.refused) {
    // Over the client's budget: what the cache has is still served.
    if (stale) return done(staleTile(std::move(*stale), folder, key));
    return done(overBudget(*joined.refused));
  }
  if (!joined.first) return; // someone is already fetching it
  const bool metaMiss =
      u.type != UpstreamSpec::Type::Local && options.metaTilesOnMiss && !stale && metaCapable(l, u);
  // A metatile's tiles are looked up again once its shared lease is held (fetchBlockUnderLease),
  // or when its holder wakes this one: not here too, a round trip before the upstream is asked.
  if (!(metaMiss && options.leases) && landIfCachedNow(fk, folder)) return;
  if (u.type == UpstreamSpec::Type::Local) {
    renderLocal(fk, l, g, folder, std::move(stale));
  } else if (metaMiss) {
    missUnderMetaLease(fk, l, u, g, folder, std::string(time));
  } else if (options.leases) {
    fetchUnderLease(fk, l, u, g, folder, std::string(time), std::move(stale));
  } else {
    fetchRemote(fk, l, u, g, folder, std::string(time), std::move(stale));
  }
}

void TileService::Impl::serveWithoutIndex(DatasetId id,
                                          const std::string& folder,
                                          const TileKey& key,
                                          Done done) {
  // The shared index cannot be reached: what the store holds is served (tiles are stored whole),
  // nothing is fetched or stored until the index answers again.
  if (!indexDown.exchange(true)) {
    logger().log(LogLevel::Error,
                 "cache",
                 "the shared index is unreachable: serving the stored tiles, read-only",
                 {});
  }
  servedWithoutIndex.fetch_add(1, std::memory_order_relaxed);
  // A tile fetched but not stored (its commit failed as the index went away, or the store was
  // full) is newer than whatever the store holds: served from memory; stored once the index is
  // back (a request then finds it kept, getTile).
  if (auto kept = unstored.find(folder, key, nowMillis())) {
    kept->storeNow = false;
    return serveKept(id, folder, key, *kept, done);
  }
  auto stored = cache.openFromStore(id, key);
  if (stored && stored->kind == CacheLookup::Kind::Hit) {
    return done(tile(TileOrigin::Hit,
                     {},
                     std::move(stored->meta.contentType),
                     0,
                     folder,
                     key,
                     std::move(stored->file)));
  }
  TileAnswer a = error("the shared cache index is unreachable and the tile is not stored");
  a.failure = TileAnswer::Failure::Unavailable;
  a.retryAfterSeconds = kMinRetryAfterSeconds;
  done(std::move(a));
}

void TileService::Impl::fetchUnderLease(const FlightKey& fk,
                                        const LayerSpec& l,
                                        const UpstreamSpec& u,
                                        const TileGrid& g,
                                        const std::string& folder,
                                        const std::string& time,
                                        std::optional<CacheLookup> stale) {
  // On a shared index a miss fetches its metatile under the metatile's lease (TileMetaFetch.cpp);
  // a refresh (one tile, conditional) takes that same lease, so that it never overlaps another
  // instance's fetch of the block it is in.
  const bool inMeta = options.metaTilesOnMiss && metaCapable(l, u);
  const TileBlock meta = metaTileOf(g, fk.key, inMeta ? u.metaTiles : 1);
  const LeaseKey lease{folder, TileKey{meta.level, meta.row0, meta.col0}};
  auto kept = std::make_shared<std::optional<CacheLookup>>(std::move(stale));
  const auto hold = takeLease(lease, [fk, &l, &u, &g, folder, time, kept](Impl& im) {
    if (im.landIfCachedNow(fk, folder)) return; // the holder stored it
    im.fetchUnderLease(fk, l, u, g, folder, time, std::move(*kept));
  });
  if (!hold) return; // waiting
  if (*hold) {
    {
      std::lock_guard lock(flightsMutex);
      heldLeases.insert_or_assign(fk, *hold);
    }
    // Another process may have stored it between our look and the lease.
    if (landIfCachedNow(fk, folder)) return;
  }
  fetchRemote(fk, l, u, g, folder, time, std::move(*kept));
}

std::optional<std::shared_ptr<TileService::Impl::LeaseHold>>
TileService::Impl::takeLease(const LeaseKey& lease, std::function<void(Impl&)> again) {
  // Woken on the lease service's thread: the look at the cache and the next try run on a worker.
  auto retry = [weak = weak_from_this(), again = std::move(again)] {
    const auto self = weak.lock();
    if (!self) return;
    self->workers->post([im = self.get(), again] { again(*im); });
  };
  const LeaseOutcome got =
      options.leases->acquireOrWait(lease, options.leaseRecheck, std::move(retry));
  if (got == LeaseOutcome::Waiting) {
    leaseWaits.fetch_add(1, std::memory_order_relaxed);
    return std::nullopt;
  }
  if (got == LeaseOutcome::Acquired) return std::make_shared<LeaseHold>(options.leases, lease);
  return std::shared_ptr<LeaseHold>{};
}

} // namespace tellus
