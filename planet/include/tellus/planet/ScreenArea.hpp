#pragma once
/**
 * @file ScreenArea.hpp
 * @brief The stream score's base (thesis 4.6.2): the area in pixels of a node's corner quad
 * projected and clipped to the viewport. The quad is clipped against the near plane in clip space
 * first, so corners behind the camera end on the near plane instead of projecting through the eye.
 */

#include <tellus/planet/Camera.hpp>
#include <tellus/planet/Patch.hpp>

namespace tellus::planet {

/** Pixels (0 when nothing of the quad is in front of the camera and inside the viewport); never
 * NaN. No allocation. */
double clippedScreenArea(const Camera& camera, const std::array<glm::dvec3, 4>& corners) noexcept;

/** The node's clipped area: its corner quad's, or for a polar cap (a sector spanning every
 * longitude from a pole, whose corner quad is a line) the sum over 16 equal wedges of the rim
 * points' and the pole's quads. */
double nodeScreenArea(const Camera& camera, const NodeGeometry& node) noexcept;

} // namespace tellus::planet
