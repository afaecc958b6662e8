#pragma once
/**
 * @file PendingRows.hpp
 * @brief Write-behind puts whose rows are queued but not committed yet
 * (TileCache::Options::indexWriteBehind): visible to this process at once, from their staged
 * bytes, until the writer has committed (or dropped) them.
 */

#include "RowCache.hpp"

#include <tellus/cache/CacheTypes.hpp>
#include <tellus/cache/TileStore.hpp>

#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <unordered_map>

namespace tellus::detail {

struct PendingRow {
  std::int64_t size = 0;
  TileMeta meta;
  std::uint64_t generation = 0;
  std::shared_ptr<StagedTile> staged; // the bytes until the writer puts them into place
};

class PendingRows {
public:
  std::optional<PendingRow> find(const RowKey& key) const {
    std::lock_guard lock(mutex_);
    const auto it = rows_.find(key);
    if (it == rows_.end()) return std::nullopt;
    return it->second;
  }

  /** Adds or replaces a key's pending row; returns its generation (for dropIfStill). */
  std::uint64_t add(const RowKey& key,
                    std::int64_t size,
                    const TileMeta& meta,
                    std::shared_ptr<StagedTile> staged) {
    std::lock_guard lock(mutex_);
    const std::uint64_t generation = ++generation_;
    rows_.insert_or_assign(key, PendingRow{size, meta, generation, std::move(staged)});
    return generation;
  }

  void drop(const RowKey& key) {
    std::lock_guard lock(mutex_);
    rows_.erase(key);
  }

  /** Drops a key's pending row unless a later put replaced it. */
  void dropIfStill(const RowKey& key, std::uint64_t generation) {
    std::lock_guard lock(mutex_);
    const auto it = rows_.find(key);
    if (it != rows_.end() && it->second.generation == generation) rows_.erase(it);
  }

private:
  mutable std::mutex mutex_;
  std::unordered_map<RowKey, PendingRow, RowKeyHash> rows_;
  std::uint64_t generation_ = 0;
};

} // namespace tellus::detail
