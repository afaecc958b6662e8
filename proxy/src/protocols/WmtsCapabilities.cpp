// The WMTS 1.0.0 Capabilities document and the OWS 1.1 exception report (Wmts.hpp); valid
// against the vendored wmtsGetCapabilities_response.xsd and owsExceptionReport.xsd
// (tests/data/schemas, TestWmtsCapabilities).
#include <tellus/proxy/OgcExceptionFormat.hpp>
#include <tellus/proxy/Wmts.hpp>

#include <charconv>

namespace tellus {

namespace {

std::string number(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v == 0.0 ? 0.0 : v);
  return std::string(buf, r.ptr);
}

/** A URL path segment: unreserved characters as they are, the rest %XX. */
std::string segment(std::string_view s) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string out;
  for (const char c : s) {
    const auto u = static_cast<unsigned char>(c);
    if ((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-' ||
        c == '.' || c == '_' || c == '~') {
      out += c;
    } else {
      out += '%';
      out += kHex[u >> 4];
      out += kHex[u & 15];
    }
  }
  return out;
}

class Writer {
public:
  explicit Writer(std::string& out) : out_(out) {}
  void line(int depth, std::string_view text) {
    out_.append(static_cast<std::size_t>(depth) * 2, ' ');
    out_.append(text);
    out_ += '\n';
  }
  void element(int depth, std::string_view tag, std::string_view text) {
    line(depth, "<" + std::string(tag) + ">" + xmlEscape(text) + "</" + std::string(tag) + ">");
  }

private:
  std::string& out_;
};

void operation(Writer& w, std::string_view name, const std::string& base) {
  w.line(2, "<ows:Operation name=\"" + std::string(name) + "\">");
  w.line(3, "<ows:DCP>");
  w.line(4, "<ows:HTTP>");
  for (const auto& [href, encoding] :
       {std::pair{base + "/wmts?", "KVP"}, std::pair{base + "/wmts/1.0.0/", "RESTful"}}) {
    w.line(5, "<ows:Get xlink:href=\"" + xmlEscape(href) + "\">");
    w.line(6, "<ows:Constraint name=\"GetEncoding\">");
    w.line(7, "<ows:AllowedValues>");
    w.element(8, "ows:Value", encoding);
    w.line(7, "</ows:AllowedValues>");
    w.line(6, "</ows:Constraint>");
    w.line(5, "</ows:Get>");
  }
  w.line(4, "</ows:HTTP>");
  w.line(3, "</ows:DCP>");
  w.line(2, "</ows:Operation>");
}

void layer(Writer& w, const WmtsLayerInfo& l, const std::string& base) {
  w.line(2, "<Layer>");
  w.element(3, "ows:Title", l.title);
  if (!l.abstract.empty()) w.element(3, "ows:Abstract", l.abstract);
  if (l.bodyCrs.empty()) {
    w.line(3, "<ows:WGS84BoundingBox>");
    w.element(4, "ows:LowerCorner", number(l.bbox.west) + " " + number(l.bbox.south));
    w.element(4, "ows:UpperCorner", number(l.bbox.east) + " " + number(l.bbox.north));
    w.line(3, "</ows:WGS84BoundingBox>");
  }
  w.element(3, "ows:Identifier", l.identifier);
  if (!l.bodyCrs.empty()) {
    // Another body: no WGS 84 box; the box in the body's CRS, latitude first as its axes are.
    w.line(3, "<ows:BoundingBox crs=\"" + xmlEscape(l.bodyCrs) + "\">");
    w.element(4, "ows:LowerCorner", number(l.bbox.south) + " " + number(l.bbox.west));
    w.element(4, "ows:UpperCorner", number(l.bbox.north) + " " + number(l.bbox.east));
    w.line(3, "</ows:BoundingBox>");
  }
  w.line(3, "<Style isDefault=\"true\">");
  w.element(4, "ows:Identifier", "default");
  w.line(3, "</Style>");
  w.element(3, "Format", l.format);
  const bool timed = !l.timeValues.empty() || !l.timePeriod.empty();
  if (timed) {
    w.line(3, "<Dimension>");
    w.element(4, "ows:Identifier", "Time");
    w.element(4, "ows:UOM", "ISO8601");
    if (!l.timeDefault.empty()) w.element(4, "Default", l.timeDefault);
    w.element(4, "Current", "false");
    for (const std::string& v : l.timeValues)
      w.element(4, "Value", v);
    if (!l.timePeriod.empty()) w.element(4, "Value", l.timePeriod);
    w.line(3, "</Dimension>");
  }
  for (const WmtsTileMatrixSet* s : l.sets) {
    w.line(3, "<TileMatrixSetLink>");
    w.element(4, "TileMatrixSet", s->identifier);
    w.line(4, "<TileMatrixSetLimits>");
    for (const WmtsTileMatrix& m : s->matrices) {
      w.line(5, "<TileMatrixLimits>");
      w.element(6, "TileMatrix", m.identifier);
      w.element(6, "MinTileRow", std::to_string(m.minRow));
      w.element(6, "MaxTileRow", std::to_string(m.maxRow));
      w.element(6, "MinTileCol", std::to_string(m.minCol));
      w.element(6, "MaxTileCol", std::to_string(m.maxCol));
      w.line(5, "</TileMatrixLimits>");
    }
    w.line(4, "</TileMatrixSetLimits>");
    w.line(3, "</TileMatrixSetLink>");
  }
  const std::string url = base + "/wmts/1.0.0/" + segment(l.identifier) + "/{Style}/" +
                          (timed ? "{Time}/" : "") +
                          "{TileMatrixSet}/{TileMatrix}/{TileRow}/{TileCol}." + l.extension;
  w.line(3,
         "<ResourceURL format=\"" + xmlEscape(l.format) + "\" resourceType=\"tile\" template=\"" +
             xmlEscape(url) + "\"/>");
  w.line(2, "</Layer>");
}

void matrixSet(Writer& w, const WmtsTileMatrixSet& s) {
  w.line(2, "<TileMatrixSet>");
  w.element(3, "ows:Identifier", s.identifier);
  w.element(3, "ows:SupportedCRS", s.crs);
  if (!s.wellKnownScaleSet.empty()) w.element(3, "WellKnownScaleSet", s.wellKnownScaleSet);
  for (const WmtsTileMatrix& m : s.matrices) {
    w.line(3, "<TileMatrix>");
    w.element(4, "ows:Identifier", m.identifier);
    w.element(4, "ScaleDenominator", number(m.scaleDenominator));
    w.element(4,
              "TopLeftCorner",
              s.latFirst ? number(m.top) + " " + number(m.left)
                         : number(m.left) + " " + number(m.top));
    w.element(4, "TileWidth", std::to_string(m.tileWidth));
    w.element(4, "TileHeight", std::to_string(m.tileHeight));
    w.element(4, "MatrixWidth", std::to_string(m.matrixWidth));
    w.element(4, "MatrixHeight", std::to_string(m.matrixHeight));
    w.line(3, "</TileMatrix>");
  }
  w.line(2, "</TileMatrixSet>");
}

} // namespace

std::string wmtsCapabilitiesXml(const WmtsCapabilitiesModel& model) {
  std::string out;
  out.reserve(16384);
  Writer w(out);
  w.line(0, R"(<?xml version="1.0" encoding="UTF-8"?>)");
  w.line(
      0,
      R"(<Capabilities xmlns="http://www.opengis.net/wmts/1.0" )"
      R"(xmlns:ows="http://www.opengis.net/ows/1.1" xmlns:xlink="http://www.w3.org/1999/xlink" )"
      R"(xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" )"
      R"(xsi:schemaLocation="http://www.opengis.net/wmts/1.0 )"
      R"(http://schemas.opengis.net/wmts/1.0/wmtsGetCapabilities_response.xsd" version="1.0.0">)");
  w.line(1, "<ows:ServiceIdentification>");
  w.element(2, "ows:Title", model.title);
  if (!model.abstract.empty()) w.element(2, "ows:Abstract", model.abstract);
  w.element(2, "ows:ServiceType", "OGC WMTS");
  w.element(2, "ows:ServiceTypeVersion", "1.0.0");
  w.line(1, "</ows:ServiceIdentification>");
  w.line(1, "<ows:OperationsMetadata>");
  operation(w, "GetCapabilities", model.baseUrl);
  operation(w, "GetTile", model.baseUrl);
  w.line(1, "</ows:OperationsMetadata>");
  w.line(1, "<Contents>");
  for (const WmtsLayerInfo& l : model.layers)
    layer(w, l, model.baseUrl);
  for (const WmtsTileMatrixSet* s : model.sets)
    matrixSet(w, *s);
  w.line(1, "</Contents>");
  w.line(1,
         "<ServiceMetadataURL xlink:href=\"" +
             xmlEscape(model.baseUrl + "/wmts/1.0.0/WMTSCapabilities.xml") + "\"/>");
  w.line(0, "</Capabilities>");
  return out;
}

std::string wmtsExceptionXml(const OgcException& e) {
  std::string message = sanitizeForClient(e.message);
  if (message.size() > kMaxClientMessageBytes) message.resize(kMaxClientMessageBytes);
  std::string out = R"(<?xml version="1.0" encoding="UTF-8"?>)"
                    "\n"
                    R"(<ExceptionReport xmlns="http://www.opengis.net/ows/1.1" )"
                    R"(xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" )"
                    R"(xsi:schemaLocation="http://www.opengis.net/ows/1.1 )"
                    R"(http://schemas.opengis.net/ows/1.1.0/owsExceptionReport.xsd" )"
                    R"(version="1.0.0" xml:lang="en">)"
                    "\n  <Exception exceptionCode=\"" +
                    xmlEscape(e.code) + "\"";
  if (!e.locator.empty()) out += " locator=\"" + xmlEscape(sanitizeForClient(e.locator)) + "\"";
  out += ">\n    <ExceptionText>" + xmlEscape(message) +
         "</ExceptionText>\n  </Exception>\n</ExceptionReport>\n";
  return out;
}

} // namespace tellus
