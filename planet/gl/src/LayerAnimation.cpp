#include "LayerAnimation.hpp"

#include <vector>

namespace tellus::planet {

void stepAnimations(LayerSet& layers, double nowS) {
  for (std::size_t i = 0; i < layers.size(); ++i) {
    LayerSlot& slot = layers[i];
    if (!slot.animation) continue;
    const std::string want = slot.animation->update(nowS, slot.current->time);
    const std::string& asked = slot.pending ? slot.pending->time : slot.current->time;
    if (want != asked) layers.setTime(i, want); // the current time cancels a pending one
  }
}

void fetchAhead(LayerSet& layers) {
  for (LayerSlot& slot : layers.slots()) {
    if (!slot.animation || !slot.prefetch) continue;
    const LayerTextures& l = slot.pending ? *slot.pending : *slot.current;
    const std::vector<std::string> ahead =
        slot.animation->state() == PlayState::Ended
            ? std::vector<std::string>{}
            : slot.animation->ahead(slot.animation->options().fetchAhead);
    slot.prefetch->followNodeTiles(l.streamer->nodeTiles()); // its fallback (NodeTiles.hpp)
    slot.prefetch->update(*l.tree, ahead);
  }
}

void observeAnimations(LayerSet& layers, double nowS) {
  for (LayerSlot& slot : layers.slots())
    if (slot.animation) slot.animation->observe(nowS, slot.current->time);
}

} // namespace tellus::planet
