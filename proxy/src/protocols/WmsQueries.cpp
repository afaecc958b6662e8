// GetLegendGraphic and GetFeatureInfo: their parameters (Wms.hpp). GetFeatureInfo's map part is
// read by parseWms as the GetMap it copies, so its errors are GetMap's.
#include <tellus/proxy/Query.hpp>
#include <tellus/proxy/Wms.hpp>

#include <algorithm>
#include <array>
#include <charconv>

namespace tellus {

namespace {

using Failure = std::unexpected<OgcException>;

Failure fail(std::string_view code, std::string_view locator, std::string message) {
  return Failure(OgcException{std::string(code), std::string(locator), std::move(message)});
}

bool iequals(std::string_view a, std::string_view b) noexcept {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           const auto lower = [](char c) {
             return c >= 'A' && c <= 'Z' ? static_cast<char>(c - 'A' + 'a') : c;
           };
           return lower(x) == lower(y);
         });
}

std::optional<std::string_view> nonEmpty(const QueryParams& p, std::string_view key) {
  auto v = p.get(key);
  if (!v || v->empty()) return std::nullopt;
  return v;
}

/** A whole number in [lo, hi], else nullopt. */
std::optional<std::int32_t> wholeNumber(std::string_view text, std::int32_t lo, std::int32_t hi) {
  std::int32_t v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc{} || end != text.data() + text.size() || v < lo || v > hi)
    return std::nullopt;
  return v;
}

std::string shortened(std::string_view value) {
  return "'" + std::string(value.substr(0, 40)) + (value.size() > 40 ? "...'" : "'");
}

template <std::size_t N>
std::optional<OgcException> conflicting(const QueryParams& p,
                                        const std::array<std::string_view, N>& names) {
  for (const std::string_view name : names) {
    std::string lower(name);
    std::transform(lower.begin(), lower.end(), lower.begin(), [](char c) {
      return c >= 'A' && c <= 'Z' ? static_cast<char>(c - 'A' + 'a') : c;
    });
    if (p.isConflicting(lower))
      return OgcException{std::string(ogc::kInvalidParameterValue),
                          std::string(name),
                          std::string(name) + " is given more than once with different values"};
  }
  return std::nullopt;
}

WmsVersion versionOf(const QueryParams& p) {
  const auto v = nonEmpty(p, "version");
  return v && (*v == "1.1.1" || *v == "1.1.0" || *v == "1.0.0") ? WmsVersion::V111
                                                                : WmsVersion::V130;
}

std::optional<InfoFormat> parseInfoFormat(std::string_view text) {
  const auto semicolon = text.find(';');
  const std::string_view type = text.substr(0, semicolon);
  if (iequals(type, "text/plain")) return InfoFormat::Text;
  if (iequals(type, "text/html")) return InfoFormat::Html;
  if (iequals(type, "application/json") || iequals(type, "application/geo+json"))
    return InfoFormat::Json;
  if (iequals(type, "application/vnd.ogc.gml") || iequals(type, "application/gml+xml"))
    return InfoFormat::Gml;
  if (iequals(type, "text/xml")) return InfoFormat::GmlXml;
  return std::nullopt;
}

/** The GetMap that GetFeatureInfo's map part copies: REQUEST=GetMap, FORMAT and STYLES
 * defaulted (image/png; the default styles) when left out, EXCEPTIONS dropped (GetFeatureInfo
 * reports in XML). */
QueryParams mapPart(const QueryParams& p) {
  QueryParams out;
  out.add("request", "GetMap");
  for (const QueryParams::Entry& e : p.entries()) {
    if (e.key == "request" || e.key == "exceptions") continue;
    out.add(e.key, e.value);
  }
  if (!nonEmpty(p, "format")) out.add("format", "image/png");
  if (!p.contains("styles")) out.add("styles", "");
  return out;
}

std::expected<std::pair<std::int32_t, std::int32_t>, OgcException>
readPoint(const QueryParams& p, const GetMapRequest& map) {
  const bool v130 = map.version == WmsVersion::V130;
  // Each version's names first; the other's accepted as clients mix them.
  const std::string_view iKey = v130 ? "i" : "x", jKey = v130 ? "j" : "y";
  const auto iText = nonEmpty(p, iKey) ? nonEmpty(p, iKey) : nonEmpty(p, v130 ? "x" : "i");
  const auto jText = nonEmpty(p, jKey) ? nonEmpty(p, jKey) : nonEmpty(p, v130 ? "y" : "j");
  const std::string iName = v130 ? "I" : "X", jName = v130 ? "J" : "Y";
  if (!iText) return fail(ogc::kMissingParameterValue, iName, iName + " is required");
  if (!jText) return fail(ogc::kMissingParameterValue, jName, jName + " is required");
  constexpr std::int32_t kBig = 1 << 30;
  const auto i = wholeNumber(*iText, -kBig, kBig), j = wholeNumber(*jText, -kBig, kBig);
  if (!i) return fail(ogc::kInvalidParameterValue, iName, iName + " is not a whole number");
  if (!j) return fail(ogc::kInvalidParameterValue, jName, jName + " is not a whole number");
  const std::string_view code = v130 ? ogc::kInvalidPoint : ogc::kInvalidParameterValue;
  if (*i < 0 || *i >= map.width)
    return fail(
        code, iName, iName + " lies outside the map's " + std::to_string(map.width) + " columns");
  if (*j < 0 || *j >= map.height)
    return fail(
        code, jName, jName + " lies outside the map's " + std::to_string(map.height) + " rows");
  return std::pair{*i, *j};
}

} // namespace

std::string_view toString(InfoFormat format) noexcept {
  switch (format) {
  case InfoFormat::Text:
    return "text/plain";
  case InfoFormat::Html:
    return "text/html";
  case InfoFormat::Json:
    return "application/json";
  case InfoFormat::Gml:
    return "application/vnd.ogc.gml";
  case InfoFormat::GmlXml:
    return "text/xml";
  }
  return "text/plain";
}

std::expected<WmsRequest, OgcException> parseGetLegendGraphic(const QueryParams& p) {
  constexpr std::array<std::string_view, 9> kNames{"VERSION",
                                                   "SERVICE",
                                                   "REQUEST",
                                                   "LAYER",
                                                   "STYLE",
                                                   "FORMAT",
                                                   "WIDTH",
                                                   "HEIGHT",
                                                   "SLD_VERSION"};
  if (auto e = conflicting(p, kNames)) return std::unexpected(std::move(*e));
  GetLegendGraphicRequest r;
  r.version = versionOf(p);
  if (const auto service = nonEmpty(p, "service"); service && !iequals(*service, "WMS"))
    return fail(
        ogc::kInvalidParameterValue, "SERVICE", "SERVICE " + shortened(*service) + " is not WMS");
  const auto layer = nonEmpty(p, "layer");
  if (!layer) return fail(ogc::kMissingParameterValue, "LAYER", "LAYER is required");
  r.layer = std::string(*layer);
  r.style = std::string(p.get("style").value_or(""));
  const auto format = nonEmpty(p, "format");
  if (!format) return fail(ogc::kMissingParameterValue, "FORMAT", "FORMAT is required");
  if (!iequals(format->substr(0, format->find(';')), "image/png"))
    return fail(ogc::kInvalidFormat, "FORMAT", "legends are image/png, not " + shortened(*format));
  for (const auto& [key, name, out] :
       {std::tuple{"width", "WIDTH", &r.width}, std::tuple{"height", "HEIGHT", &r.height}}) {
    const auto text = nonEmpty(p, key);
    if (!text) continue;
    const auto v = wholeNumber(*text, 32, 4096);
    if (!v)
      return fail(ogc::kInvalidParameterValue, name, std::string(name) + " must be 32 to 4096");
    *out = *v;
  }
  if (const auto sld = nonEmpty(p, "sld_version"); sld && *sld != "1.1.0")
    return fail(ogc::kInvalidParameterValue, "SLD_VERSION", "SLD_VERSION must be 1.1.0");
  return r;
}

std::expected<WmsRequest, OgcException> parseGetFeatureInfo(const QueryParams& p,
                                                            const WmsLimits& limits) {
  constexpr std::array<std::string_view, 8> kNames{
      "QUERY_LAYERS", "INFO_FORMAT", "I", "J", "X", "Y", "FEATURE_COUNT", "EXCEPTIONS"};
  if (auto e = conflicting(p, kNames)) return std::unexpected(std::move(*e));
  auto parsed = parseWms(mapPart(p), limits);
  if (!parsed) return std::unexpected(std::move(parsed.error()));
  GetFeatureInfoRequest r;
  r.map = std::move(std::get<GetMapRequest>(*parsed));
  const auto query = nonEmpty(p, "query_layers");
  if (!query) return fail(ogc::kMissingParameterValue, "QUERY_LAYERS", "QUERY_LAYERS is required");
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = query->find(',', start);
    r.queryLayers.emplace_back(query->substr(start, comma - start));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  for (const std::string& name : r.queryLayers)
    if (std::find(r.map.layers.begin(), r.map.layers.end(), name) == r.map.layers.end())
      return fail(ogc::kLayerNotDefined,
                  "QUERY_LAYERS",
                  "QUERY_LAYERS names " + shortened(name) + ", which LAYERS does not");
  const auto info = nonEmpty(p, "info_format");
  if (!info && r.map.version == WmsVersion::V130)
    return fail(ogc::kMissingParameterValue, "INFO_FORMAT", "INFO_FORMAT is required");
  if (info) {
    const auto f = parseInfoFormat(*info);
    if (!f)
      return fail(ogc::kInvalidFormat,
                  "INFO_FORMAT",
                  "INFO_FORMAT " + shortened(*info) +
                      " is not served (text/plain, text/html, application/json, "
                      "application/vnd.ogc.gml, text/xml)");
    r.infoFormat = *f;
  }
  auto point = readPoint(p, r.map);
  if (!point) return std::unexpected(std::move(point.error()));
  r.i = point->first;
  r.j = point->second;
  if (const auto count = nonEmpty(p, "feature_count")) {
    const auto v = wholeNumber(*count, 1, 1 << 30);
    if (!v)
      return fail(ogc::kInvalidParameterValue,
                  "FEATURE_COUNT",
                  "FEATURE_COUNT must be a whole number >= 1");
    r.featureCount = *v;
  }
  return r;
}

} // namespace tellus
