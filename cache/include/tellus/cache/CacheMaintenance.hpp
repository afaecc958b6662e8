#pragma once
/**
 * @file CacheMaintenance.hpp
 * @brief What runs beside the hot path of a TileCache: statistics, verify, rebuild, prune and LRU
 * eviction (`tellus cache ...`, and eviction after writes when a size limit is set).
 *
 * - verify compares the index with the store both ways (rows without tiles, tiles without rows,
 *   sizes), counts temp files of running writers and lists those of writers that are gone, and
 *   runs the index's own consistency check. Read-only.
 * - rebuild refills the index from the store alone: datasets from their descriptors, tiles from
 *   their names (fetched-at from when they were written); it removes temp files of writers that
 *   are gone.
 * - prune and eviction remove rows in chunks of at most 1000, each chunk under the store's changes
 *   lock: rows first, committed, then their tiles (no put can put a new tile into place between
 *   the commit and the removal). When the index cannot commit for lack of space, a chunk's tiles
 *   go first (freeing the room) and its rows after.
 *
 * A CacheMaintenance is a view of one TileCache: it holds nothing of its own and must not outlive
 * the cache. Every method may be called from any thread.
 */

#include <tellus/cache/CacheError.hpp>
#include <tellus/cache/CacheTypes.hpp>
#include <tellus/cache/TileCache.hpp>

#include <cstdint>
#include <expected>
#include <vector>

namespace tellus {

class CacheMaintenance {
public:
  explicit CacheMaintenance(TileCache& cache) noexcept;

  /** Tiles, absent markers and bytes per dataset and level. */
  std::expected<std::vector<DatasetStats>, CacheError> stats() const;
  /** What prune(options) would remove now: per dataset with such tiles, their count and bytes
   * (levels left empty). Read-only; `tellus cache prune` says it before it removes anything. */
  std::expected<std::vector<DatasetStats>, CacheError> prunable(const PruneOptions& options) const;
  std::expected<VerifyReport, CacheError> verify() const;
  /** Rebuilds the index from the store; returns the number of tiles indexed. */
  std::expected<std::int64_t, CacheError> rebuild();
  /** Removes tiles as selected; returns how many. */
  std::expected<std::int64_t, CacheError> prune(const PruneOptions& options);
  /** Evicts least recently used tiles of unpinned datasets down to 95% of the size limit when the
   * total is over it; returns the number evicted. Pinned data over the limit stays. */
  std::expected<std::int64_t, CacheError> evictToLimit();
  /** Total bytes of all cached tiles (from the index's counters, no scan). */
  std::expected<std::int64_t, CacheError> totalBytes() const;

private:
  friend class TileCache;
  explicit CacheMaintenance(TileCache::Impl& impl) noexcept : impl_(&impl) {}
  TileCache::Impl* impl_;
};

} // namespace tellus
