#pragma once
/**
 * @file RowCache.hpp
 * @brief In-process memory of index rows for present tiles, with their files held open (the hit
 * path's answer to SQLite lookups and open/fstat/close per request, like nginx's open_file_cache).
 *
 * Correctness rests on invalidation, not on expiry:
 * - this process's own writes invalidate their keys after commit and before the writer reports
 *   success, so a put followed by a get always sees the new tile;
 * - an insert is dropped when any invalidation happened since the caller read the row (the
 *   generation check), so a row read before a commit is never cached after it;
 * - other processes' writes are noticed through the index (ITileIndex::changedByOthers, SQLite's
 *   `PRAGMA data_version`; TileCache polls it), which clears everything;
 * - a file replaced or removed behind the index is noticed by a stat every `fileRecheck`.
 */

#include <tellus/cache/CacheTypes.hpp>
#include <tellus/cache/Dataset.hpp>
#include <tellus/cache/TileFile.hpp>
#include <tellus/cache/TileKey.hpp>
#include <tellus/cache/TileStore.hpp>

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <unordered_map>

namespace tellus::detail {

struct RowKey {
  DatasetId dataset;
  TileKey key;
  bool operator==(const RowKey&) const = default;
};
struct RowKeyHash {
  std::size_t operator()(const RowKey& t) const noexcept {
    return TileKeyHash{}(t.key) ^ (static_cast<std::size_t>(t.dataset) * 0x9E3779B97F4A7C15ULL);
  }
};

/** A present tile's row, and its open file. Immutable once shared, except the recheck time. */
struct CachedRow {
  TileMeta meta;
  std::int64_t size = 0;
  std::shared_ptr<const TileFile> file;
  TileVersion version;                              ///< of the stored tile the file is
  mutable std::atomic<std::int64_t> checkedAtNs{0}; ///< steady clock: last time the version matched
  mutable std::atomic<std::int64_t> touchedAtMs{0}; ///< last access recorded for LRU (Unix ms)
};

class RowCache {
public:
  /** Sets the limits; before first use only. */
  void configure(std::size_t capacity, std::size_t maxFiles) {
    capacity_ = capacity;
    maxFiles_ = maxFiles;
  }

  /** Read before looking a row up in SQLite; pass it back to insert(). */
  std::uint64_t generation() const noexcept { return generation_.load(std::memory_order_acquire); }

  std::shared_ptr<const CachedRow> find(const RowKey& k) const {
    std::lock_guard lock(mutex_);
    const auto it = rows_.find(k);
    return it == rows_.end() ? nullptr : it->second;
  }

  /** Caches a row read while the generation was `seen`; nothing happens if it moved since. */
  void insert(const RowKey& k, std::shared_ptr<const CachedRow> row, std::uint64_t seen) {
    if (capacity_ == 0) return;
    std::lock_guard lock(mutex_);
    if (generation_.load(std::memory_order_relaxed) != seen) return;
    if (row->file && maxFiles_ == 0) return;
    if (row->file && files_ >= maxFiles_) dropSome(true);
    if (rows_.size() >= capacity_) dropSome(false);
    auto [it, fresh] = rows_.try_emplace(k, row);
    if (!fresh) {
      if (it->second->file) --files_;
      it->second = std::move(row);
    }
    if (it->second->file) ++files_;
  }

  /** Forgets one key (after this process changed its row). */
  void invalidate(const RowKey& k) {
    std::lock_guard lock(mutex_);
    generation_.fetch_add(1, std::memory_order_acq_rel);
    const auto it = rows_.find(k);
    if (it == rows_.end()) return;
    if (it->second->file) --files_;
    rows_.erase(it);
  }

  /** Forgets everything (another process wrote, or a bulk change). */
  void clear() {
    std::lock_guard lock(mutex_);
    generation_.fetch_add(1, std::memory_order_acq_rel);
    rows_.clear();
    files_ = 0;
  }

  std::size_t size() const {
    std::lock_guard lock(mutex_);
    return rows_.size();
  }

private:
  /** Drops about a quarter of the rows (only those holding files when `withFiles`). Bucket order
   * is effectively random, which is good enough for a cache in front of an index. */
  void dropSome(bool withFiles) {
    const std::size_t target = withFiles ? maxFiles_ - maxFiles_ / 4 : capacity_ - capacity_ / 4;
    for (auto it = rows_.begin(); it != rows_.end();) {
      if ((withFiles ? files_ : rows_.size()) <= target) break;
      if (withFiles && !it->second->file) {
        ++it;
        continue;
      }
      if (it->second->file) --files_;
      it = rows_.erase(it);
    }
  }

  std::size_t capacity_ = 0;
  std::size_t maxFiles_ = 0;
  mutable std::mutex mutex_;
  std::unordered_map<RowKey, std::shared_ptr<const CachedRow>, RowKeyHash> rows_;
  std::size_t files_ = 0;
  std::atomic<std::uint64_t> generation_{0};
};

} // namespace tellus::detail
