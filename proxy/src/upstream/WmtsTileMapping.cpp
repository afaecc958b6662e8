// A WMTS layer's matrices mapped onto a World Wind grid, and tile URLs (WmtsUpstream.hpp).

#include "WmtsMercator.hpp"

#include <tellus/proxy/MapBox.hpp>
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

/** A REST template can address tiles only if it names the matrix, the row and the column (WMTS
 * 1.0.0, 10.2.1); a ResourceURL without them (or without a template at all) is not used. */
bool addressesTiles(std::string_view tmpl) {
  const auto has = [&](std::string_view name) {
    for (std::size_t open = tmpl.find('{'); open != std::string_view::npos;
         open = tmpl.find('{', open + 1)) {
      const std::size_t close = tmpl.find('}', open);
      if (close == std::string_view::npos) return false;
      if (iequals(tmpl.substr(open + 1, close - open - 1), name)) return true;
    }
    return false;
  };
  return has("TileMatrix") && has("TileRow") && has("TileCol");
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

/** Whether `crs` names a body's planetocentric geographic IAU CRS (code NAIF id x 100, e.g.
 * IAU:30100, IAU2000:49900, urn:ogc:def:crs:IAU:2015:30100, .../def/crs/IAU/2015/30100). */
bool iauGeographic(std::string_view crs) {
  if (crs.find("IAU") == std::string_view::npos) return false;
  const auto at = crs.find_last_of(":/");
  if (at == std::string_view::npos) return false;
  const std::string_view digits = crs.substr(at + 1);
  if (digits.size() < 3 || digits.size() > 7 ||
      !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return false;
  return digits.ends_with("00");
}

Axes axesOf(std::string_view crs, bool otherBody) {
  const auto has = [&](std::string_view s) { return crs.find(s) != std::string_view::npos; };
  if (has("CRS84") || has("CRS:84") || has("OGC:2:84") || has("OGC/1.3/CRS84")) return Axes::LonLat;
  const bool epsg4326 = (has("EPSG") && (crs.ends_with(":4326") || crs.ends_with("/4326")));
  // The IAU 2015 geographic CRSs put latitude first, as EPSG:4326 does.
  return epsg4326 || (otherBody && iauGeographic(crs)) ? Axes::LatLon : Axes::Other;
}

/** The metres per degree a lat/long set's scale denominators are counted with: the Earth's, or a
 * body's when only that count makes one of its matrices span exactly 360 degrees. */
double metresPerDegreeOf(const UpstreamTileMatrixSet& set, double bodyMetresPerDegree) {
  const auto global = [&](double metresPerDegree) {
    return std::ranges::any_of(set.matrices, [&](const UpstreamTileMatrix& m) {
      const double width = m.scaleDenominator * kPixelMetres / metresPerDegree *
                           static_cast<double>(m.tileWidth) * static_cast<double>(m.matrixWidth);
      return std::fabs(width - 360.0) <= 360.0 * 1e-6;
    });
  };
  if (bodyMetresPerDegree > 0.0 && !global(kMetresPerDegree) && global(bodyMetresPerDegree))
    return bodyMetresPerDegree;
  return kMetresPerDegree;
}

/** Whether `v` is within `tol` of a whole number; the number. */
std::optional<std::int64_t> whole(double v, double tol) {
  const double r = std::round(v);
  if (std::fabs(v - r) > tol || std::fabs(r) > 9.0e15) return std::nullopt;
  return static_cast<std::int64_t>(r);
}

std::string setDescription(const UpstreamTileMatrixSet& set) {
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

/** The grid's levels on a Web Mercator set: each composed from the coarsest zoom whose pixel spans
 * at most the level's pixel in longitude (WmtsMercator.hpp), within a bound on the tiles one grid
 * tile needs (counted at the tile nearest the square's north edge, where it is largest). */
std::expected<void, std::string>
bindMercatorLevels(WmtsTiles& t, const UpstreamTileMatrixSet& set, const GridSpec& grid) {
  constexpr std::size_t kMaxTiles = 256;
  for (std::int32_t level = 0; level < grid.numLevels; ++level) {
    const double span = grid.levelZeroDeltaDeg / std::ldexp(1.0, level);
    const double pixel = span / grid.tileWidth;
    int from = -1;
    for (std::size_t i = 0; i < t.matrices.size(); ++i) {
      const WmtsMatrixGeometry& m = t.matrices[i];
      if (m.pixelDeg > pixel * (1.0 + 1e-9)) continue;
      if (from < 0 || m.pixelDeg > t.matrices[static_cast<std::size_t>(from)].pixelDeg)
        from = static_cast<int>(i);
    }
    if (from < 0)
      return std::unexpected(
          "tile matrix set '" + set.identifier + "' (Web Mercator) " +
          (level == 0
               ? std::string("has no zoom as fine as the grid's level 0: its matrices are ") +
                     setDescription(set)
               : "reaches levels 0-" + std::to_string(level - 1) +
                     " of the grid only: set grid.levels to at most " + std::to_string(level)));
    const WmtsMatrixGeometry& m = t.matrices[static_cast<std::size_t>(from)];
    // World Wind's origin is (-90, -180); the row holding 85.0511 N needs the most rows.
    const double south = -90.0 + std::floor((mercator::kMaxLatitude + 90.0) / span) * span;
    const Sector worst{-180.0, south, -180.0 + span, south + span};
    const auto r = wmtsmercator::sourceRange(m, worst, grid.tileWidth, grid.tileHeight);
    const auto n = static_cast<std::size_t>(std::max<std::int64_t>(0, r.r1 - r.r0 + 1) *
                                            std::max<std::int64_t>(0, r.c1 - r.c0 + 1));
    if (n > kMaxTiles)
      return std::unexpected("level " + std::to_string(level) +
                             " of the grid would be composed from up to " + std::to_string(n) +
                             " tiles of matrix '" + m.identifier + "' each: more than " +
                             std::to_string(kMaxTiles));
    WmtsLevel lv;
    lv.composeFrom = from;
    lv.matrix = m.identifier;
    t.levels.push_back(std::move(lv));
  }
  return {};
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
  const UpstreamTileMatrixSet* set = caps.tileMatrixSet(t.tileMatrixSet);
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
    if (r.format == t.format && (r.resourceType.empty() || r.resourceType == "tile") &&
        addressesTiles(r.tmpl))
      resource = &r;
  if (choice.encoding == WmtsEncoding::Rest && !resource)
    return std::unexpected(what + " has no ResourceURL template for '" + t.format +
                           "' that names {TileMatrix}, {TileRow} and {TileCol}: use encoding kvp");
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
  if (wmtsmercator::isMercatorCrs(set->crs)) {
    auto merc = wmtsmercator::matrices(*set);
    if (!merc) return std::unexpected(merc.error());
    t.matrices = std::move(*merc);
    t.mercator = true;
    if (auto levels = bindMercatorLevels(t, *set, grid); !levels)
      return std::unexpected(levels.error());
    return t;
  }
  const Axes axes = axesOf(set->crs, choice.bodyMetresPerDegree > 0.0);
  const double metresPerDegree = metresPerDegreeOf(*set, choice.bodyMetresPerDegree);
  if (axes == Axes::Other)
    return std::unexpected("tile matrix set '" + set->identifier + "' is in " +
                           (set->crs.empty() ? std::string("no CRS") : "'" + set->crs + "'") +
                           ": only lat/long sets (EPSG:4326, CRS84) can be mapped onto the grid; "
                           "of the projected ones only Web Mercator (EPSG:3857) is");
  for (const auto& m : set->matrices) {
    const double lon = axes == Axes::LonLat ? m.topLeftX : m.topLeftY;
    const double lat = axes == Axes::LonLat ? m.topLeftY : m.topLeftX;
    // Some servers (GIBS) write EPSG:4326 corners longitude first: a "latitude" beyond 90 says so.
    const bool swapped = axes == Axes::LatLon && std::fabs(lat) > 90.0;
    t.matrices.push_back(WmtsMatrixGeometry{m.identifier,
                                            swapped ? lat : lon,
                                            swapped ? lon : lat,
                                            m.scaleDenominator * kPixelMetres / metresPerDegree,
                                            m.tileWidth,
                                            m.tileHeight,
                                            m.matrixWidth,
                                            m.matrixHeight});
  }
  for (std::int32_t level = 0; level < grid.numLevels; ++level) {
    const double span = grid.levelZeroDeltaDeg / std::ldexp(1.0, level);
    const double pixel = span / grid.tileWidth;
    const double tol = kTolerancePx / grid.tileWidth;
    WmtsLevel lv;
    for (std::size_t i = 0; i < t.matrices.size() && lv.matrix.empty(); ++i) {
      const WmtsMatrixGeometry& m = t.matrices[i];
      if (m.tileWidth != grid.tileWidth || m.tileHeight != grid.tileHeight) continue;
      if (std::fabs(m.pixelDeg * m.tileWidth - span) * static_cast<double>(m.matrixWidth) >
          kTolerancePx * pixel)
        continue;
      // World Wind's origin is (-90, -180): tile (row, col) spans from -90 + row * span north.
      const auto colBase = whole((-180.0 - m.west) / span, tol);
      const auto northRows = whole((m.north + 90.0) / span, tol);
      if (!colBase || !northRows) continue;
      lv.matrix = m.identifier;
      lv.colBase = *colBase;
      lv.rowBase = *northRows - 1;
      lv.matrixWidth = m.matrixWidth;
      lv.matrixHeight = m.matrixHeight;
    }
    if (lv.matrix.empty()) {
      // Composed from the coarsest matrix at least as fine as the level.
      int from = -1;
      for (std::size_t i = 0; i < t.matrices.size(); ++i) {
        const WmtsMatrixGeometry& m = t.matrices[i];
        if (m.pixelDeg > pixel * (1.0 + 1e-9)) continue;
        if (from < 0 || m.pixelDeg > t.matrices[static_cast<std::size_t>(from)].pixelDeg)
          from = static_cast<int>(i);
      }
      if (from < 0) {
        if (level == 0)
          return std::unexpected("tile matrix set '" + set->identifier +
                                 "' has no matrix as fine as the grid's level 0 (" +
                                 std::to_string(grid.tileWidth) + " px tiles of " +
                                 std::to_string(grid.levelZeroDeltaDeg) +
                                 " degrees): its matrices are " + setDescription(*set));
        return std::unexpected("tile matrix set '" + set->identifier + "' reaches levels 0-" +
                               std::to_string(level - 1) + " of the grid only (its finest is " +
                               set->matrices.back().identifier + "): set grid.levels to at most " +
                               std::to_string(level));
      }
      const WmtsMatrixGeometry& m = t.matrices[static_cast<std::size_t>(from)];
      // At most this many upstream tiles make one grid tile (a sanity bound).
      const double across = std::ceil(span / (m.pixelDeg * m.tileWidth)) + 1.0;
      const double down = std::ceil(span / (m.pixelDeg * m.tileHeight)) + 1.0;
      if (across * down > 64.0)
        return std::unexpected("level " + std::to_string(level) +
                               " of the grid would be composed from " +
                               std::to_string(static_cast<long long>(across * down)) +
                               " tiles of matrix '" + m.identifier + "' each: more than 64");
      lv.composeFrom = from;
      lv.matrix = m.identifier;
    }
    t.levels.push_back(std::move(lv));
  }
  return t;
}

namespace {

std::string urlOf(const WmtsTiles& t,
                  const std::string& matrix,
                  std::int64_t row,
                  std::int64_t col,
                  std::string_view time) {
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
           "&TILEMATRIXSET=" + encode(t.tileMatrixSet) + "&TILEMATRIX=" + encode(matrix) +
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
      value = matrix;
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

} // namespace

bool wmtsComposed(const WmtsTiles& t, const TileKey& key) noexcept {
  return key.level >= 0 && static_cast<std::size_t>(key.level) < t.levels.size() &&
         t.levels[static_cast<std::size_t>(key.level)].composeFrom >= 0;
}

std::vector<WmtsSourceTile> wmtsSourceTiles(const WmtsTiles& t,
                                            const TileKey& key,
                                            const Sector& s,
                                            int width,
                                            int height,
                                            std::string_view time) {
  std::vector<WmtsSourceTile> out;
  if (!wmtsComposed(t, key) || width < 1 || height < 1) return out;
  const auto from = t.levels[static_cast<std::size_t>(key.level)].composeFrom;
  const WmtsMatrixGeometry& m = t.matrices[static_cast<std::size_t>(from)];
  if (t.mercator) {
    const auto r = wmtsmercator::sourceRange(m, s, width, height);
    for (std::int64_t row = r.r0; row <= r.r1; ++row)
      for (std::int64_t col = r.c0; col <= r.c1; ++col)
        out.push_back(WmtsSourceTile{row, col, urlOf(t, m.identifier, row, col, time)});
    return out;
  }
  const double mw = static_cast<double>(m.matrixWidth) * m.tileWidth;   // pixels across
  const double mh = static_cast<double>(m.matrixHeight) * m.tileHeight; // pixels down
  // The source pixels the bilinear samples at the first and last output pixel centres touch
  // (composeWmtsTile samples at the same places), clipped to the matrix.
  const double pxW = (s.east - s.west) / width;
  const double pxH = (s.north - s.south) / height;
  // (A millionth of a pixel of slack: a weight that small is no reason to fetch a tile.)
  const auto lo = [](double v) { return std::floor(v + 1e-6); };
  const auto hi = [](double v) { return std::ceil(v - 1e-6); };
  const double u0 = lo((s.west + 0.5 * pxW - m.west) / m.pixelDeg - 0.5);
  const double u1 = hi((s.east - 0.5 * pxW - m.west) / m.pixelDeg - 0.5);
  const double v0 = lo((m.north - (s.north - 0.5 * pxH)) / m.pixelDeg - 0.5);
  const double v1 = hi((m.north - (s.south + 0.5 * pxH)) / m.pixelDeg - 0.5);
  if (u1 < 0 || v1 < 0 || u0 >= mw || v0 >= mh) return out; // outside the matrix: no tile
  const auto tileOf = [](double px, double max, std::int32_t size) {
    return static_cast<std::int64_t>(std::clamp(px, 0.0, max - 1) / size);
  };
  const std::int64_t c0 = tileOf(u0, mw, m.tileWidth), c1 = tileOf(u1, mw, m.tileWidth);
  const std::int64_t r0 = tileOf(v0, mh, m.tileHeight), r1 = tileOf(v1, mh, m.tileHeight);
  for (std::int64_t r = r0; r <= r1; ++r)
    for (std::int64_t c = c0; c <= c1; ++c)
      out.push_back(WmtsSourceTile{r, c, urlOf(t, m.identifier, r, c, time)});
  return out;
}

std::optional<std::string>
wmtsTileUrl(const WmtsTiles& t, const TileKey& key, std::string_view time) {
  if (key.level < 0 || static_cast<std::size_t>(key.level) >= t.levels.size()) return std::nullopt;
  const WmtsLevel& lv = t.levels[static_cast<std::size_t>(key.level)];
  if (lv.composeFrom >= 0) return std::nullopt;
  const std::int64_t row = lv.rowBase - key.row;
  const std::int64_t col = lv.colBase + key.col;
  if (row < 0 || col < 0 || row >= lv.matrixHeight || col >= lv.matrixWidth) return std::nullopt;
  return urlOf(t, lv.matrix, row, col, time);
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
