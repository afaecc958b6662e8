#pragma once
// Tiles fetched but not stored (a full disk, an unreachable shared store), kept in memory so that
// the next request for one is answered without asking the upstream again, and the tile is stored
// from here once the cache takes tiles again (TileFlights.cpp). Bounded in bytes, least recently
// used first out; an entry past its tile's expiry is dropped, never served. Thread-safe.

#include <tellus/cache/CacheTypes.hpp>
#include <tellus/cache/TileKey.hpp>

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <list>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

namespace tellus {

class UnstoredTiles {
public:
  struct Kept {
    std::vector<std::byte> bytes;
    TileMeta meta;
    bool storeNow = false; ///< this caller should try to store it (one try per retry interval)
  };
  struct Stats {
    std::uint64_t tiles = 0;
    std::uint64_t bytes = 0;
    std::uint64_t served = 0;      ///< answers given from here
    std::uint64_t storedLater = 0; ///< kept tiles stored once the cache took tiles again
  };

  UnstoredTiles(std::size_t limitBytes, UnixMillis retryEveryMs)
      : limit_(limitBytes), retryEvery_(retryEveryMs) {}

  /** Keeps a copy (replacing an older one); nothing when it alone passes the limit. */
  void keep(const std::string& folder,
            const TileKey& key,
            std::span<const std::byte> bytes,
            const TileMeta& meta,
            UnixMillis now) {
    if (limit_ == 0 || bytes.size() > limit_) return;
    std::string n = name(folder, key);
    std::lock_guard lock(mutex_);
    dropLocked(n);
    order_.push_front(Entry{
        std::move(n), std::vector<std::byte>(bytes.begin(), bytes.end()), meta, now + retryEvery_});
    index_.emplace(order_.front().name, order_.begin());
    empty_.store(false, std::memory_order_relaxed);
    bytes_ += bytes.size();
    while (bytes_ > limit_)
      dropLocked(order_.back().name);
  }

  /** A copy of the kept tile, unless none or it expired (then dropped). `storeNow` is set for at
   * most one caller per retry interval. */
  std::optional<Kept> find(const std::string& folder, const TileKey& key, UnixMillis now) {
    if (empty_.load(std::memory_order_relaxed)) return std::nullopt;
    std::lock_guard lock(mutex_);
    const auto it = index_.find(name(folder, key));
    if (it == index_.end()) return std::nullopt;
    Entry& e = *it->second;
    if (e.meta.expiresAt && *e.meta.expiresAt <= now) {
      dropLocked(e.name);
      return std::nullopt;
    }
    order_.splice(order_.begin(), order_, it->second);
    Kept k{e.bytes, e.meta, now >= e.nextStoreTry};
    if (k.storeNow) e.nextStoreTry = now + retryEvery_;
    ++served_;
    return k;
  }

  /** The tile was stored: its copy here is no longer needed. `later`: stored from here. */
  void stored(const std::string& folder, const TileKey& key, bool later) {
    if (empty_.load(std::memory_order_relaxed)) return;
    std::lock_guard lock(mutex_);
    if (dropLocked(name(folder, key)) && later) ++storedLater_;
  }

  Stats stats() const {
    std::lock_guard lock(mutex_);
    return {index_.size(), bytes_, served_, storedLater_};
  }

private:
  struct Entry {
    std::string name;
    std::vector<std::byte> bytes;
    TileMeta meta;
    UnixMillis nextStoreTry = 0;
  };
  static std::string name(const std::string& folder, const TileKey& k) {
    return folder + '/' + std::to_string(k.level) + '/' + std::to_string(k.row) + '/' +
           std::to_string(k.col);
  }
  bool dropLocked(const std::string& n) {
    const auto it = index_.find(n);
    if (it == index_.end()) return false;
    bytes_ -= it->second->bytes.size();
    order_.erase(it->second);
    index_.erase(it);
    empty_.store(index_.empty(), std::memory_order_relaxed);
    return true;
  }

  const std::size_t limit_;
  const UnixMillis retryEvery_;
  mutable std::mutex mutex_;
  std::list<Entry> order_; // most recently used first
  std::unordered_map<std::string, std::list<Entry>::iterator> index_;
  std::size_t bytes_ = 0;
  std::uint64_t served_ = 0;
  std::uint64_t storedLater_ = 0;
  std::atomic<bool> empty_{true};
};

} // namespace tellus
