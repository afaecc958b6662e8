#pragma once
/**
 * @file ViewerValues.hpp
 * @brief `tellus view` and layers of values (issue 24): the keys that change a value layer's
 * colour scale, and the value under the cursor for the status line.
 *
 * Keys act on the selected layer when it is a layer of values, else on the first one: C the next
 * colour map (values::colourMaps() in order, round), Z narrows the range to 0.8 of its width
 * about its middle, X widens it by 1.25, Q and E shift it down and up by a tenth of its width (a
 * log scale's range in log10: the factors apply to the decades), G shows or hides the legends.
 * A range set by a key replaces `range: data`. The value under the cursor: the point on the
 * globe under it (planet/Pick.hpp) and the value the layer holds there
 * (Renderer::layerValueAt): "title 12.5 K", "title no data", or nothing off the globe.
 */

#include <tellus/planet_gl/Renderer.hpp>

#include <optional>
#include <string>

namespace tellus::planet {

/** What a scale key does (GL-free). */
enum class ScaleKey { NextMap, Narrow, Widen, ShiftDown, ShiftUp };

/** The options after a scale key (GL-free; min < max kept, log ranges stay above 0). */
ValueLayerOptions adjustedScale(const ValueLayerOptions& now, ScaleKey key);

/** The layer the value keys and the cursor's value are about: `selected` when it is a layer of
 * values, else the first layer of values; nullopt when there is none. */
std::optional<std::size_t> valueLayerFor(const Renderer& renderer, std::size_t selected);

/** A GLFW key among those of the file comment, applied (the change printed); false for other
 * keys or without a layer of values (G works with any). */
bool valueKey(Renderer& renderer, std::size_t selected, int glfwKey);

/** "title value unit" for the cursor at framebuffer pixel (x, y) from the top left; "" when
 * there is no layer of values or the cursor is off the globe. */
std::string valueUnderCursor(const Renderer& renderer, std::size_t selected, double x, double y);

} // namespace tellus::planet
