#include <tellus/planet/Quadtree.hpp>

#include <algorithm>

namespace tellus::planet {

namespace {

/** A key's extent in rows and columns of a finer (or equal) level. */
struct Extent {
  std::int64_t r0, r1, c0, c1;
};

Extent extentAt(const NodeKey& k, std::int32_t level) noexcept {
  const int shift = level - k.level;
  return {k.row << shift, (k.row + 1) << shift, k.col << shift, (k.col + k.span) << shift};
}

Direction opposite(Direction d) noexcept {
  switch (d) {
  case Direction::North:
    return Direction::South;
  case Direction::South:
    return Direction::North;
  case Direction::East:
    return Direction::West;
  case Direction::West:
    return Direction::East;
  }
  return Direction::North;
}

constexpr std::array<Direction, 4> kDirections{
    Direction::North, Direction::East, Direction::South, Direction::West};

} // namespace

Node* Quadtree::rootContaining(std::int32_t level,
                               std::int64_t row,
                               std::int64_t col) const noexcept {
  const std::int64_t r = row >> level, c = col >> level;
  if (r < 0 || c < 0 || c >= rootCols_ || r >= grid_.rowCount(0)) return nullptr;
  if (isCapKey({0, r, 0, rootCols_})) return roots_[static_cast<std::size_t>(r * rootCols_)].get();
  return roots_[static_cast<std::size_t>(r * rootCols_ + c)].get();
}

Node* Quadtree::findNeighbour(const Node& node, Direction d) const noexcept {
  const NodeKey& k = node.key_;
  const std::int32_t L = k.level;
  const std::int64_t cols = grid_.colCount(L);
  std::int64_t row = k.row, c0 = k.col, c1 = k.col + k.span;
  switch (d) {
  case Direction::North:
    if (k.row + 1 >= grid_.rowCount(L)) return nullptr; // across the pole: none
    row = k.row + 1;
    break;
  case Direction::South:
    if (k.row == 0) return nullptr;
    row = k.row - 1;
    break;
  case Direction::East:
    c0 = (k.col + k.span) % cols;
    c1 = c0 + 1;
    break;
  case Direction::West:
    c0 = (k.col - 1 + cols) % cols;
    c1 = c0 + 1;
    break;
  }
  auto covers = [&](const Node& n) {
    const Extent e = extentAt(n.key_, L);
    return e.r0 <= row && row < e.r1 && e.c0 <= c0 && c1 <= e.c1;
  };
  Node* n = rootContaining(L, row, c0);
  if (n == nullptr || !covers(*n)) return nullptr;
  for (;;) {
    Node* next = nullptr;
    for (const auto& ch : n->children_)
      if (ch && ch->key_.level <= L && covers(*ch)) {
        next = ch.get();
        break;
      }
    if (next == nullptr) break;
    n = next;
  }
  // Covering the edge from inside an ancestor means the nodes across are narrower than this one
  // (equatorward of a merged polar row): no single neighbour.
  const Extent self = extentAt(k, L);
  const Extent e = extentAt(n->key_, L);
  if (e.r0 <= self.r0 && self.r1 <= e.r1 && e.c0 <= self.c0 && self.c1 <= e.c1) return nullptr;
  return n;
}

void Quadtree::linkNeighbours(Node& node) noexcept {
  for (Direction d : kDirections)
    node.neighbours_[static_cast<std::size_t>(d)] = findNeighbour(node, d);
}

bool Quadtree::borders(const Node& q, const Node& p, Direction side) const noexcept {
  const std::int32_t M = std::max(q.key_.level, p.key_.level);
  const Extent a = extentAt(p.key_, M), b = extentAt(q.key_, M);
  const std::int64_t cols = grid_.colCount(M);
  const bool colsOverlap = std::max(a.c0, b.c0) < std::min(a.c1, b.c1);
  const bool rowsOverlap = std::max(a.r0, b.r0) < std::min(a.r1, b.r1);
  switch (side) {
  case Direction::North:
    return b.r0 == a.r1 && colsOverlap;
  case Direction::South:
    return b.r1 == a.r0 && colsOverlap;
  case Direction::East:
    return b.c0 == a.c1 % cols && rowsOverlap;
  case Direction::West:
    return b.c1 % cols == a.c0 && rowsOverlap;
  }
  return false;
}

void Quadtree::relinkBorderingIn(Node& n, const Node& around, Direction side) noexcept {
  // n intersects the one-cell-wide strip (at the deepest level) just across around's edge?
  const std::int32_t M = grid_.numLevels() - 1;
  const Extent a = extentAt(around.key_, M), b = extentAt(n.key_, M);
  const std::int64_t cols = grid_.colCount(M);
  bool hit = false;
  switch (side) {
  case Direction::North:
    hit = b.r0 <= a.r1 && a.r1 < b.r1 && std::max(a.c0, b.c0) < std::min(a.c1, b.c1);
    break;
  case Direction::South:
    hit = b.r0 <= a.r0 - 1 && a.r0 - 1 < b.r1 && std::max(a.c0, b.c0) < std::min(a.c1, b.c1);
    break;
  case Direction::East: {
    const std::int64_t c = a.c1 % cols;
    hit = b.c0 <= c && c < b.c1 && std::max(a.r0, b.r0) < std::min(a.r1, b.r1);
    break;
  }
  case Direction::West: {
    const std::int64_t c = (a.c0 - 1 + cols) % cols;
    hit = b.c0 <= c && c < b.c1 && std::max(a.r0, b.r0) < std::min(a.r1, b.r1);
    break;
  }
  }
  if (!hit) return;
  if (n.key_.level >= around.key_.level && borders(n, around, side)) {
    const Direction back = opposite(side);
    n.neighbours_[static_cast<std::size_t>(back)] = findNeighbour(n, back);
  }
  for (auto& ch : n.children_)
    if (ch) relinkBorderingIn(*ch, around, side);
}

void Quadtree::relinkAround(const Node& node) noexcept {
  for (Direction d : kDirections)
    for (auto& r : roots_)
      if (r) relinkBorderingIn(*r, node, d);
}

} // namespace tellus::planet
