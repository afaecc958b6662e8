#pragma once
/**
 * @file BodiesPass.hpp
 * @brief The scene's other bodies (issue 26, RendererOptions::sceneBodies): a scene pass after the
 * globe that draws each as a coarse globe (planet/SceneBodies.hpp's DistantGlobe) with its global
 * image, placed and turned by the ephemeris at the scene's time in the drawn body's frame, lit by
 * the scene's sun (FrameContext::sun and sunlight, as the globe), depth-tested against the globe
 * with the same reversed-Z conventions (Depth.hpp: 0.1 m and 1e9 m in one frustum), so the Earth
 * hides the Moon behind it and the Moon the Earth.
 *
 * Precision: every frame each body's vertices are made camera-relative on the CPU in double
 * (DistantGlobe::cameraRelative: the body's centre minus the eye, plus the rotated offset) and
 * uploaded as floats (8,385 vertices, 268 KB a body a frame); the shader adds nothing large. The
 * triangles drawn are the grid's coarsest within 0.1 pixel of the ellipsoid at the body's size in
 * the image (DistantGlobe::strideFor: 256 triangles for a few pixels, 16,256 at the finest). In the
 * direct dome they go through the fisheye map (shaders/body.vert, TELLUS_FISHEYE); in the cube
 * faces each face draws them with its own camera.
 *
 * Drawn before the atmosphere pass, which therefore sees their depth as something drawn: the sky
 * does not cover them and the orbited body's air lies over them by the distance it reads. Main
 * thread, context current; leaves the depth conventions of ScenePass.hpp.
 */

#include "GlContext.hpp"
#include "GlObjects.hpp"
#include "ScenePass.hpp"

#include <tellus/planet/SceneBodies.hpp>
#include <tellus/planet_gl/Renderer.hpp>

#include <array>
#include <expected>
#include <memory>
#include <string>
#include <vector>

namespace tellus::planet {

class BodiesPass final : public ScenePass {
public:
  /** Compiles the program and makes each body's globe and texture. `frameBody` is the drawn
   * body's (the scene's frame); bodies with its name are skipped. Empty `bodies`: nothing drawn. */
  static std::expected<std::unique_ptr<BodiesPass>, std::string>
  create(const GlCapabilities& gl,
         bool fisheye,
         astro::EphemerisBody frameBody,
         const std::vector<RendererOptions::SceneBody>& bodies);

  const char* name() const noexcept override { return "bodies"; }
  void draw(const FrameContext& frame) override;
  std::size_t bodyCount() const noexcept { return bodies_.size(); }

private:
  struct Drawn {
    astro::EphemerisBody which;
    DistantGlobe globe;
    GlTexture texture{NoCreate};
    GlBuffer vbo{NoCreate};
    GlBuffer ibo{NoCreate};
    GlVertexArray vao{NoCreate};
    /** Per stride 1, 2, 4, 8 (DistantGlobe::indices): the first index and the count in ibo. */
    std::array<std::pair<std::size_t, std::size_t>, 4> ranges{};
  };
  BodiesPass() = default;

  astro::EphemerisBody frameBody_ = astro::EphemerisBody::earth;
  GlProgram program_{NoCreate};
  GLint uViewProj_ = -1, uSun_ = -1, uTexture_ = -1;
  std::vector<std::unique_ptr<Drawn>> bodies_;
  std::vector<float> scratch_;
};

} // namespace tellus::planet
