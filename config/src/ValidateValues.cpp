// Validation of a value layer's `values` (Config.hpp's ValueSettings), for configurations built
// in code as well as parsed ones: the format fits the samples, the numbers are finite, the colour
// maps exist, the range and percentiles are ordered.

#include "ConfigInternal.hpp"

#include <tellus/values/ColourMap.hpp>

#include <algorithm>
#include <cmath>

namespace tellus::detail {

namespace {

using Issue = std::optional<std::pair<std::string, std::string>>;

Issue problem(std::string key, std::string message) {
  return std::pair{std::move(key), std::move(message)};
}

Issue checkSamples(const LayerConfig& l) {
  const ValueSettings& v = l.values;
  const std::string& m = l.dataset.mimeType;
  if (m != "application/bil16" && m != "image/tiff" && m != "image/png")
    return problem("format",
                   "a value layer needs application/bil16, image/tiff or image/png, not " + m);
  if (v.format.encoding == values::Encoding::Float32 && m != "image/tiff")
    return problem("values.encoding", "float32 samples come in image/tiff only, not " + m);
  if (!std::isfinite(v.format.scale) || v.format.scale == 0.0)
    return problem("values.scale", "must be a finite number other than 0");
  if (!std::isfinite(v.format.offset)) return problem("values.offset", "must be a finite number");
  if (v.format.unit.size() > 32 ||
      std::any_of(v.format.unit.begin(), v.format.unit.end(), [](char c) {
        return static_cast<unsigned char>(c) < 0x20 || c == 0x7f;
      }))
    return problem("values.unit", "has a control character or more than 32 bytes");
  return std::nullopt;
}

Issue checkColouring(const ValueSettings& v) {
  if (values::findColourMap(v.colourMap) == nullptr)
    return problem("values.colour_map", "unknown colour map '" + v.colourMap + "'");
  for (const std::string& s : v.styles)
    if (values::findColourMap(s) == nullptr)
      return problem("values.styles", "unknown colour map '" + s + "'");
  if (!v.styles.empty() &&
      std::find(v.styles.begin(), v.styles.end(), v.colourMap) == v.styles.end())
    return problem("values.styles",
                   "the default colour map '" + v.colourMap + "' must be one of the styles");
  if (v.rangeFromData) {
    if (!(v.lowPercent >= 0.0 && v.lowPercent < v.highPercent && v.highPercent <= 100.0))
      return problem("values.percentiles", "must satisfy 0 <= low < high <= 100");
    return std::nullopt;
  }
  if (!std::isfinite(v.min) || !std::isfinite(v.max) || !(v.min < v.max))
    return problem("values.range", "min and max must be finite with min < max");
  if (v.scaling == values::Scaling::Log && v.min <= 0.0)
    return problem("values.range", "a log scale needs a range above 0");
  return std::nullopt;
}

} // namespace

std::optional<std::pair<std::string, std::string>> checkValueSettings(const LayerConfig& layer) {
  if (layer.kind == LayerKind::Values) {
    if (auto e = checkSamples(layer)) return e;
  }
  return checkColouring(layer.values);
}

} // namespace tellus::detail
