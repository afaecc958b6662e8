#include <tellus/planet/TextureFallback.hpp>

#include <cmath>

namespace tellus::planet {

UvTransform ancestorUv(const NodeKey& node, const NodeKey& ancestor) noexcept {
  const int k = node.level - ancestor.level;
  // In the node's level: the ancestor spans [ancestor.col * 2^k, (col + span) * 2^k) columns and
  // one row of 2^k rows. Integers below 2^53 and powers of two: every step is exact.
  const double cols = std::ldexp(static_cast<double>(ancestor.span), k);
  const double rows = std::ldexp(1.0, k);
  const double colStart = std::ldexp(static_cast<double>(ancestor.col), k);
  const double rowStart = std::ldexp(static_cast<double>(ancestor.row), k);
  UvTransform t;
  t.scale = {static_cast<double>(node.span) / cols, 1.0 / rows};
  t.offset = {(static_cast<double>(node.col) - colStart) / cols,
              (static_cast<double>(node.row) - rowStart) / rows};
  return t;
}

UvTransform globalUv(const Sector& s) noexcept {
  UvTransform t;
  t.scale = {(s.east - s.west) / 360.0, (s.north - s.south) / 180.0};
  t.offset = {(s.west + 180.0) / 360.0, (s.south + 90.0) / 180.0};
  return t;
}

namespace {

bool ready(const Node& n) noexcept {
  return n.texture == TextureState::Finished;
}

/** The nearest ready ancestor of `from` (inclusive) or the global texture, for `region`. */
TexturePart fallback(const Node& region, const Node* from) noexcept {
  for (const Node* a = from; a != nullptr; a = a->parent())
    if (ready(*a)) return {&region, TextureSource::Ancestor, a, ancestorUv(region.key(), a->key())};
  return {&region, TextureSource::Global, nullptr, globalUv(region.sector())};
}

} // namespace

TexturePlan planTexture(const Node& node) noexcept {
  TexturePlan plan;
  if (ready(node)) {
    plan.partCount = 1;
    plan.parts[0] = {&node, TextureSource::Own, &node, UvTransform{}};
    return plan;
  }
  // A cap's children (the next cap and a ring of up to twenty nodes) are not drawn as its parts:
  // it shows its nearest ready ancestor, a cap as well, or the global texture.
  bool anyChildReady = false;
  for (int s = 0; s < (node.isCap() ? 0 : 4); ++s)
    if (const Node* c = node.child(s); c && ready(*c)) anyChildReady = true;
  if (anyChildReady) {
    plan.drawnInParts = true;
    for (int s = 0; s < 4; ++s) {
      const Node* c = node.child(s);
      if (c == nullptr) continue;
      TexturePart& part = plan.parts[static_cast<std::size_t>(plan.partCount++)];
      if (ready(*c)) {
        part = {c, TextureSource::Own, c, UvTransform{}};
      } else {
        part = fallback(*c, node.parent());
        plan.mixed = true;
      }
    }
    return plan;
  }
  plan.partCount = 1;
  plan.parts[0] = fallback(node, node.parent());
  return plan;
}

bool overviewSuffices(const Node& node, double factor) noexcept {
  return factor > 0.0 && node.level() == 0 && node.drawnTexelRatioSquared() > 0.0 &&
         node.drawnTexelRatioSquared() * factor * factor <= 1.0;
}

} // namespace tellus::planet
