#include "DrawList.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_set>
#include <utility>

namespace tellus::planet {

std::uint32_t DrawList::passes(std::uint32_t k) const {
  std::uint32_t most = 0;
  for (const DrawPart& p : parts)
    most = std::max(most, p.overlayEnd - p.overlayBegin);
  return std::max<std::uint32_t>(1, (most + k - 1) / k);
}

UvTransform regionToNodeUv(const Node& node, const Node& region, const UvTransform& regionUv) {
  if (&region == &node) return regionUv;
  const Sector& s = node.sector();
  const Sector& c = region.sector();
  const double w = s.east - s.west, h = s.north - s.south;
  const glm::dvec2 k{w / (c.east - c.west), h / (c.north - c.south)};
  const glm::dvec2 o{(c.west - s.west) / w, (c.south - s.south) / h};
  // uvRegion = (uvNode - o) * k, then the region's transform.
  UvTransform t;
  t.scale = k * regionUv.scale;
  t.offset = regionUv.offset - o * k * regionUv.scale;
  return t;
}

DrawPart partFor(const Node& node,
                 const Node& region,
                 const GlTexture& texture,
                 const UvTransform& regionUv) {
  DrawPart d{&node, &texture, regionUv, 0, 4};
  if (&region == &node) return d;
  const Sector& s = node.sector();
  const Sector& c = region.sector();
  d.uv = regionToNodeUv(node, region, regionUv);
  const bool south = c.south == s.south;
  const bool fullWidth = c.west == s.west && c.east == s.east;
  if (fullWidth) {
    d.firstQuadrant = south ? 0 : 2;
    d.lastQuadrant = d.firstQuadrant + 2;
  } else {
    d.firstQuadrant = (south ? 0 : 2) + (c.west == s.west ? 0 : 1);
    d.lastQuadrant = d.firstQuadrant + 1;
  }
  return d;
}

std::vector<std::optional<ValueScaleUniform>> valueScales(const LayerSet& layers) {
  std::vector<std::optional<ValueScaleUniform>> out(layers.size());
  for (std::size_t i = 0; i < layers.size(); ++i)
    if (const auto& v = layers[i].opt.values)
      out[i] = valueScaleUniform(colourScaleFor(*v, layers[i].dataRange));
  return out;
}

void updateDataRanges(LayerSet& layers) {
  for (LayerSlot& slot : layers.slots()) {
    if (!slot.opt.values || !slot.opt.values->rangeFromData) continue;
    const ValueLayerOptions& v = *slot.opt.values;
    LayerTextures& l = *slot.current;
    std::vector<float> samples;
    std::unordered_set<NodeKey, NodeKeyHash> seen;
    for (const Node* n : l.tree->drawList())
      for (const Node* a = n; a != nullptr; a = a->parent()) {
        const auto it = l.textures.find(a->key());
        if (it == l.textures.end()) continue;
        if (seen.insert(a->key()).second)
          samples.insert(samples.end(), it->second.sample.begin(), it->second.sample.end());
        break;
      }
    if (auto r = values::rangeFromData(
            samples, v.lowPercent, v.highPercent, v.scaling == values::Scaling::Log))
      slot.dataRange = r;
  }
}

void bindOverlays(const LayerSet& layers,
                  const Node& region,
                  DrawPart& part,
                  std::vector<OverlayBinding>& bindings,
                  const std::vector<std::optional<ValueScaleUniform>>& scales) {
  part.overlayBegin = static_cast<std::uint32_t>(bindings.size());
  for (std::size_t i = 1; i < layers.size(); ++i) {
    const LayerSlot& slot = layers[i];
    if (!slot.opt.visible || !(slot.opt.opacity > 0.0)) continue;
    LayerTextures& l = *slot.current;
    for (const Node* a = &region; a != nullptr; a = a->parent()) {
      if (a->level() >= l.grid.numLevels()) continue;
      const auto it = l.textures.find(a->key());
      if (it == l.textures.end()) continue;
      l.lru.use(a->key());
      bindings.push_back({&it->second.texture,
                          regionToNodeUv(*part.node, region, ancestorUv(region.key(), a->key())),
                          static_cast<float>(slot.opt.opacity),
                          slot.opt.night,
                          i < scales.size() ? scales[i] : std::nullopt});
      break;
    }
  }
  part.overlayEnd = static_cast<std::uint32_t>(bindings.size());
}

namespace {

/** What a part showed before its texture (of node `from`) arrived: the nearest ancestor of `from`
 * with a resident texture (marked used), else the global texture; its uv transform for the
 * region's coordinates in `uv`. */
const GlTexture* fadeSource(LayerTextures& base,
                            const GlTexture& global,
                            const Node& from,
                            const Node& region,
                            UvTransform& uv) {
  for (const Node* a = from.parent(); a != nullptr; a = a->parent()) {
    const auto it = base.textures.find(a->key());
    if (it == base.textures.end()) continue;
    base.lru.use(a->key());
    uv = ancestorUv(region.key(), a->key());
    return &it->second.texture;
  }
  uv = globalUv(region.sector());
  return &global;
}

/** The fade of a part drawn with `texture` (of node `from`): its weight at nowS, and what it
 * fades from while that is below 1 (fadeSource). */
void planFade(LayerTextures& base,
              const GlTexture& global,
              NodeTexture& texture,
              const Node& from,
              const Node& region,
              double nowS,
              double fadeInS,
              DrawList& list) {
  if (!(fadeInS > 0.0)) return;
  if (std::isnan(texture.shownSinceS)) texture.shownSinceS = nowS;
  const double f = (nowS - texture.shownSinceS) / fadeInS;
  if (f >= 1.0) return;
  DrawPart& part = list.parts.back();
  part.fade = static_cast<float>(std::clamp(f, 0.0, 1.0));
  UvTransform uv;
  part.fadeFrom = fadeSource(base, global, from, region, uv);
  part.fadeUv = regionToNodeUv(*part.node, region, uv);
  list.fading = true;
}

/** The nearest ancestor of `from` with a resident texture (null: none), and that texture. */
std::pair<const Node*, NodeTexture*> residentAncestor(LayerTextures& base, const Node& from) {
  for (const Node* a = from.parent(); a != nullptr; a = a->parent())
    if (const auto it = base.textures.find(a->key()); it != base.textures.end())
      return {a, &it->second};
  return {nullptr, nullptr};
}

bool stillFading(const NodeTexture& t, double nowS, double fadeInS) {
  return std::isnan(t.shownSinceS) || nowS - t.shownSinceS < fadeInS;
}

} // namespace

DrawList planDraw(const LayerSet& layers,
                  const GlTexture& global,
                  RenderStats& stats,
                  double nowS,
                  double fadeInS) {
  DrawList list;
  layers.forEach([](LayerTextures& l) {
    for (const auto& root : l.tree->roots())
      if (root) l.lru.use(root->key());
  });
  LayerTextures& base = layers.base();
  const auto scales = valueScales(layers);
  stats.mergedNodesDrawn = 0;
  for (const Node* n : layers.geo().drawList()) {
    if (n->key().span > 1) ++stats.mergedNodesDrawn;
    const TexturePlan plan = planTexture(*n);
    for (int i = 0; i < plan.partCount; ++i) {
      const TexturePart& p = plan.parts[static_cast<std::size_t>(i)];
      const GlTexture* texture = &global;
      NodeTexture* own = nullptr;
      UvTransform uv = p.uv;
      const Node* from = p.texture;
      if (p.source != TextureSource::Global && p.texture != nullptr) {
        if (auto it = base.textures.find(p.texture->key()); it != base.textures.end()) {
          own = &it->second;
          texture = &it->second.texture;
          base.lru.use(p.texture->key());
        } else {
          uv = globalUv(p.region->sector());
        }
      }
      // A texture not shown yet waits while what it would fade from is itself fading in: the part
      // keeps drawing that ancestor's fade, so a fade always starts from what was on screen.
      if (own != nullptr && fadeInS > 0.0 && std::isnan(own->shownSinceS)) {
        const auto [a, at] = residentAncestor(base, *from);
        if (a != nullptr && stillFading(*at, nowS, fadeInS)) {
          from = a;
          own = at;
          texture = &at->texture;
          uv = ancestorUv(p.region->key(), a->key());
          base.lru.use(a->key());
        }
      }
      list.parts.push_back(partFor(*n, *p.region, *texture, uv));
      if (own != nullptr) planFade(base, global, *own, *from, *p.region, nowS, fadeInS, list);
      bindOverlays(layers, *p.region, list.parts.back(), list.bindings, scales);
    }
  }
  return list;
}

bool drawsWhatLodAsks(const LayerSet& layers,
                      const FrameStats& tree,
                      const std::function<bool(const Node&)>& heightsDone) {
  bool complete = tree.splitsDeferred == 0;
  for (std::size_t i = 0; i < layers.size(); ++i) {
    const LayerSlot& slot = layers[i];
    complete = complete && !slot.pending;
    if (i == 0 || !slot.opt.visible) continue;
    const LayerTextures& l = *slot.current;
    for (const Node* n : l.tree->drawList())
      complete = complete && l.done(*n);
  }
  const LayerTextures& base = layers.base();
  for (const Node* n : layers.geo().drawList()) {
    complete = complete && base.done(*n);
    complete = complete && heightsDone(*n);
  }
  return complete;
}

} // namespace tellus::planet
