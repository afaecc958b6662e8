#include "ViewerAnimation.hpp"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <cstdio>

namespace tellus::planet {

std::optional<std::size_t> animatedLayerFor(const Renderer& renderer, std::size_t selected) {
  if (renderer.layerAnimation(selected) != nullptr) return selected;
  for (std::size_t i = 0; i < renderer.layerCount(); ++i)
    if (renderer.layerAnimation(i) != nullptr) return i;
  return std::nullopt;
}

bool animationKey(Renderer& renderer, std::size_t selected, int glfwKey) {
  std::optional<std::size_t> layer;
  if (glfwKey == GLFW_KEY_SPACE) {
    layer = animatedLayerFor(renderer, selected);
    if (!layer) return false;
    renderer.toggleLayerAnimation(*layer);
  } else if (glfwKey == GLFW_KEY_LEFT_BRACKET || glfwKey == GLFW_KEY_RIGHT_BRACKET) {
    if (renderer.layerAnimation(selected) == nullptr) return false;
    layer = selected;
    renderer.stepLayerAnimation(selected, glfwKey == GLFW_KEY_RIGHT_BRACKET ? 1 : -1);
  } else {
    return false;
  }
  const TimeAnimation& a = *renderer.layerAnimation(*layer);
  std::printf("animation of layer %zu: %s, time %s (%zu of %zu)\n",
              *layer,
              playStateName(a.state()),
              a.target().c_str(),
              a.targetIndex() + 1,
              a.instants().size());
  std::fflush(stdout);
  return true;
}

bool animationRuns(const Renderer& renderer) {
  for (std::size_t i = 0; i < renderer.layerCount(); ++i)
    if (const TimeAnimation* a = renderer.layerAnimation(i))
      if (a->state() == PlayState::Playing || a->state() == PlayState::Holding) return true;
  return false;
}

std::string animationStatus(const Renderer& renderer) {
  std::string out;
  const auto& layers = renderer.stats().layers;
  for (std::size_t i = 0; i < renderer.layerCount() && i < layers.size(); ++i) {
    const TimeAnimation* a = renderer.layerAnimation(i);
    if (a == nullptr) continue;
    out += "  " + layers[i].name + " " + layers[i].time + " " + playStateName(a->state());
  }
  return out;
}

} // namespace tellus::planet
