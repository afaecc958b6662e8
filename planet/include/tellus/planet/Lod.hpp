#pragma once
/**
 * @file Lod.hpp
 * @brief The texel-to-pixel LOD test (thesis 4.2): the node's four surface corners, a plane
 * approximation, are projected; the node splits when a projected edge is longer than the tile's
 * size in texels times the threshold (squared lengths, no square root).
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
};

struct LodResult {
  bool split = false;
  /** A corner is on or behind the near plane: the node straddles the camera; it splits. */
  bool cornerBehindCamera = false;
  /** Largest (projected edge length / (tile size * threshold))^2 over the edges; 0 when a corner
   * is behind the camera. Above 1 means split. */
  double worstRatioSquared = 0.0;
};

/** Never produces NaN: a node whose corners cannot all be projected (behind the near plane, or a
 * non-finite clip position) is treated as needing refinement. Invalid params (tile size < 1,
 * threshold not > 0 or not finite) split nothing. */
LodResult
evaluateLod(const Camera& camera, const NodeGeometry& node, const LodParams& params) noexcept;

} // namespace tellus::planet
