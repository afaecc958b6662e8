#pragma once
/**
 * @file Overview.hpp
 * @brief The global texture from an overview layer (issue 29): the whole globe of the base
 * layer's imagery on a coarser grid (e.g. 90-degree level-zero tiles of 512 px: 2048 x 1024
 * texels, about a screen), its level-zero tiles asked of the tile source like any other (so
 * cached like any tile) where the view draws, and composed into one equirectangular image as they
 * come. The global texture is then the base layer's own coarsest data instead of a bundled
 * picture, and a root whose texels it shows within the LOD threshold is drawn with it
 * (overviewSuffices): a view fetches only the level-zero tiles it needs, a whole-globe view none.
 * Main thread; the source's callbacks only push into a locked inbox.
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

class Node;

class Overview {
public:
  /** An error names an unknown layer or a grid that does not cover the globe in at most 64
   * level-zero tiles. baseTexelDeg: the base layer's level-zero texel (its level-zero delta over
   * its tile width), for texelFactor(). Asks for nothing yet. */
  static std::expected<std::unique_ptr<Overview>, std::string> start(ITileSource& source,
                                                                     const std::string& layer,
                                                                     const std::string& time,
                                                                     double baseTexelDeg);
  ~Overview();
  Overview(const Overview&) = delete;
  Overview& operator=(const Overview&) = delete;

  /** Asks for the tiles under these nodes not asked for yet (highest priority). */
  void want(const std::vector<Node*>& drawn);
  /** Whether every tile under these level-zero nodes has come (absent or not decodable counts). */
  bool covers(const std::vector<Node*>& drawn) const;
  /** When tiles came since the last call: the image of those so far (RGBA8, rows from the south,
   * -180 at the left; dark blue where none is), else nullopt. A failed tile is asked again. */
  std::optional<MipLevel> take();
  /** The overview's texel over the base layer's level-zero texel (> 0). */
  double texelFactor() const noexcept { return factor_; }

private:
  struct Inbox;
  struct Tile {
    TileKey key;
    bool asked = false;
    TileRequestId id = 0;
    std::optional<TileResult> result;
    std::vector<std::uint8_t> rgba; ///< decoded, rows from the top; empty: none
  };
  Overview(ITileSource& source, std::string layer, std::string time, TileGrid grid, double f);
  void request(std::size_t i);
  template <typename F> void forTilesUnder(const Node& n, F&& f) const;

  ITileSource& source_;
  std::string layer_;
  std::string time_;
  TileGrid grid_;
  double factor_;
  std::shared_ptr<Inbox> inbox_;
  std::vector<Tile> tiles_; ///< row-major from the south-west
};

struct LayerTextures;

/** Once a frame, before the layers' update: the tiles that came become the global texture, and
 * the base layer's streamer does not ask for roots the overview shows (from the start, so that
 * none is fetched before it comes). */
void applyOverview(Overview& overview, GlTexture& global, LayerTextures& base);
/** After the update: asks for the overview's tiles under what the base layer draws; the roots it
 * shows count as done once all of its tiles under the drawn roots are in. */
void overviewUnder(Overview& overview, LayerTextures& base);

} // namespace tellus::planet
