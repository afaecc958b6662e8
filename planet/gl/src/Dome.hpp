#pragma once
/**
 * @file Dome.hpp
 * @brief The dome (issue #7): an angular fisheye domemaster drawn as cube faces, then a warp pass,
 * or directly (the node shader's fisheye map, DomeMethod::Direct; then a mask).
 *
 * The tree's update and the streaming run once per frame with the fisheye camera (Camera with a
 * Fisheye: LOD in the fisheye's pixels, culling against its cone); then each cube face the cone
 * reaches draws the same draw list through the renderer's draw function into its layer of a cube
 * map (each face skipping nodes whose sphere is outside its frustum, and clearing and drawing only
 * the part of the face the cone reaches: a scissor), and the warp pass samples the cube map with
 * seamless filtering (GL_TEXTURE_CUBE_MAP_SEAMLESS: no lines at face borders) into the
 * renderer's framebuffer: the inscribed circle, black outside. Lighting is in world space in the
 * node shader, so faces agree. The direct method instead draws the draw list once into the
 * renderer's framebuffer with the node program's fisheye map (shaders/planet.vert, TELLUS_FISHEYE:
 * beginDirect sets its uniforms and the clip plane), then paints black what lies outside the
 * circle (drawMask: a ring from just inside the circle to the border). GL-private; used by
 * SceneDraw (the draw phase) and GlobePass. GL objects owned by handles (GlObjects.hpp): main
 * thread, context current.
 */

#include "GlObjects.hpp"
#include "ScenePass.hpp"

#include <tellus/planet/Camera.hpp>
#include <tellus/planet/Culling.hpp>
#include <tellus/planet/DomeDirect.hpp>
#include <tellus/planet/Quadtree.hpp>

#include <array>
#include <expected>
#include <functional>
#include <memory>
#include <string>

namespace tellus::planet {

/** The part of a face (pixels [x0, x1) x [y0, y1), bottom-up) whose directions lie within
 * halfAngleRad of -Z, plus a margin of a few pixels for bilinear taps; empty (x0 == x1) when the
 * cone does not reach the face. */
struct FaceRect {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
};
class Dome {
public:
  /** faceSize: the cube faces' size in pixels; glslHeader: the "#version ..." line. With
   * allocateFaces false the cube map and the faces' depth buffer (faceBytes()) are made on the
   * first render(): a direct-method dome that never falls back never holds them. */
  static std::expected<std::unique_ptr<Dome>, std::string>
  create(int faceSize, const std::string& glslHeader, bool allocateFaces = true);
  Dome(const Dome&) = delete;
  Dome& operator=(const Dome&) = delete;

  using DrawFace = std::function<void(const Camera& face, const DrawTarget& target)>;
  /** Draws the faces the fisheye camera's cone reaches through drawFace, then warps them into
   * target (width x height: the circle of diameter min(width, height), centred; black around).
   * Makes the faces first when they are not there yet (allocateFaces()); fails, drawing nothing,
   * only when that fails. */
  std::expected<void, std::string>
  render(const Camera& fisheye, const DrawFace& drawFace, GLuint target, int width, int height);
  int faceSize() const noexcept { return size_; }
  /** The cube map (RGBA8) and the faces' depth buffer (32-bit float); idempotent. */
  std::expected<void, std::string> allocateFaces();
  bool facesAllocated() const noexcept { return cube_.created(); }
  /** GPU bytes of the faces when allocated: 6 x faceSize^2 x 4 + faceSize^2 x 4. */
  std::size_t faceBytes() const noexcept { return facesAllocated() ? bytesOfFaces(size_) : 0u; }
  static std::size_t bytesOfFaces(int faceSize) noexcept {
    return 28u * static_cast<std::size_t>(faceSize) * static_cast<std::size_t>(faceSize);
  }

  /** The direct method: with the node program (compiled with TELLUS_FISHEYE) current, switches
   * its vertex map to the fisheye of this camera for a width x height framebuffer (the circle of
   * diameter min(width, height), centred) and enables gl_ClipDistance[0]. */
  void beginDirect(const GlProgram& nodeProgram, const Camera& fisheye, int width, int height);
  /** Ends what beginDirect began (the program still current: back to its perspective, the clip
   * plane off). */
  void endDirect(const GlProgram& nodeProgram);
  /** The direct method's last step, after every pass: paints black everything in target
   * (width x height) outside the circle. */
  void drawMask(GLuint target, int width, int height);
  /** Faces drawn by the last render(). */
  int facesDrawn() const noexcept { return facesDrawn_; }

private:
  Dome() = default;
  int size_ = 0;
  GlTexture cube_{NoCreate};
  GlRenderbuffer depth_{NoCreate};
  GlProgram program_{NoCreate};
  GlVertexArray vao_{NoCreate};
  std::array<GlFramebuffer, 6> fbos_{GlFramebuffer(NoCreate),
                                     GlFramebuffer(NoCreate),
                                     GlFramebuffer(NoCreate),
                                     GlFramebuffer(NoCreate),
                                     GlFramebuffer(NoCreate),
                                     GlFramebuffer(NoCreate)};
  GLint uCube_ = -1, uCircle_ = -1, uViewport_ = -1;
  GlBuffer meshVbo_{NoCreate}, meshEbo_{NoCreate};
  GLsizei meshIndices_ = 0;
  double meshFor_ = -1.0; ///< (half-angle, circle radius in pixels) the warp mesh was made for
  double meshRadius_ = -1.0;
  void buildMesh(double halfAngleRad, double radiusPx);
  int facesDrawn_ = 0;
  // The direct method's node-program uniforms (looked up for directProgram_, which the caller
  // owns) and the mask.
  const GlProgram* directProgram_ = nullptr;
  GLint uFisheye_ = -1, uDomeRotation_ = -1, uDomeMap_ = -1;
  GlProgram maskProgram_{NoCreate};
  GlVertexArray maskVao_{NoCreate};
  GlBuffer maskVbo_{NoCreate};
  GLint uMaskViewport_ = -1, uMaskCircle_ = -1;
  GLsizei maskVertices_ = 0;
  int maskW_ = 0, maskH_ = 0;
  void buildMask(int width, int height);
  void freeFaces();
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
