#pragma once
/**
 * @file NodeTextures.hpp
 * @brief Textures of nodes: how one is made (RGBA8, every mip level down to 1 x 1, immutable
 * storage where the GL has it), the pool of a layer's free ones, and the global texture (the
 * always-resident last fallback). Main thread, context current (GlObjects.hpp).
 */

#include "GlObjects.hpp"

#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <vector>

namespace tellus::planet {

/** How node textures are made on this GL: glTexStorage2D (4.2 or ARB_texture_storage), and the
 * anisotropic filtering asked for (1: off; already capped by the GL). */
struct NodeTextureFormat {
  bool storage = false;
  float anisotropy = 1.0f;
  /** A layer of values (issue 24): one level of R32F, nearest filtering (ValueTexture.hpp). */
  bool values = false;
};

/** The mip levels of a width x height texture: every level down to 1 x 1, as the decoder builds
 * them. */
int nodeTextureLevels(int width, int height) noexcept;

/** A new node texture of that size with all its levels allocated, linear-mipmap filtered,
 * clamped at its edges (format.values: one R32F level, nearest). Left bound to GL_TEXTURE_2D. */
GlTexture makeNodeTexture(int width, int height, const NodeTextureFormat& format);

/** A node texture and whether it is wider than its layer's tiles (a polar cap's: never pooled). */
struct NodeTexture {
  GlTexture texture{NoCreate};
  bool wide = false;
  /** The frame time (RendererOptions::frameClock, s) it was first drawn at, for its fade-in; NaN:
   * not drawn yet; -infinity: shown at once (no fade: a layer time swapped in whole). */
  double shownSinceS = std::numeric_limits<double>::quiet_NaN();
  /** A layer of values: a bounded sample of its finite values (`range: data`), and the texture's
   * floats kept on the CPU (rows from the south, 4 bytes each; width x height) for the value
   * under the cursor (Renderer::layerValueAt). */
  std::vector<float> sample{};
  std::vector<std::uint8_t> values{};
  int width = 0, height = 0;
};

/** The free node textures of one layer. Every node texture of a layer has its grid's tile size
 * (but a polar cap's), so any freed one fits the next node: evicted textures wait here (up to
 * kMaxFree) and are reused before a new one is made. */
class TexturePool {
public:
  static constexpr std::size_t kMaxFree = 64;
  /** A texture for a width x height image of a layer whose tiles are tileWidth x tileHeight: a
   * free one when the sizes agree and one is free (then ++*reused), else a new one. */
  NodeTexture acquire(int width,
                      int height,
                      int tileWidth,
                      int tileHeight,
                      const NodeTextureFormat& format,
                      std::size_t* reused);
  /** A texture no longer drawn: kept for reuse, or deleted when wide or the pool is full. */
  void release(NodeTexture texture);
  std::size_t size() const noexcept { return free_.size(); }

private:
  std::vector<GlTexture> free_;
};

struct MipLevel;

/** The global texture from an equirectangular JPEG/PNG of the whole globe (north up, -180 at the
 * left; CPU mip levels, wrapping east-west); `flat` (a dark blue) when the path is empty or the
 * file unreadable. Left bound to GL_TEXTURE_2D. */
GlTexture makeGlobalTexture(const std::filesystem::path& image,
                            std::array<std::uint8_t, 3> flat = {10, 20, 60});
/** The same from an image already in memory (rows from the south; empty: dark blue). */
GlTexture makeGlobalTexture(MipLevel base);

} // namespace tellus::planet
