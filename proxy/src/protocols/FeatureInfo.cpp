// GetFeatureInfo's answer in each INFO_FORMAT (FeatureInfo.hpp).
#include <tellus/proxy/Capabilities.hpp>
#include <tellus/proxy/FeatureInfo.hpp>
#include <tellus/proxy/Query.hpp>

#include <array>
#include <charconv>

namespace tellus {

namespace {

std::string valueText(float v) {
  std::array<char, 32> buf{};
  const auto [end, ec] = std::to_chars(buf.data(), buf.data() + buf.size(), v);
  return ec == std::errc{} ? std::string(buf.data(), end) : std::string("0");
}

std::string jsonString(std::string_view s) {
  std::string out = "\"";
  for (const char c : s) {
    const auto u = static_cast<unsigned char>(c);
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (u < 0x20) {
      char esc[8];
      std::snprintf(esc, sizeof esc, "\\u%04x", u);
      out += esc;
    } else {
      out += c;
    }
  }
  return out + "\"";
}

std::string text(const std::vector<FeatureInfoValue>& values) {
  std::string out = "GetFeatureInfo results:\n";
  for (const FeatureInfoValue& v : values) {
    out += "\nLayer '" + v.layer + "'\n";
    out += "  lon = " + formatCoordinate(v.lon) + ", lat = " + formatCoordinate(v.lat) + "\n";
    out += "  value = " +
           (v.value ? valueText(*v.value) + (v.unit.empty() ? "" : " " + v.unit) : "no data") +
           "\n";
  }
  return out;
}

std::string html(const std::vector<FeatureInfoValue>& values) {
  std::string out = "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>GetFeatureInfo"
                    "</title></head><body>\n<table>\n<tr><th>layer</th><th>longitude</th>"
                    "<th>latitude</th><th>value</th><th>unit</th></tr>\n";
  for (const FeatureInfoValue& v : values) {
    out += "<tr><td>" + xmlEscape(v.layer) + "</td><td>" + formatCoordinate(v.lon) + "</td><td>" +
           formatCoordinate(v.lat) + "</td><td>" + (v.value ? valueText(*v.value) : "no data") +
           "</td><td>" + xmlEscape(v.unit) + "</td></tr>\n";
  }
  return out + "</table>\n</body></html>\n";
}

std::string json(const std::vector<FeatureInfoValue>& values) {
  std::string out = "{\"type\":\"FeatureCollection\",\"features\":[";
  for (std::size_t k = 0; k < values.size(); ++k) {
    const FeatureInfoValue& v = values[k];
    out += (k ? "," : "") + std::string("{\"type\":\"Feature\",\"id\":") + jsonString(v.layer) +
           ",\"geometry\":{\"type\":\"Point\",\"coordinates\":[" + formatCoordinate(v.lon) + "," +
           formatCoordinate(v.lat) + "]},\"properties\":{\"layer\":" + jsonString(v.layer) +
           ",\"value\":" + (v.value ? valueText(*v.value) : "null") +
           ",\"unit\":" + jsonString(v.unit) + "}}";
  }
  return out + "]}\n";
}

std::string gml(const std::vector<FeatureInfoValue>& values) {
  std::string out = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<msGMLOutput "
                    "xmlns:gml=\"http://www.opengis.net/gml\" "
                    "xmlns:xlink=\"http://www.w3.org/1999/xlink\" "
                    "xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\">\n";
  for (const FeatureInfoValue& v : values) {
    // Layer names are [A-Za-z0-9_.-]: valid in element names after the first character.
    const std::string name = xmlEscape(v.layer);
    const std::string point = formatCoordinate(v.lon) + "," + formatCoordinate(v.lat);
    out += "  <" + name + "_layer>\n    <gml:name>" + name + "</gml:name>\n";
    out += "    <" + name +
           "_feature>\n      <gml:boundedBy>\n        <gml:Box srsName=\"EPSG:4326\">"
           "\n          <gml:coordinates>" +
           point + " " + point + "</gml:coordinates>\n        </gml:Box>\n      </gml:boundedBy>\n";
    out += "      <x>" + formatCoordinate(v.lon) + "</x>\n      <y>" + formatCoordinate(v.lat) +
           "</y>\n      <value_0>" + (v.value ? valueText(*v.value) : "") + "</value_0>\n";
    out += "      <unit>" + xmlEscape(v.unit) + "</unit>\n";
    out += "    </" + name + "_feature>\n  </" + name + "_layer>\n";
  }
  return out + "</msGMLOutput>\n";
}

} // namespace

std::string featureInfoBody(InfoFormat format, const std::vector<FeatureInfoValue>& values) {
  switch (format) {
  case InfoFormat::Text:
    return text(values);
  case InfoFormat::Html:
    return html(values);
  case InfoFormat::Json:
    return json(values);
  case InfoFormat::Gml:
  case InfoFormat::GmlXml:
    return gml(values);
  }
  return text(values);
}

std::string_view featureInfoContentType(InfoFormat format) noexcept {
  switch (format) {
  case InfoFormat::Text:
    return "text/plain; charset=utf-8";
  case InfoFormat::Html:
    return "text/html; charset=utf-8";
  case InfoFormat::Json:
    return "application/json";
  case InfoFormat::Gml:
    return "application/vnd.ogc.gml";
  case InfoFormat::GmlXml:
    return "text/xml";
  }
  return "text/plain; charset=utf-8";
}

} // namespace tellus
