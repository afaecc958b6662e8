#pragma once
/**
 * @file DrawList.hpp
 * @brief What a frame draws (GL-free planning, between the upload of textures and the draw):
 * for each node of the base layer's draw list its TexturePlan (thesis 4.4: its own texture, its
 * children's with the node's geometry drawn in parts, an ancestor's, or the global texture), and
 * over each part the overlays' textures. Geometry is therefore always the draw list's, which is
 * what edge fixing reasons about. Textures are referred to, not owned: a DrawList lives for one
 * frame, during which no texture it names is deleted (what it names is marked used in the LRUs
 * before anything new is inserted, so nothing it draws is evicted this frame).
 */

#include "GlObjects.hpp"
#include "LayerSet.hpp"
#include "ValueTexture.hpp"

#include <tellus/planet/Quadtree.hpp>
#include <tellus/planet/TextureFallback.hpp>

#include <cstdint>
#include <functional>
#include <vector>

namespace tellus::planet {

/** What one draw call draws: a range of a drawn node's triangles (all of it, or the quarter or
 * half under one child whose texture it shows) with a texture through a uv transform of the
 * node's own texture coordinates. */
struct DrawPart {
  const Node* node = nullptr;
  const GlTexture* texture = nullptr;
  UvTransform uv;
  int firstQuadrant = 0; ///< quadrant ranges [first, last) of GpuMesh::quadrantStart
  int lastQuadrant = 4;
  std::uint32_t overlayBegin = 0; ///< its overlays: DrawList::bindings[overlayBegin, overlayEnd)
  std::uint32_t overlayEnd = 0;
  /** Fade-in (RendererOptions::fadeInSeconds): the base colour is mix(fadeFrom through fadeUv,
   * texture through uv, fade); fade = 1 (no fadeFrom) draws the texture alone. */
  float fade = 1.0f;
  const GlTexture* fadeFrom = nullptr;
  UvTransform fadeUv{};
};

/** One overlay's texture on a drawn part: the texture, the transform of the node's coordinates
 * into it, the layer's opacity, whether it is a night layer (LayerOptions::night: shown on
 * the dark side only, as light), and for a layer of values its colour scale (issue 24). */
struct OverlayBinding {
  const GlTexture* texture = nullptr;
  UvTransform uv;
  float opacity = 0.0f;
  bool night = false;
  std::optional<ValueScaleUniform> values; ///< a layer of values: texture holds floats
};

/** The colour scale of each layer of values at this frame (by slot; nullopt for imagery): its
 * options and, for `range: data`, slot.dataRange. */
std::vector<std::optional<ValueScaleUniform>> valueScales(const LayerSet& layers);

/** `range: data` (ValueLayerOptions::rangeFromData): each such layer's dataRange from the
 * samples of the textures its drawn nodes show (the node's own, else its nearest resident
 * ancestor's; each texture once): bounded by the draw list's size times kDataRangeSample. A
 * layer with nothing resident keeps the range it had. */
void updateDataRanges(LayerSet& layers);

struct DrawList {
  std::vector<DrawPart> parts;
  std::vector<OverlayBinding> bindings;
  bool fading = false; ///< some part's fade is below 1: the frame is not complete
  /** Draw passes the parts need with k overlay textures a pass: pass 0 the base and the first k
   * overlays of each part, pass j the parts with more, the next k (at least 1). */
  std::uint32_t passes(std::uint32_t k) const;
};

/** uvNode -> uvTexture, given uvRegion -> uvTexture, for a region that is the node or a child. */
UvTransform regionToNodeUv(const Node& node, const Node& region, const UvTransform& regionUv);

/** The part of `node` under `region` (the node itself or one of its children): which quadrant
 * ranges, and the uv transform for the node's coordinates given the one for region's. */
DrawPart partFor(const Node& node,
                 const Node& region,
                 const GlTexture& texture,
                 const UvTransform& regionUv);

/** The overlays over one drawn part (the node, or the child region whose texture it shows): each
 * visible overlay's texture of the region, else of its nearest ancestor that has one (the
 * ancestor's area through an exact uv transform), marked used in its LRU. An overlay with nothing
 * there yet is skipped: what lies under it shows. */
void bindOverlays(const LayerSet& layers,
                  const Node& region,
                  DrawPart& part,
                  std::vector<OverlayBinding>& bindings,
                  const std::vector<std::optional<ValueScaleUniform>>& scales = {});

/** The frame's draw list (see the file comment): every layer's resident roots marked used (once
 * fetched, a level-zero texture stays resident like the global texture: the fallback of every
 * node under it), then each drawn node's parts with the base layer's textures (marked
 * used) or the global one, and their overlays. Counts stats.mergedNodesDrawn.
 * Fading (fadeInS > 0): a base texture first drawn at frame time t0 (set now, when first drawn)
 * is drawn with fade = (nowS - t0) / fadeInS (clamped to [0, 1]) over what the part showed
 * before: the nearest ancestor of its texture's node with a resident texture (marked used), or the
 * global texture. A texture not yet shown waits (the part draws that ancestor's fade) while the
 * ancestor it would fade from is itself fading in, so every fade starts from what was on screen. */
DrawList planDraw(const LayerSet& layers,
                  const GlTexture& global,
                  RenderStats& stats,
                  double nowS = 0.0,
                  double fadeInS = 0.0);

/** The frame shows what its LOD asks for: no split deferred, no layer switching time, every
 * visible overlay's and the base layer's drawn nodes done (LayerTextures::done), and the heights
 * every drawn node needs in (heightsDone). */
bool drawsWhatLodAsks(const LayerSet& layers,
                      const FrameStats& tree,
                      const std::function<bool(const Node&)>& heightsDone);

} // namespace tellus::planet
