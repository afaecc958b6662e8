#pragma once
/**
 * @file TextureFallback.hpp
 * @brief Which texture a drawn node uses while its own is not ready (thesis 4.4): the children's
 * textures (the node drawn in parts), then the nearest ancestor's with recomputed texture
 * coordinates, then the always-resident global texture; mixed when only some children are
 * ready. Pure functions of the tree's texture states; no GL.
 */

#include <tellus/planet/Quadtree.hpp>

#include <glm/vec2.hpp>

#include <array>

namespace tellus::planet {

/** uvTexture = uvNode * scale + offset (u east, v north, both 0..1 across the node). Computed in
 * double; exact for ancestors (integers and powers of two), so it stays right 20+ levels up. */
struct UvTransform {
  glm::dvec2 scale{1.0};
  glm::dvec2 offset{0.0};
  glm::dvec2 apply(const glm::dvec2& uvNode) const noexcept { return uvNode * scale + offset; }
};

/** Where `node`'s area lies in `ancestor`'s texture. Precondition: ancestor covers node (a
 * proper ancestor in the tree, or the same key). */
UvTransform ancestorUv(const NodeKey& node, const NodeKey& ancestor) noexcept;
/** Where a sector lies in the global texture: ((lon + 180) / 360, (lat + 90) / 180). */
UvTransform globalUv(const Sector& sector) noexcept;

enum class TextureSource : std::uint8_t { Own, Ancestor, Global };

/** One part of a drawn node: the area of `region` (the node itself, or one of its children)
 * drawn with `texture`'s texture (null for the global one) through `uv`. */
struct TexturePart {
  const Node* region = nullptr;
  TextureSource source = TextureSource::Global;
  const Node* texture = nullptr;
  UvTransform uv{};
};

struct TexturePlan {
  int partCount = 0;
  std::array<TexturePart, 4> parts{};
  bool drawnInParts = false; ///< the children's areas, at least one with its own texture
  bool mixed = false;        ///< in parts, and some part falls back to an ancestor or global
};

/** Ready means TextureState::Finished. */
TexturePlan planTexture(const Node& node) noexcept;

/** Whether a drawn root may show the global texture instead of its own (issue 29): the global
 * texture is an overview of the layer `factor` times coarser than level zero (texel size over
 * level zero's; <= 0: no overview) and its texels on screen, the node's own times factor, stay
 * within the LOD threshold. Then the root's own tiles are not fetched: a whole-globe view costs
 * the overview's texels, not level zero's. False below level zero. */
bool overviewSuffices(const Node& node, double factor) noexcept;

} // namespace tellus::planet
