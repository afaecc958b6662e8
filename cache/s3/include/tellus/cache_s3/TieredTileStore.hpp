#pragma once
/**
 * @file TieredTileStore.hpp
 * @brief An instance's own disk in front of a shared store (issue 27, "tiers"): the file tree
 * under the cache root holds copies of the tiles this instance served or stored, the shared store
 * (S3) all of them.
 *
 * Reads try the local tier first; a tile only the shared store has is copied into the local tier
 * as it is read (the next read is a local hit, sent with sendfile(2) from the local file). Writes
 * and removals go to both, the shared store first (what the other instances see), the local tier
 * second; a rollback undoes both. Descriptors are written to both and read from the shared store;
 * maintenance (datasets, scans) lists the shared store, whose tiles the index describes. The
 * changes lock, the free space and the temp files are the local tier's.
 *
 * With a limit (`cache.s3.local_tier_limit`) the local tier is bounded: an in-memory record of its
 * tile files (bytes, and their order of last use: a read that hits, a copy, a write) is kept,
 * filled at start by a scan of the tree on a thread of its own (in the order of use a clean stop
 * saved in `<root>/.local-tier-order`, read once and removed; files it does not list, or all of
 * them after a crash, by mtime (a copy's fetched-at), the oldest as least recently used) and kept
 * up to date by every
 * read, copy, write and removal through this store. When the tiles recorded pass the limit, that
 * thread unlinks the local copies of the least recently used ones until they are under the
 * low-water mark (90 % of the limit). Only local tile files are ever removed: never an index row,
 * never a shared object, never a temp file, a descriptor or the changes lock (none of them is
 * recorded). A later read of an evicted tile misses the local tier and is read from the shared
 * store (and copied back). A reader holding the evicted file open (the cache's RowCache) keeps
 * reading it: unlink leaves an open file whole (POSIX).
 *
 * The record follows the files closely, not exactly: a file changed behind this store (or in a race
 * of a removal with a copy of the same tile) is recorded as it was last seen until it is read,
 * written or evicted again; the next start's scan counts the tree afresh.
 */

#include <tellus/cache/TileStore.hpp>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>

namespace tellus {

/** The bound of the local tier. */
struct LocalTierOptions {
  std::uint64_t limitBytes = 0; ///< 0: unbounded (nothing recorded, no scan, no thread)
  double lowWater = 0.9;        ///< eviction stops at this share of the limit
  /** The local tree's root, scanned at start for the tiles already there (its dataset folders,
   * `<root>/<server>/<dataset>`); empty: no scan. */
  std::filesystem::path root;
  /** Called on the tier's thread just before the start's scan; tests hold the scan there to
   * write while it has not looked. Empty: nothing. */
  std::function<void()> beforeScan;
};

/** What the local tier holds, as recorded. */
struct LocalTierStats {
  std::uint64_t bytes = 0;        ///< of the tile files recorded
  std::uint64_t files = 0;        ///< tile files recorded
  std::uint64_t evictions = 0;    ///< local copies removed for the limit since start
  std::uint64_t evictedBytes = 0; ///< their bytes
  bool scanned = false;           ///< the start's scan is done (or there was none)
};

class TieredTileStore : public ITileStore {
public:
  /** The record of the local tier (all zero without a limit). Any thread. */
  virtual LocalTierStats localTier() const = 0;
  /** Waits until the start's scan is done and the tier is not over its limit (the eviction thread
   * idle). For tests and tools; returns at once without a limit. */
  virtual void settle() = 0;
};

/** `local` (the file tree) in front of `shared` (the S3 store). */
std::unique_ptr<TieredTileStore> makeTieredTileStore(std::shared_ptr<ITileStore> local,
                                                     std::shared_ptr<ITileStore> shared,
                                                     LocalTierOptions tier = {});

} // namespace tellus
