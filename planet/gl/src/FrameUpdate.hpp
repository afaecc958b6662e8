#pragma once
/**
 * @file FrameUpdate.hpp
 * @brief The frame's update phase for the layers (GL-free): each tree's LOD and culling from the
 * camera, and each streamer's requests in the tree's order. The base layer's tree is always
 * updated (it is what is drawn); an overlay's only while visible; a layer switching to another
 * time streams the new time's tiles only (the old time's stop being asked for) while its old
 * tree keeps its LRU frame. The heights' part of the phase is TerrainState::want.
 */

#include "LayerSet.hpp"

#include <tellus/planet/Camera.hpp>
#include <tellus/planet/Quadtree.hpp>

namespace tellus::planet {

/** Updates every layer's tree and streamer for this camera at nowS (seconds since the renderer
 * began) and marks each LayerTextures::updated; the base tree's figures (a copy: the tree may be
 * swapped out at the end of the frame). */
FrameStats updateLayers(LayerSet& layers, const Camera& camera, double nowS);

} // namespace tellus::planet
