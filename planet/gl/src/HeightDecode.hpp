#pragma once
// Elevation tiles to metres for the renderer's HeightStreamer: BIL16 (the planet core) and 8- or
// 16-bit greyscale PNG (the codec module's exact samples). Thread safe: runs on the tile source's
// workers.

#include <tellus/planet/Terrain.hpp>

#include <cstddef>
#include <expected>
#include <span>
#include <string>
#include <string_view>

namespace tellus::planet {

std::expected<HeightTile, std::string> decodeHeights(const TileKey& key,
                                                     int width,
                                                     int height,
                                                     std::span<const std::byte> bytes,
                                                     std::string_view contentType,
                                                     const HeightEncoding& encoding);

} // namespace tellus::planet
