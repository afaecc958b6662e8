#pragma once
/**
 * @file WmtsCompose.hpp
 * @brief A grid tile composed from the WMTS tiles that cover it, for the levels of a layer that
 * no matrix of its set lines up with (WmtsUpstream.hpp). Each output pixel centre (lat/long of the
 * grid tile, rows from the north) is sampled bilinearly in the source matrix's pixels across the
 * mosaic of fetched tiles (edges clamped to what was fetched); a source tile the server does not
 * have (404) is transparent. Web Mercator sets are sampled at each pixel centre's Mercator x and
 * y (WmtsMercator.hpp); past the square's edges its edge pixels repeat, and rows beyond +-85.0511
 * degrees are empty. JPEG layers are encoded RGB at quality 90 (empty: black), PNG layers RGBA
 * (empty: transparent).
 */

#include <tellus/proxy/WmtsUpstream.hpp>

#include <cstddef>
#include <expected>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace tellus {

struct WmtsFetchedTile {
  WmtsSourceTile source;
  std::vector<std::byte> bytes; ///< the upstream's tile (JPEG or PNG); empty: it has none
};

std::expected<std::vector<std::byte>, std::string>
composeWmtsTile(const WmtsTiles& tiles,
                const TileKey& key,
                const Sector& sector,
                int width,
                int height,
                std::span<const WmtsFetchedTile> fetched,
                std::string_view mimeType);

} // namespace tellus
