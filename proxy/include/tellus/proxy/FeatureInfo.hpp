#pragma once
/**
 * @file FeatureInfo.hpp
 * @brief GetFeatureInfo's answers for value layers: the value at the queried pixel with its unit,
 * written in each INFO_FORMAT tellus serves. Pure functions (the front end finds the values).
 *
 * - text/plain: "GetFeatureInfo results:" then per layer "Layer 'name'", the point and
 *   "value = 21.5 °C" (or "value = no data"), MapServer's layout of raster answers.
 * - text/html: a small page with one table row per layer (name, longitude, latitude, value,
 *   unit), text escaped.
 * - application/json: a GeoJSON FeatureCollection, one Point feature per layer (id = layer name,
 *   properties: layer, value (null for no data), unit), as GeoServer answers.
 * - application/vnd.ogc.gml and text/xml: MapServer's msGMLOutput (GML 2): per layer
 *   <NAME_layer><gml:name>, one <NAME_feature> with a gml:boundedBy box at the point and
 *   <value_0>, <x>, <y> and <unit>.
 * Values are printed as the shortest text that reads back as the same float.
 */

#include <tellus/proxy/Wms.hpp>

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace tellus {

struct FeatureInfoValue {
  std::string layer;
  double lon = 0.0; ///< degrees, the pixel's centre
  double lat = 0.0;
  std::optional<float> value; ///< nullopt: no data there (or no tile)
  std::string unit;
};

/** The answer's body in `format`. */
std::string featureInfoBody(InfoFormat format, const std::vector<FeatureInfoValue>& values);

/** Its Content-Type (UTF-8 text types say their charset). */
std::string_view featureInfoContentType(InfoFormat format) noexcept;

} // namespace tellus
