#pragma once
/**
 * @file Overview.hpp
 * @brief The global texture from an overview layer (issue 29): the whole globe of the base
 * layer's imagery on a coarser grid (e.g. 90-degree level-zero tiles of 512 px: 2048 x 1024
 * texels, about a screen), its level-zero tiles asked of the tile source like any other (so
 * cached like any tile), composed into one equirectangular image once all have come. The global
 * texture is then the base layer's own coarsest data instead of a bundled picture, and a root
 * whose texels it shows within the LOD threshold is drawn with it (overviewSuffices): a view
 * fetches only the level-zero tiles it needs, a whole-globe view none. Main thread; the source's
 * callbacks only push into a locked inbox.
 */

#include "GlObjects.hpp"
#include "TextureDecoder.hpp"

#include <tellus/cache/TileGrid.hpp>
#include <tellus/cache/TileSource.hpp>

#include <cstddef>
#include <expected>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace tellus::planet {

class Overview {
public:
  /** Asks for every level-zero tile of `layer` (at `time`). An error names an unknown layer or
   * a grid that does not cover the globe. baseTexelDeg: the base layer's level-zero texel (its
   * level-zero delta over its tile width), for texelFactor(). */
  static std::expected<std::unique_ptr<Overview>, std::string> start(ITileSource& source,
                                                                     const std::string& layer,
                                                                     const std::string& time,
                                                                     double baseTexelDeg);
  ~Overview();
  Overview(const Overview&) = delete;
  Overview& operator=(const Overview&) = delete;

  /** Once every tile has come: the composed image (RGBA8, rows from the south, -180 at the
   * left), once; nullopt before and after. A tile that is absent or does not decode leaves its
   * area dark blue (the global texture's colour without an image); a failed one is asked again. */
  std::optional<MipLevel> take();
  /** The overview's texel over the base layer's level-zero texel (> 0). */
  double texelFactor() const noexcept { return factor_; }
  bool composed() const noexcept { return composed_; }
  std::size_t requested() const noexcept { return requested_; }

private:
  struct Inbox;
  Overview(ITileSource& source, std::string layer, std::string time, TileGrid grid, double f);
  void request(const TileKey& key);

  ITileSource& source_;
  std::string layer_;
  std::string time_;
  TileGrid grid_;
  double factor_;
  std::shared_ptr<Inbox> inbox_;
  std::vector<TileKey> keys_;
  std::vector<std::optional<TileResult>> results_;
  std::vector<TileRequestId> ids_;
  std::size_t requested_ = 0;
  bool composed_ = false;
};

struct LayerTextures;

/** Once a frame, before the layers' update: the base layer's streamer stops asking for roots the
 * overview will show (from the start, so that none is fetched before it comes); once composed,
 * the overview becomes the global texture and those roots count as done. */
void applyOverview(Overview& overview, GlTexture& global, LayerTextures& base);

} // namespace tellus::planet
