// The map of one GetMap from its tiles' answers (MapComposer::finish's work, on a composer
// worker), in the order of its steps: the validators (a client that has the map gets 304 before
// anything is decoded); the canvas; per layer the tiles decoded (TileDecode.cpp: only the part
// sampled, or whole and kept), the holes filled from the nearest coarser cached tile, the samples
// drawn (on Y, Cb and Cr planes when every tile is a 4:2:0 JPEG, else on RGB(A) or heights, with
// the RGB path taking over when a tile turns out not to be); then the map encoded. See
// docs/design/composition.md.
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

namespace {

/** How fresh an origin is, for "the least fresh tile" (X-Cache of a composed map). */
int staleness(TileOrigin o) noexcept {
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

std::optional<std::vector<std::byte>> bytesOf(const TileAnswer& a) {
  if (a.file) return a.file->readAll();
  return a.bytes;
}

struct KeyLess {
  bool operator()(const TileKey& a, const TileKey& b) const noexcept {
    return std::tie(a.level, a.row, a.col) < std::tie(b.level, b.row, b.col);
  }
};

using Layer = MapComposer::Job::Layer;
using DecodedTiles = std::map<TileKey, std::shared_ptr<const DecodedTile>, KeyLess>;

/** A quoted ETag: the hash of a map's validators. */
std::string etagOf(const std::string& validators) {
  char etag[24];
  std::snprintf(
      etag, sizeof etag, "\"%016llx\"", static_cast<unsigned long long>(stableHash64(validators)));
  return etag;
}

/** One map in the making: the steps of renderMap and what they pass on to each other. */
class MapRender {
public:
  MapRender(const MapComposer::Job& job,
            TileService& tiles,
            DecodedTileCache* cache,
            int jpegQuality)
      : job_(job), r_(job.request), tiles_(tiles), cache_(cache), jpegQuality_(jpegQuality) {}

  ComposedMap run() {
    summarise();
    map_.etag = etagOf(validators_);
    if (notModified()) {
      map_.kind = ComposedMap::Kind::NotModified;
      return std::move(map_);
    }
    prepare();
    const bool ycc = composeOnEitherPath();
    if (failed_ && missing_ > 0) {
      // An upstream failed and nothing cached covers the hole: an error, not a map with a hole
      // that a client would keep.
      return error("part of the map is not available: " + failure_);
    }
    if (!complete_) {
      // Filled in from coarser levels (or empty where the upstream has nothing): not for long.
      map_.maxAgeSeconds = std::min<std::int64_t>(map_.maxAgeSeconds, 60);
      map_.etag = etagOf(validators_);
    }
    auto encoded = encode(ycc);
    if (!encoded) return error("cannot encode the map: " + encoded.error());
    if (canvas_.capacity() > (16u << 20)) canvas_ = {}; // a huge map's canvas is not kept
    if (buffers_.cb.capacity() > (4u << 20)) buffers_.cb = buffers_.cr = {};
    map_.kind = ComposedMap::Kind::Map;
    map_.bytes = std::move(*encoded);
    map_.contentType = std::string(contentTypeOf(r_.format));
    return std::move(map_);
  }

private:
  ComposedMap error(std::string message) {
    map_.kind = ComposedMap::Kind::Error;
    map_.message = std::move(message);
    return std::move(map_);
  }

  // ---- the validators ---------------------------------------------------------------------------

  /** The map's validators (the request and its tiles' ETags), the least fresh origin, the layers'
   * max-age, and whether a tile is missing or failed; every tile answer is shown to onTile. */
  void summarise() {
    validators_ = std::string(toString(r_.format)) + "|" + std::to_string(r_.width) + "x" +
                  std::to_string(r_.height) + "|" + (r_.transparent ? "t" : "o") + "|" +
                  std::to_string(r_.bgcolor.value_or(0x1000000));
    char box[128];
    std::snprintf(box,
                  sizeof box,
                  "|%.17g,%.17g,%.17g,%.17g",
                  r_.bbox.west,
                  r_.bbox.south,
                  r_.bbox.east,
                  r_.bbox.north);
    validators_ += box;
    if (r_.bbox.rows == MapRows::Mercator) {
      std::snprintf(box, sizeof box, "|3857:%.17g,%.17g", r_.bbox.southY, r_.bbox.northY);
      validators_ += box;
    }
    map_.origin = TileOrigin::Hit;
    map_.maxAgeSeconds = 86400 * 365;
    for (const auto& l : job_.layers) {
      validators_ +=
          "|" + l.spec.layer->name + "@" + l.spec.time + "#" + std::to_string(l.spec.opacity);
      if (l.spec.colourMap) validators_ += "~" + std::string(l.spec.colourMap->name);
      map_.maxAgeSeconds = std::min<std::int64_t>(map_.maxAgeSeconds, l.spec.layer->maxAge.count());
      for (const TileAnswer& a : l.answers)
        summarise(*l.spec.layer, a);
    }
  }

  void summarise(const LayerSpec& layer, const TileAnswer& a) {
    if (job_.onTile) job_.onTile(layer, a);
    if (staleness(a.origin) > staleness(map_.origin)) map_.origin = a.origin;
    if (a.kind == TileAnswer::Kind::Tile) {
      validators_ += a.etag;
      return;
    }
    complete_ = false;
    if (a.kind != TileAnswer::Kind::Error) return;
    failed_ = true;
    failure_ = a.message;
    const auto rank = [](TileAnswer::Failure f) {
      return f == TileAnswer::Failure::Unavailable  ? 2
             : f == TileAnswer::Failure::OverBudget ? 1
                                                    : 0;
    };
    if (rank(a.failure) > rank(map_.failure)) map_.failure = a.failure;
    map_.retryAfterSeconds = std::max(map_.retryAfterSeconds, a.retryAfterSeconds);
  }

  bool notModified() const {
    return complete_ && !r_.ifNoneMatch.empty() &&
           (r_.ifNoneMatch == "*" || r_.ifNoneMatch.find(map_.etag) != std::string::npos);
  }

  // ---- the canvas -------------------------------------------------------------------------------

  /** Opaque output (JPEG, 24-bit PNG, PNG without TRANSPARENT) composes on an RGB canvas; a JPEG
   * map of one opaque layer of 4:2:0 JPEG tiles on Y, Cb and Cr planes (see
   * tellus/codec/JpegYcc.hpp). */
  void prepare() {
    png8_ = r_.format == MapFormat::Png8;
    cc_ = r_.format == MapFormat::Png32 ||
                  (r_.transparent &&
                   (r_.format == MapFormat::Png || png8_ || r_.format == MapFormat::Tiff))
              ? 4
              : 3;
    pixels_ = static_cast<std::size_t>(r_.width) * static_cast<std::size_t>(r_.height);
    const std::uint32_t bgColour = r_.bgcolor.value_or(0xFFFFFF);
    bg_[0] = static_cast<std::uint8_t>(bgColour >> 16);
    bg_[1] = static_cast<std::uint8_t>(bgColour >> 8);
    bg_[2] = static_cast<std::uint8_t>(bgColour);
    bg_[3] = static_cast<std::uint8_t>(r_.transparent ? 0 : 255);
    if (job_.ycc) chroma_ = chromaLayout(*job_.layers.front().grid, r_.bbox, r_.width, r_.height);
  }

  void fill(bool ycc) {
    if (r_.values) {
      values_.assign(pixels_, std::numeric_limits<float>::quiet_NaN());
    } else if (r_.heights) {
      heights_.assign(pixels_, r_.noData);
    } else if (ycc) {
      // Nothing to fill: composePlane writes every sample of the planes, the background where
      // no tile covers it (a map's single layer; the RGB path fills again if it takes over).
    } else {
      canvas_.resize(pixels_ * static_cast<std::size_t>(cc_));
      // The first row pixel by pixel, the others copied from it.
      const auto rowBytes = static_cast<std::size_t>(r_.width) * static_cast<std::size_t>(cc_);
      for (std::size_t p = 0; p < static_cast<std::size_t>(r_.width); ++p)
        std::copy(bg_, bg_ + cc_, &canvas_[p * static_cast<std::size_t>(cc_)]);
      for (std::size_t y = 1; y < static_cast<std::size_t>(r_.height); ++y)
        std::memcpy(&canvas_[y * rowBytes], canvas_.data(), rowBytes);
    }
  }

  // ---- the layers -------------------------------------------------------------------------------

  /** Composes every layer on the YCbCr path when the job may take it, else (or when a tile turns
   * out not to be a 4:2:0 JPEG, starting again) on the RGB path; true when the map is on planes. */
  bool composeOnEitherPath() {
    bool ycc = job_.ycc && chroma_.has_value();
    // What a retry on the RGB path starts again from.
    const std::string validatorsBefore = validators_;
    const TileOrigin originBefore = map_.origin;
    fill(ycc);
    if (!composeLayers(ycc)) {
      ycc = false;
      validators_ = validatorsBefore;
      map_.origin = originBefore;
      map_.decodedTiles = 0;
      map_.tiles = 0;
      map_.fallbackPixels = 0;
      missing_ = 0;
      fill(false);
      composeLayers(false);
    }
    return ycc;
  }

  /** False (having composed nothing more) when `ycc` and a tile is not a 4:2:0 JPEG. */
  bool composeLayers(bool ycc) {
    for (const auto& l : job_.layers) {
      if (!composeLayer(l, ycc)) return false;
    }
    return true;
  }

  bool composeLayer(const Layer& l, bool ycc) {
    DecodedTiles decoded;
    std::vector<TileKey> holes;
    bool notYcc = false;
    for (std::size_t k = 0; k < l.keys.size() && !notYcc; ++k) {
      const TileAnswer& a = l.answers[k];
      std::shared_ptr<const DecodedTile> d;
      if (a.kind == TileAnswer::Kind::Tile) d = decode(l, a, &l.keys[k].region, ycc, notYcc);
      if (d) {
        decoded.emplace(l.keys[k].key, std::move(d));
      } else {
        holes.push_back(l.keys[k].key);
      }
    }
    if (notYcc || !fillHoles(l, ycc, holes, decoded)) return false;
    map_.tiles += decoded.size();
    if (ycc)
      drawPlanes(l, decoded);
    else
      drawLayer(l, decoded);
    return true;
  }

  /** Each hole: the nearest cached ancestor (looked up once per ancestor); false when `ycc` and
   * one is not a 4:2:0 JPEG. */
  bool
  fillHoles(const Layer& l, bool ycc, const std::vector<TileKey>& holes, DecodedTiles& decoded) {
    std::map<TileKey, bool, KeyLess> looked;
    bool notYcc = false;
    for (TileKey key : holes) {
      while (key.level > 0) {
        const auto parent = l.grid->parent(key);
        if (!parent) break;
        key = *parent;
        if (auto it = looked.find(key); it != looked.end()) {
          if (it->second) break;
          continue;
        }
        bool found = false;
        if (auto a = tiles_.cachedTile(l.spec.layer->name, l.spec.time, key)) {
          if (auto d = decode(l, *a, nullptr, ycc, notYcc)) {
            decoded.emplace(key, std::move(d));
            found = true;
            if (staleness(a->origin) > staleness(map_.origin)) map_.origin = a->origin;
            validators_ += a->etag;
          }
        }
        if (notYcc) return false;
        looked.emplace(key, found);
        if (found) break;
      }
    }
    return true;
  }

  /** A tile decoded: kept whole in the cache when maps keep asking for it, else only the part of
   * it that is sampled (JPEG: whole blocks around `region`); null when it does not decode, and
   * with `notYcc` set when `ycc` and it is not a 4:2:0 JPEG. */
  std::shared_ptr<const DecodedTile> decode(const Layer& l,
                                            const TileAnswer& a,
                                            const std::array<std::int32_t, 4>* region,
                                            bool ycc,
                                            bool& notYcc) {
    const LayerSpec& spec = *l.spec.layer;
    const GridSpec& g = l.grid->spec();
    // Decoded tiles are kept (whole) in an LRU by their ETag, which names their bytes.
    const bool valued = (l.spec.colourMap != nullptr || r_.values) && spec.values.has_value();
    const std::string cacheKey = spec.name + '\n' + l.spec.time + '\n' + a.etag +
                                 (ycc ? "\nycc" : "") + (valued ? "\nvalues" : "");
    bool keep = false;
    if (cache_ && !a.etag.empty()) {
      if (auto hit = cache_->get(cacheKey)) return hit;
      // A tile that maps keep asking for is decoded whole and kept; one that is not (yet) worth
      // a place is decoded only in the part this map samples.
      const auto texels =
          static_cast<std::size_t>(g.tileWidth) * static_cast<std::size_t>(g.tileHeight);
      keep = cache_->admits(cacheKey,
                            valued           ? texels * 4
                            : spec.elevation ? texels * 2
                            : ycc            ? texels * 3 / 2
                                             : texels * 3);
      if (keep) region = nullptr;
    }
    const std::string_view type =
        a.contentType.empty() ? std::string_view(spec.dataset.mimeType) : a.contentType;
    if (ycc && type != "image/jpeg") {
      notYcc = true;
      return nullptr;
    }
    auto bytes = bytesOf(a);
    if (!bytes) return nullptr;
    ++map_.decodedTiles;
    auto d = std::make_shared<DecodedTile>();
    const bool ok = valued           ? decodeValuesInto(*d, *bytes, *spec.values, g)
                    : spec.elevation ? decodeHeightsInto(*d, *bytes, spec, g)
                    : ycc            ? decodePlanesInto(*d, *bytes, g, region, keep, notYcc)
                                     : decodeRgbInto(*d, *bytes, type, g, region, keep);
    if (!ok) return nullptr;
    // Counted by what they hold (storage of their own size, not a reused larger buffer).
    if (keep)
      cache_->put(cacheKey,
                  d,
                  d->rgb.capacity() + d->heights.capacity() * sizeof(std::int16_t) +
                      d->values.capacity() * sizeof(float));
    return d;
  }

  /** The three planes, each from the tiles' plane of the same index, each sample written (the
   * background's Y, Cb or Cr where no tile covers it). */
  void drawPlanes(const Layer& l, const DecodedTiles& decoded) {
    const auto ycbcr = codec::rgbToYcc(bg_[0], bg_[1], bg_[2]);
    ComposeStats stats;
    for (int plane = 0; plane < 3; ++plane) {
      const TileLookup lookup = [&decoded, plane](const TileKey& key) -> const TileSamples* {
        const auto it = decoded.find(key);
        return it == decoded.end() ? nullptr : &it->second->planes[static_cast<std::size_t>(plane)];
      };
      std::vector<std::uint8_t>& target = plane == 0   ? canvas_
                                          : plane == 1 ? buffers_.cb
                                                       : buffers_.cr;
      const auto background = ycbcr[static_cast<std::size_t>(plane)];
      // One band (MapComposer takes a map of several off the planes).
      const std::int32_t level = l.bands.front().level;
      const ComposeStats s =
          plane == 0
              ? composePlane(
                    *l.grid, r_.bbox, r_.width, r_.height, level, 0, lookup, background, target)
              : composePlane(chroma_->grid,
                             chroma_->box,
                             chroma_->width,
                             chroma_->height,
                             level,
                             0,
                             lookup,
                             background,
                             target);
      if (plane == 0) stats = s; // the map's pixels are the luma's
    }
    count(stats);
  }

  /** A layer on the RGB(A) canvas or the heights: as what it is, or heights as grey in a
   * picture, or a picture as its luminance in heights. */
  void drawLayer(const Layer& l, const DecodedTiles& decoded) {
    const LayerSpec& spec = *l.spec.layer;
    const TileLookup lookup = [&decoded](const TileKey& key) -> const TileSamples* {
      const auto it = decoded.find(key);
      return it == decoded.end() ? nullptr : &it->second->view;
    };
    // Every level of the grid is served (firstLevel is an upstream offset): first level 0.
    const TileGrid& grid = *l.grid;
    if (r_.values) { // a map of values: every layer is a value layer (the front end checks)
      for (const ComposeBand& b : l.bands)
        count(composeValues(grid, b.box, r_.width, r_.height, b.level, 0, lookup, values_));
    } else if (l.spec.colourMap && spec.values) {
      drawValueLayer(l, lookup);
    } else if (spec.elevation && r_.heights) {
      for (const ComposeBand& b : l.bands)
        count(composeHeights(
            grid, b.box, r_.width, r_.height, b.level, 0, lookup, spec.noData, heights_));
    } else if (spec.elevation) { // heights in a picture: grey over the canvas
      layerHeights_.assign(pixels_, spec.noData);
      for (const ComposeBand& b : l.bands)
        count(composeHeights(
            grid, b.box, r_.width, r_.height, b.level, 0, lookup, spec.noData, layerHeights_));
      drawHeightsAsGrey(layerHeights_, spec.noData, l.spec.opacity, canvas_, cc_);
    } else if (r_.heights) { // a picture in heights: its luminance where it is opaque
      layerPicture_.assign(pixels_ * 4, 0);
      for (const ComposeBand& b : l.bands)
        count(composeImagery(
            grid, b.box, r_.width, r_.height, b.level, 0, lookup, 1.0, layerPicture_, 4));
      drawLuminanceAsHeights(layerPicture_, heights_);
    } else {
      for (const ComposeBand& b : l.bands)
        count(composeImagery(
            grid, b.box, r_.width, r_.height, b.level, 0, lookup, l.spec.opacity, canvas_, cc_));
    }
  }

  /** A value layer coloured by its style: values sampled per pixel, then coloured (the range
   * from this map's values when the layer says so); in a heights map, the colours' luminance. */
  void drawValueLayer(const Layer& l, const TileLookup& lookup) {
    const ValueLayerSpec& spec = *l.spec.layer->values;
    layerValues_.assign(pixels_, std::numeric_limits<float>::quiet_NaN());
    for (const ComposeBand& b : l.bands)
      count(composeValues(*l.grid, b.box, r_.width, r_.height, b.level, 0, lookup, layerValues_));
    const values::ColourScale scale = spec.scale(*l.spec.colourMap, layerValues_);
    if (r_.heights) {
      layerPicture_.assign(pixels_ * 4, 0);
      drawValuesAsColours(layerValues_, scale, 1.0, layerPicture_, 4);
      drawLuminanceAsHeights(layerPicture_, heights_);
      return;
    }
    drawValuesAsColours(layerValues_, scale, l.spec.opacity, canvas_, cc_);
  }

  void count(const ComposeStats& s) {
    map_.fallbackPixels += s.fallbackPixels;
    missing_ += s.missingPixels;
  }

  // ---- the bytes --------------------------------------------------------------------------------

  std::expected<std::vector<std::byte>, std::string> encode(bool ycc) {
    if (r_.values) {
      if (!std::isnan(r_.valueNoData))
        std::replace_if(
            values_.begin(), values_.end(), [](float v) { return std::isnan(v); }, r_.valueNoData);
      return encodeBil32(r_.width, r_.height, values_.data());
    }
    if (r_.heights) {
      return encodeHeights(r_.format == MapFormat::Png ? "image/png" : toString(r_.format),
                           r_.width,
                           r_.height,
                           heights_.data());
    }
    if (ycc) {
      return codec::encodeJpegYcc(r_.width,
                                  r_.height,
                                  canvas_.data(),
                                  buffers_.cb.data(),
                                  buffers_.cr.data(),
                                  jpegQuality_);
    }
    if (png8_) {
      const codec::PalettedImage p = codec::quantize(canvas_.data(), cc_, pixels_);
      return codec::encodePngPalette(r_.width, r_.height, p.palette, p.indices.data());
    }
    return encodeImage(r_.format == MapFormat::Jpeg   ? "image/jpeg"
                       : r_.format == MapFormat::Tiff ? "image/tiff"
                                                      : "image/png",
                       r_.width,
                       r_.height,
                       cc_,
                       canvas_.data(),
                       false,
                       jpegQuality_);
  }

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

} // namespace

ComposedMap renderMap(const MapComposer::Job& job,
                      TileService& tiles,
                      DecodedTileCache* decoded,
                      int jpegQuality) {
  return MapRender(job, tiles, decoded, jpegQuality).run();
}

} // namespace tellus
