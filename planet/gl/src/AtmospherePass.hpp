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
 * heights, in the flat view, each cube face of the dome and the direct fisheye alike.
 *
 * The cost (bench/RESULTS.md): per pixel the pass does not march or look up Bruneton's 4D tables.
 * After Hillaire (2020), it reads two small view tables that depend only on the eye's altitude
 * and the sun's elevation there, remade (shaders/atmosphere_lut.frag, from the 4D tables, as
 * AtmosphereTables::ray() computes) when either changed since the last scene, so once a frame at
 * most, not per cube face:
 * - the sky table, kSkyAzimuth x the scattering table's mu size: per view direction (azimuth from
 *   the sun's, u^2 pi; zenith by Bruneton's map at the eye, or where the ray enters the shell from
 *   above: its rows are the 4D table's mu rows, so the zenith interpolation is the same) the
 *   Rayleigh (with the multiple scattering) and Mie inscatter without their phase functions, and
 *   the transmittance;
 * - the aerial table, kAirAzimuth x kAirZenith x kAirSlices: the same along each ray to
 *   kAirSlices distances between where it enters the shell and where it leaves it (the ground or
 *   the top), spaced logarithmically from both ends (shaders/atmosphere_common.glsl, sliceUnit).
 * Per pixel: the direction's coordinates (a few square roots), three bilinear (sky) or trilinear
 * (terrain) lookups, the phase functions at the exact nu, the sun's disc and the display map.
 *
 * At a lower resolution (`divisor` 2 or 4, renderer.atmosphere.resolution; full by default:
 * bench/RESULTS.md): the shader above (TELLUS_ATMOSPHERE_SPLIT) draws the haze's display value, its
 * factor, the transmittance to space and a key of the depth (log2 of the distance) into three
 * textures of 1 / divisor the target's size; a second full-screen pass
 * (TELLUS_ATMOSPHERE_COMPOSITE) spreads them over the target (bilinear) where their key agrees with
 * the pixel's own depth, computes the pixel in full where it does not (the limb, silhouettes
 * against the sky or far terrain keep their sharp edge), and draws the sun's disc at full
 * resolution. The accuracy and the time this trades are measured
 * (AtmosphereGl.LowerResolutionsAgreeWithTheFullOne, bench/RESULTS.md).
 *
 * One triangle covers the target; each pixel's direction comes from the inverse view-projection
 * (flat, cube faces) or the inverse fisheye map (direct dome: theta = |ndc / perRadian|). The
 * eye's altitude and frame are computed here in double (camera-relative: per pixel only a unit
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

#include <glm/vec3.hpp>

#include <expected>
#include <memory>
#include <string>

namespace tellus::planet {

class AtmospherePass final : public ScenePass {
public:
  /** Computes the tables for `parameters` (its bottom radius <= 0: the body's equatorial radius),
   * or reads them from `cacheDir` (AtmosphereCache.hpp; empty: no cache), and makes the program
   * and textures. exposure: the display's scale of radiance (solar units). */
  static std::expected<std::unique_ptr<AtmospherePass>, std::string>
  create(const GlCapabilities& gl,
         AtmosphereParameters parameters,
         double exposure,
         const Geodesy& body,
         const std::string& cacheDir = {},
         int divisor = kDefaultDivisor);

  /** With tables already computed (tests share one set between contexts). */
  static std::expected<std::unique_ptr<AtmospherePass>, std::string>
  create(const GlCapabilities& gl,
         AtmosphereTables tables,
         double exposure,
         const Geodesy& body,
         int divisor = kDefaultDivisor);

  /** The resolution's divisor by default: full resolution (the lower ones cost more on Mesa
   * llvmpipe: docs/design/atmosphere.md). */
  static constexpr int kDefaultDivisor = 1;

  const char* name() const noexcept override { return "atmosphere"; }
  void draw(const FrameContext& frame) override;
  /** Seconds the tables took to compute (or to read from the cache). */
  double precomputeSeconds() const noexcept { return tables_.precomputeSeconds(); }
  const AtmosphereTables& tables() const noexcept { return tables_; }

  /** The view tables' sizes (azimuth, zenith, slices). */
  static constexpr int kSkyAzimuth = 64;
  static constexpr int kAirAzimuth = 16;
  static constexpr int kAirZenith = 64;
  static constexpr int kAirSlices = 32;
  /** The aerial slices' logarithmic map's constant c (sliceUnit, from both ends of the ray):
   * consecutive slices e^(2c/31) = 1.57 times farther from their end, the first at 1/2200 of the
   * ray's span through the shell. */
  static constexpr double kAirLogC = 7.0;
  /** How many times the view tables were made (tests: not per cube face, not when still). */
  int viewTableUpdates() const noexcept { return updates_; }

private:
  AtmospherePass(
      AtmosphereTables tables, double exposure, const Geodesy& body, bool clipControl, int divisor);
  std::expected<void, std::string> makeGl(const GlCapabilities& gl);
  /** The view tables' textures and framebuffers; false when they cannot be rendered into. */
  bool makeViewTables();
  /** The target's depth into depth_ (and, when its size changed, the haze's textures). */
  void copyDepth(const DrawTarget& target);
  /** divisor_ > 1: the three textures of the haze at 1 / divisor_ of depth_'s size; false:
   * incomplete. */
  bool makeHaze();
  /** The eye's altitude (m, sphere space) and frame for a scene. */
  struct EyeFrame {
    glm::dvec3 up, sun, side, normal;
    double altitude = 0.0;
  };
  EyeFrame eyeFrame(const FrameContext& frame) const;
  void setShellUniforms(GLuint program);
  void updateViewTables(float altitude, float muS);
  void setUniforms(GLuint program, const FrameContext& frame, const EyeFrame& e);

  AtmosphereTables tables_;
  double exposure_;
  double polarStretch_; ///< equatorial / polar radius of the body
  bool clipControl_;
  int divisor_; ///< 1: full resolution; 2, 4: the haze at that fraction, then composited
  GlProgram program_{NoCreate}, lutProgram_{NoCreate}, compositeProgram_{NoCreate};
  GlVertexArray vao_{NoCreate};
  GlTexture transmittance_{NoCreate}, scattering_{NoCreate}, mie_{NoCreate}, depth_{NoCreate};
  GlTexture skyRayleigh_{NoCreate}, skyMie_{NoCreate}, skyTransmittance_{NoCreate};
  GlTexture airRayleigh_{NoCreate}, airMie_{NoCreate}, airTransmittance_{NoCreate};
  GlTexture glow_{NoCreate}, factor_{NoCreate}, sunLight_{NoCreate};
  GlFramebuffer depthFbo_{NoCreate}, skyFbo_{NoCreate}, airFbo_{NoCreate}, hazeFbo_{NoCreate};
  int depthWidth_ = 0, depthHeight_ = 0, hazeWidth_ = 0, hazeHeight_ = 0;
  bool tablesMade_ = false; ///< the view tables hold lastAltitude_, lastMuS_
  float lastAltitude_ = 0.0f, lastMuS_ = 0.0f;
  int updates_ = 0;
};

} // namespace tellus::planet
