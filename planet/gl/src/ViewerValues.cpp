#include "ViewerValues.hpp"

#include <tellus/planet/Pick.hpp>
#include <tellus/values/ColourMap.hpp>

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace tellus::planet {

ValueLayerOptions adjustedScale(const ValueLayerOptions& now, ScaleKey key) {
  ValueLayerOptions o = now;
  if (key == ScaleKey::NextMap) {
    const auto maps = values::colourMaps();
    std::size_t i = 0;
    while (i < maps.size() && maps[i].name != o.colourMap)
      ++i;
    o.colourMap = std::string(maps[(i + 1) % maps.size()].name);
    return o;
  }
  const bool log = o.scaling == values::Scaling::Log;
  double lo = log ? std::log10(o.min) : o.min, hi = log ? std::log10(o.max) : o.max;
  const double mid = 0.5 * (lo + hi), half = 0.5 * (hi - lo);
  switch (key) {
  case ScaleKey::Narrow:
    lo = mid - 0.8 * half;
    hi = mid + 0.8 * half;
    break;
  case ScaleKey::Widen:
    lo = mid - 1.25 * half;
    hi = mid + 1.25 * half;
    break;
  case ScaleKey::ShiftDown:
  case ScaleKey::ShiftUp: {
    const double step = (key == ScaleKey::ShiftUp ? 0.2 : -0.2) * half;
    lo += step;
    hi += step;
    break;
  }
  case ScaleKey::NextMap:
    break;
  }
  const double newMin = log ? std::pow(10.0, lo) : lo, newMax = log ? std::pow(10.0, hi) : hi;
  if (!(newMin < newMax) || !std::isfinite(newMin) || !std::isfinite(newMax) ||
      (log && !(newMin > 0.0)))
    return now; // too narrow (or wide) for a double: unchanged
  o.min = newMin;
  o.max = newMax;
  o.rangeFromData = false;
  return o;
}

std::optional<std::size_t> valueLayerFor(const Renderer& renderer, std::size_t selected) {
  if (renderer.layerValues(selected)) return selected;
  for (std::size_t i = 0; i < renderer.layerCount(); ++i)
    if (renderer.layerValues(i)) return i;
  return std::nullopt;
}

bool valueKey(Renderer& renderer, std::size_t selected, int key) {
  if (key == GLFW_KEY_G) {
    renderer.setLegend(!renderer.legend());
    std::printf("legends %s\n", renderer.legend() ? "shown" : "hidden");
    std::fflush(stdout);
    return true;
  }
  std::optional<ScaleKey> k;
  if (key == GLFW_KEY_C) k = ScaleKey::NextMap;
  if (key == GLFW_KEY_Z) k = ScaleKey::Narrow;
  if (key == GLFW_KEY_X) k = ScaleKey::Widen;
  if (key == GLFW_KEY_Q) k = ScaleKey::ShiftDown;
  if (key == GLFW_KEY_E) k = ScaleKey::ShiftUp;
  const auto layer = valueLayerFor(renderer, selected);
  if (!k || !layer) return false;
  const ValueLayerOptions o = adjustedScale(*renderer.layerValues(*layer), *k);
  try {
    renderer.setLayerValues(*layer, o);
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "view: %s\n", e.what());
    return false;
  }
  std::printf("layer %zu: %s, range %g to %g %s%s\n",
              *layer,
              o.colourMap.c_str(),
              o.min,
              o.max,
              o.format.unit.c_str(),
              o.scaling == values::Scaling::Log ? " (log)" : "");
  std::fflush(stdout);
  return true;
}

std::string valueUnderCursor(const Renderer& renderer, std::size_t selected, double x, double y) {
  const auto layer = valueLayerFor(renderer, selected);
  if (!layer) return {};
  const Camera cam = renderer.camera(renderer.drawnPose());
  // On the ellipsoid: over relief the point is off by the height's parallax (a texel or so at
  // the views where relief shows).
  const auto g =
      pickGlobe(cam, renderer.geodesy(), x - 0.5 * renderer.width(), 0.5 * renderer.height() - y);
  if (!g) return {};
  const auto v = renderer.layerValueAt(*layer, g->latDeg, g->lonDeg);
  const auto o = renderer.layerValues(*layer);
  if (!v || !o) return {};
  const std::string title = o->title.empty() ? "value" : o->title;
  if (std::isnan(*v)) return title + " no data";
  char buf[64];
  std::snprintf(buf, sizeof buf, " %.5g", static_cast<double>(*v));
  return title + buf + (o->format.unit.empty() ? "" : " " + o->format.unit);
}

} // namespace tellus::planet
