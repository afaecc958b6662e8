#pragma once
/**
 * @file TerrainState.hpp
 * @brief The renderer's heights (issue #6; GL-free): the elevation layer's HeightField and its
 * HeightStreamer, which heights a frame needs, and whether the frame shows relief at all.
 *
 * - Update phase (want): the drawn nodes' heights, each at the elevation level whose samples are
 *   as fine as its grid (one heightmap serves several node levels, thesis 4.5.1), coarse levels
 *   first.
 * - Start of a frame (deliver): a few arrivals go into the field; every layer's tree refreshes
 *   the bounds they change, so LOD and culling agree with the geometry drawn, and the meshes they
 *   change are rebuilt in the same frame (NodeMeshes), so every frame's meshes come from one state
 *   of the heights.
 * - "Model only what a scene requires" (issue #8, chooseRelief): a frame draws heights only when
 *   relief could move the nearest surface point by RendererOptions::terrainMinReliefPx pixels; a
 *   pure function of the camera (reliefCouldShow), so a frame does not depend on what earlier
 *   frames loaded. Switching re-applies the heights (flat or not) to every tree; the meshes see
 *   reliefOff() and rebuild.
 *
 * Issue 26 (other bodies): heights are metres along the body's normal; the body comes in through
 * the trees' Geodesy, so this class needs no change beyond its relief bound (Everest's here).
 * Main thread only.
 */

#include <tellus/cache/TileSource.hpp>
#include <tellus/planet/Camera.hpp>
#include <tellus/planet/HeightStreamer.hpp>
#include <tellus/planet/Quadtree.hpp>
#include <tellus/planet/Terrain.hpp>
#include <tellus/planet_gl/Renderer.hpp>

#include <cstddef>
#include <expected>
#include <memory>
#include <string>
#include <vector>

namespace tellus::planet {

class LayerSet;

/** Whether relief of at most boundM metres (along the normal) could move a surface point by at
 * least minPx pixels seen from altitudeM (the distance to the nearest point of the ellipsoid):
 * boundM * f / (altitudeM - boundM) with f the view's focal length in pixels (the fisheye's
 * pixels per radian). True when the camera is within boundM of the ellipsoid. */
bool reliefCouldShow(const Camera& camera, double altitudeM, double boundM, double minPx);

class TerrainState {
public:
  /** Without open(): no elevation layer, heights 0 everywhere. options must outlive this. */
  explicit TerrainState(const RendererOptions& options) : opt_(options) {}
  TerrainState(const TerrainState&) = delete;
  TerrainState& operator=(const TerrainState&) = delete;

  /** The options' elevation layer: its field and streamer. Fails with a message (a bad
   * exaggeration, an unknown layer or grid). */
  std::expected<void, std::string> open(ITileSource& source);
  bool enabled() const noexcept { return field_ != nullptr; }
  const HeightField* field() const noexcept { return field_.get(); }
  /** This frame draws the bare ellipsoid and fetches no heights. */
  bool reliefOff() const noexcept { return reliefOff_; }
  /** Height in metres (exaggerated) at a point as the meshes take it: 0 without an elevation
   * layer or while the relief is off. */
  double heightAt(double latDeg, double lonDeg) const {
    return field_ && !reliefOff_ ? field_->heightAt(latDeg, lonDeg) * opt_.verticalExaggeration
                                 : 0.0;
  }

  /** A tree's height ranges and its horizon occluder: below the lowest height, less the depth of
   * its coarsest chords (chordDepthM), so the horizon test never culls what shows over a sagging
   * triangle nearer the camera. */
  void applyTo(Quadtree& tree, double chordDepthM) const;
  /** Switches the relief on or off for this camera (reliefCouldShow with the data's bound) and
   * re-applies the heights to every layer's tree when it changes. */
  void chooseRelief(const Camera& camera, double altitudeM, LayerSet& layers);
  /** The frame's time (RendererOptions::frameClock, s) for the height tiles' fade-in
   * (HeightField::setFade: RendererOptions::fadeInSeconds, as textures). */
  void setTime(double nowS) {
    if (field_) field_->setTime(nowS);
  }
  /** A few decoded height tiles into the field; every layer's tree refreshed where they changed. */
  void deliver(LayerSet& layers);
  /** The update phase's heights: what the drawn nodes need, to the streamer (RenderStats'
   * height figures and nodesWithoutHeights). */
  void want(const Quadtree& geo, double nowS, RenderStats& stats);
  /** Every height tile the node's mesh needs is settled and none over it still fades in (or
   * heights are off). */
  bool complete(const Node& node) const;
  bool busy() const { return heights_ && heights_->busy(); }

  /** The elevation level a node's mesh needs (samples as fine as its grid); for a cap, the finest
   * level whose tiles over the whole cap number at most kCapHeightKeys. */
  int heightLevelFor(const Node& node) const;
  static constexpr std::size_t kCapHeightKeys = 64;

private:
  const RendererOptions& opt_;
  std::unique_ptr<HeightField> field_; ///< null without an elevation layer
  std::unique_ptr<HeightStreamer> heights_;
  std::vector<TileKey> wish_;
  bool reliefOff_ = false;
};

} // namespace tellus::planet
