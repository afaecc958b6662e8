#pragma once
/**
 * @file Lod.hpp
 * @brief The texel-to-pixel LOD test (thesis 4.2): the node's four surface corners, a plane
 * approximation, are projected; the node splits when a projected edge is longer than the tile's
 * size in texels times the threshold (squared lengths, no square root).
 *
 * The corner test alone measures the average texel along an edge: perspective enlarges the near
 * texels of a tilted view (1.6 px at 60 degrees), and a camera above the interior of a large node
 * whose corners are all far away sees texels far larger than the corners show (3.5 px tilted over
 * a level-2 polar wedge from 240 km). With LodParams::perspectiveAware (the default) the node also
 * splits when the local size of one texel, east-west or north-south, projects longer than the
 * threshold at any of its sample points: the four corners, the node's point nearest below the
 * camera (its latitude and longitude clamped into the sector) when it is in the viewport, and the
 * points of the ground seen through the viewport's corners, edge midpoints and centre that lie in
 * the node (Camera::viewportGround: the nearest visible ground of a tilted view). The local size is
 * the projection's derivative (exact, not a plane approximation) applied to one texel's step along
 * the surface. The nearest visible point of a node lies at one of these up to the surface's
 * curvature, so the largest texel of a drawn node stays within a few percent of the threshold.
 *
 * threshold is the user's speed/accuracy knob: 1.0 keeps a texel never larger than a pixel, 2.0
 * allows two pixels per texel (fewer nodes), 0.5 asks for supersampling.
 */

#include <tellus/planet/Camera.hpp>
#include <tellus/planet/Patch.hpp>

namespace tellus::planet {

struct LodParams {
  int tileWidthPx = 512;  ///< texels across a tile (east-west edges compare to this)
  int tileHeightPx = 512; ///< texels along a tile (north-south edges compare to this)
  double threshold = 1.0; ///< > 0
  /** Also split when a texel's local projected size exceeds the threshold at the corners, the
   * point below the camera or the viewport's ground points in the node (see the file comment);
   * false: the thesis's corner-edge test alone (for comparison). */
  bool perspectiveAware = true;
  /** With perspectiveAware, in a perspective view: only what the viewport shows counts. A corner
   * off screen is no sample; an edge counts by its part inside the frustum, against that part's
   * share of the tile's texels, and where it crosses the viewport's border the crossing is a
   * sample of the local test (the largest visible texel of a node lies at a vertex of its visible
   * part: a visible corner, a border crossing, or a viewport corner's ground point). Off-screen
   * corners are where perspective stretches texels most (1 / cos^2 of the angle off the axis)
   * and, in a tilted view, where the ground is nearest: counting them refined every node of the
   * Alps view one level deeper than the screen needs (issue 29). Merged polar rows and caps
   * (evaluateLod's merged), the fisheye, and a node whose on-screen samples all lie on the
   * globe's far side (hidden; culling's bounds are conservative) keep the whole-node test.
   * false: every corner and whole edges (for comparison). */
  bool onScreenOnly = true;
};

struct LodResult {
  bool split = false;
  /** A corner is on or behind the near plane: the node straddles the camera; it splits. */
  bool cornerBehindCamera = false;
  /** Largest (projected edge length / (tile size * threshold))^2 over the edges; 0 when a corner
   * is behind the camera. Above 1 means split. */
  double worstRatioSquared = 0.0;
  /** With perspectiveAware: the largest (local projected texel size / threshold)^2 over the
   * sample points; computed only when the edges alone do not split (0 otherwise). Above 1 means
   * split. */
  double worstTexelRatioSquared = 0.0;
  /** Which axis of the local texel test is over the limit (set only when that test ran). East-
   * west alone: a merged polar row must split east-west, since children as wide as itself would
   * keep the same east-west texels where the sample lies. */
  bool eastWestOver = false;
  bool northSouthOver = false;
};

/** Never produces NaN: a node whose corners cannot all be projected (behind the near plane, or a
 * non-finite clip position) is treated as needing refinement. Invalid params (tile size < 1,
 * threshold not > 0 or not finite) split nothing. merged: the node is a merged polar row or a
 * cap (NodeKey::span > 1), which keeps the whole-node test (LodParams::onScreenOnly). */
LodResult evaluateLod(const Camera& camera,
                      const NodeGeometry& node,
                      const LodParams& params,
                      bool merged = false) noexcept;

} // namespace tellus::planet
