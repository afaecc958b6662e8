// layers[i].values: a value layer's samples (kind: values) and the colouring of value and
// elevation layers (ParseSections.hpp; the meaning of each key: Config.hpp's ValueSettings).

#include "ParseSections.hpp"

#include <tellus/values/ColourMap.hpp>

#include <algorithm>
#include <array>

namespace tellus::detail::yaml {

namespace {

/** The keys about samples: kind: values only (an elevation layer has its `elevation` block). */
constexpr std::string_view kSampleKeys[] = {
    "encoding", "byte_order", "scale", "offset", "no_data", "unit"};

std::string colourMapName(Reader& r, const YAML::Node& n, const std::string& path) {
  std::string name = text(r, n, path);
  if (values::findColourMap(name) != nullptr) return name;
  std::string known;
  for (const values::ColourMap& m : values::colourMaps())
    known += (known.empty() ? "" : ", ") + std::string(m.name);
  r.fail(n.Mark(), path, "unknown colour map '" + name + "' (known: " + known + ")");
}

/** `range: [min, max]` or `range: data`. */
void readRange(Reader& r, const YAML::Node& n, const std::string& path, ValueSettings& v) {
  if (n.IsScalar()) {
    if (n.Scalar() != "data")
      r.fail(n.Mark(), path, "expected [min, max] or 'data', got " + describe(n));
    v.rangeFromData = true;
    return;
  }
  const auto items = list(r, n, path);
  if (items.size() != 2)
    r.fail(n.Mark(), path, "expected [min, max] or 'data', got " + describe(n));
  v.rangeFromData = false;
  v.min = number(r, items[0], indexPath(path, 0));
  v.max = number(r, items[1], indexPath(path, 1));
  if (!(v.min < v.max)) r.fail(n.Mark(), path, "the range's min must be less than its max");
}

void readPercentiles(Reader& r, const YAML::Node& n, const std::string& path, ValueSettings& v) {
  const auto items = list(r, n, path);
  if (items.size() != 2) r.fail(n.Mark(), path, "expected [low, high] percentiles");
  v.lowPercent = number(r, items[0], indexPath(path, 0));
  v.highPercent = number(r, items[1], indexPath(path, 1));
  if (!(v.lowPercent >= 0.0 && v.lowPercent < v.highPercent && v.highPercent <= 100.0))
    r.fail(n.Mark(), path, "percentiles must satisfy 0 <= low < high <= 100");
}

void readStyles(Reader& r, const YAML::Node& n, const std::string& path, ValueSettings& v) {
  const auto items = list(r, n, path);
  if (items.empty()) r.fail(n.Mark(), path, "a value layer offers at least one colour map");
  v.styles.clear();
  for (std::size_t i = 0; i < items.size(); ++i) {
    const std::string ip = indexPath(path, i);
    r.remember(ip, items[i].Mark());
    std::string name = colourMapName(r, items[i], ip);
    if (std::find(v.styles.begin(), v.styles.end(), name) != v.styles.end())
      r.fail(items[i].Mark(), ip, "colour map '" + name + "' is listed twice");
    v.styles.push_back(std::move(name));
  }
}

void readSamples(Reader& r, const Map& m, ValueSettings& v) {
  if (auto n = m.get("encoding")) {
    const std::size_t i = choice(r, *n, m.path("encoding"), {"int16", "uint16", "float32"});
    v.format.encoding = *values::parseEncoding(std::array{"int16", "uint16", "float32"}[i]);
  }
  if (auto n = m.get("byte_order"))
    v.format.byteOrder = choice(r, *n, m.path("byte_order"), {"little", "big"}) == 0
                             ? values::ByteOrder::Little
                             : values::ByteOrder::Big;
  if (auto n = m.get("scale")) {
    v.format.scale = number(r, *n, m.path("scale"));
    if (v.format.scale == 0.0) r.fail(n->Mark(), m.path("scale"), "must not be 0");
  }
  if (auto n = m.get("offset")) v.format.offset = number(r, *n, m.path("offset"));
  if (auto n = m.get("no_data")) v.format.noData = number(r, *n, m.path("no_data"), true);
  if (auto n = m.get("unit")) v.format.unit = text(r, *n, m.path("unit"));
}

void readColouring(Reader& r, const Map& m, ValueSettings& v, bool rangeRequired) {
  if (auto n = m.get("colour_map")) v.colourMap = colourMapName(r, *n, m.path("colour_map"));
  if (auto n = m.get("styles")) readStyles(r, *n, m.path("styles"), v);
  if (!v.styles.empty() &&
      std::find(v.styles.begin(), v.styles.end(), v.colourMap) == v.styles.end())
    r.fail(m.keyMark("styles"),
           m.path("styles"),
           "the default colour map '" + v.colourMap + "' must be one of the styles");
  if (auto n = m.get("range"))
    readRange(r, *n, m.path("range"), v);
  else if (rangeRequired)
    r.fail(m.mark(), m.path("range"), "a value layer needs range: [min, max] or range: data");
  if (auto n = m.get("percentiles")) {
    if (!v.rangeFromData)
      r.fail(m.keyMark("percentiles"), m.path("percentiles"), "applies with range: data only");
    readPercentiles(r, *n, m.path("percentiles"), v);
  }
  if (auto n = m.get("scaling"))
    v.scaling = choice(r, *n, m.path("scaling"), {"linear", "log"}) == 0 ? values::Scaling::Linear
                                                                         : values::Scaling::Log;
  if (auto n = m.get("out_of_range"))
    v.outOfRange = choice(r, *n, m.path("out_of_range"), {"clamp", "transparent"}) == 0
                       ? values::OutOfRange::Clamp
                       : values::OutOfRange::Transparent;
  if (v.scaling == values::Scaling::Log && !v.rangeFromData && v.min <= 0.0)
    r.fail(m.keyMark("range"), m.path("range"), "a log scale needs a range above 0");
}

/** An elevation layer's samples as the values module reads them (its `elevation` block). */
void elevationFormat(LayerConfig& l) {
  values::ValueFormat& f = l.values.format;
  f.encoding = values::Encoding::Int16; // bil16 and int16-tiff
  f.scale = l.elevation.scale;
  f.offset = l.elevation.offset;
  f.noData = l.elevation.noData;
  if (f.container == values::Container::Png) {
    // tellus's 16-bit PNG heights hold height + 32768 (the proxy's encodeHeights, the planet's
    // HeightDecode): unsigned samples, the shift folded into the offset and no-data.
    f.encoding = values::Encoding::UInt16;
    f.offset -= 32768.0 * f.scale;
    f.noData = *f.noData + 32768.0;
  }
  f.unit = "m";
  l.values.colourMap = "terrain";
  l.values.min = -8000.0; // the terrain map has sea level at its middle
  l.values.max = 8000.0;
}

} // namespace

void readValues(Reader& r, const Map& layer, LayerConfig& l) {
  if (l.kind == LayerKind::Imagery) {
    if (layer.has("values"))
      r.fail(layer.keyMark("values"),
             layer.path("values"),
             "'values' applies to value and elevation layers only (kind: values or elevation)");
    return;
  }
  l.values.format.container =
      values::containerForMimeType(l.dataset.mimeType).value_or(values::Container::Bil);
  if (l.kind == LayerKind::Elevation) elevationFormat(l);
  const auto [node, where] = layer.child("values");
  if (node.IsNull() && l.kind == LayerKind::Values)
    r.fail(layer.mark(), layer.path("values"), "a value layer (kind: values) needs 'values'");
  if (node.IsNull()) return;
  const Map m(r,
              node,
              layer.path("values"),
              where,
              {"encoding",
               "byte_order",
               "scale",
               "offset",
               "no_data",
               "unit",
               "colour_map",
               "styles",
               "range",
               "percentiles",
               "scaling",
               "out_of_range"});
  if (l.kind == LayerKind::Elevation) {
    for (const std::string_view key : kSampleKeys)
      if (m.has(key))
        r.fail(m.keyMark(key),
               m.path(key),
               "an elevation layer's samples are described under 'elevation' (metres)");
  }
  readSamples(r, m, l.values);
  readColouring(r, m, l.values, l.kind == LayerKind::Values);
}

} // namespace tellus::detail::yaml
