// The layers of a map composed on its canvas (MapRender.hpp): per layer the tiles decoded
// (TileDecode.cpp), the holes filled from the nearest coarser cached tile, the samples drawn.
#include "compose/MapRender.hpp"

namespace tellus {

namespace {

std::optional<std::vector<std::byte>> bytesOf(const TileAnswer& a) {
  if (a.file) return a.file->readAll();
  return a.bytes;
}

} // namespace

bool MapRender::composeOnEitherPath() {
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

bool MapRender::composeLayers(bool ycc) {
  for (const auto& l : job_.layers) {
    if (!composeLayer(l, ycc)) return false;
  }
  return true;
}

bool MapRender::composeLayer(const Layer& l, bool ycc) {
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

bool MapRender::fillHoles(const Layer& l,
                          bool ycc,
                          const std::vector<TileKey>& holes,
                          DecodedTiles& decoded) {
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

std::shared_ptr<const DecodedTile> MapRender::decode(const Layer& l,
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

void MapRender::drawPlanes(const Layer& l, const DecodedTiles& decoded) {
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

void MapRender::drawLayer(const Layer& l, const DecodedTiles& decoded) {
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

void MapRender::drawValueLayer(const Layer& l, const TileLookup& lookup) {
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

void MapRender::count(const ComposeStats& s) {
  map_.fallbackPixels += s.fallbackPixels;
  missing_ += s.missingPixels;
}

} // namespace tellus
