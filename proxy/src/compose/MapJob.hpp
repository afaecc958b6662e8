#pragma once
// What MapComposer.cpp (asking for a map's tiles) and MapRender.cpp (making the map of them) share:
// a map's job, and decoded tiles with the cache that keeps them between maps.

#include "compose/AdmittingLru.hpp"
#include "compose/MapComposer.hpp"

#include <tellus/proxy/Compose.hpp>

#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <vector>

namespace tellus {

/** A decoded tile and the samples view of it (or of its Y, Cb and Cr planes, stored one after the
 * other in `rgb`); its pixel storage goes back to the composer thread's buffers (TileDecode.cpp).
 */
struct DecodedTile {
  TileSamples view{};
  std::array<TileSamples, 3> planes{};
  std::vector<std::uint8_t> rgb;
  std::vector<std::int16_t> heights;
  std::vector<float> values; ///< a value layer's tile drawn coloured (NaN = no data)
  DecodedTile() = default;
  DecodedTile(const DecodedTile&) = delete;
  DecodedTile& operator=(const DecodedTile&) = delete;
  ~DecodedTile();
};

/** Decoded tiles by their ETag, least recently used first out, within a byte budget; a tile is
 * kept once it is used often enough (AdmittingLru.hpp). Shared by the composer's workers. */
class DecodedTileCache : public AdmittingLru<DecodedTile> {
public:
  using AdmittingLru::AdmittingLru;
};

/** One map: the request, and per layer its tiles and their answers as they arrive. */
struct MapComposer::Job {
  struct Layer {
    ComposeLayer spec;
    const TileGrid* grid = nullptr;
    std::vector<ComposeBand> bands;  // one for a map of latitude rows
    std::vector<ComposeTile> keys;   // with the part of each tile that is sampled
    std::vector<TileAnswer> answers; // parallel to keys
  };
  ComposeRequest request;
  /// Composed as Y, Cb and Cr planes when every tile turns out to be a 4:2:0 JPEG: a JPEG map of
  /// one opaque imagery layer (else, or when a tile is not, the RGB path).
  bool ycc = false;
  std::vector<Layer> layers;
  std::atomic<std::size_t> pending{0};
  std::function<void(const LayerSpec&, const TileAnswer&)> onTile;
  std::function<void(ComposedMap&&)> done;
};

/** The map of a job whose tiles have all answered (MapComposer::finish, on a composer worker):
 * validators first (304), then decode, fill holes from coarser cached tiles, sample and encode.
 * `decoded` may be null (no decoded tiles kept). May throw std::bad_alloc. */
ComposedMap renderMap(const MapComposer::Job& job,
                      TileService& tiles,
                      DecodedTileCache* decoded,
                      int jpegQuality);

} // namespace tellus
