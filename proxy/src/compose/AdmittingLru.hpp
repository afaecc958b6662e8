#pragma once
// A least-recently-used cache within a byte budget that admits a value only when it is used often
// enough to be worth its place: the composer's decoded tiles (MapComposer's decoded_tile_cache).
//
// Why admission: keeping a decoded tile means decoding it whole, where a map that needs part of a
// tile decodes only that part; and maps spread over more tiles than the budget holds would push
// tiles through a plain LRU before their next use (that made every map dearer: bench/RESULTS.md).
// So, as TinyLFU does (Einziger, Friedman and Manes, "TinyLFU: A Highly Efficient Cache Admission
// Policy", 2017), the cache counts every use of every key, kept or not, and a missed key is kept
// only from its second use on and, when the budget is full, only if it was used more often than
// the least recently used value it would push out. The counts are halved every ten uses per kept
// value (at least 1,024), so that what was popular an hour ago does not stay forever; the keys
// counted are bounded too. Hot tiles (a region clients keep looking at, the coarse levels every
// zoomed-out map needs) stay decoded; a stream of tiles used once or twice passes by.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <iterator>
#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

namespace tellus {

template <class V> class AdmittingLru {
public:
  explicit AdmittingLru(std::size_t budgetBytes) : budget_(budgetBytes) {}

  /** The value of `key`, or null; either way the use is counted. */
  std::shared_ptr<const V> get(const std::string& key) {
    std::lock_guard lock(mutex_);
    count(key);
    const auto it = index_.find(key);
    if (it == index_.end()) return nullptr;
    lru_.splice(lru_.begin(), lru_, it->second);
    return it->second->value;
  }

  /** After a miss of `key` (counted by get): whether a value of `bytes` for it would be kept. */
  bool admits(const std::string& key, std::size_t bytes) {
    std::lock_guard lock(mutex_);
    if (bytes > budget_) return false;
    const std::uint32_t f = frequency(key);
    if (f < 2) return false;
    if (bytes_ + bytes <= budget_ || lru_.empty()) return true;
    return f > frequency(lru_.back().key);
  }

  /** Keeps `value` (least recently used values out until it fits). */
  void put(const std::string& key, std::shared_ptr<const V> value, std::size_t bytes) {
    if (bytes > budget_) return;
    std::vector<std::shared_ptr<const V>> evicted; // released outside the lock
    std::lock_guard lock(mutex_);
    if (index_.contains(key)) return;
    lru_.push_front(Entry{key, std::move(value), bytes});
    index_.emplace(key, lru_.begin());
    bytes_ += bytes;
    while (bytes_ > budget_) {
      bytes_ -= lru_.back().bytes;
      index_.erase(lru_.back().key);
      evicted.push_back(std::move(lru_.back().value));
      lru_.pop_back();
    }
  }

  std::size_t bytes() const {
    std::lock_guard lock(mutex_);
    return bytes_;
  }
  std::size_t size() const {
    std::lock_guard lock(mutex_);
    return lru_.size();
  }
  bool contains(const std::string& key) const {
    std::lock_guard lock(mutex_);
    return index_.contains(key);
  }
  /** The keys whose uses are counted (bounded by kMaxCountedKeys). */
  std::size_t countedKeys() const {
    std::lock_guard lock(mutex_);
    return counts_.size();
  }
  /** The counted uses of `key` (halved with age). */
  std::uint32_t uses(const std::string& key) const {
    std::lock_guard lock(mutex_);
    return frequency(key);
  }

  static constexpr std::size_t kMaxCountedKeys = 65536;
  static constexpr std::size_t kMinAgingPeriod = 1024;

private:
  struct Entry {
    std::string key;
    std::shared_ptr<const V> value;
    std::size_t bytes;
  };

  std::uint32_t frequency(const std::string& key) const {
    const auto it = counts_.find(key);
    return it == counts_.end() ? 0 : it->second;
  }

  void count(const std::string& key) {
    if (counts_.size() >= kMaxCountedKeys && !counts_.contains(key)) age();
    auto& c = counts_[key];
    if (c < UINT32_MAX) ++c;
    if (++uses_ >= std::max(kMinAgingPeriod, 10 * lru_.size())) age();
  }

  /** Halves every count (forgetting the keys at zero). */
  void age() {
    for (auto it = counts_.begin(); it != counts_.end();) {
      it->second /= 2;
      it = it->second == 0 ? counts_.erase(it) : std::next(it);
    }
    uses_ = 0;
  }

  mutable std::mutex mutex_;
  std::list<Entry> lru_;
  std::unordered_map<std::string, typename std::list<Entry>::iterator> index_;
  std::unordered_map<std::string, std::uint32_t> counts_;
  std::size_t uses_ = 0;
  std::size_t bytes_ = 0;
  std::size_t budget_;
};

} // namespace tellus
