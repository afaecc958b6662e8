// A WMTS layer's matrices mapped onto a World Wind grid, and tile URLs (WmtsUpstream.hpp).

#include <tellus/proxy/WmtsUpstream.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

namespace tellus {

namespace {

/// OGC WMTS 1.0.0 (6.1, Annex E): the standardized rendering pixel is 0.28 mm, and a degree of
/// EPSG:4326 counts as 2 pi 6378137 / 360 metres.
constexpr double kPixelMetres = 0.00028;
constexpr double kMetresPerDegree = 111319.49079327357;
/// Alignment tolerance, in pixels (the file comment of WmtsUpstream.hpp).
constexpr double kTolerancePx = 0.01;

std::string encode(std::string_view s) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string out;
  for (const char ch : s) {
    const auto c = static_cast<unsigned char>(ch);
    if ((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-' ||
        c == '_' || c == '.' || c == '~' || c == ':') {
      out.push_back(ch);
    } else {
      out.push_back('%');
      out.push_back(kHex[c >> 4]);
      out.push_back(kHex[c & 15]);
    }
  }
  return out;
}

bool iequals(std::string_view a, std::string_view b) {
  return std::ranges::equal(a, b, [](char x, char y) {
    const auto lo = [](char c) { return (c >= 'A' && c <= 'Z') ? static_cast<char>(c + 32) : c; };
    return lo(x) == lo(y);
  });
}

std::string joined(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names)
    out += (out.empty() ? "'" : ", '") + n + "'";
  return out.empty() ? "none" : out;
}

/** The CRS's axis order for a lat/long set: lon-first (CRS84), lat-first (EPSG:4326), or not a
 * lat/long CRS at all. */
enum class Axes { LonLat, LatLon, Other };

Axes axesOf(std::string_view crs) {
  const auto has = [&](std::string_view s) { return crs.find(s) != std::string_view::npos; };
  if (has("CRS84") || has("CRS:84") || has("OGC:2:84") || has("OGC/1.3/CRS84")) return Axes::LonLat;
  const bool epsg4326 = (has("EPSG") && (crs.ends_with(":4326") || crs.ends_with("/4326")));
  return epsg4326 ? Axes::LatLon : Axes::Other;
}

/** Whether `v` is within `tol` of a whole number; the number. */
std::optional<std::int64_t> whole(double v, double tol) {
  const double r = std::round(v);
  if (std::fabs(v - r) > tol || std::fabs(r) > 9.0e15) return std::nullopt;
  return static_cast<std::int64_t>(r);
}

std::string setDescription(const WmtsTileMatrixSet& set) {
  std::string out;
  for (const auto& m : set.matrices) {
    const double deg = m.scaleDenominator * kPixelMetres / kMetresPerDegree * m.tileWidth;
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.6g", deg);
    out += (out.empty() ? "" : ", ") + m.identifier + ": " + buf + " deg x " +
           std::to_string(m.tileWidth) + " px";
  }
  return out;
}

} // namespace

std::expected<WmtsTiles, std::string>
bindWmtsLayer(const WmtsCapabilities& caps, const WmtsChoice& choice, const GridSpec& grid) {
  const WmtsLayer* layer = caps.layer(choice.layer);
  if (!layer) {
    std::vector<std::string> names;
    for (const auto& l : caps.layers)
      names.push_back(l.identifier);
    if (names.size() > 20) {
      names.resize(20);
      names.emplace_back("...");
    }
    return std::unexpected("the WMTS has no layer '" + choice.layer + "' (it has " + joined(names) +
                           ")");
  }
  const std::string what = "WMTS layer '" + layer->identifier + "'";
  WmtsTiles t;
  t.layer = layer->identifier;
  // Style: as chosen, else the default one (listed first).
  if (choice.style.empty()) {
    t.style = layer->styles.empty() ? std::string("default") : layer->styles.front();
  } else if (std::ranges::find(layer->styles, choice.style) == layer->styles.end()) {
    return std::unexpected(what + " has no style '" + choice.style + "' (it has " +
                           joined(layer->styles) + ")");
  } else {
    t.style = choice.style;
  }
  if (std::ranges::find(layer->formats, choice.format) == layer->formats.end())
    return std::unexpected(what + " has no format '" + choice.format + "' (it has " +
                           joined(layer->formats) + ")");
  t.format = choice.format;
  if (choice.tileMatrixSet.empty()) {
    if (layer->tileMatrixSets.size() != 1)
      return std::unexpected(what + " links " + std::to_string(layer->tileMatrixSets.size()) +
                             " tile matrix sets (" + joined(layer->tileMatrixSets) +
                             "): choose one with tile_matrix_set");
    t.tileMatrixSet = layer->tileMatrixSets.front();
  } else if (std::ranges::find(layer->tileMatrixSets, choice.tileMatrixSet) ==
             layer->tileMatrixSets.end()) {
    return std::unexpected(what + " has no tile matrix set '" + choice.tileMatrixSet +
                           "' (it links " + joined(layer->tileMatrixSets) + ")");
  } else {
    t.tileMatrixSet = choice.tileMatrixSet;
  }
  const WmtsTileMatrixSet* set = caps.tileMatrixSet(t.tileMatrixSet);
  if (!set)
    return std::unexpected("tile matrix set '" + t.tileMatrixSet + "' linked by " + what +
                           " is not described in the capabilities");
  // Dimensions: time comes from the request, the others stay at their defaults.
  for (const auto& d : layer->dimensions) {
    if (iequals(d.identifier, "time")) {
      t.timeName = d.identifier;
      t.timeDefault = d.defaultValue;
    } else {
      if (d.defaultValue.empty())
        return std::unexpected(what + ": dimension '" + d.identifier + "' has no default");
      t.dimensions.emplace_back(d.identifier, d.defaultValue);
    }
  }
  // Encoding: REST with the layer's template for the format, or KVP.
  const WmtsResourceUrl* resource = nullptr;
  for (const auto& r : layer->resourceUrls)
    if (r.format == t.format && (r.resourceType.empty() || r.resourceType == "tile")) resource = &r;
  if (choice.encoding == WmtsEncoding::Rest && !resource)
    return std::unexpected(what + " has no ResourceURL template for '" + t.format +
                           "': use encoding kvp");
  t.rest = resource && choice.encoding != WmtsEncoding::Kvp;
  if (t.rest) {
    t.urlTemplate = resource->tmpl;
  } else {
    t.urlTemplate = caps.getTileKvpUrl;
    if (t.urlTemplate.empty()) {
      t.urlTemplate = choice.capabilitiesUrl;
      if (const auto q = t.urlTemplate.find('?'); q != std::string::npos) t.urlTemplate.resize(q);
    }
  }
  // The matrices, level by level.
  const Axes axes = axesOf(set->crs);
  if (axes == Axes::Other)
    return std::unexpected("tile matrix set '" + set->identifier + "' is in " +
                           (set->crs.empty() ? std::string("no CRS") : "'" + set->crs + "'") +
                           ": only lat/long sets (EPSG:4326, CRS84) can be mapped onto the grid; "
                           "Web Mercator and other projected upstream sets are not supported yet");
  for (std::int32_t level = 0; level < grid.numLevels; ++level) {
    const double span = grid.levelZeroDeltaDeg / std::ldexp(1.0, level);
    const double pixel = span / grid.tileWidth;
    const WmtsTileMatrix* found = nullptr;
    for (const auto& m : set->matrices) {
      if (m.tileWidth != grid.tileWidth || m.tileHeight != grid.tileHeight) continue;
      const double mPixel = m.scaleDenominator * kPixelMetres / kMetresPerDegree;
      const double mSpan = mPixel * m.tileWidth;
      if (std::fabs(mSpan - span) * static_cast<double>(m.matrixWidth) > kTolerancePx * pixel)
        continue;
      found = &m;
      break;
    }
    if (!found) {
      if (level == 0)
        return std::unexpected(
            "tile matrix set '" + set->identifier + "' does not line up with the layer's grid (" +
            std::to_string(grid.levelZeroDeltaDeg) + "-degree level 0, " +
            std::to_string(grid.tileWidth) + " px tiles): its matrices are " +
            setDescription(*set) + "; composing sets that do not line up is not supported yet");
      return std::unexpected("tile matrix set '" + set->identifier + "' lines up with levels 0-" +
                             std::to_string(level - 1) + " of the grid only (its finest is " +
                             set->matrices.back().identifier + "): set grid.levels to at most " +
                             std::to_string(level));
    }
    const double lon = axes == Axes::LonLat ? found->topLeftX : found->topLeftY;
    const double lat = axes == Axes::LonLat ? found->topLeftY : found->topLeftX;
    // Some servers (GIBS) write EPSG:4326 corners longitude first: a "latitude" beyond 90 says so.
    const bool swapped = axes == Axes::LatLon && std::fabs(lat) > 90.0;
    const double west = swapped ? lat : lon;
    const double north = swapped ? lon : lat;
    const double tol = kTolerancePx / grid.tileWidth;
    // World Wind's origin is (-90, -180): tile (row, col) spans from -90 + row * span northwards.
    const auto colBase = whole((-180.0 - west) / span, tol);
    const auto northRows = whole((north + 90.0) / span, tol);
    if (!colBase || !northRows)
      return std::unexpected("tile matrix '" + found->identifier + "' of set '" + set->identifier +
                             "' has its top-left corner off the grid's tile " +
                             "edges; composing sets that do not line up is not supported yet");
    WmtsLevel lv;
    lv.matrix = found->identifier;
    lv.colBase = *colBase;
    lv.rowBase = *northRows - 1;
    lv.matrixWidth = found->matrixWidth;
    lv.matrixHeight = found->matrixHeight;
    t.levels.push_back(std::move(lv));
  }
  return t;
}

std::optional<std::string>
wmtsTileUrl(const WmtsTiles& t, const TileKey& key, std::string_view time) {
  if (key.level < 0 || static_cast<std::size_t>(key.level) >= t.levels.size()) return std::nullopt;
  const WmtsLevel& lv = t.levels[static_cast<std::size_t>(key.level)];
  const std::int64_t row = lv.rowBase - key.row;
  const std::int64_t col = lv.colBase + key.col;
  if (row < 0 || col < 0 || row >= lv.matrixHeight || col >= lv.matrixWidth) return std::nullopt;
  const std::string timeValue(time.empty() ? std::string_view(t.timeDefault) : time);
  if (!t.rest) {
    std::string url = t.urlTemplate;
    if (url.find('?') == std::string::npos) {
      url += '?';
    } else if (url.back() != '?' && url.back() != '&') {
      url += '&';
    }
    url += "SERVICE=WMTS&REQUEST=GetTile&VERSION=1.0.0&LAYER=" + encode(t.layer) +
           "&STYLE=" + encode(t.style) + "&FORMAT=" + encode(t.format) +
           "&TILEMATRIXSET=" + encode(t.tileMatrixSet) + "&TILEMATRIX=" + encode(lv.matrix) +
           "&TILEROW=" + std::to_string(row) + "&TILECOL=" + std::to_string(col);
    if (!t.timeName.empty() && !timeValue.empty()) url += "&TIME=" + encode(timeValue);
    for (const auto& [name, value] : t.dimensions)
      url += "&" + encode(name) + "=" + encode(value);
    return url;
  }
  // REST: every {Name} of the template replaced (names compared without case, as servers differ
  // from their own dimension identifiers: GIBS's "time" dimension is {Time} in its templates).
  std::string url;
  const std::string& s = t.urlTemplate;
  std::size_t i = 0;
  while (i < s.size()) {
    const std::size_t open = s.find('{', i);
    const std::size_t close = open == std::string::npos ? open : s.find('}', open);
    if (open == std::string::npos || close == std::string::npos) {
      url.append(s, i);
      break;
    }
    url.append(s, i, open - i);
    const std::string_view name(s.data() + open + 1, close - open - 1);
    std::string value;
    bool known = true;
    if (iequals(name, "TileMatrixSet"))
      value = t.tileMatrixSet;
    else if (iequals(name, "TileMatrix"))
      value = lv.matrix;
    else if (iequals(name, "TileRow"))
      value = std::to_string(row);
    else if (iequals(name, "TileCol"))
      value = std::to_string(col);
    else if (iequals(name, "Style"))
      value = t.style;
    else if (!t.timeName.empty() && iequals(name, t.timeName))
      value = timeValue;
    else {
      known = false;
      for (const auto& [dn, dv] : t.dimensions)
        if (iequals(name, dn)) {
          value = dv;
          known = true;
        }
    }
    if (known)
      url += encode(value);
    else
      url.append(s, open, close - open + 1); // left as written: the server says what it means
    i = close + 1;
  }
  return url;
}

std::string wmtsCapabilitiesUrl(const std::string& url) {
  std::string lower;
  for (const char c : url)
    lower += (c >= 'A' && c <= 'Z') ? static_cast<char>(c + 32) : c;
  const std::size_t q = lower.find('?');
  const std::string path = lower.substr(0, q);
  if (lower.find("request=", q == std::string::npos ? lower.size() : q) != std::string::npos ||
      path.ends_with(".xml"))
    return url;
  std::string out = url;
  if (q == std::string::npos) {
    out += '?';
  } else if (out.back() != '?' && out.back() != '&') {
    out += '&';
  }
  return out + "SERVICE=WMTS&REQUEST=GetCapabilities&VERSION=1.0.0";
}

} // namespace tellus
