#pragma once
/**
 * @file ProjectorWarp.hpp
 * @brief A projector channel's warp and blend on the GPU (issue 28, docs/design/cluster-live.md):
 * the scene framebuffer's colour copied into a texture, drawn through the warp mesh and multiplied
 * by the blend mask into a projector-sized framebuffer, which the window shows (present) and
 * readPresented reads. The same image as planet::warpAndBlend (ChannelWarp.hpp) of readPixels(),
 * to rounding: the fragment shader (shaders/projector_warp.frag) follows the CPU's conventions
 * step by step (pixel centres, bilinear (u, v) in a cell from texelFetch of the mesh, top-left
 * origin, clamped bilinear sampling), the rows turned over where GL counts them from the bottom.
 * Main thread, context current.
 */

#include "GlObjects.hpp"

#include <tellus/planet/ChannelWarp.hpp>

#include <cstdint>
#include <expected>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace tellus::planet {

class ProjectorWarp {
public:
  /** The pass for a sourceWidth x sourceHeight rendered image and a width x height projector
   * (the warp's mesh and the blend's weights, either optional; the blend width x height; no
   * mesh: the image scaled). A message when it cannot be made. */
  static std::expected<std::unique_ptr<ProjectorWarp>, std::string>
  create(const std::string& glslHeader,
         int sourceWidth,
         int sourceHeight,
         int width,
         int height,
         const std::optional<WarpMesh>& mesh,
         const std::optional<std::vector<float>>& blend);

  /** The scene framebuffer (sceneFbo, sourceWidth x sourceHeight) warped and blended into the
   * pass's own (width x height); the viewport is restored. */
  void apply(GLuint sceneFbo);
  /** The projector's framebuffer (what the window shows). */
  GLuint framebuffer() const noexcept { return outFbo_.id(); }
  int width() const noexcept { return width_; }
  int height() const noexcept { return height_; }
  /** The projector's image as RGBA8, rows from the top. */
  std::vector<std::uint8_t> readPixels() const;

private:
  ProjectorWarp() = default;
  int sourceWidth_ = 0, sourceHeight_ = 0;
  int width_ = 0, height_ = 0;
  int meshColumns_ = 0, meshRows_ = 0;
  bool hasBlend_ = false;
  GlProgram program_{NoCreate};
  GlVertexArray vao_{NoCreate};
  GlTexture rendered_{NoCreate}, mesh_{NoCreate}, blend_{NoCreate}, out_{NoCreate};
  GlFramebuffer renderedFbo_{NoCreate}, outFbo_{NoCreate};
  GLint uRendered_ = -1, uMesh_ = -1, uBlend_ = -1, uSource_ = -1, uOut_ = -1, uMeshSize_ = -1,
        uHasBlend_ = -1, uSamples_ = -1;
};

} // namespace tellus::planet
