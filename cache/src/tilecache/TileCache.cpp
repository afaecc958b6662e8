// TileCache: opening, and the hot path (lookups, puts, removals) over an index and a tile store.

#include "CacheCore.hpp"
#include "RowRemoval.hpp"

#include <tellus/cache/CacheMaintenance.hpp>
#include <tellus/cache/TileCache.hpp>

namespace tellus {

namespace fs = std::filesystem;

namespace {

using Result = std::expected<void, CacheError>;
using detail::RowKey;

constexpr std::int64_t kTouchResolutionMs = 60000; // last-access times of remembered rows

CacheError readOnlyError() {
  return CacheError{CacheErrc::ReadOnly, "the cache is read-only"};
}

detail::WriteQueue::Settings writerSettings(const TileCache::Options& o) {
  return detail::WriteQueue::Settings{
      o.readOnly, o.sizeLimitBytes > 0, o.accessFlushInterval, o.busyTimeout};
}

std::shared_ptr<const Clock> clockOf(const TileCache::Options& o) {
  return o.clock ? o.clock : systemClock();
}

/** A present row as a lookup gives it, stale or not at `now`. */
CacheLookup hitOf(TileMeta meta, std::int64_t size, UnixMillis now) {
  CacheLookup out;
  out.kind = CacheLookup::Kind::Hit;
  out.meta = std::move(meta);
  out.size = size;
  out.stale = out.meta.expiresAt && *out.meta.expiresAt <= now;
  return out;
}

} // namespace

// ---------------------------------------------------------------------------------- the core

TileCache::Impl::Impl(const Options& o,
                      std::shared_ptr<ITileIndex> i,
                      std::shared_ptr<ITileStore> s)
    : options(o), clock(clockOf(o)), index(std::move(i)), store(std::move(s)), datasets(*index),
      gate(o.root, *store, *clock, o.fullRecheck),
      writer(*index, *store, rows, *clock, writerSettings(o)) {
  options.clock = clock;
  // After writes, on the writer thread (set before it starts).
  if (options.sizeLimitBytes > 0)
    writer.setEviction([this] { (void)detail::evictOverLimit(*this); });
}

TileCache::Impl::~Impl() {
  writer.stop();
}

void TileCache::Impl::noticeOtherWriters() {
  const auto interval = options.otherWritersCheck.count();
  if (interval <= 0) {
    rows.clear(); // every lookup goes to the index
    return;
  }
  const std::int64_t now = steadyNs();
  if (now < nextVersionCheckNs.load(std::memory_order_relaxed)) return;
  auto w = writer.tryLock();
  if (!w) return; // the writer is busy; the next reader looks
  nextVersionCheckNs.store(now + interval * 1000000, std::memory_order_relaxed);
  if (index->changedByOthers()) rows.clear();
}

Result TileCache::Impl::writeRow(DatasetId id, const TileKey& key, TileRow row) {
  if (row.meta.fetchedAt == 0) row.meta.fetchedAt = clock->now();
  writer.rowChanged(id, key);
  return index->putRow(id, key, row);
}

Result TileCache::Impl::writeRows(DatasetId id, std::vector<std::pair<TileKey, TileRow>> many) {
  for (auto& [key, row] : many) {
    if (row.meta.fetchedAt == 0) row.meta.fetchedAt = clock->now();
    writer.rowChanged(id, key);
  }
  return index->putRows(id, many);
}

Result TileCache::Impl::deleteRow(DatasetId id, const TileKey& key) {
  writer.rowChanged(id, key);
  return index->deleteRow(id, key);
}

Result TileCache::Impl::healRow(DatasetId id, const TileKey& key) {
  const auto d = datasets.find(id);
  if (!d) return {};
  const auto bytes = index->presentBytes(id, key);
  if (!bytes) return std::unexpected(bytes.error());
  if (!*bytes) return {};
  const auto asked = store->statOrError(d->at(key));
  if (!asked) return {}; // the store is out of reach: keep the row, ask again on the next open
  const auto& stored = *asked;
  if (stored && stored->size == **bytes) return {};
  // A tile of another size than its row says is not that tile: both go (it is fetched again).
  if (stored) store->remove(d->at(key));
  return deleteRow(id, key);
}

// ---------------------------------------------------------------------------------- opening

std::expected<std::unique_ptr<TileCache>, CacheError> TileCache::open(const Options& options) {
  auto store =
      openFileTileStore(FileTileStoreOptions{options.root, options.readOnly, options.fsyncTiles});
  if (!store) return std::unexpected(store.error());
  auto index = openSqliteTileIndex(SqliteTileIndexOptions{options.root,
                                                          options.readOnly,
                                                          options.busyTimeout,
                                                          options.readConnections,
                                                          clockOf(options)});
  if (!index) return std::unexpected(index.error());
  return open(options, std::move(*index), std::move(*store));
}

std::expected<std::unique_ptr<TileCache>, CacheError> TileCache::open(
    const Options& options, std::shared_ptr<ITileIndex> index, std::shared_ptr<ITileStore> store) {
  if (!index || !store)
    return std::unexpected(CacheError{CacheErrc::InvalidArgument, "no index or no tile store"});
  auto impl = std::make_unique<Impl>(options, std::move(index), std::move(store));
  impl->rebuiltAtOpen = impl->index->damagedAtOpen();
  if (auto r = impl->datasets.load(); !r) return std::unexpected(r.error());
  if (!options.readOnly) {
    // Temp files of writers that are gone (killed mid-write): only where writers put them, no scan.
    impl->tempFilesRemoved = impl->store->removeDeadTemps("");
    for (const auto& d : impl->datasets.known())
      impl->tempFilesRemoved += impl->store->removeDeadTemps(d.folder);
  }
  impl->rows.configure(options.rowCacheEntries, options.openFiles);
  std::unique_ptr<TileCache> cache(new TileCache(std::move(impl)));
  if (!options.readOnly) cache->impl_->writer.start();
  if (cache->impl_->rebuiltAtOpen) {
    if (auto n = CacheMaintenance(*cache).rebuild(); !n) return std::unexpected(n.error());
  }
  return cache;
}

TileCache::TileCache(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

TileCache::~TileCache() {
  if (impl_) impl_->writer.stop();
}

const fs::path& TileCache::root() const noexcept {
  return impl_->options.root;
}
bool TileCache::wasRebuiltAtOpen() const noexcept {
  return impl_->rebuiltAtOpen;
}

// ---------------------------------------------------------------------------------- lookups

std::expected<CacheLookup, CacheError> TileCache::peek(DatasetId id, const TileKey& key) const {
  auto one = peekMany(id, std::span<const TileKey>(&key, 1));
  if (!one) return std::unexpected(one.error());
  return std::move(one->front());
}

std::expected<std::vector<CacheLookup>, CacheError>
TileCache::peekMany(DatasetId id, std::span<const TileKey> keys) const {
  Impl& im = *impl_;
  for (const TileKey& k : keys)
    if (auto d = im.datasets.checked(id, k); !d) return std::unexpected(d.error());
  const UnixMillis now = im.clock->now();
  std::vector<CacheLookup> out(keys.size());
  // Rows written behind and not yet committed first, then the index for the others (a row
  // committed in between is found there).
  std::vector<std::size_t> looked;
  std::vector<TileKey> lookedKeys;
  for (std::size_t i = 0; i < keys.size(); ++i) {
    if (im.options.indexWriteBehind) {
      if (const auto p = im.pending.find(RowKey{id, keys[i]})) {
        out[i] = hitOf(p->meta, p->size, now);
        continue;
      }
    }
    looked.push_back(i);
    lookedKeys.push_back(keys[i]);
  }
  if (looked.empty()) return out;
  auto rows = im.index->lookupMany(id, lookedKeys);
  if (!rows) return std::unexpected(rows.error());
  for (std::size_t j = 0; j < looked.size(); ++j) {
    auto& row = (*rows)[j];
    CacheLookup& o = out[looked[j]];
    if (!row) continue;
    if (!row->present) {
      o.kind = CacheLookup::Kind::Absent;
      o.retryAfter = row->retryAfter.value_or(0);
      continue;
    }
    o = hitOf(std::move(row->meta), row->bytes, now);
  }
  return out;
}

namespace {

/** A remembered row for a tile just opened. */
std::shared_ptr<detail::CachedRow>
rememberedRow(StoredTile tile, const CacheLookup& row, std::int64_t steadyNs) {
  auto r = std::make_shared<detail::CachedRow>();
  r->meta = row.meta;
  r->size = row.size;
  r->file = std::move(tile.file);
  r->version = tile.version;
  r->checkedAtNs.store(steadyNs, std::memory_order_relaxed);
  return r;
}

} // namespace

std::expected<CacheLookup, CacheError> TileCache::openTile(DatasetId id, const TileKey& key) {
  auto one = openTiles(id, std::span<const TileKey>(&key, 1));
  if (!one) return std::unexpected(one.error());
  return std::move(one->front());
}

std::expected<std::vector<CacheLookup>, CacheError>
TileCache::openTiles(DatasetId id, std::span<const TileKey> keys) {
  Impl& im = *impl_;
  std::shared_ptr<const detail::DatasetEntry> entry;
  for (const TileKey& k : keys) {
    auto d = im.datasets.checked(id, k);
    if (!d) return std::unexpected(d.error());
    entry = std::move(*d);
  }
  if (!entry) return std::vector<CacheLookup>{};
  const detail::DatasetEntry& d = *entry;
  auto hit = [&](const RowKey& rk, const detail::CachedRow& r) {
    const UnixMillis now = im.clock->now();
    CacheLookup out = hitOf(r.meta, r.size, now);
    out.file = r.file;
    // Last access only steers LRU eviction: a minute's resolution is plenty, and a hot tile then
    // costs the writer one update a minute instead of one a second (its bursts hurt tail latency).
    if (now - r.touchedAtMs.load(std::memory_order_relaxed) < kTouchResolutionMs) return out;
    r.touchedAtMs.store(now, std::memory_order_relaxed);
    im.writer.recordTouch(rk, now);
    return out;
  };
  im.noticeOtherWriters();
  std::vector<CacheLookup> out(keys.size());
  std::vector<std::size_t> looked; // those the index is asked for
  std::vector<bool> pending(keys.size(), false);
  for (std::size_t i = 0; i < keys.size(); ++i) {
    const RowKey rk{id, keys[i]};
    const auto pendingRow =
        im.options.indexWriteBehind ? im.pending.find(rk) : std::optional<detail::PendingRow>{};
    if (pendingRow) {
      pending[i] = true;
      // Written, not yet committed: the bytes are staged, or already in place.
      CacheLookup row = hitOf(pendingRow->meta, pendingRow->size, 0);
      if (auto t = pendingRow->staged->open(pendingRow->size)) {
        out[i] = hit(rk, *rememberedRow(std::move(*t), row, im.steadyNs()));
        continue;
      }
      // Neither: committed (or dropped) meanwhile; the index says which.
    } else if (auto r = im.rows.find(rk)) {
      const auto recheck = im.options.fileRecheck.count() * 1000000;
      const std::int64_t now = im.steadyNs();
      if (now - r->checkedAtNs.load(std::memory_order_relaxed) < recheck) {
        out[i] = hit(rk, *r);
        continue;
      }
      // Still the tile the index names? (replaced or deleted behind the cache's back otherwise)
      const auto stored = im.store->stat(d.at(keys[i]));
      if (stored && stored->version == r->version) {
        r->checkedAtNs.store(now, std::memory_order_relaxed);
        out[i] = hit(rk, *r);
        continue;
      }
      im.rows.invalidate(rk);
    }
    looked.push_back(i);
  }
  if (looked.empty()) return out;
  // One index round trip for the rest (a metatile's tiles at once: peekMany).
  const std::uint64_t generation = im.rows.generation();
  std::vector<TileKey> lookedKeys;
  lookedKeys.reserve(looked.size());
  for (const std::size_t i : looked)
    lookedKeys.push_back(keys[i]);
  auto found = peekMany(id, lookedKeys);
  if (!found) return std::unexpected(found.error());
  for (std::size_t j = 0; j < looked.size(); ++j) {
    const std::size_t i = looked[j];
    CacheLookup& f = (*found)[j];
    if (f.kind != CacheLookup::Kind::Hit) {
      out[i] = std::move(f);
      continue;
    }
    auto at = d.at(keys[i]);
    at.fetchedAt = f.meta.fetchedAt; // a local tier's copy of another version is stale
    auto tile = im.store->open(at, f.size);
    if (!tile) {
      // The tile vanished or changed under us: report a miss, and let the writer drop the row if
      // it still names no such tile (self-healing).
      im.writer.submitDetached([&im, id, key = keys[i]] { return im.healRow(id, key); });
      continue; // a Miss
    }
    const RowKey rk{id, keys[i]};
    auto row = rememberedRow(std::move(*tile), f, im.steadyNs());
    if (!pending[i]) im.rows.insert(rk, row, generation);
    out[i] = hit(rk, *row);
  }
  return out;
}

std::expected<CacheLookup, CacheError> TileCache::openFromStore(DatasetId id, const TileKey& key) {
  Impl& im = *impl_;
  auto d = im.datasets.checked(id, key);
  if (!d) return std::unexpected(d.error());
  const auto at = (*d)->at(key);
  const auto stat = im.store->stat(at);
  if (!stat) return CacheLookup{};
  auto tile = im.store->open(at, stat->size);
  if (!tile) return CacheLookup{};
  CacheLookup out;
  out.kind = CacheLookup::Kind::Hit;
  out.file = std::move(tile->file);
  out.size = stat->size;
  out.meta.contentType = (*d)->info.spec.mimeType;
  return out;
}

std::expected<CacheLookup, CacheError> TileCache::get(DatasetId id, const TileKey& key) {
  auto found = openTile(id, key);
  if (!found || found->kind != CacheLookup::Kind::Hit) return found;
  auto bytes = found->file->readAll();
  if (!bytes) {
    Impl& im = *impl_;
    im.rows.invalidate(RowKey{id, key});
    im.writer.submitDetached([&im, id, key] { return im.healRow(id, key); });
    return CacheLookup{};
  }
  found->bytes = std::move(*bytes);
  found->file.reset();
  return found;
}

std::expected<void, CacheError>
TileCache::forEachTile(DatasetId id,
                       std::int32_t fromLevel,
                       std::int32_t toLevel,
                       const std::function<bool(const TileKey&, std::int64_t)>& visit) const {
  return impl_->index->forEachTile(id, fromLevel, toLevel, visit);
}

// ---------------------------------------------------------------------------------- changes

namespace {

/** In the writer's transaction, under the changes lock: a staged tile goes into place and its row
 * is written; after the commit (or the rollback) the staged tile keeps or undoes what it did. */
Result install(TileCache::Impl& im,
               DatasetId id,
               const TileKey& key,
               std::int64_t n,
               const TileMeta& m,
               StagedTile& tile) {
  if (auto r = tile.install(); !r) return r;
  return im.writeRow(id, key, TileRow{true, n, m, std::nullopt});
}

/** Write-behind: visible to this process at once through the pending overlay (from the staged
 * bytes until they are in place), put into place and committed by the writer with whatever else
 * is queued. Counted, not printed: the seeder reports how many were dropped (storeStatus). */
void putBehind(TileCache::Impl& im,
               DatasetId id,
               const TileKey& key,
               std::int64_t n,
               const TileMeta& m,
               const std::shared_ptr<StagedTile>& tile) {
  const RowKey rk{id, key};
  const std::uint64_t generation = im.pending.add(rk, n, m, tile);
  im.writer.submitDetached([&im, id, key, n, m, tile] { return install(im, id, key, n, m, *tile); },
                           [&im, rk, generation, tile](const Result& r) {
                             tile->finish(r.has_value());
                             im.pending.dropIfStill(rk, generation);
                             im.gate.writeBehindOutcome(r);
                           });
}

} // namespace

std::expected<void, CacheError> TileCache::put(DatasetId id,
                                               const TileKey& key,
                                               std::span<const std::byte> bytes,
                                               const TileMeta& meta) {
  Impl& im = *impl_;
  if (im.options.readOnly) return std::unexpected(readOnlyError());
  auto d = im.datasets.checked(id, key);
  if (!d) return std::unexpected(d.error());
  if (auto refused = im.gate.refuseWhileFull(); !refused) return refused;
  TileMeta m = meta;
  if (m.contentType.empty()) m.contentType = (*d)->info.spec.mimeType;
  if (m.fetchedAt == 0) m.fetchedAt = im.clock->now();
  auto at = (*d)->at(key);
  at.fetchedAt = m.fetchedAt; // the stored copy's version (TileLocation::fetchedAt)
  auto staged = im.store->stage(at, bytes);
  if (!staged) return im.gate.putOutcome(std::unexpected(staged.error()));
  const auto n = static_cast<std::int64_t>(bytes.size());
  if (im.options.indexWriteBehind) {
    putBehind(im, id, key, n, m, *staged);
    return {};
  }
  return im.gate.putOutcome(im.writer.submit(
      [&im, id, key, n, m, tile = *staged] { return install(im, id, key, n, m, *tile); },
      [tile = *staged](const Result& r) { tile->finish(r.has_value()); }));
}

std::expected<void, CacheError>
TileCache::putMany(DatasetId id, std::span<const TileBytes> tiles, const TileMeta& meta) {
  Impl& im = *impl_;
  if (im.options.readOnly) return std::unexpected(readOnlyError());
  if (tiles.empty()) return {};
  std::shared_ptr<const detail::DatasetEntry> d;
  for (const TileBytes& t : tiles) {
    auto checked = im.datasets.checked(id, t.key);
    if (!checked) return std::unexpected(checked.error());
    d = std::move(*checked);
  }
  if (auto refused = im.gate.refuseWhileFull(); !refused) return refused;
  TileMeta m = meta;
  if (m.contentType.empty()) m.contentType = d->info.spec.mimeType;
  if (m.fetchedAt == 0) m.fetchedAt = im.clock->now();
  std::vector<TileToStage> toStage;
  toStage.reserve(tiles.size());
  for (const TileBytes& t : tiles) {
    toStage.push_back(TileToStage{d->at(t.key), t.bytes});
    toStage.back().at.fetchedAt = m.fetchedAt;
  }
  auto staged = im.store->stageMany(toStage);
  if (!staged) return im.gate.putOutcome(std::unexpected(staged.error()));
  if (im.options.indexWriteBehind) { // as put(), tile by tile: nobody waits for the rows
    for (std::size_t i = 0; i < tiles.size(); ++i) {
      const auto n = static_cast<std::int64_t>(tiles[i].bytes.size());
      putBehind(im, id, tiles[i].key, n, m, (*staged)[i]);
    }
    return {};
  }
  // Every tile into place and its row written in one of the writer's transactions: a failure of
  // any rolls back all, and each staged tile undoes what it did.
  std::vector<std::pair<TileKey, std::int64_t>> rows;
  rows.reserve(tiles.size());
  for (const TileBytes& t : tiles)
    rows.emplace_back(t.key, static_cast<std::int64_t>(t.bytes.size()));
  auto apply = [&im, id, m, rows = std::move(rows), all = *staged]() -> Result {
    // Every tile into place, then their rows in one putRows (one statement on PostgreSQL).
    std::vector<std::pair<TileKey, TileRow>> indexed;
    indexed.reserve(all.size());
    for (std::size_t i = 0; i < all.size(); ++i) {
      if (auto r = all[i]->install(); !r) return r;
      indexed.emplace_back(rows[i].first, TileRow{true, rows[i].second, m, std::nullopt});
    }
    return im.writeRows(id, std::move(indexed));
  };
  return im.gate.putOutcome(im.writer.submit(std::move(apply), [all = *staged](const Result& r) {
    for (const auto& tile : all)
      tile->finish(r.has_value());
  }));
}

std::expected<void, CacheError>
TileCache::revalidated(DatasetId id, const TileKey& key, const TileMeta& meta) {
  Impl& im = *impl_;
  auto d = im.datasets.checked(id, key);
  if (!d) return std::unexpected(d.error());
  return im.writer.submit([&im, id, key, meta]() -> Result {
    TileMeta m = meta;
    if (m.fetchedAt == 0) m.fetchedAt = im.clock->now();
    im.writer.rowChanged(id, key);
    return im.index->revalidate(id, key, m);
  });
}

namespace {

/** Removes a tile with its row replaced by `writeRow` (an absent marker) or deleted. */
Result removeTile(TileCache::Impl& im,
                  const std::shared_ptr<const detail::DatasetEntry>& d,
                  const TileKey& key,
                  std::optional<TileRow> marker) {
  im.pending.drop(RowKey{d->info.id, key});
  auto removal = im.store->stageRemoval(d->at(key));
  return im.writer.submit(
      [&im, id = d->info.id, key, removal, marker]() -> Result {
        if (auto r = removal->hide(); !r) return r;
        return marker ? im.writeRow(id, key, *marker) : im.deleteRow(id, key);
      },
      [removal](const Result& r) { removal->finish(r.has_value()); });
}

} // namespace

std::expected<void, CacheError>
TileCache::putAbsent(DatasetId id, const TileKey& key, UnixMillis retryAfter) {
  auto d = impl_->datasets.checked(id, key);
  if (!d) return std::unexpected(d.error());
  TileRow marker{false, 0, TileMeta{}, retryAfter};
  marker.meta.fetchedAt = impl_->clock->now();
  return removeTile(*impl_, *d, key, marker);
}

std::expected<void, CacheError> TileCache::erase(DatasetId id, const TileKey& key) {
  auto d = impl_->datasets.checked(id, key);
  if (!d) return std::unexpected(d.error());
  return removeTile(*impl_, *d, key, std::nullopt);
}

void TileCache::flush() {
  impl_->writer.flush();
}

// ---------------------------------------------------------------------------------- status

StoreStatus TileCache::storeStatus() const noexcept {
  return impl_->gate.status();
}

std::optional<DiskSpace> TileCache::diskSpace() const {
  return impl_->store->freeSpace();
}

std::size_t TileCache::tempFilesRemovedAtOpen() const noexcept {
  return impl_->tempFilesRemoved;
}

// ---------------------------------------------------------------------------------- formats

std::string extensionForMimeType(std::string_view m) {
  if (m == "image/jpeg" || m == "image/jpg") return "jpg";
  if (m == "image/png" || m.starts_with("image/png;")) return "png";
  if (m == "image/tiff" || m == "image/geotiff") return "tif";
  if (m == "application/bil16" || m == "application/bil" || m == "image/bil") return "bil";
  if (m == "image/webp") return "webp";
  if (m == "image/gif") return "gif";
  if (m == "image/dds") return "dds";
  return "bin";
}

std::string mimeTypeForExtension(std::string_view e) {
  if (e == "jpg" || e == "jpeg") return "image/jpeg";
  if (e == "png") return "image/png";
  if (e == "tif" || e == "tiff") return "image/tiff";
  if (e == "bil") return "application/bil16";
  if (e == "webp") return "image/webp";
  if (e == "gif") return "image/gif";
  if (e == "dds") return "image/dds";
  return "application/octet-stream";
}

} // namespace tellus
