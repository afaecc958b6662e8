#include <tellus/values/ColourScale.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace tellus::values {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

} // namespace

std::expected<void, std::string> checkScale(const ColourScale& scale) {
  if (scale.map == nullptr || scale.map->table == nullptr)
    return std::unexpected("the colour scale has no colour map");
  if (!std::isfinite(scale.min) || !std::isfinite(scale.max))
    return std::unexpected("the colour scale's range is not finite");
  if (scale.scaling == Scaling::Log && (scale.min <= 0.0 || scale.max <= 0.0))
    return std::unexpected("a log colour scale needs a range above 0, not [" +
                           std::to_string(scale.min) + ", " + std::to_string(scale.max) + "]");
  return {};
}

double scalePosition(const ColourScale& scale, float v) noexcept {
  if (std::isnan(v)) return std::numeric_limits<double>::quiet_NaN();
  const double value = static_cast<double>(v);
  if (scale.scaling == Scaling::Log && value <= 0.0) return -kInf;
  if (std::isinf(value)) return value;
  if (scale.min == scale.max) return value < scale.min ? -kInf : value > scale.max ? kInf : 0.5;
  if (scale.scaling == Scaling::Log) {
    const double lo = std::log10(scale.min);
    return (std::log10(value) - lo) / (std::log10(scale.max) - lo);
  }
  return (value - scale.min) / (scale.max - scale.min);
}

int colourIndex(const ColourScale& scale, float v) noexcept {
  const double t = scalePosition(scale, v);
  if (std::isnan(t)) return -1;
  if ((t < 0.0 || t > 1.0) && scale.outOfRange == OutOfRange::Transparent) return -1;
  if (t <= 0.0) return 0;
  if (t >= 1.0) return 255;
  return std::min(static_cast<int>(std::floor(t * 256.0)), 255);
}

Rgba8 colourOf(const ColourScale& scale, float v) noexcept {
  const int index = colourIndex(scale, v);
  if (index < 0 || scale.map == nullptr || scale.map->table == nullptr) return {0, 0, 0, 0};
  const Rgb8& c = (*scale.map->table)[static_cast<std::size_t>(index)];
  return {c[0], c[1], c[2], 255};
}

std::expected<codec::Image, std::string> apply(const ValueRaster& raster,
                                               const ColourScale& scale) {
  if (auto ok = checkScale(scale); !ok) return std::unexpected(ok.error());
  codec::Image out{raster.width, raster.height, 4, {}};
  out.pixels.resize(raster.values.size() * 4);
  for (std::size_t i = 0; i < raster.values.size(); ++i) {
    const Rgba8 c = colourOf(scale, raster.values[i]);
    std::copy(c.begin(), c.end(), out.pixels.begin() + static_cast<std::ptrdiff_t>(i * 4));
  }
  return out;
}

std::optional<ValueRange> rangeFromData(std::span<const float> values,
                                        double lowPercent,
                                        double highPercent,
                                        bool positiveOnly) {
  if (!(lowPercent >= 0.0 && lowPercent <= highPercent && highPercent <= 100.0))
    return std::nullopt;
  std::vector<float> kept;
  kept.reserve(values.size());
  for (float v : values)
    if (std::isfinite(v) && (!positiveOnly || v > 0.0f)) kept.push_back(v);
  if (kept.empty()) return std::nullopt;
  // Nearest rank: the value at index round(p / 100 * (n - 1)) of the sorted values.
  auto rank = [&](double percent) {
    const double position = percent / 100.0 * static_cast<double>(kept.size() - 1);
    const auto k = static_cast<std::size_t>(std::llround(position));
    std::nth_element(kept.begin(), kept.begin() + static_cast<std::ptrdiff_t>(k), kept.end());
    return static_cast<double>(kept[k]);
  };
  const double lo = rank(lowPercent);
  const double hi = rank(highPercent);
  return ValueRange{lo, hi};
}

std::string_view scalingName(Scaling scaling) noexcept {
  return scaling == Scaling::Log ? "log" : "linear";
}

std::optional<Scaling> parseScaling(std::string_view name) noexcept {
  if (name == "linear") return Scaling::Linear;
  if (name == "log") return Scaling::Log;
  return std::nullopt;
}

std::string_view outOfRangeName(OutOfRange outOfRange) noexcept {
  return outOfRange == OutOfRange::Transparent ? "transparent" : "clamp";
}

std::optional<OutOfRange> parseOutOfRange(std::string_view name) noexcept {
  if (name == "clamp") return OutOfRange::Clamp;
  if (name == "transparent") return OutOfRange::Transparent;
  return std::nullopt;
}

} // namespace tellus::values
