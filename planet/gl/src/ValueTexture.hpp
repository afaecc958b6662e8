#pragma once
/**
 * @file ValueTexture.hpp
 * @brief Layers of values in the renderer (issue 24), GL-free: a node's tiles of raw samples
 * become one texture of floats (decodeValueTexture, on the decoder workers), and a layer's colour
 * scale becomes the uniforms planet.frag colours them with (valueScaleFor).
 *
 * The texture: the node's tiles decoded by values::decode (the values module: BIL, TIFF, 16-bit
 * PNG; value = raw * scale + offset, no data = NaN), side by side for a merged polar node (each
 * texel takes the value of the tile column nearest its centre: values are never averaged here;
 * the shader samples them by values/Sample.hpp's rule), rows from the south. One level, 4 bytes a
 * texel (R32F: the decoded float exactly, the value the proxy's values::apply colours). Texels no
 * tile covers are NaN (transparent). An undecodable tile leaves its columns NaN and the error in
 * DecodedTexture.
 *
 * The scale: the map's row in the colour map texture (values::colourMaps() in order, one row
 * each), the range (log: of log10 values, as ColourScale.hpp's rule), the scaling and what
 * happens outside the range. `range: data` takes the percentiles of the samples of the textures
 * the layer's drawn nodes show (a bounded sample each: kDataRangeSample values).
 */

#include "LayerSet.hpp"
#include "TextureDecoder.hpp"

#include <tellus/planet_gl/Renderer.hpp>
#include <tellus/values/ColourScale.hpp>

#include <optional>
#include <span>
#include <vector>

namespace tellus::planet {

/** The job's tiles as one level of floats (see the file comment). Thread safe (pure). */
DecodedTexture decodeValueTexture(const DecodeJob& job);

/** Up to `count` finite values of `values`, taken at an even stride (the whole set when fewer). */
std::vector<float> finiteSample(std::span<const float> values, std::size_t count);

/** The value at (latDeg, lonDeg) in a value texture covering `sector` (width x height floats,
 * rows from the south, 4 bytes each as DecodedTexture keeps them): values::sample at the point's
 * pixel coordinates (bilinear between texel centres; the nearest texel where a neighbour is no
 * data). NaN outside the sector or for a malformed texture. */
float sampleValueTexture(const Sector& sector,
                         int width,
                         int height,
                         std::span<const std::uint8_t> floats,
                         double latDeg,
                         double lonDeg);

/** The value a layer of values holds at a point: the deepest of its resident textures whose
 * node contains it, sampled by sampleValueTexture (the value under `view`'s cursor). NaN when
 * none is resident there, or no data. */
float valueAtPoint(const LayerTextures& layer, double latDeg, double lonDeg);

/** What planet.frag needs of a layer's scale (uOverlayValues, uOverlayRange). */
struct ValueScaleUniform {
  int mapRow = 0;              ///< the map's index in values::colourMaps()
  bool log = false;            ///< log10 scaling
  bool transparentOut = false; ///< OutOfRange::Transparent
  double low = 0.0;            ///< min (log: log10(min))
  double high = 1.0;           ///< max (log: log10(max))
};

/** The scale of a layer: its options, the range from the data when it asks for that and
 * `dataRange` has one. */
values::ColourScale colourScaleFor(const ValueLayerOptions& options,
                                   const std::optional<values::ValueRange>& dataRange);

/** The uniforms of a scale (scale.map must be one of values::colourMaps()). */
ValueScaleUniform valueScaleUniform(const values::ColourScale& scale);

} // namespace tellus::planet
