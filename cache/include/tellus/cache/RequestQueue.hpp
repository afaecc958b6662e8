#pragma once
/**
 * @file RequestQueue.hpp
 * @brief The priority queue behind every ITileSource: highest priority first, equal priorities in
 * arrival order, with cancel and reprioritize by id. Not thread safe: its owner locks.
 */

#include <tellus/cache/TileSource.hpp>

#include <cstdint>
#include <map>
#include <optional>
#include <unordered_map>
#include <utility>

namespace tellus {

template <class Job> class RequestQueue {
public:
  /** Adds a job; returns its id (never 0). */
  TileRequestId push(double priority, Job job) {
    const TileRequestId id = nextId_++;
    entries_.emplace(id, Entry{std::move(job), priority});
    order_.emplace(Key{priority, id}, id);
    return id;
  }
  /** Takes the job that runs next. */
  std::optional<std::pair<TileRequestId, Job>> pop() {
    if (order_.empty()) return std::nullopt;
    const auto first = order_.begin();
    const TileRequestId id = first->second;
    order_.erase(first);
    auto it = entries_.find(id);
    std::pair<TileRequestId, Job> out{id, std::move(it->second.job)};
    entries_.erase(it);
    return out;
  }
  /** True when the job was still queued (it is dropped). */
  bool cancel(TileRequestId id) {
    const auto it = entries_.find(id);
    if (it == entries_.end()) return false;
    order_.erase(Key{it->second.priority, id});
    entries_.erase(it);
    return true;
  }
  void reprioritize(TileRequestId id, double priority) {
    const auto it = entries_.find(id);
    if (it == entries_.end()) return;
    order_.erase(Key{it->second.priority, id});
    it->second.priority = priority;
    order_.emplace(Key{priority, id}, id);
  }
  std::size_t size() const noexcept { return entries_.size(); }
  bool empty() const noexcept { return entries_.empty(); }
  void clear() {
    order_.clear();
    entries_.clear();
  }

private:
  // Ids grow with arrival, so (priority descending, id ascending) is the run order.
  using Key = std::pair<double, TileRequestId>;
  struct KeyLess {
    bool operator()(const Key& a, const Key& b) const {
      return a.first != b.first ? a.first > b.first : a.second < b.second;
    }
  };
  struct Entry {
    Job job;
    double priority;
  };
  TileRequestId nextId_ = 1;
  std::map<Key, TileRequestId, KeyLess> order_;
  std::unordered_map<TileRequestId, Entry> entries_;
};

} // namespace tellus
