// The Renderer's layer methods (Renderer.hpp): the layer set's own rules (LayerSet.hpp) and time
// that plays (LayerAnimation.hpp); a change that drops textures needs the context.

#include "LayerAnimation.hpp"
#include "RendererImpl.hpp"
#include "ValueTexture.hpp"

#include <tellus/values/ColourMap.hpp>
#include <tellus/values/ColourScale.hpp>

#include <chrono>
#include <stdexcept>
#include <utility>

namespace tellus::planet {

double Renderer::Impl::frameClockNow() const {
  if (opt.frameClock) return opt.frameClock();
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Layers: the set's own rules (LayerSet.hpp); a change that drops textures needs the context.
std::size_t Renderer::layerCount() const noexcept {
  return impl_->layers.size();
}
void Renderer::setLayerOpacity(std::size_t layer, double opacity) {
  impl_->layers.setOpacity(layer, opacity);
}
void Renderer::setLayerVisible(std::size_t layer, bool visible) {
  impl_->layers.setVisible(layer, visible);
}
void Renderer::setLayerMaxLevel(std::size_t layer, int maxLevel) {
  impl_->context->makeCurrent();
  impl_->layers.setMaxLevel(layer, maxLevel);
}
std::optional<ValueLayerOptions> Renderer::layerValues(std::size_t layer) const {
  if (layer >= impl_->layers.size()) return std::nullopt;
  return impl_->layers[layer].opt.values;
}

void Renderer::setLayerValues(std::size_t layer, const ValueLayerOptions& v) {
  if (layer >= impl_->layers.size() || !impl_->layers[layer].opt.values)
    throw std::invalid_argument("only a layer of values has a colour scale");
  values::ColourScale s{values::findColourMap(v.colourMap), v.min, v.max, v.scaling, v.outOfRange};
  if (auto ok = values::checkScale(s); !ok) throw std::invalid_argument(ok.error());
  if (!(v.min < v.max)) throw std::invalid_argument("the range must be min < max");
  ValueLayerOptions& now = *impl_->layers[layer].opt.values;
  const values::ValueFormat format = now.format; // the tiles' format never changes here
  now = v;
  now.format = format;
}

std::optional<float> Renderer::layerValueAt(std::size_t layer, double latDeg, double lonDeg) const {
  if (layer >= impl_->layers.size() || !impl_->layers[layer].opt.values) return std::nullopt;
  return valueAtPoint(*impl_->layers[layer].current, latDeg, lonDeg);
}

void Renderer::setLegend(bool on) {
  impl_->opt.legend = on;
}
bool Renderer::legend() const noexcept {
  return impl_->opt.legend;
}

void Renderer::moveLayer(std::size_t from, std::size_t to) {
  impl_->layers.move(from, to);
}
void Renderer::setLayerTime(std::size_t layer, std::string time) {
  impl_->context->makeCurrent();
  impl_->layers.setTime(layer, std::move(time));
}

void Renderer::animateLayer(std::size_t layer, std::optional<TimeAnimation> animation) {
  impl_->context->makeCurrent();
  impl_->layers.animate(layer, std::move(animation));
}
const TimeAnimation* Renderer::layerAnimation(std::size_t layer) const noexcept {
  if (layer >= impl_->layers.size() || !impl_->layers[layer].animation) return nullptr;
  return &*impl_->layers[layer].animation;
}
void Renderer::toggleLayerAnimation(std::size_t layer) {
  if (layer < impl_->layers.size() && impl_->layers[layer].animation)
    impl_->layers[layer].animation->togglePause(impl_->frameClockNow());
}
void Renderer::stepLayerAnimation(std::size_t layer, int delta) {
  if (layer < impl_->layers.size() && impl_->layers[layer].animation)
    impl_->layers[layer].animation->step(delta);
}

} // namespace tellus::planet
