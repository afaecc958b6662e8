#pragma once
/**
 * @file Compose.hpp
 * @brief GetMap for any box and size: which tiles a map needs, and the map sampled from them.
 *
 * Pure functions over decoded tiles (no I/O, no threads), so the geometry is tested on its own:
 *
 * - **Level**: the coarsest level whose texels are no larger than the map's pixels on either axis
 *   (the finest not coarser than the request), so the map is never magnified from a coarser level
 *   while a fine-enough one exists; the deepest level when none is fine enough; never above the
 *   layer's first level.
 * - **Sampling**: pixel centres (west + (i + 0.5) * dx, north - (j + 0.5) * dy) are mapped onto the
 *   level's texel grid (texel centres at half-integers) and sampled bilinearly (weights in 1/256,
 *   integer arithmetic), so a map aligned with the texel grid gets the tile's values exactly.
 *   Longitudes wrap around a global layer (a box from 170 to 190 crosses the antimeridian, and
 *   bilinear filtering joins the last and the first column); latitudes past +-90 and places
 *   outside the layer's sector are left as they were (the background). At the poles the edge row
 *   is repeated (clamped), never wrapped. Each row's latitude is the box's (MapBox.hpp): evenly
 *   spaced, or for a Web Mercator map the inverse Mercator of the row centre's y (rows past the
 *   Mercator square left as they were); only the rows of the box's band are drawn.
 * - **Fallback**: where a tile of the level is missing, the nearest coarser tile that is present
 *   is sampled instead, per pixel, with the same filter at its own resolution.
 * - **Heights**: bilinear on raw 16-bit values; where one of the four texels is no-data, the
 *   valid texel of the largest weight is used (so no-data never blends into a height).
 */

#include <tellus/cache/TileGrid.hpp>
#include <tellus/cache/TileKey.hpp>
#include <tellus/proxy/MapBox.hpp>
#include <tellus/values/ColourScale.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace tellus {

/** The most a composed map magnifies its level's texels along either axis (issue 29): sqrt(2).
 * Of the two levels around a pixel's size, the one nearer in log2 of the texel size (as CesiumJS
 * picks an imagery level): a map costs 0.5 to 2 texels of its level a pixel, where the finer of
 * the two alone would cost 1 to 4. */
inline constexpr double kMaxUpsampling = 1.4142135623730951;

/** The coarsest level from `firstLevel` whose texels are at most kMaxUpsampling times a pixel of
 * pixelX x pixelY degrees on both axes (the rule of composeLevel and composeBands); none when
 * even the deepest level's are not. */
std::optional<std::int32_t>
fineEnoughLevel(const TileGrid& grid, double pixelX, double pixelY, std::int32_t firstLevel = 0);

/** The level a map of `width` x `height` pixels over `box` is composed from (a Mercator map's:
 * the finest of its bands', composeBands): the coarsest level whose texels are at most
 * kMaxUpsampling times the map's pixels on both axes (a pixel of exactly a level's texel takes
 * that level); the deepest level when none is fine enough; never above `firstLevel`. */
std::int32_t composeLevel(const TileGrid& grid,
                          const MapBox& box,
                          std::int32_t width,
                          std::int32_t height,
                          std::int32_t firstLevel);

/**
 * A band of a map's rows and the level it is composed from. A map of latitude rows is one band at
 * composeLevel. A Web Mercator map's pixel covers cos(latitude) times fewer degrees of latitude
 * than of longitude, so one level for the whole map would either blur the rows near the poles
 * (the level of the equator's pixels magnified 5.8 times at 80 degrees) or need the finest
 * level's tiles over the whole box (16 to 256 times the tiles of a world map): each row takes the
 * level composeLevel's rule gives its pixels (its extent in latitude from its two edges' inverse
 * Mercator: near the poles the latitude axis decides), and runs of rows of the same level are one
 * band. Rows
 * past the Mercator square join a neighbouring band (they draw nothing). Bands cover rows
 * [0, height) in order, each drawn by the composers below with its own box (rowBegin, rowEnd)
 * and level.
 */
struct ComposeBand {
  MapBox box;
  std::int32_t level = 0;
};
std::vector<ComposeBand> composeBands(const TileGrid& grid,
                                      const MapBox& box,
                                      std::int32_t width,
                                      std::int32_t height,
                                      std::int32_t firstLevel);

/** A tile a map needs, and the part of it that sampling reads: texels [x0, x1) x [y0, y1), rows
 * from the top (what a decoder may limit itself to). */
struct ComposeTile {
  TileKey key;
  std::array<std::int32_t, 4> region; ///< x0, y0, x1, y1
};

/**
 * The tiles of `level` that sampling the map touches (with the bilinear filter's one-texel
 * margin), wrapped across the antimeridian for a global layer, without duplicates, in row-major
 * order from the north-west. An error (with the count) when more than `maxTiles` are needed.
 */
std::expected<std::vector<ComposeTile>, std::size_t> composeTiles(const TileGrid& grid,
                                                                  const MapBox& box,
                                                                  std::int32_t width,
                                                                  std::int32_t height,
                                                                  std::int32_t level,
                                                                  std::size_t maxTiles);

/**
 * The chroma planes of a 4:2:0 map (JPEG's centred siting): a chroma sample of the map covers 2 x 2
 * pixels, (width + 1) / 2 x (height + 1) / 2 of them over `box` widened by the odd pixel, and a
 * chroma texel of a tile covers 2 x 2 texels, so the tiles' chroma planes form `grid`: the same
 * levels and tiles at half the tile size. No value when the tile size is odd.
 */
struct ChromaLayout {
  TileGrid grid;
  MapBox box;
  std::int32_t width = 0;
  std::int32_t height = 0;
};
std::optional<ChromaLayout>
chromaLayout(const TileGrid& grid, const MapBox& box, std::int32_t width, std::int32_t height);

/**
 * composeTiles for a map composed as Y, Cb and Cr planes: the tiles and regions the luma needs
 * and those the chroma planes need (regions in luma texels), so a chroma sample at the map's edge
 * that reaches one texel into a tile the luma does not touch finds it. The limit applies to the
 * luma's tiles (the chroma adds at most a row and a column).
 */
std::expected<std::vector<ComposeTile>, std::size_t> composeTilesYcc(const TileGrid& grid,
                                                                     const MapBox& box,
                                                                     std::int32_t width,
                                                                     std::int32_t height,
                                                                     std::int32_t level,
                                                                     std::size_t maxTiles);

/** A decoded tile to sample from: `channels` samples per texel, row-major, top row first. */
struct TileSamples {
  std::int32_t width = 0;
  std::int32_t height = 0;
  std::int32_t channels = 0;         ///< imagery 3 (RGB) or 4 (RGBA); heights 1
  const std::uint8_t* rgb = nullptr; ///< imagery
  const std::int16_t* heights = nullptr;
  const float* values = nullptr; ///< value layers decoded by tellus::values (NaN = no data)
};

/** The decoded tiles at hand: nullptr for a tile that is not there (any level). */
using TileLookup = std::function<const TileSamples*(const TileKey&)>;

/**
 * Draws one imagery layer over `canvas` (width * height RGBA, straight alpha, or RGB when
 * `canvasChannels` is 3: an opaque canvas): each pixel is the tile's colour with alpha (tile
 * alpha * opacity) composited "over" what the canvas holds. With `canvasChannels` 1 the tiles are
 * one plane each (channels 1, opaque: a Y, Cb or Cr plane) and the canvas one plane of the map;
 * the opacity is then ignored (drawn at 1).
 * Returns how many pixels came from a coarser level than `level` (fallback) and how many had no
 * tile at all.
 */
struct ComposeStats {
  std::size_t fallbackPixels = 0;
  std::size_t missingPixels = 0;
};
ComposeStats composeImagery(const TileGrid& grid,
                            const MapBox& box,
                            std::int32_t width,
                            std::int32_t height,
                            std::int32_t level,
                            std::int32_t firstLevel,
                            const TileLookup& tiles,
                            double opacity,
                            std::vector<std::uint8_t>& canvas,
                            std::int32_t canvasChannels = 4);

/**
 * composeImagery for one plane (tiles of one channel, opaque; `canvasChannels` 1) that writes every
 * pixel of `plane` (resized to width * height): `background` where no tile covers it (outside the
 * layer, past a pole, no tile at any level; of the box's band: the rows outside it are left as
 * they are). The same plane as filling it with `background` and
 * then composing over it, without the fill (a composed JPEG map's planes are nearly always all
 * sampled).
 */
ComposeStats composePlane(const TileGrid& grid,
                          const MapBox& box,
                          std::int32_t width,
                          std::int32_t height,
                          std::int32_t level,
                          std::int32_t firstLevel,
                          const TileLookup& tiles,
                          std::uint8_t background,
                          std::vector<std::uint8_t>& plane);

/** Draws one elevation layer into `heights` (width * height): pixels with a value that is not
 * `noData` replace what is there (later layers win where they have data). */
ComposeStats composeHeights(const TileGrid& grid,
                            const MapBox& box,
                            std::int32_t width,
                            std::int32_t height,
                            std::int32_t level,
                            std::int32_t firstLevel,
                            const TileLookup& tiles,
                            std::int16_t noData,
                            std::vector<std::int16_t>& heights);

/** Draws one value layer into `values` (width * height floats, NaN = no data) by the one
 * sampling rule of values/Sample.hpp (values::bilinearValue in double, across tile edges):
 * bilinear between texel centres; where one of the four texels is NaN, the texel the pixel's
 * centre lies in (NaN when that one is). Pixels with a value replace what is there. */
ComposeStats composeValues(const TileGrid& grid,
                           const MapBox& box,
                           std::int32_t width,
                           std::int32_t height,
                           std::int32_t level,
                           std::int32_t firstLevel,
                           const TileLookup& tiles,
                           std::vector<float>& values);

/** Draws `values` (one layer composed with composeValues) over `canvas` coloured by `scale`
 * (values::colourOf: the exact index rule, no data and transparent out-of-range left as they
 * are), each pixel "over" with `opacity` as composeImagery draws a layer. */
void drawValuesAsColours(const std::vector<float>& values,
                         const values::ColourScale& scale,
                         double opacity,
                         std::vector<std::uint8_t>& canvas,
                         std::int32_t canvasChannels);

/**
 * Heights as a picture (a heights layer in a JPEG or 8-bit PNG map): one fixed, linear grey ramp
 * over the Earth's relief, raw value -11000 black and +9000 white (sea level 0 is grey 140),
 * clamped outside; the same for every map, so that tiles of a picture fit together. Raw values are
 * the layer's samples before its scale and offset.
 */
inline constexpr std::int32_t kGreyRampLow = -11000;
inline constexpr std::int32_t kGreyRampHigh = 9000;
std::uint8_t heightToGrey(std::int16_t raw) noexcept;

/** Draws a map of heights (width * height values, one layer composed with composeHeights) over
 * `canvas` as grey (heightToGrey), pixels of `noData` left as they are, the others drawn "over"
 * with `opacity` (as composeImagery draws a layer). */
void drawHeightsAsGrey(const std::vector<std::int16_t>& heights,
                       std::int16_t noData,
                       double opacity,
                       std::vector<std::uint8_t>& canvas,
                       std::int32_t canvasChannels);

/** A picture as heights (an imagery layer in a BIL16, TIFF or 16-bit PNG map): the luminance of
 * each pixel of `rgba` (width * height RGBA, one layer composed on a transparent canvas),
 * Y = 0.299 R + 0.587 G + 0.114 B rounded (0 - 255, JPEG's and MapServer's weights), written into
 * `heights` where the pixel's alpha is at least 128; the rest keeps what `heights` holds (later
 * layers win where they have data, as composeHeights draws). */
void drawLuminanceAsHeights(const std::vector<std::uint8_t>& rgba,
                            std::vector<std::int16_t>& heights);

/** The luminance drawLuminanceAsHeights writes for one colour. */
std::uint8_t luminance(std::uint8_t r, std::uint8_t g, std::uint8_t b) noexcept;

} // namespace tellus
