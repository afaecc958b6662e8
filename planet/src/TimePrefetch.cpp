#include <tellus/planet/TimePrefetch.hpp>

#include <algorithm>
#include <mutex>
#include <utility>
#include <vector>

namespace tellus::planet {

struct TimePrefetcher::Inbox {
  std::mutex mutex;
  std::vector<std::pair<std::uint64_t, TileResult>> done;
};

TimePrefetcher::TimePrefetcher(ITileSource& source, PrefetchParams params)
    : source_(source), params_(std::move(params)), inbox_(std::make_shared<Inbox>()) {
  params_.maxInFlight = std::max<std::size_t>(1, params_.maxInFlight);
}

TimePrefetcher::~TimePrefetcher() {
  for (auto& [time, tiles] : times_)
    for (auto& [key, e] : tiles)
      if (e.open) source_.cancel(e.id);
}

void TimePrefetcher::drain() {
  std::vector<std::pair<std::uint64_t, TileResult>> done;
  {
    std::lock_guard lock(inbox_->mutex);
    done.swap(inbox_->done);
  }
  for (auto& [token, result] : done) {
    const auto it = byToken_.find(token);
    if (it == byToken_.end()) continue; // cancelled after it ran
    const auto t = times_.find(it->second.first);
    if (t != times_.end())
      if (auto e = t->second.find(it->second.second); e != t->second.end()) e->second.open = false;
    if (result.status == TileStatus::Failed) nodeTiles_.refused(it->second.second, true);
    byToken_.erase(it);
    --stats_.inFlight;
    switch (result.status) {
    case TileStatus::Ok:
      ++stats_.received;
      stats_.bytes += result.bytes.size();
      break;
    case TileStatus::Absent:
      ++stats_.absent;
      break;
    case TileStatus::Failed:
      ++stats_.failed;
      break;
    }
  }
}

void TimePrefetcher::update(const Quadtree& tree, std::span<const std::string> times) {
  drain();
  // Times no longer ahead: their queued requests cancelled, their tiles forgotten.
  for (auto it = times_.begin(); it != times_.end();) {
    if (std::find(times.begin(), times.end(), it->first) != times.end()) {
      ++it;
      continue;
    }
    for (auto& [key, e] : it->second) {
      if (!e.open) continue;
      byToken_.erase(e.token);
      --stats_.inFlight;
      if (source_.cancel(e.id)) ++stats_.cancelled;
      // A callback that runs anyway finds no token: it is not counted twice.
    }
    it = times_.erase(it);
  }
  stats_.wanted = 0;
  stats_.settled = 0;
  for (const std::string& time : times) {
    TimeTiles& tiles = times_[time];
    for (const Node* n : tree.drawList()) {
      for (std::int64_t i = 0; i < nodeTiles_.count(n->key()); ++i) {
        const TileKey key = nodeTiles_.tile(n->key(), i);
        ++stats_.wanted;
        if (const auto e = tiles.find(key); e != tiles.end()) {
          if (!e->second.open) ++stats_.settled;
          continue;
        }
        if (stats_.inFlight >= params_.maxInFlight) continue;
        const std::uint64_t token = nextToken_++;
        Entry& e = tiles[key];
        e.token = token;
        byToken_.emplace(token, std::pair{time, key});
        ++stats_.inFlight;
        ++stats_.requested;
        stats_.maxInFlightSeen = std::max(stats_.maxInFlightSeen, stats_.inFlight);
        std::weak_ptr<Inbox> weak = inbox_;
        e.id = source_.request(nodeTiles_.address(params_.layer, time, key),
                               params_.priority,
                               [weak, token](TileResult&& r) {
                                 if (auto inbox = weak.lock()) {
                                   std::lock_guard lock(inbox->mutex);
                                   inbox->done.emplace_back(token, std::move(r));
                                 }
                               });
      }
    }
  }
}

} // namespace tellus::planet
