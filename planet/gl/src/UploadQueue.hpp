#pragma once
/**
 * @file UploadQueue.hpp
 * @brief The frame's upload phase: decoded textures go to the GL in row bands of one mip level at
 * a time, within the frame's byte and time caps (UploadPacer). A texture is taken from its
 * layer's pool, or made, when its first band goes, so that making many textures is spread over
 * frames like their bytes. The texture is not in the LRU (its node is Uploading, never Finished)
 * until every level is there, so no frame samples a half-uploaded level; then it is installed in
 * its layer (LayerTextures::install) and drawn from the next frame on. An upload whose layer was
 * swapped out meanwhile is dropped, its texture with it. Main thread, context current.
 */

#include "LayerSet.hpp"
#include "NodeTextures.hpp"
#include "TextureDecoder.hpp"
#include "UploadPacer.hpp"

#include <cstddef>
#include <deque>

namespace tellus::planet {

/** A decoded texture on its way to the GL: the band that goes next. */
struct Upload {
  DecodedTexture texture; ///< its tag names the layer (LayerTextures::tag)
  NodeTexture gl;         ///< made or taken from the pool when the first band goes
  std::size_t level = 0;
  int row = 0;
};

/** Rows of a band: as many of rowBytes as fit in bandBytes, at least one, at most rowsLeft. */
int bandRows(std::size_t bandBytes, std::size_t rowBytes, int rowsLeft) noexcept;

class UploadQueue {
public:
  void push(DecodedTexture texture);
  /** Uploads bands while the pacer lets this frame continue (adds to stats.bytesUploaded,
   * texturesUploaded, texturesReused). */
  void step(LayerSet& layers,
            const UploadPacer& pacer,
            const NodeTextureFormat& format,
            RenderStats& stats);
  bool empty() const noexcept { return queue_.empty(); }
  std::size_t size() const noexcept { return queue_.size(); }

private:
  std::deque<Upload> queue_;
};

} // namespace tellus::planet
