#pragma once
// A composed map's tiles decoded into samples (MapRender.cpp's decode step): imagery as RGB(A),
// a 4:2:0 JPEG as its Y, Cb and Cr planes, heights, and a value layer's values; and the pixel
// buffers each composer thread keeps between maps, which tiles and canvases reuse.

#include "compose/MapJob.hpp"

#include <tellus/cache/TileGrid.hpp>
#include <tellus/proxy/TileService.hpp>
#include <tellus/proxy/ValueLayer.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

namespace tellus {

/**
 * Pixel buffers kept by each composer thread between maps: a map decodes a dozen tiles of the same
 * size and fills a canvas of the same size as the last one, so reusing the storage spares the
 * allocation, the kernel's page faults and the clearing of fresh memory (a third of the CPU time
 * of a 1024x768 map before, by perf).
 */
struct ComposerBuffers {
  std::vector<std::vector<std::uint8_t>> spare;
  std::vector<std::uint8_t> canvas;
  std::vector<std::uint8_t> cb, cr; // the chroma planes of a map composed as YCbCr
  std::vector<std::uint8_t> take() {
    if (spare.empty()) return {};
    auto b = std::move(spare.back());
    spare.pop_back();
    return b;
  }
  void give(std::vector<std::uint8_t>&& b) {
    // At most 16 tiles' worth (about 12 MiB of 512-pixel RGB) stays per thread.
    if (spare.size() < 16 && b.capacity() > 0 && b.capacity() <= (4u << 20))
      spare.push_back(std::move(b));
  }
};

/** This composer thread's buffers. */
ComposerBuffers& composerBuffers() noexcept;

/** A heights layer's tile (BIL16, or TIFF and 16-bit PNG through imaging) into `d.heights`. */
bool decodeHeightsInto(DecodedTile& d,
                       std::span<const std::byte> bytes,
                       const LayerSpec& spec,
                       const GridSpec& g);

/** A value layer's tile as values (tellus::values; the whole tile: values are few). */
bool decodeValuesInto(DecodedTile& d,
                      std::span<const std::byte> bytes,
                      const ValueLayerSpec& spec,
                      const GridSpec& g);

/** A JPEG tile as its Y, Cb and Cr planes (only `region` when not null and not `keep`); false,
 * with `notYcc` set, when it is not a 4:2:0 JPEG. */
bool decodePlanesInto(DecodedTile& d,
                      std::span<const std::byte> bytes,
                      const GridSpec& g,
                      const std::array<std::int32_t, 4>* region,
                      bool keep,
                      bool& notYcc);

/** An imagery tile of any format (`type`) as RGB or RGBA (only `region` when not null and not
 * `keep`). */
bool decodeRgbInto(DecodedTile& d,
                   std::span<const std::byte> bytes,
                   std::string_view type,
                   const GridSpec& g,
                   const std::array<std::int32_t, 4>* region,
                   bool keep);

} // namespace tellus
