#include "FrameUpdate.hpp"

namespace tellus::planet {

FrameStats updateLayers(LayerSet& layers, const Camera& camera, double nowS) {
  const FrameStats fs = layers.geo().update(camera);
  for (std::size_t i = 0; i < layers.size(); ++i) {
    LayerSlot& slot = layers[i];
    const bool shown = i == 0 || slot.opt.visible;
    for (LayerTextures* l : {slot.current.get(), slot.pending.get()}) {
      if (l == nullptr) continue;
      const bool isPending = l == slot.pending.get();
      l->updated = shown && (isPending || !slot.pending);
      if (!l->updated && !(i == 0 && !isPending)) continue;
      if (l != &layers.base()) l->tree->update(camera);
      l->lru.beginFrame();
      if (l->updated) l->streamer->update(*l->tree, camera, nowS, &l->lru);
    }
  }
  return fs;
}

} // namespace tellus::planet
