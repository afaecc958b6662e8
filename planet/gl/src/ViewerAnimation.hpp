#pragma once
/**
 * @file ViewerAnimation.hpp
 * @brief `tellus view` and time that plays (issue 24; planet/TimeAnimation.hpp): Space plays or
 * pauses the selected layer's animation (else the first animated layer's), [ and ] on an animated
 * layer step its animation by hand (paused) instead of the configured times, and the status line
 * ends with each animated layer's "name TIME state" (state: playing, holding while the next
 * time's tiles come, paused, ended).
 */

#include <tellus/planet_gl/Renderer.hpp>

#include <cstddef>
#include <optional>
#include <string>

namespace tellus::planet {

/** The layer Space acts on: `selected` when animated, else the first animated layer. */
std::optional<std::size_t> animatedLayerFor(const Renderer& renderer, std::size_t selected);

/** Space, [ or ] as the file comment says (the change printed); false for other keys, and for
 * [ ] when the selected layer is not animated. */
bool animationKey(Renderer& renderer, std::size_t selected, int glfwKey);

/** Whether an animation runs (playing or holding): the viewer draws every frame then. */
bool animationRuns(const Renderer& renderer);

/** "  sst 2024-03-01 playing" for each animated layer; "" when none. */
std::string animationStatus(const Renderer& renderer);

} // namespace tellus::planet
