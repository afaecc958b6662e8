#pragma once
/**
 * @file ScenePass.hpp
 * @brief The frame's draw passes: what every pass of a scene shares (FrameContext) and the
 * interface a pass implements (ScenePass).
 *
 * A scene is drawn into one target (the renderer's framebuffer, or a cube face of the dome): the
 * target is bound, its viewport set, the depth conventions of Depth.hpp begun (32-bit float,
 * reversed Z, cleared to 0 = infinity, GL_GREATER) and colour and depth cleared to the
 * background; then each pass of SceneDraw's list draws, in order. Today the list is the stars
 * (StarsPass.hpp, when RendererOptions::stars is set) and the globe (GlobePass: the node meshes
 * with their textures and overlays). The next passes go into the same
 * list (SceneDraw::addPass), each in its own file with its own program:
 *
 * - issue 23, the planetarium look: a stars pass before the globe (depth test off, nothing written
 *   to depth), the globe, then an atmosphere pass after it (it reads the depth the globe wrote:
 *   sky where depth is 0, aerial perspective over the terrain's real heights elsewhere); the sun
 *   direction comes from FrameContext::sun (today RendererOptions::sunLatLon; a date and time
 *   then). Fading textures in and geomorphing are changes inside GlobePass and NodeMeshes.
 * - issue 26, other bodies: the body is FrameContext::body (today the Geodesy given to
 *   Renderer::create); several bodies in one scene are several globe passes, each with its body,
 *   its layers and its camera-relative origin.
 *
 * Every pass draws camera-relative (the eye at the origin: FrameContext::viewProjection is the
 * rotation and projection only, FrameContext::eye the eye's ECEF position in double), so no float
 * holds an Earth-sized coordinate. With the direct dome method (FrameContext::fisheye) a pass
 * maps its vertices through the fisheye itself (shaders/planet.vert, TELLUS_FISHEYE, set up by
 * Dome::beginDirect for the globe's program); SceneDraw blackens outside the circle after the
 * last pass. With the cube method each face is a scene of its own (a 90-degree camera, a target
 * with the face's frustum and scissor), so passes need nothing special there.
 *
 * Main thread, context current; a pass may leave any GL state except the bound framebuffer and
 * the depth conventions, which the next pass relies on (blending off, depth writes on, depth
 * function GL_GREATER when it returns).
 */

#include "DrawList.hpp"

#include <tellus/planet/Camera.hpp>
#include <tellus/planet/Culling.hpp>
#include <tellus/planet/Geodesy.hpp>
#include <tellus/planet_gl/Renderer.hpp>

#include <epoxy/gl.h>
#include <glm/mat4x4.hpp>

#include <array>
#include <optional>

namespace tellus::planet {

class Dome;

/** Where a scene is drawn: a framebuffer of a size, and the frustum whose outside nodes are
 * skipped (null: none; a cube face's). The framebuffer is referred to, not owned. */
struct DrawTarget {
  GLuint fbo = 0;
  int width = 0;
  int height = 0;
  const Frustum* frustum = nullptr;
  bool draws(const Node& node) const noexcept {
    return frustum == nullptr ||
           classify(*frustum, node.geometry().bounds()) != FrustumResult::Outside;
  }
};

/** What every pass of one scene shares. */
struct FrameContext {
  const Camera& camera; ///< this scene's (a cube face's for the dome's faces)
  const DrawTarget& target;
  const Geodesy& body;      ///< the body drawn (issue 26)
  const DrawList& drawList; ///< what the globe draws this frame (DrawList.hpp)
  glm::mat4 viewProjection; ///< rotation and projection only: the eye at the origin
  glm::dvec3 eye;           ///< the eye's ECEF position, metres
  /** Unit direction to the sun (ECEF) when it is known: RendererOptions::sunLatLon, else the
   * sun at timeUnixSeconds (astro::sunDirectionEcef). The sky and the atmosphere use it. */
  std::optional<Ecef> sun;
  /** The globe is lit by `sun` (RendererOptions::sunlight with a sun, or sunLatLon): the day
   * side, the terminator and the night layers (GlobePass, shaders/planet.frag). */
  bool sunlight = false;
  /** The scene's time (UTC, POSIX seconds; RendererOptions::timeUnixSeconds): with
   * astro::celestialToEcef it places the sky. */
  std::optional<double> timeUnixSeconds;
  /** The direct dome method is drawing this scene (null otherwise): the fisheye map. */
  Dome* fisheye = nullptr;
  int framebufferWidth = 0; ///< the renderer's framebuffer (the fisheye map's circle)
  int framebufferHeight = 0;
  RenderStats& stats;
};

/** The view-projection every pass uses: the camera's rotation and projection (the eye at the
 * origin), narrowed to float. */
glm::mat4 eyeCentredViewProjection(const Camera& camera);

/** One pass of the scene (see the file comment). */
class ScenePass {
public:
  virtual ~ScenePass() = default;
  /** A short name for statistics and messages ("globe", "stars", "atmosphere"). */
  virtual const char* name() const noexcept = 0;
  virtual void draw(const FrameContext& frame) = 0;
};

} // namespace tellus::planet
