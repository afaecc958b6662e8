#include <tellus/proxy/BodyCrs.hpp>
#include <tellus/proxy/Capabilities.hpp>
#include <tellus/proxy/MapBox.hpp>
#include <tellus/proxy/Query.hpp>

#include <algorithm>
#include <array>
#include <charconv>

namespace tellus {

namespace {

constexpr std::string_view kXlinkNs = "http://www.w3.org/1999/xlink";
constexpr std::string_view kSldNs = "http://www.opengis.net/sld";

// Appends lines with two-space indentation.
class XmlWriter {
public:
  explicit XmlWriter(std::string& out) : out_(out) {}

  void line(int depth, std::string_view text) {
    out_.append(static_cast<std::size_t>(depth) * 2, ' ');
    out_.append(text);
    out_.push_back('\n');
  }
  // <tag>escaped text</tag>
  void element(int depth, std::string_view tag, std::string_view text) {
    std::string s = "<";
    s.append(tag);
    s += '>';
    s += xmlEscape(text);
    s += "</";
    s.append(tag);
    s += '>';
    line(depth, s);
  }

private:
  std::string& out_;
};

std::string attr(std::string_view name, std::string_view value) {
  std::string s = " ";
  s.append(name);
  s += "=\"";
  s += xmlEscape(value);
  s += '"';
  return s;
}

std::string attrNum(std::string_view name, double value) {
  return attr(name, formatCoordinate(value));
}

Sector unionOf(const std::vector<CapabilitiesLayer>& layers) {
  if (layers.empty()) return Sector{};
  Sector u = layers.front().bbox;
  for (const CapabilitiesLayer& l : layers) {
    u.west = std::min(u.west, l.bbox.west);
    u.south = std::min(u.south, l.bbox.south);
    u.east = std::max(u.east, l.bbox.east);
    u.north = std::max(u.north, l.bbox.north);
  }
  return u;
}

std::string timeExtent(const CapabilitiesLayer& layer) {
  std::string s;
  for (const std::string& v : layer.timeValues) {
    if (!s.empty()) s += ',';
    s += v;
  }
  if (!layer.timePeriod.empty()) {
    if (!s.empty()) s += ',';
    s += layer.timePeriod;
  }
  return s;
}

bool hasTime(const CapabilitiesLayer& layer) {
  return !layer.timeValues.empty() || !layer.timePeriod.empty();
}

std::string onlineResource(std::string_view href, bool declareXlink) {
  std::string s = "<OnlineResource";
  if (declareXlink) s += attr("xmlns:xlink", kXlinkNs);
  s += attr("xlink:type", "simple");
  s += attr("xlink:href", href);
  s += "/>";
  return s;
}

void writeDcpType(XmlWriter& w, int depth, std::string_view href, bool declareXlink) {
  w.line(depth, "<DCPType>");
  w.line(depth + 1, "<HTTP>");
  w.line(depth + 2, "<Get>");
  w.line(depth + 3, onlineResource(href, declareXlink));
  w.line(depth + 2, "</Get>");
  w.line(depth + 1, "</HTTP>");
  w.line(depth, "</DCPType>");
}

void writeServiceCommon(XmlWriter& w,
                        const CapabilitiesModel& m,
                        std::string_view name,
                        bool declareXlink) {
  w.element(2, "Name", name);
  w.element(2, "Title", m.title);
  if (!m.abstract.empty()) w.element(2, "Abstract", m.abstract);
  if (!m.lastUpdate.empty()) {
    w.line(2, "<KeywordList>");
    w.element(3, "Keyword", "LastUpdate=" + m.lastUpdate);
    w.line(2, "</KeywordList>");
  }
  w.line(2, onlineResource(m.onlineResource, declareXlink));
  w.element(2, "Fees", "none");
  w.element(2, "AccessConstraints", "none");
}

/** One operation of Request: its formats and the one GET URL. */
void writeOperation(XmlWriter& w,
                    std::string_view tag,
                    const std::vector<std::string>& formats,
                    const CapabilitiesModel& m,
                    bool declareXlink) {
  w.line(3, "<" + std::string(tag) + ">");
  for (const std::string& f : formats)
    w.element(4, "Format", f);
  writeDcpType(w, 4, m.onlineResource, declareXlink);
  w.line(3, "</" + std::string(tag) + ">");
}

/** `legendTag`: GetLegendGraphic's element, "GetLegendGraphic" in 1.1.1 (the DTD's, after
 * DescribeLayer's place), "sld:GetLegendGraphic" in 1.3.0 (an _ExtendedOperation of SLD 1.1.0). */
void writeRequest(XmlWriter& w,
                  const CapabilitiesModel& m,
                  std::string_view capsFormat,
                  std::string_view legendTag,
                  bool declareXlink) {
  w.line(2, "<Request>");
  w.line(3, "<GetCapabilities>");
  w.element(4, "Format", capsFormat);
  writeDcpType(w, 4, m.onlineResource, declareXlink);
  w.line(3, "</GetCapabilities>");
  w.line(3, "<GetMap>");
  for (const std::string& f : m.getMapFormats)
    w.element(4, "Format", f);
  writeDcpType(w, 4, m.onlineResource, declareXlink);
  w.line(3, "</GetMap>");
  if (!m.getFeatureInfoFormats.empty())
    writeOperation(w, "GetFeatureInfo", m.getFeatureInfoFormats, m, declareXlink);
  if (!m.getLegendGraphicFormats.empty())
    writeOperation(w, legendTag, m.getLegendGraphicFormats, m, declareXlink);
  w.line(2, "</Request>");
}

void writeExceptionFormats(XmlWriter& w, const std::array<std::string_view, 3>& formats) {
  w.line(2, "<Exception>");
  for (const std::string_view f : formats)
    w.element(3, "Format", f);
  w.line(2, "</Exception>");
}

void writeLayerKeywords(XmlWriter& w, int depth, const CapabilitiesLayer& layer) {
  if (layer.lastUpdateMillis <= 0) return;
  w.line(depth, "<KeywordList>");
  w.element(depth + 1, "Keyword", "LastUpdate=" + std::to_string(layer.lastUpdateMillis));
  w.line(depth, "</KeywordList>");
}

void writeStyles(XmlWriter& w, int depth, const CapabilitiesLayer& layer, bool declareXlink) {
  for (const std::string& s : layer.styles) {
    w.line(depth, "<Style>");
    w.element(depth + 1, "Name", s);
    w.element(depth + 1, "Title", s);
    w.line(depth, "</Style>");
  }
  for (const CapabilitiesStyle& s : layer.legendStyles) {
    w.line(depth, "<Style>");
    w.element(depth + 1, "Name", s.name);
    w.element(depth + 1, "Title", s.title);
    if (!s.legendUrl.empty()) {
      w.line(depth + 1,
             "<LegendURL" + attr("width", std::to_string(s.legendWidth)) +
                 attr("height", std::to_string(s.legendHeight)) + ">");
      w.element(depth + 2, "Format", "image/png");
      w.line(depth + 2, onlineResource(s.legendUrl, declareXlink));
      w.line(depth + 1, "</LegendURL>");
    }
    w.line(depth, "</Style>");
  }
}

std::string layerOpen(const CapabilitiesLayer& layer) {
  return std::string("<Layer") + attr("queryable", layer.queryable ? "1" : "0") +
         attr("opaque", layer.opaque ? "1" : "0") + ">";
}

// ---- 1.1.1 -----------------------------------------------------------------------------------

/** A layer's box in EPSG:3857 metres (x, y), clamped to the Mercator square. */
std::string mercatorBoxAttributes(const Sector& b) {
  using namespace mercator;
  const auto x = [](double lon) { return xOfLongitude(std::clamp(lon, -180.0, 180.0)); };
  // The square's edges exactly (the formula's tangent at 85.05 is 1e-11 off).
  const auto y = [](double lat) {
    return lat >= kMaxLatitude ? kMaxY : lat <= -kMaxLatitude ? -kMaxY : yOfLatitude(lat);
  };
  return attrNum("minx", x(b.west)) + attrNum("miny", y(b.south)) + attrNum("maxx", x(b.east)) +
         attrNum("maxy", y(b.north));
}

void writeBoxes111(XmlWriter& w, int depth, const Sector& b) {
  w.line(depth,
         "<LatLonBoundingBox" + attrNum("minx", b.west) + attrNum("miny", b.south) +
             attrNum("maxx", b.east) + attrNum("maxy", b.north) + "/>");
  w.line(depth,
         "<BoundingBox" + attr("SRS", "EPSG:4326") + attrNum("minx", b.west) +
             attrNum("miny", b.south) + attrNum("maxx", b.east) + attrNum("maxy", b.north) + "/>");
  w.line(depth, "<BoundingBox" + attr("SRS", "EPSG:3857") + mercatorBoxAttributes(b) + "/>");
}

/** A body's layer in 1.1.1: its IAU2000 SRS and boxes (lon/lat: 1.1.1 has no axis order). */
void writeBodyLayer111(XmlWriter& w, int depth, const CapabilitiesLayer& layer) {
  const std::string srs = iauCrs111(layer.iauCode);
  const Sector& b = layer.bbox;
  w.element(depth, "SRS", srs);
  w.line(depth,
         "<LatLonBoundingBox" + attrNum("minx", b.west) + attrNum("miny", b.south) +
             attrNum("maxx", b.east) + attrNum("maxy", b.north) + "/>");
  w.line(depth,
         "<BoundingBox" + attr("SRS", srs) + attrNum("minx", b.west) + attrNum("miny", b.south) +
             attrNum("maxx", b.east) + attrNum("maxy", b.north) + "/>");
}

bool anyOtherBody(const CapabilitiesModel& m) {
  return std::any_of(
      m.layers.begin(), m.layers.end(), [](const CapabilitiesLayer& l) { return l.iauCode != 0; });
}

std::string capabilities111(const CapabilitiesModel& m) {
  std::string out;
  XmlWriter w(out);
  w.line(0, R"(<?xml version="1.0" encoding="UTF-8"?>)");
  w.line(0,
         R"(<!DOCTYPE WMT_MS_Capabilities SYSTEM )"
         R"("http://schemas.opengis.net/wms/1.1.1/WMS_MS_Capabilities.dtd">)");
  std::string root = "<WMT_MS_Capabilities" + attr("version", "1.1.1");
  if (!m.updateSequence.empty()) root += attr("updateSequence", m.updateSequence);
  w.line(0, root + ">");
  w.line(1, "<Service>");
  writeServiceCommon(w, m, "OGC:WMS", true);
  w.line(1, "</Service>");
  w.line(1, "<Capability>");
  writeRequest(w, m, "application/vnd.ogc.wms_xml", "GetLegendGraphic", true);
  writeExceptionFormats(w,
                        {"application/vnd.ogc.se_xml",
                         "application/vnd.ogc.se_inimage",
                         "application/vnd.ogc.se_blank"});
  w.line(2, "<Layer>");
  w.element(3, "Title", m.title);
  const bool perLayer = anyOtherBody(m);
  if (perLayer) {
    const Sector b = unionOf(m.layers);
    w.line(3,
           "<LatLonBoundingBox" + attrNum("minx", b.west) + attrNum("miny", b.south) +
               attrNum("maxx", b.east) + attrNum("maxy", b.north) + "/>");
  } else {
    w.element(3, "SRS", "EPSG:4326");
    w.element(3, "SRS", "EPSG:3857");
    writeBoxes111(w, 3, unionOf(m.layers));
  }
  for (const CapabilitiesLayer& layer : m.layers) {
    w.line(3, layerOpen(layer));
    w.element(4, "Name", layer.name);
    w.element(4, "Title", layer.title);
    if (!layer.abstract.empty()) w.element(4, "Abstract", layer.abstract);
    writeLayerKeywords(w, 4, layer);
    if (layer.iauCode != 0) {
      writeBodyLayer111(w, 4, layer);
    } else {
      if (perLayer) {
        w.element(4, "SRS", "EPSG:4326");
        w.element(4, "SRS", "EPSG:3857");
      }
      writeBoxes111(w, 4, layer.bbox);
    }
    if (hasTime(layer)) {
      w.line(4, "<Dimension" + attr("name", "time") + attr("units", "ISO8601") + "/>");
      std::string extent = "<Extent" + attr("name", "time");
      if (!layer.timeDefault.empty()) extent += attr("default", layer.timeDefault);
      extent += ">" + xmlEscape(timeExtent(layer)) + "</Extent>";
      w.line(4, extent);
    }
    writeStyles(w, 4, layer, true);
    w.line(3, "</Layer>");
  }
  w.line(2, "</Layer>");
  w.line(1, "</Capability>");
  w.line(0, "</WMT_MS_Capabilities>");
  return out;
}

// ---- 1.3.0 -----------------------------------------------------------------------------------

void writeGeographicBox130(XmlWriter& w, int depth, const Sector& b);

void writeBoxes130(XmlWriter& w, int depth, const Sector& b) {
  writeGeographicBox130(w, depth, b);
  w.line(depth,
         "<BoundingBox" + attr("CRS", "CRS:84") + attrNum("minx", b.west) +
             attrNum("miny", b.south) + attrNum("maxx", b.east) + attrNum("maxy", b.north) + "/>");
  // EPSG:4326 in WMS 1.3.0 follows the EPSG axis order: x is latitude, y is longitude.
  w.line(depth,
         "<BoundingBox" + attr("CRS", "EPSG:4326") + attrNum("minx", b.south) +
             attrNum("miny", b.west) + attrNum("maxx", b.north) + attrNum("maxy", b.east) + "/>");
  w.line(depth, "<BoundingBox" + attr("CRS", "EPSG:3857") + mercatorBoxAttributes(b) + "/>");
}

void writeGeographicBox130(XmlWriter& w, int depth, const Sector& b) {
  w.line(depth, "<EX_GeographicBoundingBox>");
  w.element(depth + 1, "westBoundLongitude", formatCoordinate(b.west));
  w.element(depth + 1, "eastBoundLongitude", formatCoordinate(b.east));
  w.element(depth + 1, "southBoundLatitude", formatCoordinate(b.south));
  w.element(depth + 1, "northBoundLatitude", formatCoordinate(b.north));
  w.line(depth, "</EX_GeographicBoundingBox>");
}

/** A body's layer in 1.3.0: its IAU CRS, the box in degrees of the body (as planetary servers
 * write EX_GeographicBoundingBox) and in the CRS's own axis order, latitude first. */
void writeBodyLayer130(XmlWriter& w, int depth, const CapabilitiesLayer& layer) {
  const std::string crs = iauCrs130(layer.iauCode);
  const Sector& b = layer.bbox;
  w.element(depth, "CRS", crs);
  writeGeographicBox130(w, depth, b);
  w.line(depth,
         "<BoundingBox" + attr("CRS", crs) + attrNum("minx", b.south) + attrNum("miny", b.west) +
             attrNum("maxx", b.north) + attrNum("maxy", b.east) + "/>");
}

void writeEarthCrs130(XmlWriter& w, int depth) {
  w.element(depth, "CRS", "EPSG:4326");
  w.element(depth, "CRS", "CRS:84");
  w.element(depth, "CRS", "EPSG:3857");
}

std::string capabilities130(const CapabilitiesModel& m) {
  std::string out;
  XmlWriter w(out);
  w.line(0, R"(<?xml version="1.0" encoding="UTF-8"?>)");
  std::string root = "<WMS_Capabilities" + attr("version", "1.3.0");
  if (!m.updateSequence.empty()) root += attr("updateSequence", m.updateSequence);
  root += attr("xmlns", "http://www.opengis.net/wms");
  root += attr("xmlns:xlink", kXlinkNs);
  // GetLegendGraphic is the SLD profile's operation: its element and schema are SLD 1.1.0's.
  const bool sld = !m.getLegendGraphicFormats.empty();
  if (sld) root += attr("xmlns:sld", kSldNs);
  root += attr("xmlns:xsi", "http://www.w3.org/2001/XMLSchema-instance");
  std::string schemas = "http://www.opengis.net/wms "
                        "http://schemas.opengis.net/wms/1.3.0/capabilities_1_3_0.xsd";
  if (sld)
    schemas +=
        " " + std::string(kSldNs) + " http://schemas.opengis.net/sld/1.1.0/sld_capabilities.xsd";
  root += attr("xsi:schemaLocation", schemas);
  w.line(0, root + ">");
  w.line(1, "<Service>");
  writeServiceCommon(w, m, "WMS", false);
  if (m.maxWidth > 0) w.element(2, "MaxWidth", std::to_string(m.maxWidth));
  if (m.maxHeight > 0) w.element(2, "MaxHeight", std::to_string(m.maxHeight));
  w.line(1, "</Service>");
  w.line(1, "<Capability>");
  writeRequest(w, m, "text/xml", "sld:GetLegendGraphic", false);
  writeExceptionFormats(w, {"XML", "INIMAGE", "BLANK"});
  w.line(2, "<Layer>");
  w.element(3, "Title", m.title);
  const bool perLayer = anyOtherBody(m);
  if (perLayer) {
    writeGeographicBox130(w, 3, unionOf(m.layers));
  } else {
    writeEarthCrs130(w, 3);
    writeBoxes130(w, 3, unionOf(m.layers));
  }
  for (const CapabilitiesLayer& layer : m.layers) {
    w.line(3, layerOpen(layer));
    w.element(4, "Name", layer.name);
    w.element(4, "Title", layer.title);
    if (!layer.abstract.empty()) w.element(4, "Abstract", layer.abstract);
    writeLayerKeywords(w, 4, layer);
    if (layer.iauCode != 0) {
      writeBodyLayer130(w, 4, layer);
    } else {
      if (perLayer) writeEarthCrs130(w, 4);
      writeBoxes130(w, 4, layer.bbox);
    }
    if (hasTime(layer)) {
      std::string dim = "<Dimension" + attr("name", "time") + attr("units", "ISO8601");
      if (!layer.timeDefault.empty()) dim += attr("default", layer.timeDefault);
      dim += ">" + xmlEscape(timeExtent(layer)) + "</Dimension>";
      w.line(4, dim);
    }
    writeStyles(w, 4, layer, false);
    w.line(3, "</Layer>");
  }
  w.line(2, "</Layer>");
  w.line(1, "</Capability>");
  w.line(0, "</WMS_Capabilities>");
  return out;
}

} // namespace

std::string formatCoordinate(double value) {
  if (value == 0.0) return "0"; // also -0
  std::array<char, 32> buf{};
  const auto [ptr, ec] = std::to_chars(buf.data(), buf.data() + buf.size(), value);
  if (ec != std::errc{}) return "0";
  return std::string(buf.data(), ptr);
}

std::string capabilitiesXml(WmsVersion version, const CapabilitiesModel& model) {
  return version == WmsVersion::V111 ? capabilities111(model) : capabilities130(model);
}

std::string_view capabilitiesContentType(WmsVersion version) noexcept {
  return version == WmsVersion::V111 ? "application/vnd.ogc.wms_xml" : "text/xml";
}

} // namespace tellus
