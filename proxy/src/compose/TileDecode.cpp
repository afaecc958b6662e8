// A composed map's tiles decoded into samples (TileDecode.hpp).
#include "compose/TileDecode.hpp"

#include <tellus/codec/JpegYcc.hpp>
#include <tellus/proxy/ImageCodec.hpp>
#include <tellus/values/ValueFormat.hpp>

#include <string>
#include <utility>

namespace tellus {

namespace {

thread_local ComposerBuffers buffers;

} // namespace

ComposerBuffers& composerBuffers() noexcept {
  return buffers;
}

DecodedTile::~DecodedTile() {
  buffers.give(std::move(rgb));
}

bool decodeHeightsInto(DecodedTile& d,
                       std::span<const std::byte> bytes,
                       const LayerSpec& spec,
                       const GridSpec& g) {
  auto h = decodeHeights(bytes, spec.dataset.mimeType, g.tileWidth, g.tileHeight);
  if (!h) return false;
  d.heights = std::move(*h);
  d.view = TileSamples{g.tileWidth, g.tileHeight, 1, nullptr, d.heights.data()};
  return true;
}

/** A value layer's tile as values (tellus::values; the whole tile: values are few). */
bool decodeValuesInto(DecodedTile& d,
                      std::span<const std::byte> bytes,
                      const ValueLayerSpec& spec,
                      const GridSpec& g) {
  auto v = values::decode(bytes, spec.format, g.tileWidth, g.tileHeight);
  if (!v) return false;
  d.values = std::move(v->values);
  d.view = TileSamples{g.tileWidth, g.tileHeight, 1, nullptr, nullptr, d.values.data()};
  return true;
}

bool decodePlanesInto(DecodedTile& d,
                      std::span<const std::byte> bytes,
                      const GridSpec& g,
                      const std::array<std::int32_t, 4>* region,
                      bool keep,
                      bool& notYcc) {
  const auto w = static_cast<std::size_t>(g.tileWidth);
  const auto h = static_cast<std::size_t>(g.tileHeight);
  if (!keep) d.rgb = buffers.take(); // a kept tile gets storage of its own size
  d.rgb.resize(w * h + 2 * (w / 2) * (h / 2));
  std::uint8_t* y = d.rgb.data();
  std::uint8_t* cb = y + w * h;
  std::uint8_t* cr = cb + (w / 2) * (h / 2);
  std::string message;
  switch (codec::decodeJpegYcc(bytes, g.tileWidth, g.tileHeight, region, y, cb, cr, message)) {
  case codec::YccDecode::Ok:
    break;
  case codec::YccDecode::NotYcc420:
    notYcc = true;
    return false;
  case codec::YccDecode::Failed:
    return false;
  }
  d.planes = {TileSamples{g.tileWidth, g.tileHeight, 1, y, nullptr},
              TileSamples{g.tileWidth / 2, g.tileHeight / 2, 1, cb, nullptr},
              TileSamples{g.tileWidth / 2, g.tileHeight / 2, 1, cr, nullptr}};
  return true;
}

bool decodeRgbInto(DecodedTile& d,
                   std::span<const std::byte> bytes,
                   std::string_view type,
                   const GridSpec& g,
                   const std::array<std::int32_t, 4>* region,
                   bool keep) {
  if (!keep) d.rgb = buffers.take();
  const auto channels = decodeImageryInto(bytes, type, g.tileWidth, g.tileHeight, d.rgb, region);
  if (!channels) return false;
  d.view = TileSamples{g.tileWidth, g.tileHeight, *channels, d.rgb.data(), nullptr};
  return true;
}

} // namespace tellus
