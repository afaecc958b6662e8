// Columns that would alias (ComposeSampling.hpp's columnSamples, composeWide): a Mercator row's
// level is chosen from its extent in latitude, cos(latitude) times smaller than its extent in
// longitude, so near the poles one pixel spans many texels of its row; sampled once (bilinear
// at its centre) fine east-west detail aliases. Such a band is composed with several samples
// across each pixel, evenly spaced, and the pixel is their mean: a box filter over its width.
#include "compose/ComposeSampling.hpp"

#include <cstring>

namespace tellus::compose {

std::int32_t
columnSamples(const TileGrid& grid, const MapBox& box, std::int32_t width, std::int32_t level) {
  // Lat/long maps as before: square pixels never span more than two texels, and a map of wide
  // pixels (a box stretched east-west) is sampled once a pixel as it always was.
  if (box.rows != MapRows::Mercator) return 1;
  if (width <= 0 || level < 0 || level >= grid.numLevels()) return 1;
  const double pixelX = (box.east - box.west) / width;
  const double texelX = grid.deltaDeg(level) / grid.spec().tileWidth;
  if (!(pixelX > 0.0) || !(texelX > 0.0)) return 1;
  // A pixel spanning up to two texels is sampled once (what a lat/long map's pixel spans: its
  // level is the coarsest no larger than the pixel); past that, samples at most one texel apart,
  // so that the bilinear samples of a run of texels sum to the run's mean whatever their phase
  // (two apart, a pattern of alternate texels would alias to a flat colour). The tolerance: a map
  // composed this many times as wide asks for one sample.
  const double k = pixelX / texelX;
  if (k <= 2.0 * (1.0 + 1e-9)) return 1;
  return std::min(kMaxColumnSamples, static_cast<std::int32_t>(std::ceil(k * (1.0 - 1e-9))));
}

ComposeStats composeWide(const MapBox& box,
                         std::int32_t width,
                         std::int32_t height,
                         std::int32_t samples,
                         std::int32_t channels,
                         bool over,
                         std::uint8_t* canvas,
                         const WideDraw& draw) {
  const std::int32_t begin = std::max(0, box.rowBegin), end = std::min(height, box.rowEnd);
  if (end <= begin || samples <= 1) return {};
  // The band's rows alone, as a map of their own (the same row centres).
  MapBox band = box;
  const std::int32_t rows = end - begin;
  if (box.rows == MapRows::Mercator) {
    const double dy = (box.northY - box.southY) / height;
    band.northY = box.northY - begin * dy;
    band.southY = box.northY - end * dy;
    band.north = mercator::latitudeOfY(std::clamp(band.northY, -mercator::kMaxY, mercator::kMaxY));
    band.south = mercator::latitudeOfY(std::clamp(band.southY, -mercator::kMaxY, mercator::kMaxY));
  } else {
    const double dy = (box.north - box.south) / height;
    band.north = box.north - begin * dy;
    band.south = box.north - end * dy;
  }
  band.rowBegin = 0;
  band.rowEnd = rows;
  const std::int32_t wide = width * samples;
  const auto cc = static_cast<std::size_t>(channels);
  const auto w = static_cast<std::size_t>(width);
  const auto s = static_cast<std::size_t>(samples);
  const std::size_t rowBytes = w * s * cc;
  std::vector<std::uint8_t> scratch(rowBytes * static_cast<std::size_t>(rows));
  if (over) {
    // Starting as the canvas (each pixel repeated): a layer drawn "over" it, averaged, is the
    // layer's mean drawn over the pixel.
    for (std::int32_t j = 0; j < rows; ++j) {
      const std::uint8_t* from = canvas + static_cast<std::size_t>(begin + j) * w * cc;
      std::uint8_t* to = &scratch[static_cast<std::size_t>(j) * rowBytes];
      for (std::size_t i = 0; i < w; ++i, from += cc)
        for (std::size_t k = 0; k < s; ++k, to += cc)
          for (std::size_t ch = 0; ch < cc; ++ch)
            to[ch] = from[ch];
    }
  }
  ComposeStats stats = draw(band, wide, rows, scratch);
  const auto half = static_cast<std::uint32_t>(samples / 2);
  const auto n = static_cast<std::uint32_t>(samples);
  for (std::int32_t j = 0; j < rows; ++j) {
    const std::uint8_t* from = &scratch[static_cast<std::size_t>(j) * rowBytes];
    std::uint8_t* to = canvas + static_cast<std::size_t>(begin + j) * w * cc;
    for (std::size_t i = 0; i < w; ++i, from += s * cc) {
      for (std::size_t ch = 0; ch < cc; ++ch) {
        std::uint32_t sum = half;
        for (std::size_t k = 0; k < s; ++k)
          sum += from[k * cc + ch];
        *to++ = static_cast<std::uint8_t>(sum / n);
      }
    }
  }
  // In pixels of the map (a pixel any of whose samples fell back counts).
  stats.fallbackPixels = (stats.fallbackPixels + s - 1) / s;
  stats.missingPixels = (stats.missingPixels + s - 1) / s;
  return stats;
}

} // namespace tellus::compose
