#pragma once
/**
 * @file CacheCore.hpp
 * @brief TileCache::Impl: the composition of an index, a tile store and what keeps them in step
 * (the writer, the row cache, the write-behind overlay, the full-disk gate, the datasets). The hot
 * path (TileCache.cpp), dataset registration (Registration.cpp) and maintenance
 * (CacheMaintenance.cpp, RowRemoval.cpp) all work on it.
 *
 * Which thread does what:
 * - readers (get, openTile, peek) read the index and the store at once, remember rows and open
 *   tiles (RowCache), and queue access times and self-healing clean-ups for the writer;
 * - every change to the index and the store goes through the WriteQueue: one writer per process,
 *   under the store's changes lock, so that a tile and its row always change together.
 */

#include "DatasetRegistry.hpp"
#include "PendingRows.hpp"
#include "RowCache.hpp"
#include "StoreGate.hpp"
#include "WriteQueue.hpp"

#include <tellus/cache/Clock.hpp>
#include <tellus/cache/TileCache.hpp>
#include <tellus/cache/TileIndex.hpp>
#include <tellus/cache/TileStore.hpp>

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>

namespace tellus {

struct TileCache::Impl {
  using Result = std::expected<void, CacheError>;

  Impl(const Options& o, std::shared_ptr<ITileIndex> i, std::shared_ptr<ITileStore> s);
  ~Impl();

  // Declared in the order they are built; the writer, last, stops first.
  Options options;
  std::shared_ptr<const Clock> clock;
  std::shared_ptr<ITileIndex> index;
  std::shared_ptr<ITileStore> store;
  detail::DatasetRegistry datasets;
  detail::StoreGate gate;
  detail::RowCache rows;
  detail::PendingRows pending;
  detail::WriteQueue writer;

  bool rebuiltAtOpen = false;
  std::size_t tempFilesRemoved = 0;
  // When readers next look for other processes' commits (steady ns).
  std::atomic<std::int64_t> nextVersionCheckNs{0};

  std::int64_t steadyNs() const {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(clock->steady().time_since_epoch())
        .count();
  }

  /** Drops every remembered row when another process has committed since the last look; runs at
   * most every otherWritersCheck, on whichever reader comes first, and never waits for the
   * writer. */
  void noticeOtherWriters();

  // --- inside writer operations (under the writer lock) ------------------------------------------
  /** Writes a row (fetched-at 0 becomes now) and marks it changed for the row cache. */
  Result writeRow(DatasetId id, const TileKey& key, TileRow row);
  /** writeRow() for several tiles (distinct keys) of one dataset, in one ITileIndex::putRows. */
  Result writeRows(DatasetId id, std::vector<std::pair<TileKey, TileRow>> many);
  Result deleteRow(DatasetId id, const TileKey& key);
  /** A reader found a present row whose tile is missing or of another size: drops the row if that
   * is still so now, under the changes lock (where a row and its tile agree unless something
   * outside the cache changed them), not if a put or a prune came between and made them agree. */
  Result healRow(DatasetId id, const TileKey& key);
};

} // namespace tellus
