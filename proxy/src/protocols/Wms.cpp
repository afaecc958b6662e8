#include <tellus/cache/TilePath.hpp>
#include <tellus/cache/TileSource.hpp>
#include <tellus/proxy/BodyCrs.hpp>
#include <tellus/proxy/Wms.hpp>

#include <array>
#include <charconv>
#include <cmath>
#include <compare>

namespace tellus {

namespace {

using Exceptions = GetMapRequest::Exceptions;

char toLowerAscii(char c) noexcept {
  return (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c;
}

bool iequals(std::string_view a, std::string_view b) noexcept {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (toLowerAscii(a[i]) != toLowerAscii(b[i])) return false;
  }
  return true;
}

bool isDigit(char c) noexcept {
  return c >= '0' && c <= '9';
}

bool allDigits(std::string_view s) noexcept {
  if (s.empty()) return false;
  for (const char c : s) {
    if (!isDigit(c)) return false;
  }
  return true;
}

std::string_view trimSpaces(std::string_view s) noexcept {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t'))
    s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t'))
    s.remove_suffix(1);
  return s;
}

// A client value quoted for a message: at most 64 bytes, cut on a UTF-8 boundary.
std::string quoted(std::string_view value) {
  constexpr std::size_t kMax = 64;
  std::string out = "'";
  if (value.size() <= kMax) {
    out.append(value);
  } else {
    std::size_t cut = kMax;
    while (cut > 0 && (static_cast<unsigned char>(value[cut]) & 0xC0u) == 0x80u)
      --cut;
    out.append(value.substr(0, cut));
    out += "...";
  }
  out += "'";
  return out;
}

std::unexpected<OgcException>
fail(std::string_view code, std::string_view locator, std::string message) {
  return std::unexpected(OgcException{std::string(code), std::string(locator), std::move(message)});
}

// A non-empty value, or std::nullopt when absent or empty.
std::optional<std::string_view> nonEmpty(const QueryParams& params, std::string_view key) {
  const auto v = params.get(key);
  if (!v || v->empty()) return std::nullopt;
  return v;
}

// ---- numbers -------------------------------------------------------------------------------

struct Version {
  std::uint32_t major = 0;
  std::uint32_t minor = 0;
  std::uint32_t patch = 0;
  friend auto operator<=>(const Version&, const Version&) = default;
};

constexpr Version kV111{1, 1, 1};
constexpr Version kV130{1, 3, 0};

// "a", "a.b" or "a.b.c" with 1 to 6 digits per component (missing components are 0).
std::optional<Version> parseVersion(std::string_view s) {
  std::array<std::uint32_t, 3> parts{};
  std::size_t n = 0;
  while (true) {
    const std::size_t dot = s.find('.');
    const std::string_view part = s.substr(0, dot);
    if (n == 3 || part.empty() || part.size() > 6 || !allDigits(part)) return std::nullopt;
    std::uint32_t v = 0;
    std::from_chars(part.data(), part.data() + part.size(), v);
    parts[n++] = v;
    if (dot == std::string_view::npos) break;
    s.remove_prefix(dot + 1);
  }
  return Version{parts[0], parts[1], parts[2]};
}

// A non-negative decimal integer: digits only (no sign, no spaces, no junk), fits in 64 bits.
std::optional<std::int64_t> parseNonNegative(std::string_view s) {
  if (!allDigits(s)) return std::nullopt;
  std::int64_t v = 0;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc{} || ptr != s.data() + s.size()) return std::nullopt;
  return v;
}

// A finite decimal number (surrounding spaces and one leading '+' tolerated); -0 becomes 0.
std::optional<double> parseCoordinate(std::string_view s) {
  s = trimSpaces(s);
  if (s.size() > 1 && s.front() == '+' && (isDigit(s[1]) || s[1] == '.')) s.remove_prefix(1);
  if (s.empty()) return std::nullopt;
  double v = 0.0;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc{} || ptr != s.data() + s.size() || !std::isfinite(v)) return std::nullopt;
  return v == 0.0 ? 0.0 : v;
}

/** A decimal number exactly: (-1)^negative * 0.digits * 10^magnitude, `digits` without leading or
 * trailing zeros (empty for zero, which is never negative). */
struct Decimal {
  bool negative = false;
  std::string digits;
  std::int64_t magnitude = 0;
};

// [+-] digits [. digits] [(e|E) [+-] digits], at least one digit in the mantissa, at most 18
// in the exponent: every lexical form of xsd:decimal and xsd:double that a client may send.
std::optional<Decimal> parseDecimal(std::string_view s) {
  Decimal d;
  std::size_t i = 0;
  if (i < s.size() && (s[i] == '+' || s[i] == '-')) d.negative = s[i++] == '-';
  std::string mantissa;
  std::int64_t pointAt = -1;
  bool anyDigit = false;
  for (; i < s.size() && (isDigit(s[i]) || (s[i] == '.' && pointAt < 0)); ++i) {
    if (s[i] == '.') {
      pointAt = static_cast<std::int64_t>(mantissa.size());
      continue;
    }
    anyDigit = true;
    mantissa.push_back(s[i]);
  }
  if (!anyDigit) return std::nullopt;
  if (pointAt < 0) pointAt = static_cast<std::int64_t>(mantissa.size());
  std::int64_t exponent = 0;
  if (i < s.size() && (s[i] == 'e' || s[i] == 'E')) {
    ++i;
    bool negativeExponent = false;
    if (i < s.size() && (s[i] == '+' || s[i] == '-')) negativeExponent = s[i++] == '-';
    const std::string_view e = s.substr(i);
    if (e.empty() || e.size() > 18 || !allDigits(e)) return std::nullopt;
    std::from_chars(e.data(), e.data() + e.size(), exponent);
    if (negativeExponent) exponent = -exponent;
    i = s.size();
  }
  if (i != s.size()) return std::nullopt;
  std::size_t lead = 0;
  while (lead < mantissa.size() && mantissa[lead] == '0')
    ++lead;
  std::size_t end = mantissa.size();
  while (end > lead && mantissa[end - 1] == '0')
    --end;
  d.digits = mantissa.substr(lead, end - lead);
  if (d.digits.empty()) return Decimal{}; // zero, whatever its sign
  d.magnitude = pointAt - static_cast<std::int64_t>(lead) + exponent;
  return d;
}

std::strong_ordering compareDecimals(const Decimal& a, const Decimal& b) {
  const auto sign = [](const Decimal& d) { return d.digits.empty() ? 0 : d.negative ? -1 : 1; };
  if (sign(a) != sign(b)) return sign(a) <=> sign(b);
  if (sign(a) == 0) return std::strong_ordering::equal;
  std::strong_ordering abs = a.magnitude <=> b.magnitude;
  if (abs == std::strong_ordering::equal) abs = a.digits.compare(b.digits) <=> 0;
  if (a.negative) return 0 <=> abs; // larger magnitudes are smaller below zero
  return abs;
}

// ---- parameters ------------------------------------------------------------------------------

std::vector<std::string> splitCommas(std::string_view s) {
  std::vector<std::string> out;
  while (true) {
    const std::size_t comma = s.find(',');
    out.emplace_back(s.substr(0, comma));
    if (comma == std::string_view::npos) break;
    s.remove_prefix(comma + 1);
  }
  return out;
}

std::optional<Exceptions> parseExceptionsValue(std::string_view v) {
  if (v.empty() || iequals(v, "XML") || iequals(v, "application/vnd.ogc.se_xml") ||
      iequals(v, "text/xml"))
    return Exceptions::Xml;
  if (iequals(v, "INIMAGE") || iequals(v, "application/vnd.ogc.se_inimage"))
    return Exceptions::InImage;
  if (iequals(v, "BLANK") || iequals(v, "application/vnd.ogc.se_blank")) return Exceptions::Blank;
  return std::nullopt;
}

std::optional<bool> parseTransparent(std::string_view v) {
  if (v.empty() || iequals(v, "FALSE")) return false;
  if (iequals(v, "TRUE")) return true;
  return std::nullopt;
}

// "0xRRGGBB" (either case).
std::optional<std::uint32_t> parseBgcolor(std::string_view v) {
  if (v.size() != 8 || v[0] != '0' || (v[1] != 'x' && v[1] != 'X')) return std::nullopt;
  std::uint32_t rgb = 0;
  for (const char c : v.substr(2)) {
    std::uint32_t d = 0;
    if (c >= '0' && c <= '9') {
      d = static_cast<std::uint32_t>(c - '0');
    } else if (c >= 'a' && c <= 'f') {
      d = static_cast<std::uint32_t>(c - 'a' + 10);
    } else if (c >= 'A' && c <= 'F') {
      d = static_cast<std::uint32_t>(c - 'A' + 10);
    } else {
      return std::nullopt;
    }
    rgb = (rgb << 4) | d;
  }
  return rgb;
}

std::optional<std::int32_t> parseSize(std::string_view v, std::int32_t max) {
  const auto n = parseNonNegative(v);
  if (!n || *n < 1 || *n > max) return std::nullopt;
  return static_cast<std::int32_t>(*n);
}

// VERSION, or WMS 1.0's WMTVER when VERSION is absent.
std::optional<std::string_view> versionValue(const QueryParams& params) {
  if (const auto v = nonEmpty(params, "version")) return v;
  return nonEmpty(params, "wmtver");
}

std::optional<OgcException> checkService(const QueryParams& params, bool required) {
  const auto service = nonEmpty(params, "service");
  if (!service) {
    if (!required) return std::nullopt;
    return OgcException{
        std::string(ogc::kMissingParameterValue), "SERVICE", "SERVICE=WMS is required"};
  }
  if (!iequals(*service, "WMS")) {
    return OgcException{std::string(ogc::kInvalidParameterValue),
                        "SERVICE",
                        "SERVICE " + quoted(*service) + " is not WMS"};
  }
  return std::nullopt;
}

// The parameters of each request's table (and the vendor ones tellus reads), upper-case as
// locators: one of them given twice with different values is ambiguous.
constexpr std::array<std::string_view, 18> kGetMapParameters{"VERSION",
                                                             "WMTVER",
                                                             "REQUEST",
                                                             "SERVICE",
                                                             "LAYERS",
                                                             "STYLES",
                                                             "CRS",
                                                             "SRS",
                                                             "BBOX",
                                                             "WIDTH",
                                                             "HEIGHT",
                                                             "FORMAT",
                                                             "TRANSPARENT",
                                                             "BGCOLOR",
                                                             "EXCEPTIONS",
                                                             "TIME",
                                                             "ELEVATION",
                                                             "OPACITIES"};
constexpr std::array<std::string_view, 6> kGetCapabilitiesParameters{
    "VERSION", "WMTVER", "REQUEST", "SERVICE", "FORMAT", "UPDATESEQUENCE"};

std::string lowerCopy(std::string_view s) {
  std::string out(s);
  for (char& c : out)
    c = toLowerAscii(c);
  return out;
}

template <std::size_t N>
std::optional<OgcException> checkConflicts(const QueryParams& params,
                                           const std::array<std::string_view, N>& names) {
  for (const std::string_view name : names) {
    if (params.isConflicting(lowerCopy(name))) {
      return OgcException{std::string(ogc::kInvalidParameterValue),
                          std::string(name),
                          std::string(name) + " is given more than once with different values"};
    }
  }
  return std::nullopt;
}

bool isGetMapName(std::string_view request) {
  return iequals(request, "GetMap") || iequals(request, "map");
}

// ---- requests ------------------------------------------------------------------------------

std::expected<WmsRequest, OgcException> parseGetCapabilities(const QueryParams& params) {
  if (auto e = checkConflicts(params, kGetCapabilitiesParameters))
    return std::unexpected(std::move(*e));
  if (auto e = checkService(params, true)) return std::unexpected(std::move(*e));
  GetCapabilitiesRequest req;
  if (const auto v = versionValue(params)) {
    const auto version = parseVersion(*v);
    if (!version) {
      return fail(ogc::kInvalidParameterValue,
                  "VERSION",
                  "VERSION " + quoted(*v) + " is not a version number");
    }
    req.version = *version >= kV130 ? WmsVersion::V130 : WmsVersion::V111;
  }
  req.updateSequence = std::string(params.get("updatesequence").value_or(""));
  req.format = std::string(params.get("format").value_or(""));
  return req;
}

std::expected<Sector, OgcException>
parseBbox(std::string_view value, bool latFirst, std::string_view crs) {
  const double limit = crs == kWebMercator ? kMaxBboxMagnitudeMetres : kMaxBboxMagnitudeDeg;
  const std::vector<std::string> parts = splitCommas(value);
  if (parts.size() != 4) {
    return fail(ogc::kInvalidParameterValue, "BBOX", "BBOX must have 4 comma-separated numbers");
  }
  std::array<double, 4> v{};
  for (std::size_t i = 0; i < 4; ++i) {
    const auto c = parseCoordinate(parts[i]);
    if (!c) {
      return fail(ogc::kInvalidParameterValue,
                  "BBOX",
                  "BBOX value " + quoted(parts[i]) + " is not a finite number");
    }
    if (std::fabs(*c) > limit) {
      return fail(ogc::kInvalidParameterValue,
                  "BBOX",
                  "BBOX value " + quoted(parts[i]) + " is out of range");
    }
    v[i] = *c;
  }
  if (!(v[0] < v[2]) || !(v[1] < v[3])) {
    return fail(
        ogc::kInvalidParameterValue,
        "BBOX",
        "BBOX minimum must be less than maximum on both axes (axis order for " + std::string(crs) +
            (latFirst ? ": minLat,minLon,maxLat,maxLon)" : ": minLon,minLat,maxLon,maxLat)"));
  }
  if (latFirst) return Sector{v[1], v[0], v[3], v[2]};
  return Sector{v[0], v[1], v[2], v[3]};
}

namespace {

// The steps of parseGetMap, in the order of the exceptions a request meets: each reads its
// parameters into `req` or says what is wrong with them.
using Step = std::expected<void, OgcException>;

Step readVersion(const QueryParams& params, GetMapRequest& req) {
  const auto versionText = versionValue(params);
  if (!versionText) {
    return fail(ogc::kMissingParameterValue, "VERSION", "VERSION is required for GetMap");
  }
  const auto version = parseVersion(*versionText);
  if (version && *version == kV130) {
    req.version = WmsVersion::V130;
  } else if (version && *version == kV111) {
    req.version = WmsVersion::V111;
  } else {
    return fail(ogc::kInvalidParameterValue,
                "VERSION",
                "VERSION " + quoted(*versionText) + " is not supported (1.1.1 or 1.3.0)");
  }
  return {};
}

Step readLayersAndStyles(const QueryParams& params, GetMapRequest& req) {
  const auto layers = nonEmpty(params, "layers");
  if (!layers) return fail(ogc::kMissingParameterValue, "LAYERS", "LAYERS is required");
  req.layers = splitCommas(*layers);
  for (const std::string& name : req.layers) {
    if (name.empty()) {
      return fail(ogc::kLayerNotDefined, "LAYERS", "LAYERS contains an empty layer name");
    }
  }
  const auto styles = params.get("styles");
  if (!styles) { // required by both versions' tables (01-068r3 7.2.3.4, 06-042 7.3.3.4)
    return fail(ogc::kMissingParameterValue,
                "STYLES",
                "STYLES is required (STYLES= selects the default styles)");
  }
  if (styles->empty()) {
    req.styles.assign(req.layers.size(), std::string());
  } else {
    req.styles = splitCommas(*styles);
    if (req.styles.size() != req.layers.size()) {
      return fail(ogc::kInvalidParameterValue,
                  "STYLES",
                  "STYLES has " + std::to_string(req.styles.size()) + " entries for " +
                      std::to_string(req.layers.size()) + " layers");
    }
  }

  return {};
}

/** CRS (1.3.0) / SRS (1.1.1), each accepting the other name, and the BBOX in its axis order. */
Step readCrsAndBbox(const QueryParams& params, GetMapRequest& req) {
  const bool v130 = req.version == WmsVersion::V130;
  std::string_view crsLocator = v130 ? "CRS" : "SRS";
  auto crs = nonEmpty(params, v130 ? "crs" : "srs");
  if (!crs) {
    crs = nonEmpty(params, v130 ? "srs" : "crs");
    if (crs) crsLocator = v130 ? "SRS" : "CRS";
  }
  if (!crs)
    return fail(ogc::kMissingParameterValue, crsLocator, std::string(crsLocator) + " is required");
  bool latFirst = false;
  if (iequals(*crs, "EPSG:4326")) {
    req.crs = "EPSG:4326";
    latFirst = v130;
  } else if (iequals(*crs, "CRS:84")) {
    req.crs = "CRS:84";
  } else if (isWebMercator(*crs)) {
    req.crs = std::string(kWebMercator); // easting, northing under both versions
  } else if (const auto iau = parseIauCrs(*crs); iau && *iau % 100 == 0) {
    // A body's geographic CRS (BodyCrs.hpp): latitude first in 1.3.0, as the IAU 2015
    // definitions order their axes; whether a layer lies on that body is the front end's.
    req.crs = iauCrs130(*iau);
    latFirst = v130;
  } else {
    return fail(invalidCrsCode(req.version),
                crsLocator,
                std::string(crsLocator) + " " + quoted(*crs) +
                    " is not supported (EPSG:4326, CRS:84, EPSG:3857 or a body's IAU:<code>)");
  }

  const auto bbox = nonEmpty(params, "bbox");
  if (!bbox) return fail(ogc::kMissingParameterValue, "BBOX", "BBOX is required");
  auto sector = parseBbox(*bbox, latFirst, req.crs);
  if (!sector) return std::unexpected(std::move(sector.error()));
  req.bbox = *sector;

  return {};
}

Step readSize(const QueryParams& params, const WmsLimits& limits, GetMapRequest& req) {
  const auto width = nonEmpty(params, "width");
  if (!width) return fail(ogc::kMissingParameterValue, "WIDTH", "WIDTH is required");
  const auto w = parseSize(*width, limits.maxWidth);
  if (!w) {
    return fail(ogc::kInvalidParameterValue,
                "WIDTH",
                "WIDTH must be a whole number from 1 to " + std::to_string(limits.maxWidth));
  }
  req.width = *w;
  const auto height = nonEmpty(params, "height");
  if (!height) return fail(ogc::kMissingParameterValue, "HEIGHT", "HEIGHT is required");
  const auto h = parseSize(*height, limits.maxHeight);
  if (!h) {
    return fail(ogc::kInvalidParameterValue,
                "HEIGHT",
                "HEIGHT must be a whole number from 1 to " + std::to_string(limits.maxHeight));
  }
  req.height = *h;

  return {};
}

Step readFormat(const QueryParams& params, GetMapRequest& req) {
  const auto format = nonEmpty(params, "format");
  if (!format) return fail(ogc::kMissingParameterValue, "FORMAT", "FORMAT is required");
  const auto mapFormat = parseMapFormat(*format);
  if (!mapFormat) {
    return fail(ogc::kInvalidFormat,
                "FORMAT",
                "FORMAT " + quoted(*format) +
                    " is not served (image/jpeg, image/png, image/png; mode=8bit, "
                    "application/bil16 or image/tiff)");
  }
  req.mapFormat = *mapFormat;
  req.format = std::string(toString(*mapFormat));

  return {};
}

/** TRANSPARENT, BGCOLOR, EXCEPTIONS and TIME. */
Step readPresentation(const QueryParams& params, GetMapRequest& req) {
  const bool v130 = req.version == WmsVersion::V130;
  const auto transparent = parseTransparent(params.get("transparent").value_or(""));
  if (!transparent) {
    return fail(ogc::kInvalidParameterValue, "TRANSPARENT", "TRANSPARENT must be TRUE or FALSE");
  }
  req.transparent = *transparent;

  if (const auto bg = nonEmpty(params, "bgcolor")) {
    req.bgcolor = parseBgcolor(*bg);
    if (!req.bgcolor) {
      return fail(ogc::kInvalidParameterValue, "BGCOLOR", "BGCOLOR must be 0xRRGGBB");
    }
  }

  const auto exceptions = parseExceptionsValue(params.get("exceptions").value_or(""));
  if (!exceptions) {
    return fail(ogc::kInvalidParameterValue,
                "EXCEPTIONS",
                v130 ? "EXCEPTIONS must be XML, INIMAGE or BLANK"
                     : "EXCEPTIONS must be application/vnd.ogc.se_xml, "
                       "application/vnd.ogc.se_inimage or application/vnd.ogc.se_blank");
  }
  req.exceptions = *exceptions;
  req.time = std::string(params.get("time").value_or(""));
  return {};
}

Step readOpacities(const QueryParams& params, GetMapRequest& req) {
  // OPACITIES (a vendor parameter, as MapServer's and GeoServer's per-layer opacity): one number
  // from 0 to 1 per layer, replacing the layers' configured opacities.
  if (const auto op = nonEmpty(params, "opacities")) {
    for (const std::string& item : splitCommas(*op)) {
      double v = -1.0;
      const auto* end = item.data() + item.size();
      const auto r = std::from_chars(item.data(), end, v);
      if (r.ec != std::errc() || r.ptr != end || !(v >= 0.0 && v <= 1.0)) {
        return fail(ogc::kInvalidParameterValue,
                    "OPACITIES",
                    "OPACITIES must list one number from 0 to 1 per layer");
      }
      req.opacities.push_back(v);
    }
    if (req.opacities.size() != req.layers.size()) {
      return fail(ogc::kInvalidParameterValue,
                  "OPACITIES",
                  "OPACITIES has " + std::to_string(req.opacities.size()) + " entries for " +
                      std::to_string(req.layers.size()) + " layers");
    }
  }
  return {};
}

} // namespace

std::expected<WmsRequest, OgcException> parseGetMap(const QueryParams& params,
                                                    const WmsLimits& limits) {
  GetMapRequest req;
  if (auto e = checkConflicts(params, kGetMapParameters)) return std::unexpected(std::move(*e));
  if (auto v = readVersion(params, req); !v) return std::unexpected(std::move(v.error()));
  // Neither version's GetMap table has SERVICE: it may be left out, but not be another service.
  if (auto e = checkService(params, false)) return std::unexpected(std::move(*e));
  for (const auto& step : {readLayersAndStyles, readCrsAndBbox}) {
    if (auto r = step(params, req); !r) return std::unexpected(std::move(r.error()));
  }
  if (auto r = readSize(params, limits, req); !r) return std::unexpected(std::move(r.error()));
  for (const auto& step : {readFormat, readPresentation, readOpacities}) {
    if (auto r = step(params, req); !r) return std::unexpected(std::move(r.error()));
  }
  return req;
}

bool isLayerChar(char c) noexcept {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || isDigit(c) || c == '_' || c == '.' ||
         c == '-';
}

bool isAlnum(char c) noexcept {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || isDigit(c);
}

} // namespace

std::optional<MapFormat> parseMapFormat(std::string_view format) noexcept {
  // Lower-cased, without spaces or tabs (a MIME type has none that matter): at most 32 bytes.
  char buf[32];
  std::size_t n = 0;
  for (const char c : format) {
    if (c == ' ' || c == '\t') continue;
    if (n == sizeof buf) return std::nullopt;
    buf[n++] = toLowerAscii(c);
  }
  const std::string_view f(buf, n);
  if (f == "image/jpeg") return MapFormat::Jpeg;
  if (f == "image/png") return MapFormat::Png;
  if (f == "image/png;mode=8bit" || f == "image/png8") return MapFormat::Png8;
  if (f == "image/png;mode=24bit") return MapFormat::Png24;
  if (f == "image/png;mode=32bit") return MapFormat::Png32;
  if (f == "application/bil16") return MapFormat::Bil16;
  if (f == "application/bil32") return MapFormat::Bil32;
  if (f == "image/tiff") return MapFormat::Tiff;
  return std::nullopt;
}

std::string_view toString(MapFormat format) noexcept {
  switch (format) {
  case MapFormat::Jpeg:
    return "image/jpeg";
  case MapFormat::Png:
    return "image/png";
  case MapFormat::Png8:
    return "image/png; mode=8bit";
  case MapFormat::Png24:
    return "image/png; mode=24bit";
  case MapFormat::Png32:
    return "image/png; mode=32bit";
  case MapFormat::Bil16:
    return "application/bil16";
  case MapFormat::Tiff:
    return "image/tiff";
  case MapFormat::Bil32:
    return "application/bil32";
  }
  return "image/png";
}

std::string_view contentTypeOf(MapFormat format) noexcept {
  switch (format) {
  case MapFormat::Png:
  case MapFormat::Png8:
  case MapFormat::Png24:
  case MapFormat::Png32:
    return "image/png";
  default:
    return toString(format);
  }
}

bool mapIsHeights(MapFormat format, bool everyLayerIsElevation) noexcept {
  return format == MapFormat::Bil16 ||
         ((format == MapFormat::Png || format == MapFormat::Tiff) && everyLayerIsElevation);
}

std::string_view toString(WmsVersion version) noexcept {
  return version == WmsVersion::V111 ? "1.1.1" : "1.3.0";
}

bool isWebMercator(std::string_view crs) noexcept {
  return iequals(crs, "EPSG:3857") || iequals(crs, "EPSG:900913") || iequals(crs, "EPSG:102100") ||
         iequals(crs, "EPSG:102113");
}

MapBox mapBoxOf(const GetMapRequest& m) noexcept {
  return m.crs == kWebMercator ? mercatorBox(m.bbox) : MapBox(m.bbox);
}

std::string_view invalidCrsCode(WmsVersion version) noexcept {
  return version == WmsVersion::V111 ? ogc::kInvalidSrs : ogc::kInvalidCrs;
}

std::expected<WmsRequest, OgcException> parseWms(const QueryParams& params,
                                                 const WmsLimits& limits) {
  const auto request = nonEmpty(params, "request");
  if (!request) return fail(ogc::kMissingParameterValue, "REQUEST", "REQUEST is required");
  if (iequals(*request, "GetCapabilities") || iequals(*request, "capabilities")) {
    return parseGetCapabilities(params);
  }
  if (isGetMapName(*request)) return parseGetMap(params, limits);
  if (iequals(*request, "GetFeatureInfo") || iequals(*request, "feature_info"))
    return parseGetFeatureInfo(params, limits);
  if (iequals(*request, "GetLegendGraphic")) return parseGetLegendGraphic(params);
  for (const std::string_view known : {"DescribeLayer", "GetStyles", "PutStyles"}) {
    if (iequals(*request, known)) {
      return fail(ogc::kOperationNotSupported,
                  "REQUEST",
                  std::string(known) + " is not supported by this server");
    }
  }
  return fail(ogc::kOperationNotSupported, "REQUEST", "unknown REQUEST " + quoted(*request));
}

WmsErrorContext wmsErrorContext(const QueryParams& params, const WmsLimits& limits) {
  WmsErrorContext ctx;
  if (const auto v = versionValue(params)) {
    const auto version = parseVersion(*v);
    if (version && *version < kV130) ctx.version = WmsVersion::V111;
  }
  const auto request = params.get("request");
  if (!request || !isGetMapName(*request)) return ctx;
  for (const std::string_view name :
       {"exceptions", "format", "width", "height", "transparent", "bgcolor"}) {
    if (params.isConflicting(name)) return ctx;
  }
  const auto exceptions = parseExceptionsValue(params.get("exceptions").value_or(""));
  if (!exceptions || *exceptions == Exceptions::Xml) return ctx;
  const auto formatText = nonEmpty(params, "format");
  if (!formatText) return ctx;
  const auto format = parseMapFormat(*formatText);
  if (!format) return ctx;
  const MapFormat mapFormat = *format;
  const auto width = parseSize(params.get("width").value_or(""), limits.maxWidth);
  const auto height = parseSize(params.get("height").value_or(""), limits.maxHeight);
  const auto transparent = parseTransparent(params.get("transparent").value_or(""));
  std::optional<std::uint32_t> bgcolor;
  if (const auto bg = nonEmpty(params, "bgcolor")) {
    bgcolor = parseBgcolor(*bg);
    if (!bgcolor) return ctx;
  }
  if (!width || !height || !transparent) return ctx;
  ctx.exceptions = *exceptions;
  ctx.mapFormat = mapFormat;
  ctx.format = std::string(toString(mapFormat));
  if (const auto layers = nonEmpty(params, "layers")) ctx.layers = splitCommas(*layers);
  if (const auto styles = nonEmpty(params, "styles")) ctx.styles = splitCommas(*styles);
  ctx.width = *width;
  ctx.height = *height;
  ctx.transparent = *transparent;
  ctx.bgcolor = bgcolor;
  return ctx;
}

std::optional<OgcException> checkUpdateSequence(std::string_view requested,
                                                std::string_view current) {
  if (requested.empty() || current.empty()) return std::nullopt;
  const auto a = parseDecimal(requested);
  const auto b = parseDecimal(current);
  const std::strong_ordering order =
      a && b ? compareDecimals(*a, *b) : requested.compare(current) <=> 0;
  if (order == std::strong_ordering::equal) {
    return OgcException{std::string(ogc::kCurrentUpdateSequence),
                        "UPDATESEQUENCE",
                        "UPDATESEQUENCE equals the current update sequence"};
  }
  if (order == std::strong_ordering::greater) {
    return OgcException{std::string(ogc::kInvalidUpdateSequence),
                        "UPDATESEQUENCE",
                        "UPDATESEQUENCE is greater than the current update sequence"};
  }
  return std::nullopt;
}

std::expected<WorldWindTileRequest, std::string> parseWorldWindTile(const QueryParams& params) {
  WorldWindTileRequest req;
  const auto t = nonEmpty(params, "t");
  if (!t) return std::unexpected("T (the dataset) is required");
  req.dataset = std::string(*t);
  const auto l = params.get("l");
  const auto x = params.get("x");
  const auto y = params.get("y");
  if (!l) return std::unexpected("L (the level) is required");
  if (!x) return std::unexpected("X (the column) is required");
  if (!y) return std::unexpected("Y (the row) is required");
  const auto level = parseNonNegative(*l);
  if (!level || *level > kMaxLevel) {
    return std::unexpected("L must be a whole number from 0 to " + std::to_string(kMaxLevel));
  }
  const auto col = parseNonNegative(*x);
  if (!col) return std::unexpected("X must be a non-negative whole number");
  const auto row = parseNonNegative(*y);
  if (!row) return std::unexpected("Y must be a non-negative whole number");
  req.level = static_cast<std::int32_t>(*level);
  req.col = *col;
  req.row = *row;
  return req;
}

std::optional<StaticTilePath> parseStaticTilePath(std::string_view pathAfterPrefix) {
  const std::size_t slash = pathAfterPrefix.find('/');
  if (slash == std::string_view::npos) return std::nullopt;
  const std::string_view name = pathAfterPrefix.substr(0, slash);
  // Without a whole row's or span's suffix (TileSource.hpp).
  const std::string_view layer = wholeBoxLayer(name).value_or(name);
  if (layer.empty() || layer.size() > kMaxStaticLayerName || layer == "." || layer == "..") {
    return std::nullopt;
  }
  for (const char c : layer) {
    if (!isLayerChar(c)) return std::nullopt;
  }
  StaticTilePath out;
  const auto key = parseTileRelativePath(pathAfterPrefix.substr(slash + 1), &out.extension);
  if (!key || out.extension.empty() || out.extension.size() > 16) return std::nullopt;
  for (const char c : out.extension) {
    if (!isAlnum(c)) return std::nullopt;
  }
  out.layer = std::string(name);
  out.key = *key;
  return out;
}

} // namespace tellus
