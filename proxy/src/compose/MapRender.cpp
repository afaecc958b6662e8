// The map of one GetMap from its tiles' answers (MapComposer::finish's work, on a composer
// worker), in the order of its steps: the validators (a client that has the map gets 304 before
// anything is decoded); the canvas; per layer the tiles decoded (TileDecode.cpp: only the part
// sampled, or whole and kept), the holes filled from the nearest coarser cached tile, the samples
// drawn (on Y, Cb and Cr planes when every tile is a 4:2:0 JPEG, else on RGB(A) or heights, with
// the RGB path taking over when a tile turns out not to be); then the map encoded. See
// docs/design/composition.md. This file: the validators, the canvas and the encoding; the layers
// are in MapRenderLayers.cpp.
#include "compose/MapRender.hpp"

#include <cstdio>

namespace tellus {

namespace {

/** A quoted ETag: the hash of a map's validators. */
std::string etagOf(const std::string& validators) {
  char etag[24];
  std::snprintf(
      etag, sizeof etag, "\"%016llx\"", static_cast<unsigned long long>(stableHash64(validators)));
  return etag;
}

} // namespace

ComposedMap MapRender::run() {
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

ComposedMap MapRender::error(std::string message) {
  map_.kind = ComposedMap::Kind::Error;
  map_.message = std::move(message);
  return std::move(map_);
}

void MapRender::summarise() {
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

void MapRender::summarise(const LayerSpec& layer, const TileAnswer& a) {
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
    return f == TileAnswer::Failure::Unavailable ? 2 : f == TileAnswer::Failure::OverBudget ? 1 : 0;
  };
  if (rank(a.failure) > rank(map_.failure)) map_.failure = a.failure;
  map_.retryAfterSeconds = std::max(map_.retryAfterSeconds, a.retryAfterSeconds);
}

bool MapRender::notModified() const {
  return complete_ && !r_.ifNoneMatch.empty() &&
         (r_.ifNoneMatch == "*" || r_.ifNoneMatch.find(map_.etag) != std::string::npos);
}

void MapRender::prepare() {
  png8_ = r_.format == MapFormat::Png8;
  cc_ = r_.format == MapFormat::Png32 || (r_.transparent && (r_.format == MapFormat::Png || png8_ ||
                                                             r_.format == MapFormat::Tiff))
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

void MapRender::fill(bool ycc) {
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

std::expected<std::vector<std::byte>, std::string> MapRender::encode(bool ycc) {
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
    return codec::encodeJpegYcc(
        r_.width, r_.height, canvas_.data(), buffers_.cb.data(), buffers_.cr.data(), jpegQuality_);
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

ComposedMap renderMap(const MapComposer::Job& job,
                      TileService& tiles,
                      DecodedTileCache* decoded,
                      int jpegQuality) {
  return MapRender(job, tiles, decoded, jpegQuality).run();
}

} // namespace tellus
