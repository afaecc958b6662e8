#pragma once
// A polar cap fetched in bands (issue 29, docs/design/poles.md). A cap's image is equirectangular,
// kWholeRowWidthFactor tiles wide so that the parallel at its rim keeps texels no wider than its
// rows are tall; nearer the pole a parallel is shorter (sin of the co-latitude), so one GetMap of
// the whole row spends most of its texels where they are only stretched. The row is asked for in
// kCapBands bands of equal rows instead, each as wide as its equatorward parallel needs (the rim's
// width times sin(its co-latitude) / sin(the rim's)), then each band is stretched back to the
// cap's width and the bands are stacked: the same image size and rows, about 0.56x the texels.
// Pure: the boxes and sizes to ask for, and the image made of the answers.

#include <tellus/cache/TileGrid.hpp>

#include <cstddef>
#include <cstdint>
#include <expected>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace tellus {

/** Bands a cap is fetched in, at most: eight bands of equal rows cost 0.5625 of the whole row's
 * texels (the continuous limit is 0.5); fewer where bands would be under kMinCapBandRows rows. */
inline constexpr int kCapBands = 8;
inline constexpr int kMinCapBandRows = 16;

/** One band of a cap: its box (every longitude), the size asked for, and its first row in the
 * cap's image (rows from the north). */
struct CapBand {
  Sector box;
  int width = 0;
  int height = 0;
  int row0 = 0;
  friend bool operator==(const CapBand&, const CapBand&) = default;
};

/**
 * The bands of the cap `row` (a whole row touching one pole: west -180, east 180, north 90 or
 * south -90) for an image of width x height, from the north down. One band (the whole row) when
 * height is under 2 kMinCapBandRows. A band's width is ceil(width sin(c) / sin(h)) - h the rim's
 * co-latitude, c the band's equatorward edge's - so no parallel of the band has wider texels (in
 * metres) than the rim.
 */
std::vector<CapBand> capBands(const Sector& row, int width, int height);

/**
 * An image from its bands' images (decoded JPEG or PNG of exactly each band's size, in the order
 * of capBands; a merged node's one band, wholeSpanTexelWidth wide): each band stretched east-west
 * to `width` (linear, premultiplied by alpha; `wrap`: around the antimeridian, the row being a
 * whole parallel, else the edge texels held), stacked, encoded as `mimeType` ("image/jpeg": RGB;
 * "image/png": RGBA if any band has alpha, else RGB) as a tile.
 */
std::expected<std::vector<std::byte>, std::string>
composeBands(std::span<const CapBand> bands,
             std::span<const std::vector<std::byte>> images,
             int width,
             int height,
             std::string_view mimeType,
             bool wrap = true);

} // namespace tellus
