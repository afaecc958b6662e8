#pragma once
/**
 * @file ValueLayer.hpp
 * @brief What the proxy knows of a value layer (issue 24): how its tiles' samples become values,
 * the colour maps it offers as WMS STYLES, and the colour scale of each.
 *
 * Value layers (configuration `kind: values`) and elevation layers carry one. The cache keeps
 * their tiles as the upstream sent them; GetMap with a style decodes the values (tellus::values),
 * samples them bilinearly per map pixel and colours each pixel by the scale's exact rule
 * (values/ColourScale.hpp), so a map and the renderer agree; GetLegendGraphic draws the scale's
 * legend and GetFeatureInfo answers the value at a pixel with its unit.
 *
 * Default style: a value layer's is its colour map (`defaultStyle`); an elevation layer's stays
 * what it was before styles (heights in a heights format, the fixed grey ramp in a picture:
 * `defaultStyle` empty), its colour maps being offered by name.
 */

#include <tellus/values/ColourScale.hpp>
#include <tellus/values/ValueFormat.hpp>

#include <span>
#include <string>
#include <vector>

namespace tellus {

struct ValueLayerSpec {
  values::ValueFormat format; ///< the tiles' samples -> values (and the unit)
  /** The colour map of STYLES "" and "default"; "" = not coloured (elevation layers). */
  std::string defaultStyle;
  std::vector<std::string> styles; ///< the colour maps offered, in capabilities order
  bool rangeFromData = false;      ///< the range from each map's values (percentiles below)
  double min = 0.0;                ///< the fixed range (rangeFromData false)
  double max = 1.0;
  double lowPercent = 0.0;
  double highPercent = 100.0;
  values::Scaling scaling = values::Scaling::Linear;
  values::OutOfRange outOfRange = values::OutOfRange::Clamp;

  /** Whether `name` is one of the offered colour maps. */
  bool offers(std::string_view name) const noexcept;

  /** The scale of `map` over the fixed range, or (rangeFromData) over the percentiles of
   * `data`'s finite values (positive ones for log; [0, 1] when there are none). */
  values::ColourScale scale(const values::ColourMap& map, std::span<const float> data = {}) const;
};

} // namespace tellus
