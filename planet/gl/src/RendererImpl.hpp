#pragma once
/**
 * @file RendererImpl.hpp
 * @brief What a Renderer holds, one member per unit of the frame (docs/design/renderer.md, "The
 * GL layer"). A frame (Renderer::frame, Renderer.cpp) runs the phases in this order:
 *
 *   begin    heights delivered (TerrainState::deliver), the pose kept above the terrain, the
 *            camera, relief on or off (TerrainState::chooseRelief)
 *   update   trees, LOD, streaming requests (FrameUpdate.hpp), the heights wanted (TerrainState)
 *   intake   received tiles kept, decodes launched, decoded textures taken (TextureIntake.hpp)
 *   plan     what is drawn, and whether that is what the LOD asks for (DrawList.hpp)
 *   upload   banded uploads under the pacer's budget (UploadQueue.hpp), then evictions (LayerSet)
 *   mesh     node meshes, edge fixing, coarse first (NodeMeshes.hpp); the camera lifted again
 *   draw     the scene passes into the framebuffer, or the dome's (SceneDraw.hpp, Dome.hpp), a
 *            projector's warp and blend (ProjectorWarp.hpp), and the window (WindowPresenter.hpp;
 *            or later, on request: RendererPresent.cpp)
 *   end      old tiles and meshes dropped, glFinish, ready layer times swapped in (LayerSet), the
 *            statistics
 *
 * Members are destroyed in reverse order: the context is declared first, so it goes last, and
 * ~Impl makes it current before any member goes (every GL object is deleted in its context).
 * Main thread only.
 */

#include "GlContext.hpp"
#include "LayerSet.hpp"
#include "LegendOverlay.hpp"
#include "NodeMeshes.hpp"
#include "NodeTextures.hpp"
#include "Overview.hpp"
#include "ProjectorWarp.hpp"
#include "SceneDraw.hpp"
#include "TerrainState.hpp"
#include "TextureDecoder.hpp"
#include "UploadPacer.hpp"
#include "UploadQueue.hpp"
#include "WindowPresenter.hpp"

#include <tellus/planet_gl/Renderer.hpp>

#include <chrono>
#include <memory>
#include <optional>
#include <string>

namespace tellus::planet {

class GlobePass;

struct Renderer::Impl {
  using Clock = std::chrono::steady_clock;

  Impl(ITileSource& s, const Geodesy& g, RendererOptions o, TileGrid baseGrid);
  ~Impl();
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;

  /** The context and everything made in it: capabilities, the globe's program and meshes, the
   * scene's framebuffer and passes, the global texture. A message when any of it fails. */
  std::string openGl();
  /** One untimed frame before the first real one (Renderer.cpp). */
  void warmUp();
  /** The pose with its altitude raised to the surface as drawn plus the clearance, when lower. */
  CameraPose clampToTerrain(const CameraPose& pose) const;
  /** The camera a pose gives at the framebuffer's size (a fisheye with a dome). */
  Camera cameraFor(const CameraPose& pose) const;
  /** The frame's first phase: the pose drawn (above the terrain) and its camera. */
  struct View {
    CameraPose pose;
    Camera camera;
  };
  View beginFrame(const CameraPose& pose);
  /** The mesh phase; the camera lifted again when the meshes put the surface above it. */
  void buildMeshes(View& view);
  /** The draw phase: the scene (SceneDraw) and, for a visible window, the presentation. */
  void draw(const Camera& camera, const DrawList& list);
  /** The presented image to the window, swapped (RendererPresent.cpp). */
  void present();
  /** The legends of the visible layers of values, into the scene's framebuffer. */
  void drawLegends();
  /** The end of the frame's work: tiles that arrived for nodes gone from view are dropped after a
   * while (asked again if needed), unused meshes too, and the window's events polled. */
  void houseKeeping();
  /** Ready layer times swapped in, and the frame's statistics. */
  void endFrame(const FrameStats& tree, bool complete, FramePhases& phases, Clock::time_point t0);
  double surfaceHeightAt(double latDeg, double lonDeg) const;
  /** The frame clock now (RendererOptions::frameClock, else seconds since start). */
  double frameClockNow() const;

  std::shared_ptr<GlContext> context; // first: destroyed last (shareWindowOf: shared)
  ITileSource& source;
  const Geodesy& geodesy;
  RendererOptions opt;
  NodeTextureFormat textureFormat;
  TerrainState terrain;
  LayerSet layers; ///< [0] the base imagery, then the overlays in drawing order
  TextureDecoder decoder;
  UploadPacer pacer;
  UploadQueue uploads;
  std::unique_ptr<NodeMeshes> meshes;
  GlTexture globalTexture{NoCreate};  ///< always resident: the last fallback
  std::unique_ptr<Overview> overview; ///< RendererOptions::overviewLayer's, else null
  std::unique_ptr<SceneDraw> scene;
  GlobePass* globePass = nullptr; ///< the scene's globe pass (owned by scene): its morph scale
  LegendOverlay legends;          ///< the layers of values' legends (RendererOptions::legend)
  WindowPresenter presenter;
  std::unique_ptr<ProjectorWarp> projector; ///< RendererOptions::projectorWarp's pass, else null
  RenderStats stats;
  bool lastComplete = false;
  /** The last frame's draw list (Renderer::redrawLast), while what it points to lives: reset when
   * a layer time swaps a tree out. */
  std::optional<DrawList> lastList;
  Clock::time_point start = Clock::now();
  double frameS = 0.0; ///< the frame clock of the frame being drawn
  CameraPose drawnPose{};
};

} // namespace tellus::planet
