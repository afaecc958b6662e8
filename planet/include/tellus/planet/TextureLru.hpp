#pragma once
/**
 * @file TextureLru.hpp
 * @brief GPU texture memory accounting without GL (thesis 4.7.1 with a byte budget): which node
 * textures are resident, least recently drawn first out. What the current frame draws is never
 * evicted; when the frame alone needs more than the budget, that is reported (overBudget()).
 */

#include <tellus/planet/Quadtree.hpp>

#include <cstddef>
#include <cstdint>
#include <list>
#include <unordered_map>
#include <vector>

namespace tellus::planet {

class TextureLru {
public:
  explicit TextureLru(std::size_t budgetBytes) : budget_(budgetBytes) {}

  /** Starts a frame: nothing is "used this frame" any more. */
  void beginFrame() noexcept;
  bool resident(const NodeKey& key) const noexcept { return index_.contains(key); }
  /** Marks a resident texture drawn this frame (no-op when not resident). */
  void use(const NodeKey& key);
  /** Adds (or resizes) a resident texture, marks it used this frame and evicts least recently
   * used textures not used this frame until the budget holds. */
  void insert(const NodeKey& key, std::size_t bytes);
  /** Drops a texture (its node went away, say). */
  void erase(const NodeKey& key);

  std::size_t bytes() const noexcept { return bytes_; }
  std::size_t budget() const noexcept { return budget_; }
  std::size_t count() const noexcept { return index_.size(); }
  /** Bytes of the textures used this frame. */
  std::size_t frameBytes() const noexcept { return frameBytes_; }
  /** This frame alone needs more than the budget (then bytes() > budget()). */
  bool overBudget() const noexcept { return bytes_ > budget_; }
  /** Keys evicted since the last call (the GL layer frees or recycles their textures). */
  std::vector<NodeKey> takeEvicted();

private:
  struct Entry {
    NodeKey key;
    std::size_t bytes;
    std::uint64_t lastUsed;
  };
  void evict();
  std::size_t budget_;
  std::size_t bytes_ = 0;
  std::size_t frameBytes_ = 0;
  std::uint64_t frame_ = 1;
  std::list<Entry> order_; // most recently used first
  std::unordered_map<NodeKey, std::list<Entry>::iterator, NodeKeyHash> index_;
  std::vector<NodeKey> evicted_;
};

} // namespace tellus::planet
