#include "ValueTexture.hpp"

#include <tellus/values/ColourMap.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace tellus::planet {

namespace {

/** Tile t of the job (span tiles west to east) into columns [x0, x1) of the floats `dst` (w x h,
 * rows from the south): each texel the sample nearest its centre. */
void place(const values::ValueRaster& r, int x0, int x1, int w, int h, std::vector<float>& dst) {
  const long n = x1 - x0;
  for (int yn = 0; yn < h; ++yn) { // texture rows from the north, stored from the south
    const int sy = std::min(r.height - 1, static_cast<int>((2L * yn + 1) * r.height / (2L * h)));
    const auto row = static_cast<std::size_t>(h - 1 - yn) * static_cast<std::size_t>(w);
    for (int x = x0; x < x1; ++x) {
      const int sx =
          std::min(r.width - 1, static_cast<int>((2L * (x - x0) + 1) * r.width / (2 * n)));
      dst[row + static_cast<std::size_t>(x)] = r.at(sx, sy);
    }
  }
}

} // namespace

std::vector<float> finiteSample(std::span<const float> values, std::size_t count) {
  std::vector<float> finite;
  for (const float v : values)
    if (std::isfinite(v)) finite.push_back(v);
  if (finite.size() <= count) return finite;
  std::vector<float> out(count);
  for (std::size_t i = 0; i < count; ++i)
    out[i] = finite[i * finite.size() / count];
  return out;
}

DecodedTexture decodeValueTexture(const DecodeJob& job) {
  DecodedTexture out;
  out.key = job.key;
  out.tag = job.tag;
  out.values = true;
  const int w = job.width, h = job.height;
  const auto span = static_cast<int>(std::max<std::size_t>(1, job.tiles.size()));
  std::vector<float> texels(static_cast<std::size_t>(w) * static_cast<std::size_t>(h),
                            std::numeric_limits<float>::quiet_NaN());
  bool any = false;
  for (int t = 0; t < span; ++t) {
    const auto& bytes = job.tiles[static_cast<std::size_t>(t)];
    if (!bytes) continue;
    auto raster = values::decode(*bytes, *job.valueFormat, job.tileWidth, job.tileHeight);
    if (!raster) {
      out.error = raster.error();
      continue;
    }
    if (raster->width <= 0 || raster->height <= 0) continue;
    any = true;
    place(*raster, t * w / span, (t + 1) * w / span, w, h, texels);
  }
  if (!any) {
    if (out.error.empty()) out.error = "no tile";
    return out;
  }
  out.sample = finiteSample(texels, ValueLayerOptions::kDataRangeSample);
  MipLevel level;
  level.width = w;
  level.height = h;
  level.rgba.resize(texels.size() * sizeof(float));
  std::memcpy(level.rgba.data(), texels.data(), level.rgba.size());
  out.bytes = level.rgba.size();
  out.levels.push_back(std::move(level));
  out.ok = true;
  return out;
}

float sampleValueTexture(const Sector& sector,
                         int width,
                         int height,
                         std::span<const std::uint8_t> floats,
                         double latDeg,
                         double lonDeg) {
  const auto n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  if (width <= 0 || height <= 0 || floats.size() != n * 4)
    return std::numeric_limits<float>::quiet_NaN();
  const double w = sector.east - sector.west, h = sector.north - sector.south;
  const double u = (lonDeg - sector.west) / w, v = (sector.north - latDeg) / h; // v from the north
  if (!(u >= 0.0 && u <= 1.0 && v >= 0.0 && v <= 1.0))
    return std::numeric_limits<float>::quiet_NaN();
  values::ValueRaster r; // rows from the north, as values::sample reads them
  r.width = width;
  r.height = height;
  r.values.resize(n);
  for (int y = 0; y < height; ++y)
    std::memcpy(r.values.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(width),
                floats.data() +
                    static_cast<std::size_t>(height - 1 - y) * static_cast<std::size_t>(width) * 4,
                static_cast<std::size_t>(width) * 4);
  return values::sample(r, u * width, v * height);
}

float valueAtPoint(const LayerTextures& l, double latDeg, double lonDeg) {
  const NodeTexture* best = nullptr;
  Sector where{};
  std::int32_t level = -1;
  for (const auto& [key, t] : l.textures) {
    if (t.values.empty() || key.level <= level) continue;
    const Sector s = l.tree->sectorOf(key);
    if (latDeg < s.south || latDeg > s.north || lonDeg < s.west || lonDeg > s.east) continue;
    best = &t;
    where = s;
    level = key.level;
  }
  if (best == nullptr) return std::numeric_limits<float>::quiet_NaN();
  return sampleValueTexture(where, best->width, best->height, best->values, latDeg, lonDeg);
}

values::ColourScale colourScaleFor(const ValueLayerOptions& o,
                                   const std::optional<values::ValueRange>& dataRange) {
  values::ColourScale s;
  s.map = values::findColourMap(o.colourMap);
  if (s.map == nullptr) s.map = values::findColourMap(values::kDefaultColourMap);
  s.min = o.min;
  s.max = o.max;
  s.scaling = o.scaling;
  s.outOfRange = o.outOfRange;
  if (o.rangeFromData && dataRange) {
    s.min = dataRange->min;
    s.max = dataRange->max;
  }
  if (!values::checkScale(s)) { // a data range unfit for the scale (log of nothing positive)
    s.min = o.min;
    s.max = o.max;
  }
  return s;
}

ValueScaleUniform valueScaleUniform(const values::ColourScale& scale) {
  ValueScaleUniform u;
  const auto maps = values::colourMaps();
  for (std::size_t i = 0; i < maps.size(); ++i)
    if (&maps[i] == scale.map || maps[i].name == scale.map->name) u.mapRow = static_cast<int>(i);
  u.log = scale.scaling == values::Scaling::Log;
  u.transparentOut = scale.outOfRange == values::OutOfRange::Transparent;
  u.low = u.log ? std::log10(scale.min) : scale.min;
  u.high = u.log ? std::log10(scale.max) : scale.max;
  return u;
}

} // namespace tellus::planet
