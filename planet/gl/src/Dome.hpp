#pragma once
/**
 * @file Dome.hpp
 * @brief The dome (issue #7): an angular fisheye domemaster drawn as cube faces, then a warp pass.
 *
 * The tree's update and the streaming run once per frame with the fisheye camera (Camera with a
 * Fisheye: LOD in the fisheye's pixels, culling against its cone); then each cube face the cone
 * reaches draws the same draw list through the renderer's draw function into its layer of a cube
 * map (each face skipping nodes whose sphere is outside its frustum, and clearing and drawing only
 * the part of the face the cone reaches: a scissor), and the warp pass samples the cube map with
 * seamless filtering (GL_TEXTURE_CUBE_MAP_SEAMLESS: no lines at face borders) into the
 * renderer's framebuffer: the inscribed circle, black outside. Lighting is in world space in the
 * node shader, so faces agree. GL-private; used by Renderer.cpp only.
 */

#include <tellus/planet/Camera.hpp>
#include <tellus/planet/Culling.hpp>
#include <tellus/planet/Quadtree.hpp>

#include <epoxy/gl.h>

#include <array>
#include <expected>
#include <functional>
#include <memory>
#include <string>

namespace tellus::planet {

/** Where Renderer::Impl::draw draws: a framebuffer of a size, the frustum whose outside nodes are
 * skipped (null: none), and whether to clear and draw the scene at all (false: only present the
 * framebuffer that the dome's warp pass filled). */
struct DrawTarget {
  GLuint fbo = 0;
  int width = 0;
  int height = 0;
  const Frustum* frustum = nullptr;
  bool scene = true;
  bool draws(const Node& node) const noexcept {
    return scene && (frustum == nullptr ||
                     classify(*frustum, node.geometry().bounds()) != FrustumResult::Outside);
  }
};

/** The part of a face (pixels [x0, x1) x [y0, y1), bottom-up) whose directions lie within
 * halfAngleRad of -Z, plus a margin of a few pixels for bilinear taps; empty (x0 == x1) when the
 * cone does not reach the face. */
struct FaceRect {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
};
class Dome {
public:
  /** faceSize: the cube faces' size in pixels; glslHeader: the "#version ..." line. */
  static std::expected<std::unique_ptr<Dome>, std::string> create(int faceSize,
                                                                  const std::string& glslHeader);
  ~Dome();
  Dome(const Dome&) = delete;
  Dome& operator=(const Dome&) = delete;

  using DrawFace = std::function<void(const Camera& face, const DrawTarget& target)>;
  /** Draws the faces the fisheye camera's cone reaches through drawFace, then warps them into
   * target (width x height: the circle of diameter min(width, height), centred; black around). */
  void
  render(const Camera& fisheye, const DrawFace& drawFace, GLuint target, int width, int height);
  int faceSize() const noexcept { return size_; }
  /** Faces drawn by the last render(). */
  int facesDrawn() const noexcept { return facesDrawn_; }

private:
  Dome() = default;
  int size_ = 0;
  GLuint cube_ = 0, depth_ = 0, program_ = 0, vao_ = 0;
  std::array<GLuint, 6> fbos_{};
  GLint uCube_ = -1, uCircle_ = -1, uViewport_ = -1;
  GLuint meshVbo_ = 0, meshEbo_ = 0;
  GLsizei meshIndices_ = 0;
  double meshFor_ = -1.0; ///< (half-angle, circle radius in pixels) the warp mesh was made for
  double meshRadius_ = -1.0;
  void buildMesh(double halfAngleRad, double radiusPx);
  int facesDrawn_ = 0;
  double regionsFor_ = -1.0; ///< the half-angle the face regions were computed for
  std::array<FaceRect, 6> regions_{};
};

/** The cube faces in GL's cube-map order (+X, -X, +Y, -Y, +Z, -Z), as forward and up directions
 * in the cube's frame (x right, y up, z back: the dome's axis is -Z), so that a face rendered with
 * that camera is the layer texture(samplerCube, direction) reads. */
struct CubeFace {
  glm::dvec3 forward, up;
};
const std::array<CubeFace, 6>& cubeFaces() noexcept;

FaceRect faceRegion(const CubeFace& face, int faceSize, double halfAngleRad) noexcept;

} // namespace tellus::planet
