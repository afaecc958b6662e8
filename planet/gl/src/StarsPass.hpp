#pragma once
/**
 * @file StarsPass.hpp
 * @brief The star background (issue 23): a scene pass drawn before the globe that puts each star
 * of a StarCatalogue (planet/StarCatalogue.hpp) at infinity, in the flat view, the direct dome and
 * the dome's cube faces (shaders/stars.vert and stars.frag).
 *
 * What it draws: a point per star brighter than the magnitude limit, its J2000 direction uploaded
 * once (float unit vectors: 6e-8 rad, far below a pixel) and turned into ECEF each frame by
 * astro::celestialToEcef at FrameContext::timeUnixSeconds (none: kJ2000UnixSeconds). Only the
 * direction enters the projection (rotation-only view-projection, w = 0), so the stars are
 * camera-relative by construction and hold still at any altitude.
 *
 * How it avoids aliasing: each star is a Gaussian footprint of fixed width (kStarSigmaPx = 0.8
 * pixels) around its exact sub-pixel window position, drawn as a 7-pixel point sprite (4.4 sigma
 * each way) and added to the framebuffer (blend ONE, ONE). Its peak is the star's energy
 * (starEnergy: brightness from magnitude, capped so the peak is at most 1) over 2 pi sigma^2, so
 * its pixels sum to that energy wherever the centre falls: turning the camera by a fraction of a
 * pixel moves the energy between neighbouring pixels smoothly instead of switching pixels on and
 * off. The colour is starColour(B-V). Footprints are sampled per view: with the cube method each
 * face draws its own stars at the face's resolution and the warp resamples them (bilinear), so
 * there they widen slightly; a star within 3.5 pixels of a face's (or the image's) edge loses the
 * part of its footprint beyond it (GL clips points by their centre).
 *
 * GL state: depth test off and no depth writes while drawing (the stars are behind everything;
 * the globe drawn after covers them); it leaves the depth conventions as ScenePass.hpp asks
 * (depth test on, depth writes on, GL_GREATER, blending off).
 *
 * Main thread, context current.
 */

#include "GlContext.hpp"
#include "GlObjects.hpp"
#include "ScenePass.hpp"

#include <tellus/planet/StarCatalogue.hpp>

#include <expected>
#include <memory>
#include <string>

namespace tellus::planet {

struct StarsPassOptions {
  bool fisheye = false;        ///< compiled with the direct dome's fisheye map (TELLUS_FISHEYE)
  double magnitudeLimit = 6.5; ///< stars fainter than this (larger V) are left out
  double brightness = 1.0;     ///< multiplies every star's energy (starEnergy), >= 0
};

class StarsPass final : public ScenePass {
public:
  /** Compiles the program and uploads the catalogue's stars within the limit (the catalogue is
   * not kept). */
  static std::expected<std::unique_ptr<StarsPass>, std::string>
  create(const GlCapabilities& gl, const StarCatalogue& catalogue, const StarsPassOptions& options);

  const char* name() const noexcept override { return "stars"; }
  void draw(const FrameContext& frame) override;
  /** Stars uploaded (within the magnitude limit). */
  std::size_t starCount() const noexcept { return static_cast<std::size_t>(count_); }

private:
  StarsPass() = default;
  void upload(const StarCatalogue& catalogue, const StarsPassOptions& options);

  GlProgram program_{NoCreate};
  GlBuffer vbo_{NoCreate};
  GlVertexArray vao_{NoCreate};
  GLsizei count_ = 0;
  GLint uCelestialToWorld_ = -1, uViewProj_ = -1, uViewport_ = -1, uInvTwoSigma2_ = -1;
};

} // namespace tellus::planet
