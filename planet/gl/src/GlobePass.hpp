#pragma once
/**
 * @file GlobePass.hpp
 * @brief The globe: the scene pass that draws the frame's DrawList, each part with its mesh
 * (NodeMeshes), its texture through its uv transform and its overlays (shaders/planet.vert and
 * planet.frag).
 *
 * Overlay textures blended in one pass: one texture unit each after the base's (unit 0), as many
 * as the GL's units allow (at most 8, RendererOptions::overlaysPerPass lower). Pass 0 draws the
 * base texture and the first overlaysPerPass overlays of each part; pass j > 0 the parts with more
 * overlays again with the next ones, blended over (same mesh, depth equal, nothing written to
 * depth). Vertex positions are doubles on OpenGL 4.x (fp64), made eye-relative by one double
 * subtraction, else high/low float pairs (GpuVertex.hpp). Lit by the sun (FrameContext::sunlight:
 * issue 23): the day side by the relief's normals, the night side dark with the night layers'
 * light, a soft terminator by the sun's elevation over the ellipsoid (shaders/planet.frag).
 * Layers of values (issue 24): their float textures on the overlays' units, coloured in the
 * shader through the colour maps' texture (one unit, after the fade's) by ColourScale.hpp's rule.
 *
 * Main thread, context current.
 */

#include "GlContext.hpp"
#include "GlObjects.hpp"
#include "NodeMeshes.hpp"
#include "ScenePass.hpp"

#include <expected>
#include <memory>
#include <string>

namespace tellus::planet {

struct GlobePassOptions {
  bool fp64 = true;        ///< positions as doubles (OpenGL 4.x only)
  bool fisheye = false;    ///< compiled with the direct dome's fisheye map (TELLUS_FISHEYE)
  int overlaysPerPass = 0; ///< 0: as many as the texture units allow, at most 8
};

class GlobePass final : public ScenePass {
public:
  /** Compiles and links the node program for this GL (its GLSL version, fp64 only on 4.x).
   * meshes must outlive the pass. */
  static std::expected<std::unique_ptr<GlobePass>, std::string>
  create(const GlCapabilities& gl, const GlobePassOptions& options, NodeMeshes& meshes);

  const char* name() const noexcept override { return "globe"; }
  void draw(const FrameContext& frame) override;
  /** Overlay textures one pass blends (texture units 1..). */
  int overlaysPerPass() const noexcept { return overlaysPerPass_; }
  bool fp64() const noexcept { return fp64_; }
  /** Geomorphing (Morph.hpp): the next frames' morph scale (morphScale); 0: no morph. */
  void setMorphScale(double scale) noexcept { morphScale_ = scale; }
  /** Back faces culled (Renderer::redrawLast: the inside of the globe never shows through the
   * part of the view the last frame culled; off for every frame). */
  void setCullBackFaces(bool cull) noexcept { cullBack_ = cull; }

private:
  explicit GlobePass(NodeMeshes& meshes) : meshes_(meshes) {}
  void setFrameUniforms(const FrameContext& frame);
  void initFade();
  void setFade(const DrawPart& part); ///< the part's fade-in (DrawPart::fade) uniforms
  void initColourMaps();              ///< the colour maps' texture (layers of values, issue 24)
  void drawPart(const DrawPart& part,
                const DrawList& list,
                std::uint32_t from,
                std::uint32_t count,
                RenderStats& stats);

  NodeMeshes& meshes_;
  GlProgram program_{NoCreate};
  bool fp64_ = false;
  bool cullBack_ = false;
  int overlaysPerPass_ = 1;
  GLint uViewProj_ = -1, uEye_ = -1, uEyeHigh_ = -1, uEyeLow_ = -1, uUv_ = -1, uTexture_ = -1;
  GLint uSun_ = -1, uBase_ = -1, uOverlayCount_ = -1, uOverlayUv_ = -1, uOverlayOpacity_ = -1;
  GLint uOverlayNight_ = -1, uPolarScale_ = -1;
  GLint uFadeFrom_ = -1, uFadeUv_ = -1, uFade_ = -1, uMorph_ = -1;
  GLint uOverlayValues_ = -1, uOverlayRange_ = -1;
  /** Every values::colourMaps() table, one row each (256 x maps, RGBA8), on the unit after the
   * fade's: what planet.frag colours layers of values with. */
  GlTexture colourMaps_{NoCreate};
  double morphScale_ = 0.0;
};

} // namespace tellus::planet
