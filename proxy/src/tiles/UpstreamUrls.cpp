// TileService's upstream requests: the URL of a tile (WMS GetMap, WorldWind, WMTS) and of a
// WMS block (a metatile).

#include "upstream/WmtsCompose.hpp"

#include <tellus/proxy/TileService.hpp>

#include <charconv>

namespace tellus {

namespace {

std::string formatNumber(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

std::string urlEncode(std::string_view s) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string out;
  for (const char ch : s) {
    const auto c = static_cast<unsigned char>(ch);
    if ((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-' ||
        c == '_' || c == '.' || c == '~' || c == ':' || c == ',') {
      out.push_back(ch);
    } else {
      out.push_back('%');
      out.push_back(kHex[c >> 4]);
      out.push_back(kHex[c & 15]);
    }
  }
  return out;
}
} // namespace

std::string TileService::upstreamUrl(const UpstreamSpec& u,
                                     const LayerSpec& l,
                                     const Sector& s,
                                     const TileKey& key,
                                     std::string_view time) {
  if (u.type == UpstreamSpec::Type::Wmts)
    return l.wmts ? wmtsTileUrl(*l.wmts, key, time).value_or(std::string()) : std::string();
  if (u.type == UpstreamSpec::Type::WorldWind) {
    std::string url = u.url;
    if (url.find('?') == std::string::npos) {
      url += '?';
    } else if (url.back() != '?' && url.back() != '&') {
      url += '&';
    }
    url += "T=" + urlEncode(l.upstreamLayer) + "&L=" + std::to_string(key.level + l.firstLevel) +
           "&X=" + std::to_string(key.col) + "&Y=" + std::to_string(key.row);
    return url;
  }
  return wmsUrl(u, l, s, l.dataset.grid.tileWidth, l.dataset.grid.tileHeight, time);
}

std::string TileService::wmsUrl(const UpstreamSpec& u,
                                const LayerSpec& l,
                                const Sector& s,
                                std::int32_t width,
                                std::int32_t height,
                                std::string_view time) {
  std::string url = u.url;
  if (url.find('?') == std::string::npos) {
    url += '?';
  } else if (url.back() != '?' && url.back() != '&') {
    url += '&';
  }
  const bool v111 = u.wmsVersion == "1.1.1";
  const bool latLon = !v111 && u.crs == "EPSG:4326"; // WMS 1.3.0 EPSG:4326 is lat/lon
  url += "SERVICE=WMS&REQUEST=GetMap&VERSION=" + u.wmsVersion;
  url += "&LAYERS=" + urlEncode(l.upstreamLayer) + "&STYLES=" + urlEncode(l.dataset.style);
  url += "&FORMAT=" + urlEncode(l.dataset.mimeType);
  url += "&WIDTH=" + std::to_string(width) + "&HEIGHT=" + std::to_string(height);
  url += v111 ? "&SRS=EPSG:4326" : "&CRS=" + urlEncode(u.crs);
  url += "&BBOX=";
  url += latLon ? formatNumber(s.south) + "," + formatNumber(s.west) + "," + formatNumber(s.north) +
                      "," + formatNumber(s.east)
                : formatNumber(s.west) + "," + formatNumber(s.south) + "," + formatNumber(s.east) +
                      "," + formatNumber(s.north);
  url += l.dataset.mimeType == "image/png" ? "&TRANSPARENT=TRUE" : "&TRANSPARENT=FALSE";
  if (!time.empty()) url += "&TIME=" + urlEncode(time);
  return url;
}

} // namespace tellus
