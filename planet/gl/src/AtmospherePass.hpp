#pragma once
/**
 * @file AtmospherePass.hpp
 * @brief The atmosphere (issue 23): the scene pass after the globe that draws the sky where the
 * globe drew nothing and the aerial perspective over what it drew (shaders/atmosphere.frag), from
 * the tables of planet/Atmosphere.hpp (computed on the CPU when the pass is made, uploaded as
 * 16-bit float textures).
 *
 * Per scene: the target's depth is copied (glBlitFramebuffer) into the pass's own depth texture,
 * which the shader reads (distance = near / depth, Depth.hpp): the air lies over the terrain's real
 * heights, in the flat view, each cube face of the dome and the direct fisheye alike. One
 * triangle covers the target; each pixel's direction comes from the inverse view-projection
 * (flat, cube faces) or the inverse fisheye map (direct dome: theta = |ndc / perRadian|). The
 * eye's altitude and zenith are computed here in double (camera-relative: per pixel only a unit
 * direction is float). Colour goes on by dual-source blending (GL 3.3 core): framebuffer =
 * inscatter + framebuffer x transmittance, in display values (1 - exp(-exposure L), gamma 2.2).
 *
 * The sun is FrameContext::sun; with none, the sun stands at the camera's zenith (the view is
 * always at local noon: the globe seen from space is lit where the camera looks).
 *
 * Main thread, context current.
 */

#include "GlContext.hpp"
#include "GlObjects.hpp"
#include "ScenePass.hpp"

#include <tellus/planet/Atmosphere.hpp>

#include <expected>
#include <memory>
#include <string>

namespace tellus::planet {

class AtmospherePass final : public ScenePass {
public:
  /** Computes the tables for `parameters` (its bottom radius <= 0: the body's equatorial radius)
   * and makes the program and textures. exposure: the display's scale of radiance (solar units). */
  static std::expected<std::unique_ptr<AtmospherePass>, std::string>
  create(const GlCapabilities& gl,
         AtmosphereParameters parameters,
         double exposure,
         const Geodesy& body);

  /** With tables already computed (tests share one set between contexts). */
  static std::expected<std::unique_ptr<AtmospherePass>, std::string>
  create(const GlCapabilities& gl, AtmosphereTables tables, double exposure, const Geodesy& body);

  const char* name() const noexcept override { return "atmosphere"; }
  void draw(const FrameContext& frame) override;
  /** Seconds the tables took to compute. */
  double precomputeSeconds() const noexcept { return tables_.precomputeSeconds(); }
  const AtmosphereTables& tables() const noexcept { return tables_; }

private:
  AtmospherePass(AtmosphereTables tables, double exposure, const Geodesy& body, bool clipControl);
  void copyDepth(const DrawTarget& target);
  void setUniforms(const FrameContext& frame);

  AtmosphereTables tables_;
  double exposure_;
  double polarStretch_; ///< equatorial / polar radius of the body
  bool clipControl_;
  GlProgram program_{NoCreate};
  GlVertexArray vao_{NoCreate};
  GlTexture transmittance_{NoCreate}, scattering_{NoCreate}, mie_{NoCreate}, depth_{NoCreate};
  GlFramebuffer depthFbo_{NoCreate};
  int depthWidth_ = 0, depthHeight_ = 0;
};

} // namespace tellus::planet
