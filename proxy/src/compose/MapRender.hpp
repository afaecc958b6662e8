#pragma once
// One map in the making (renderMap's class): MapRender.cpp has its validators, canvas and
// encoding, MapRenderLayers.cpp the layers composed on it (decoded, holes filled, drawn).
#include "compose/MapJob.hpp"
#include "compose/TileDecode.hpp"

#include <tellus/cache/TilePath.hpp>
#include <tellus/codec/JpegYcc.hpp>
#include <tellus/codec/Png.hpp>
#include <tellus/codec/Quantize.hpp>
#include <tellus/proxy/ImageCodec.hpp>
#include <tellus/values/ValueFormat.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>

namespace tellus {

/** One map in the making: the steps of renderMap and what they pass on to each other. */
class MapRender {
  struct KeyLess {
    bool operator()(const TileKey& a, const TileKey& b) const noexcept {
      return std::tie(a.level, a.row, a.col) < std::tie(b.level, b.row, b.col);
    }
  };

  using Layer = MapComposer::Job::Layer;
  using DecodedTiles = std::map<TileKey, std::shared_ptr<const DecodedTile>, KeyLess>;

  /** How fresh an origin is, for "the least fresh tile" (X-Cache of a composed map). */
  static int staleness(TileOrigin o) noexcept {
    switch (o) {
    case TileOrigin::Hit:
      return 0;
    case TileOrigin::Miss:
      return 1;
    case TileOrigin::Stale:
      return 2;
    case TileOrigin::Offline:
      return 3;
    }
    return 3;
  }

public:
  MapRender(const MapComposer::Job& job,
            TileService& tiles,
            DecodedTileCache* cache,
            int jpegQuality)
      : job_(job), r_(job.request), tiles_(tiles), cache_(cache), jpegQuality_(jpegQuality) {}

  ComposedMap run();

private:
  ComposedMap error(std::string message);

  // ---- the validators ---------------------------------------------------------------------------

  /** The map's validators (the request and its tiles' ETags), the least fresh origin, the layers'
   * max-age, and whether a tile is missing or failed; every tile answer is shown to onTile. */
  void summarise();

  void summarise(const LayerSpec& layer, const TileAnswer& a);

  bool notModified() const;

  // ---- the canvas -------------------------------------------------------------------------------

  /** Opaque output (JPEG, 24-bit PNG, PNG without TRANSPARENT) composes on an RGB canvas; a JPEG
   * map of one opaque layer of 4:2:0 JPEG tiles on Y, Cb and Cr planes (see
   * tellus/codec/JpegYcc.hpp). */
  void prepare();

  void fill(bool ycc);

  // ---- the layers -------------------------------------------------------------------------------

  /** Composes every layer on the YCbCr path when the job may take it, else (or when a tile turns
   * out not to be a 4:2:0 JPEG, starting again) on the RGB path; true when the map is on planes. */
  bool composeOnEitherPath();

  /** False (having composed nothing more) when `ycc` and a tile is not a 4:2:0 JPEG. */
  bool composeLayers(bool ycc);

  bool composeLayer(const Layer& l, bool ycc);

  /** Each hole: the nearest cached ancestor (looked up once per ancestor); false when `ycc` and
   * one is not a 4:2:0 JPEG. */
  bool
  fillHoles(const Layer& l, bool ycc, const std::vector<TileKey>& holes, DecodedTiles& decoded);

  /** A tile decoded: kept whole in the cache when maps keep asking for it, else only the part of
   * it that is sampled (JPEG: whole blocks around `region`); null when it does not decode, and
   * with `notYcc` set when `ycc` and it is not a 4:2:0 JPEG. */
  std::shared_ptr<const DecodedTile> decode(const Layer& l,
                                            const TileAnswer& a,
                                            const std::array<std::int32_t, 4>* region,
                                            bool ycc,
                                            bool& notYcc);

  /** The three planes, each from the tiles' plane of the same index, each sample written (the
   * background's Y, Cb or Cr where no tile covers it). */
  void drawPlanes(const Layer& l, const DecodedTiles& decoded);

  /** A layer on the RGB(A) canvas or the heights: as what it is, or heights as grey in a
   * picture, or a picture as its luminance in heights. */
  void drawLayer(const Layer& l, const DecodedTiles& decoded);

  /** A value layer coloured by its style: values sampled per pixel, then coloured (the range
   * from this map's values when the layer says so); in a heights map, the colours' luminance. */
  void drawValueLayer(const Layer& l, const TileLookup& lookup);

  void count(const ComposeStats& s);

  // ---- the bytes --------------------------------------------------------------------------------

  std::expected<std::vector<std::byte>, std::string> encode(bool ycc);

  const MapComposer::Job& job_;
  const ComposeRequest& r_;
  TileService& tiles_;
  DecodedTileCache* cache_;
  const int jpegQuality_;

  ComposedMap map_;
  std::string validators_;
  bool complete_ = true;
  bool failed_ = false;
  std::string failure_; ///< the message of a tile that failed

  bool png8_ = false;
  int cc_ = 3;             ///< the canvas's channels: 3 (RGB) or 4 (RGBA)
  std::size_t pixels_ = 0; ///< width * height
  std::uint8_t bg_[4] = {};
  std::optional<ChromaLayout> chroma_;
  ComposerBuffers& buffers_ = composerBuffers(); ///< this composer thread's (TileDecode.hpp)
  std::vector<std::uint8_t>& canvas_ = buffers_.canvas;
  std::vector<std::int16_t> heights_;
  std::vector<float> values_; ///< a map of values (application/bil32)
  // One layer of the other kind than the map, before it is drawn over the map (see
  // ComposeRequest::layers).
  std::vector<std::int16_t> layerHeights_;
  std::vector<std::uint8_t> layerPicture_;
  std::vector<float> layerValues_;
  std::size_t missing_ = 0; ///< pixels no tile covers
};

} // namespace tellus
