#include <tellus/planet/TextureLru.hpp>

#include <utility>

namespace tellus::planet {

void TextureLru::beginFrame() noexcept {
  ++frame_;
  frameBytes_ = 0;
}

void TextureLru::use(const NodeKey& key) {
  const auto it = index_.find(key);
  if (it == index_.end()) return;
  Entry& e = *it->second;
  if (e.lastUsed != frame_) frameBytes_ += e.bytes;
  e.lastUsed = frame_;
  order_.splice(order_.begin(), order_, it->second);
}

void TextureLru::insert(const NodeKey& key, std::size_t bytes) {
  erase(key);
  order_.push_front({key, bytes, frame_});
  index_.emplace(key, order_.begin());
  bytes_ += bytes;
  frameBytes_ += bytes;
  evict();
}

void TextureLru::erase(const NodeKey& key) {
  const auto it = index_.find(key);
  if (it == index_.end()) return;
  bytes_ -= it->second->bytes;
  if (it->second->lastUsed == frame_) frameBytes_ -= it->second->bytes;
  order_.erase(it->second);
  index_.erase(it);
}

void TextureLru::evict() {
  while (bytes_ > budget_ && !order_.empty() && order_.back().lastUsed != frame_) {
    const Entry& e = order_.back();
    bytes_ -= e.bytes;
    evicted_.push_back(e.key);
    index_.erase(e.key);
    order_.pop_back();
  }
}

std::vector<NodeKey> TextureLru::takeEvicted() {
  return std::exchange(evicted_, {});
}

} // namespace tellus::planet
