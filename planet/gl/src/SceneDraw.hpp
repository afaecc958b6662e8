#pragma once
/**
 * @file SceneDraw.hpp
 * @brief The frame's draw phase: the offscreen framebuffer (SceneFramebuffer), the ordered list of
 * scene passes (ScenePass.hpp: today the globe; issue 23's stars and atmosphere slot in with
 * addPass), and the dome's routing (issue #7, Dome.hpp):
 *
 * - a perspective camera: one scene into the framebuffer;
 * - a dome, direct method: one scene through the fisheye map (Dome::beginDirect in the globe's
 *   program), then the mask outside the circle, unless the frame's straight edges would be off
 *   by more than DomeOptions::directMaxErrorPx (directChordErrorPx, DomeDirect.hpp): then, as
 *   for the cube method, up to five cube faces each drawn as a scene of its own (a 90-degree
 *   camera, the face's frustum), then the warp into the framebuffer. A direct renderer makes its
 *   cube faces on its first fallback; should that fail (GPU memory) the frame is drawn direct,
 *   over the error bound, and RenderStats::domeError says so.
 *
 * Main thread, context current.
 */

#include "Dome.hpp"
#include "GlContext.hpp"
#include "GlObjects.hpp"
#include "ScenePass.hpp"

#include <tellus/planet_gl/Renderer.hpp>

#include <cstdint>
#include <expected>
#include <memory>
#include <string>
#include <vector>

namespace tellus::planet {

/** A framebuffer's colour (RGBA8, width x height) read back, rows from the top (GL's are from
 * the bottom): what readPixels gives, of the scene and of a projector's warped image. */
std::vector<std::uint8_t> readFramebufferTopDown(GLuint fbo, int width, int height);

/** The framebuffer every frame is drawn into and readPixels reads: RGBA8 colour and a 32-bit
 * float depth buffer (Depth.hpp), both renderbuffers. */
class SceneFramebuffer {
public:
  /** Not created (id() == 0). */
  SceneFramebuffer() = default;
  /** Makes one of that size (left bound). */
  SceneFramebuffer(int width, int height);
  GLuint id() const noexcept { return fbo_.id(); }
  int width() const noexcept { return width_; }
  int height() const noexcept { return height_; }
  /** Its colour as RGBA8, rows from the top. */
  std::vector<std::uint8_t> readPixels() const;

private:
  GlFramebuffer fbo_{NoCreate};
  GlRenderbuffer color_{NoCreate};
  GlRenderbuffer depth_{NoCreate};
  int width_ = 0, height_ = 0;
};

class SceneDraw {
public:
  /** options (its size, background, dome, sun) and geodesy must outlive this; the framebuffer is
   * made at the options' size. */
  SceneDraw(const RendererOptions& options, const Geodesy& geodesy, const GlCapabilities& gl);
  /** The options' dome (validated: field of view, face scale); none without one. */
  std::expected<void, std::string> openDome();
  /** A pass drawn after those added before it. */
  void addPass(std::unique_ptr<ScenePass> pass) { passes_.push_back(std::move(pass)); }
  const std::vector<std::unique_ptr<ScenePass>>& passes() const noexcept { return passes_; }

  /** The draw phase of a frame: the camera's scene (or the dome's) into the framebuffer.
   * drawn: the base tree's draw list, groundM the terrain's height under the camera (both for the
   * direct dome's error estimate). */
  void drawFrame(const Camera& camera,
                 const DrawList& list,
                 const std::vector<Node*>& drawn,
                 double groundM,
                 RenderStats& stats);
  /** One scene into a target: bound, viewport, depth conventions, cleared, every pass in order;
   * with `direct` the fisheye map for the passes and the mask after them. */
  void drawScene(const Camera& camera,
                 const DrawTarget& target,
                 const DrawList& list,
                 RenderStats& stats,
                 bool direct);

  const SceneFramebuffer& framebuffer() const noexcept { return framebuffer_; }
  /** A framebuffer of the options' (new) size, and the dome's faces for it (the old faces kept
   * when that fails: they still draw). */
  void resize();
  Dome* dome() const noexcept { return dome_.get(); }

private:
  int faceSize() const;
  const RendererOptions& opt_;
  const Geodesy& geodesy_;
  GlCapabilities gl_;
  SceneFramebuffer framebuffer_;
  std::vector<std::unique_ptr<ScenePass>> passes_;
  std::unique_ptr<Dome> dome_; ///< the cube faces, the warp and the direct method's mask
};

} // namespace tellus::planet
