#include <tellus/proxy/Wms.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <string>

using namespace tellus;

namespace {

using Exceptions = GetMapRequest::Exceptions;

std::expected<WmsRequest, OgcException> wms(std::string_view query, WmsLimits limits = {}) {
  const auto q = parseQuery(query);
  EXPECT_TRUE(q.has_value()) << query;
  if (!q) return std::unexpected(OgcException{"query", "", q.error()});
  return parseWms(*q, limits);
}

GetMapRequest getMap(std::string_view query, WmsLimits limits = {}) {
  const auto r = wms(query, limits);
  EXPECT_TRUE(r.has_value()) << query << " -> "
                             << (r ? "" : r.error().code + " " + r.error().message);
  if (!r || !std::holds_alternative<GetMapRequest>(*r)) {
    ADD_FAILURE() << "not a GetMap: " << query;
    return {};
  }
  return std::get<GetMapRequest>(*r);
}

GetCapabilitiesRequest getCaps(std::string_view query) {
  const auto r = wms(query);
  EXPECT_TRUE(r.has_value()) << query << " -> " << (r ? "" : r.error().message);
  if (!r || !std::holds_alternative<GetCapabilitiesRequest>(*r)) {
    ADD_FAILURE() << "not a GetCapabilities: " << query;
    return {};
  }
  return std::get<GetCapabilitiesRequest>(*r);
}

OgcException error(std::string_view query, WmsLimits limits = {}) {
  const auto r = wms(query, limits);
  EXPECT_FALSE(r.has_value()) << query;
  return r ? OgcException{} : r.error();
}

void expectError(std::string_view query,
                 std::string_view code,
                 std::string_view locator,
                 WmsLimits limits = {}) {
  const OgcException e = error(query, limits);
  EXPECT_EQ(e.code, code) << query << " -> " << e.message;
  EXPECT_EQ(e.locator, locator) << query << " -> " << e.message;
  EXPECT_FALSE(e.message.empty()) << query;
}

// A valid GetMap with one parameter replaced (or added when absent); "" removes it.
std::string with(std::string base, std::string_view key, std::string_view value) {
  const std::string k = std::string(key) + "=";
  std::size_t pos = base.find(k);
  while (pos != std::string::npos && pos != 0 && base[pos - 1] != '&')
    pos = base.find(k, pos + 1);
  if (pos != std::string::npos) {
    const std::size_t end = base.find('&', pos);
    base.erase(pos, end == std::string::npos ? std::string::npos : end - pos + 1);
    if (!base.empty() && base.back() == '&') base.pop_back();
  }
  if (value == "<absent>") return base;
  return base + "&" + std::string(key) + "=" + std::string(value);
}

const std::string k130 = "SERVICE=WMS&VERSION=1.3.0&REQUEST=GetMap&LAYERS=bmng&STYLES=&"
                         "CRS=CRS:84&BBOX=-180,-90,-144,-54&WIDTH=512&HEIGHT=512&FORMAT=image/jpeg";
const std::string k111 = "SERVICE=WMS&VERSION=1.1.1&REQUEST=GetMap&LAYERS=bmng&STYLES=&"
                         "SRS=EPSG:4326&BBOX=-180,-90,-144,-54&WIDTH=512&HEIGHT=512&"
                         "FORMAT=image/jpeg";

const Sector kFirstTile{-180.0, -90.0, -144.0, -54.0};

} // namespace

// ---- GetCapabilities ------------------------------------------------------------------------

TEST(Wms, CapabilitiesVersionNegotiation) {
  const std::string base = "SERVICE=WMS&REQUEST=GetCapabilities";
  EXPECT_EQ(getCaps(base).version, WmsVersion::V130);
  EXPECT_EQ(getCaps(base + "&VERSION=1.3.0").version, WmsVersion::V130);
  EXPECT_EQ(getCaps(base + "&VERSION=1.1.1").version, WmsVersion::V111);
  EXPECT_EQ(getCaps(base + "&VERSION=1.2.0").version, WmsVersion::V111);
  EXPECT_EQ(getCaps(base + "&VERSION=1.1.0").version, WmsVersion::V111);
  EXPECT_EQ(getCaps(base + "&VERSION=100.0.0").version, WmsVersion::V130);
  EXPECT_EQ(getCaps(base + "&VERSION=1.3.1").version, WmsVersion::V130);
  EXPECT_EQ(getCaps(base + "&VERSION=0.0.0").version, WmsVersion::V111);
  EXPECT_EQ(getCaps(base + "&WMTVER=1.0.0").version, WmsVersion::V111);
  EXPECT_EQ(getCaps(base + "&VERSION=1.3.0&WMTVER=1.0.0").version, WmsVersion::V130);
  EXPECT_EQ(getCaps(base + "&VERSION=").version, WmsVersion::V130);
  expectError(base + "&VERSION=abc", ogc::kInvalidParameterValue, "VERSION");
  expectError(base + "&VERSION=1..3", ogc::kInvalidParameterValue, "VERSION");
  expectError(base + "&VERSION=1.3.0.0", ogc::kInvalidParameterValue, "VERSION");
}

TEST(Wms, CapabilitiesNeedsServiceWms) {
  expectError("REQUEST=GetCapabilities", ogc::kMissingParameterValue, "SERVICE");
  expectError("REQUEST=GetCapabilities&SERVICE=WFS", ogc::kInvalidParameterValue, "SERVICE");
  EXPECT_EQ(getCaps("service=wms&request=getcapabilities").version, WmsVersion::V130);
  EXPECT_EQ(getCaps("SERVICE=WMS&REQUEST=capabilities&WMTVER=1.0.8").version, WmsVersion::V111);
}

TEST(Wms, CapabilitiesCarriesUpdateSequenceAndFormat) {
  const auto caps =
      getCaps("SERVICE=WMS&REQUEST=GetCapabilities&UPDATESEQUENCE=41&FORMAT=text/xml");
  EXPECT_EQ(caps.updateSequence, "41");
  EXPECT_EQ(caps.format, "text/xml");
  const auto plain = getCaps("SERVICE=WMS&REQUEST=GetCapabilities");
  EXPECT_EQ(plain.updateSequence, "");
  EXPECT_EQ(plain.format, "");
}

TEST(Wms, UpdateSequenceRules) {
  EXPECT_FALSE(checkUpdateSequence("", "42").has_value());
  EXPECT_FALSE(checkUpdateSequence("41", "").has_value());
  EXPECT_FALSE(checkUpdateSequence("41", "42").has_value());
  EXPECT_FALSE(checkUpdateSequence("9", "10").has_value()); // numeric, not string order
  const auto current = checkUpdateSequence("42", "42");
  ASSERT_TRUE(current.has_value());
  EXPECT_EQ(current->code, ogc::kCurrentUpdateSequence);
  EXPECT_EQ(current->locator, "UPDATESEQUENCE");
  EXPECT_EQ(checkUpdateSequence("042", "42")->code, ogc::kCurrentUpdateSequence);
  EXPECT_EQ(checkUpdateSequence("43", "42")->code, ogc::kInvalidUpdateSequence);
  EXPECT_EQ(checkUpdateSequence("100", "99")->code, ogc::kInvalidUpdateSequence);
  EXPECT_EQ(checkUpdateSequence("2026-11-24T00:00:00Z", "2026-11-23T00:00:00Z")->code,
            ogc::kInvalidUpdateSequence);
  EXPECT_FALSE(checkUpdateSequence("2026-11-22T00:00:00Z", "2026-11-23T00:00:00Z").has_value());
}

// Numbers compare as numbers in any lexical form a client may send (exactly, not through a
// double), anything else as strings.
TEST(Wms, UpdateSequenceComparesNumbersInAnySpelling) {
  const auto code = [](std::string_view requested, std::string_view current) {
    const auto e = checkUpdateSequence(requested, current);
    return e ? e->code : std::string("send");
  };
  const std::string equal(ogc::kCurrentUpdateSequence);
  const std::string greater(ogc::kInvalidUpdateSequence);
  for (const char* same : {"1796151274",
                           "1.796151274E9",
                           "1.796151274e+9",
                           "01796151274",
                           "+1796151274",
                           "1796151274.0",
                           "1796151274.",
                           "17961512740e-1",
                           "0.1796151274e10",
                           "1796151274.000000000000000000000000001e0"}) {
    if (std::string_view(same) == "1796151274.000000000000000000000000001e0") {
      EXPECT_EQ(code(same, "1796151274"), greater) << "no rounding through a double";
      continue;
    }
    EXPECT_EQ(code(same, "1796151274"), equal) << same;
    EXPECT_EQ(code("1796151274", same), equal) << same;
  }
  EXPECT_EQ(code("1.796151275E9", "1796151274"), greater);
  EXPECT_EQ(code("1.796151273E9", "1796151274"), "send");
  EXPECT_EQ(code("-5", "3"), "send");
  EXPECT_EQ(code("3", "-5"), greater);
  EXPECT_EQ(code("-0", "0.0"), equal);
  EXPECT_EQ(code("-1e-3", "-0.001"), equal);
  EXPECT_EQ(code("-2", "-10"), greater);
  EXPECT_EQ(code("1e400", "9e399"), greater); // beyond a double: still exact
  EXPECT_EQ(code(".5", "0.5"), equal);
  EXPECT_EQ(code("1e999999999999", "1"), greater);
  // Not numbers (or only one of them is): string order.
  for (const char* notANumber : {"1796151274x", "1.2.3", "e5", "+", ".", "1e", "0x10", " 1", "1 "})
    EXPECT_EQ(code(notANumber, notANumber), equal) << notANumber;
  EXPECT_EQ(code("b", "a"), greater);
  EXPECT_EQ(code("10", "9a"), "send"); // "10" < "9a" as strings
}

// ---- REQUEST -------------------------------------------------------------------------------

TEST(Wms, RequestMissingOrUnsupported) {
  expectError("SERVICE=WMS&VERSION=1.3.0", ogc::kMissingParameterValue, "REQUEST");
  expectError("SERVICE=WMS&REQUEST=", ogc::kMissingParameterValue, "REQUEST");
  // Served since issue 24 (value layers): their own parameters are checked.
  expectError(
      "SERVICE=WMS&VERSION=1.3.0&REQUEST=GetFeatureInfo", ogc::kMissingParameterValue, "LAYERS");
  expectError("SERVICE=WMS&VERSION=1.1.1&REQUEST=GetLegendGraphic&LAYER=bmng",
              ogc::kMissingParameterValue,
              "FORMAT");
  expectError("SERVICE=WMS&REQUEST=GetStyles", ogc::kOperationNotSupported, "REQUEST");
  expectError("SERVICE=WMS&REQUEST=DescribeLayer", ogc::kOperationNotSupported, "REQUEST");
  expectError("SERVICE=WMS&REQUEST=Frobnicate", ogc::kOperationNotSupported, "REQUEST");
}

// ---- GetMap: axis order ---------------------------------------------------------------------

TEST(Wms, AllAxisOrderFormsGiveTheSameSector) {
  const GetMapRequest epsg130 =
      getMap(with(with(k130, "CRS", "EPSG:4326"), "BBOX", "-90,-180,-54,-144"));
  const GetMapRequest crs84 = getMap(with(k130, "BBOX", "-180,-90,-144,-54"));
  const GetMapRequest epsg111 = getMap(k111);
  EXPECT_EQ(epsg130.bbox, kFirstTile);
  EXPECT_EQ(crs84.bbox, kFirstTile);
  EXPECT_EQ(epsg111.bbox, kFirstTile);
  EXPECT_EQ(epsg130.crs, "EPSG:4326");
  EXPECT_EQ(crs84.crs, "CRS:84");
  EXPECT_EQ(epsg111.crs, "EPSG:4326");
  // A lat/lon box read as lon/lat would be a different (and here inverted) box.
  EXPECT_NE(getMap(with(k130, "BBOX", "-90,-180,-54,-144")).bbox, kFirstTile);
}

TEST(Wms, AxisOrderWithNonSquareBoxes) {
  // 1.3.0 EPSG:4326: minLat,minLon,maxLat,maxLon.
  const Sector europe{-10.5, 35.25, 30.125, 71.1};
  EXPECT_EQ(getMap(with(with(k130, "CRS", "EPSG:4326"), "BBOX", "35.25,-10.5,71.1,30.125")).bbox,
            europe);
  EXPECT_EQ(getMap(with(k130, "BBOX", "-10.5,35.25,30.125,71.1")).bbox, europe);
  EXPECT_EQ(getMap(with(k111, "BBOX", "-10.5,35.25,30.125,71.1")).bbox, europe);
  // 1.1.1 with CRS:84 (not a 1.1.1 name, accepted leniently) is lon/lat too.
  EXPECT_EQ(getMap(with(with(k111, "SRS", "CRS:84"), "BBOX", "-10.5,35.25,30.125,71.1")).bbox,
            europe);
}

TEST(Wms, WorldWindJavaRequest) {
  // WorldWindJava's WMSTiledImageLayer: lower-case names, 1.3.0, CRS:84, lon/lat.
  const GetMapRequest r = getMap(
      "service=WMS&request=GetMap&version=1.3.0&crs=CRS:84&layers=bmng&styles=&"
      "format=image/png&transparent=TRUE&width=512&height=512&bbox=-180.0,-90.0,-144.0,-54.0");
  EXPECT_EQ(r.version, WmsVersion::V130);
  EXPECT_EQ(r.layers, std::vector<std::string>{"bmng"});
  EXPECT_EQ(r.styles, std::vector<std::string>{""});
  EXPECT_EQ(r.crs, "CRS:84");
  EXPECT_EQ(r.bbox, kFirstTile);
  EXPECT_EQ(r.width, 512);
  EXPECT_EQ(r.height, 512);
  EXPECT_EQ(r.format, "image/png");
  EXPECT_TRUE(r.transparent);
  EXPECT_FALSE(r.bgcolor.has_value());
  EXPECT_EQ(r.exceptions, Exceptions::Xml);
  EXPECT_EQ(r.time, "");
}

TEST(Wms, WebWorldWindRequest) {
  // WebWorldWind's WmsUrlBuilder: 1.3.0, EPSG:4326, lat/lon, optional time.
  const GetMapRequest r = getMap(
      "service=WMS&request=GetMap&version=1.3.0&transparent=TRUE&layers=bmng&styles=&"
      "format=image/png&width=256&height=256&time=2004-08&crs=EPSG:4326&bbox=-90,-180,-54,-144");
  EXPECT_EQ(r.bbox, kFirstTile);
  EXPECT_EQ(r.time, "2004-08");
  EXPECT_EQ(r.format, "image/png");
}

// ---- GetMap: SERVICE, VERSION, CRS -----------------------------------------------------------

// Neither GetMap table (06-042 Table 8, 01-068r3 7.2.2) lists SERVICE.
TEST(Wms, ServiceIsNoGetMapParameter) {
  EXPECT_EQ(getMap(with(k111, "SERVICE", "<absent>")).version, WmsVersion::V111);
  EXPECT_EQ(getMap(with(k130, "SERVICE", "<absent>")).version, WmsVersion::V130);
  EXPECT_EQ(getMap(with(k130, "SERVICE", "")).version, WmsVersion::V130);
  expectError(with(k111, "SERVICE", "WCS"), ogc::kInvalidParameterValue, "SERVICE");
  expectError(with(k130, "SERVICE", "WFS"), ogc::kInvalidParameterValue, "SERVICE");
  EXPECT_EQ(getMap(with(k130, "SERVICE", "wms")).version, WmsVersion::V130);
}

TEST(Wms, GetMapNeedsASupportedVersion) {
  expectError(with(k130, "VERSION", "<absent>"), ogc::kMissingParameterValue, "VERSION");
  expectError(with(k130, "VERSION", "1.2.0"), ogc::kInvalidParameterValue, "VERSION");
  expectError(with(k111, "VERSION", "1.0.0"), ogc::kInvalidParameterValue, "VERSION");
  expectError(with(k130, "VERSION", "2.0.0"), ogc::kInvalidParameterValue, "VERSION");
  expectError(with(k130, "VERSION", "x"), ogc::kInvalidParameterValue, "VERSION");
  EXPECT_EQ(getMap(with(with(k111, "VERSION", "<absent>"), "WMTVER", "1.1.1")).version,
            WmsVersion::V111);
  EXPECT_EQ(getMap(with(k130, "REQUEST", "map")).version, WmsVersion::V130);
  EXPECT_EQ(getMap(with(k130, "REQUEST", "getmap")).version, WmsVersion::V130);
}

TEST(Wms, CrsAndSrsNamesPerVersion) {
  // 1.3.0 reads CRS, accepts SRS as fallback; 1.1.1 the other way round.
  const std::string noCrs130 = with(k130, "CRS", "<absent>");
  const std::string noSrs111 = with(k111, "SRS", "<absent>");
  EXPECT_EQ(getMap(noCrs130 + "&SRS=CRS:84").crs, "CRS:84");
  EXPECT_EQ(getMap(noSrs111 + "&CRS=EPSG:4326").bbox, kFirstTile);
  expectError(noCrs130, ogc::kMissingParameterValue, "CRS");
  expectError(noSrs111, ogc::kMissingParameterValue, "SRS");
  expectError(with(k130, "CRS", "EPSG:32633"), ogc::kInvalidCrs, "CRS");
  expectError(with(k111, "SRS", "EPSG:32633"), ogc::kInvalidSrs, "SRS");
  expectError(noCrs130 + "&SRS=EPSG:2056", ogc::kInvalidCrs, "SRS");
  expectError(with(k130, "CRS", "EPSG:43260"), ogc::kInvalidCrs, "CRS");
  // Values are compared case-insensitively and normalised.
  EXPECT_EQ(getMap(with(k130, "CRS", "crs:84")).crs, "CRS:84");
  EXPECT_EQ(getMap(with(k111, "SRS", "epsg:4326")).crs, "EPSG:4326");
  // The primary name wins when both are given.
  EXPECT_EQ(getMap(k130 + "&SRS=EPSG:3857").crs, "CRS:84");
}

// ---- GetMap: BBOX, size, format ----------------------------------------------------------------

TEST(Wms, BboxMustBeOrdered) {
  expectError(with(k130, "BBOX", "-144,-90,-180,-54"), ogc::kInvalidParameterValue, "BBOX");
  expectError(with(k130, "BBOX", "-180,-54,-144,-90"), ogc::kInvalidParameterValue, "BBOX");
  expectError(with(k130, "BBOX", "-180,-90,-180,-54"), ogc::kInvalidParameterValue, "BBOX");
  expectError(with(k130, "BBOX", "0,0,0,0"), ogc::kInvalidParameterValue, "BBOX");
  // 1.3.0 EPSG:4326: the order is checked on the axes as given (lat first).
  expectError(with(with(k130, "CRS", "EPSG:4326"), "BBOX", "-54,-180,-90,-144"),
              ogc::kInvalidParameterValue,
              "BBOX");
  expectError(with(k130, "BBOX", "<absent>"), ogc::kMissingParameterValue, "BBOX");
  expectError(with(k130, "BBOX", ""), ogc::kMissingParameterValue, "BBOX");
}

TEST(Wms, SizeWithinLimits) {
  const WmsLimits limits{1024, 768};
  const GetMapRequest odd = getMap(with(with(k130, "WIDTH", "8"), "HEIGHT", "5"), limits);
  EXPECT_EQ(odd.width, 8);
  EXPECT_EQ(odd.height, 5);
  const GetMapRequest max = getMap(with(with(k130, "WIDTH", "1024"), "HEIGHT", "768"), limits);
  EXPECT_EQ(max.width, 1024);
  EXPECT_EQ(max.height, 768);
  expectError(with(k130, "WIDTH", "1025"), ogc::kInvalidParameterValue, "WIDTH", limits);
  expectError(with(k130, "HEIGHT", "769"), ogc::kInvalidParameterValue, "HEIGHT", limits);
  expectError(with(k130, "WIDTH", "<absent>"), ogc::kMissingParameterValue, "WIDTH");
  expectError(with(k130, "HEIGHT", "<absent>"), ogc::kMissingParameterValue, "HEIGHT");
  EXPECT_EQ(getMap(with(k130, "WIDTH", "0512")).width, 512);
}

TEST(Wms, FormatIsRequiredAndAMimeTypeOfAnyCase) {
  expectError(with(k130, "FORMAT", "<absent>"), ogc::kMissingParameterValue, "FORMAT");
  expectError(with(k130, "FORMAT", ""), ogc::kMissingParameterValue, "FORMAT");
  EXPECT_EQ(getMap(with(k130, "FORMAT", "image/png;+mode%3D8bit")).format, "image/png; mode=8bit");
  EXPECT_EQ(getMap(with(k130, "FORMAT", "image/png;mode=8bit")).mapFormat, MapFormat::Png8);
  EXPECT_EQ(getMap(with(k130, "FORMAT", "image/png8")).format, "image/png; mode=8bit");
  EXPECT_EQ(getMap(with(k130, "FORMAT", "IMAGE/JPEG")).format, "image/jpeg");
  EXPECT_EQ(getMap(with(k130, "FORMAT", "Application/BIL16")).mapFormat, MapFormat::Bil16);
  EXPECT_EQ(getMap(with(k130, "FORMAT", "image/tiff")).mapFormat, MapFormat::Tiff);
  EXPECT_EQ(getMap(with(k130, "FORMAT", "image/png;%20mode=32BIT")).mapFormat, MapFormat::Png32);
  for (const char* bad : {"image/foo",
                          "image/dds",
                          "image/png; mode=16bit",
                          "png",
                          "image/gif",
                          "image/jpeg;",
                          "image/png;mode",
                          "image%2Fpng%00"}) {
    if (std::string_view(bad).find("%00") != std::string_view::npos) continue; // parseQuery's
    expectError(with(k130, "FORMAT", bad), ogc::kInvalidFormat, "FORMAT");
  }
}

// ---- GetMap: LAYERS, STYLES
// ----------------------------------------------------------------------

TEST(Wms, LayersAndStyles) {
  const GetMapRequest two = getMap(with(k130, "LAYERS", "bmng,etopo"));
  EXPECT_EQ(two.layers, (std::vector<std::string>{"bmng", "etopo"}));
  EXPECT_EQ(two.styles, (std::vector<std::string>{"", ""}));
  const GetMapRequest styled =
      getMap(with(with(k130, "LAYERS", "bmng,etopo"), "STYLES", ",shaded"));
  EXPECT_EQ(styled.styles, (std::vector<std::string>{"", "shaded"}));
  EXPECT_EQ(getMap(with(with(k130, "LAYERS", "a,b,c"), "STYLES", ",,")).styles.size(), 3u);
  expectError(with(with(k130, "LAYERS", "bmng,etopo"), "STYLES", "default"),
              ogc::kInvalidParameterValue,
              "STYLES");
  expectError(with(k130, "STYLES", ","), ogc::kInvalidParameterValue, "STYLES");
  expectError(with(k130, "LAYERS", "<absent>"), ogc::kMissingParameterValue, "LAYERS");
  expectError(with(k130, "LAYERS", ""), ogc::kMissingParameterValue, "LAYERS");
  // Layer names are case-sensitive and kept verbatim.
  EXPECT_EQ(getMap(with(k130, "LAYERS", "BlueMarble")).layers.front(), "BlueMarble");
}

// STYLES is mandatory in both tables (06-042 Table 8, 01-068r3 7.2.3.4); STYLES= is the default.
TEST(Wms, StylesRequiredInBothVersions) {
  expectError(with(k130, "STYLES", "<absent>"), ogc::kMissingParameterValue, "STYLES");
  expectError(with(k111, "STYLES", "<absent>"), ogc::kMissingParameterValue, "STYLES");
  const GetMapRequest r = getMap(with(with(k111, "STYLES", ""), "LAYERS", "a,b"));
  EXPECT_EQ(r.styles, (std::vector<std::string>{"", ""}));
}

// ---- GetMap: TRANSPARENT, BGCOLOR, EXCEPTIONS, TIME --------------------------------------------

TEST(Wms, TransparentAndBgcolor) {
  EXPECT_FALSE(getMap(k130).transparent);
  EXPECT_TRUE(getMap(with(k130, "TRANSPARENT", "TRUE")).transparent);
  EXPECT_TRUE(getMap(with(k130, "TRANSPARENT", "true")).transparent);
  EXPECT_FALSE(getMap(with(k130, "TRANSPARENT", "False")).transparent);
  expectError(with(k130, "TRANSPARENT", "1"), ogc::kInvalidParameterValue, "TRANSPARENT");
  expectError(with(k130, "TRANSPARENT", "yes"), ogc::kInvalidParameterValue, "TRANSPARENT");
  EXPECT_EQ(getMap(with(k130, "BGCOLOR", "0xFF0000")).bgcolor, 0xFF0000u);
  EXPECT_EQ(getMap(with(k130, "BGCOLOR", "0x00ff7f")).bgcolor, 0x00FF7Fu);
  EXPECT_EQ(getMap(with(k130, "BGCOLOR", "0X000000")).bgcolor, 0u);
  EXPECT_FALSE(getMap(with(k130, "BGCOLOR", "")).bgcolor.has_value());
  for (const char* bad : {"FF0000", "%23FF0000", "0xFF00", "0xFF00000", "0xGG0000", "0x-F0000"}) {
    expectError(with(k130, "BGCOLOR", bad), ogc::kInvalidParameterValue, "BGCOLOR");
  }
}

TEST(Wms, ExceptionsInBothSpellings) {
  EXPECT_EQ(getMap(k130).exceptions, Exceptions::Xml);
  EXPECT_EQ(getMap(with(k130, "EXCEPTIONS", "XML")).exceptions, Exceptions::Xml);
  EXPECT_EQ(getMap(with(k130, "EXCEPTIONS", "INIMAGE")).exceptions, Exceptions::InImage);
  EXPECT_EQ(getMap(with(k130, "EXCEPTIONS", "blank")).exceptions, Exceptions::Blank);
  EXPECT_EQ(getMap(with(k111, "EXCEPTIONS", "application/vnd.ogc.se_xml")).exceptions,
            Exceptions::Xml);
  EXPECT_EQ(getMap(with(k111, "EXCEPTIONS", "application/vnd.ogc.se_inimage")).exceptions,
            Exceptions::InImage);
  EXPECT_EQ(getMap(with(k111, "EXCEPTIONS", "application/vnd.ogc.se_blank")).exceptions,
            Exceptions::Blank);
  // The other version's spelling is accepted too.
  EXPECT_EQ(getMap(with(k111, "EXCEPTIONS", "INIMAGE")).exceptions, Exceptions::InImage);
  EXPECT_EQ(getMap(with(k130, "EXCEPTIONS", "application/vnd.ogc.se_blank")).exceptions,
            Exceptions::Blank);
  expectError(with(k130, "EXCEPTIONS", "JSON"), ogc::kInvalidParameterValue, "EXCEPTIONS");
}

TEST(Wms, UnknownParametersAreIgnoredAndConflictingRepeatsRefused) {
  const GetMapRequest r = getMap(k130 + "&FOO=bar&VENDOR_x=1&foo=other&width=512&Layers=bmng");
  EXPECT_EQ(r.width, 512);
  EXPECT_EQ(r.layers.front(), "bmng");
  expectError(k130 + "&WIDTH=99999", ogc::kInvalidParameterValue, "WIDTH");
  expectError(k130 + "&layers=other", ogc::kInvalidParameterValue, "LAYERS");
  expectError(k130 + "&SERVICE=WFS", ogc::kInvalidParameterValue, "SERVICE");
  expectError(k130 + "&request=GetCapabilities", ogc::kInvalidParameterValue, "REQUEST");
  expectError("SERVICE=WMS&REQUEST=GetCapabilities&VERSION=1.3.0&VERSION=1.1.1",
              ogc::kInvalidParameterValue,
              "VERSION");
}

TEST(Wms, ErrorContextForUnparsedRequests) {
  const auto ctx = [](std::string_view query) {
    const auto q = parseQuery(query);
    EXPECT_TRUE(q.has_value());
    return wmsErrorContext(q ? *q : QueryParams{});
  };
  EXPECT_EQ(ctx("").version, WmsVersion::V130);
  EXPECT_EQ(ctx("VERSION=1.1.1").version, WmsVersion::V111);
  EXPECT_EQ(ctx("WMTVER=1.0.0").version, WmsVersion::V111);
  EXPECT_EQ(ctx("VERSION=junk").version, WmsVersion::V130);
  // INIMAGE with a bad CRS: the image parameters are good, so the error can be drawn.
  const auto inimage = ctx(
      with(with(with(k130, "EXCEPTIONS", "INIMAGE"), "CRS", "EPSG:32633"), "BGCOLOR", "0x112233") +
      "&TRANSPARENT=FALSE");
  EXPECT_EQ(inimage.exceptions, Exceptions::InImage);
  EXPECT_EQ(inimage.format, "image/jpeg");
  EXPECT_EQ(inimage.width, 512);
  EXPECT_EQ(inimage.height, 512);
  EXPECT_EQ(inimage.bgcolor, 0x112233u);
  EXPECT_FALSE(inimage.transparent);
  // BLANK without a usable size falls back to XML.
  EXPECT_EQ(ctx(with(with(k130, "EXCEPTIONS", "BLANK"), "WIDTH", "0")).exceptions, Exceptions::Xml);
  EXPECT_EQ(ctx(with(with(k130, "EXCEPTIONS", "BLANK"), "FORMAT", "<absent>")).exceptions,
            Exceptions::Xml);
  EXPECT_EQ(ctx(with(with(k111, "EXCEPTIONS", "application/vnd.ogc.se_blank"), "BGCOLOR", "red"))
                .exceptions,
            Exceptions::Xml);
  // Not a GetMap: always XML.
  EXPECT_EQ(ctx("REQUEST=GetCapabilities&EXCEPTIONS=INIMAGE").exceptions, Exceptions::Xml);
}

// ---- Extremes
// -------------------------------------------------------------------------------------

TEST(WmsExtremes, BboxRejectsNonFiniteAndMalformedNumbers) {
  for (const char* bad : {"nan,-90,-144,-54",
                          "-180,NaN,-144,-54",
                          "-inf,-90,-144,-54",
                          "-180,-90,inf,-54",
                          "-180,-90,-144,infinity",
                          "-180,-90,1e400,-54",
                          "-1e400,-90,-144,-54",
                          "1,2,3",
                          "1,2,3,4,5",
                          "1,2,3,4,",
                          ",1,2,3,4",
                          "1,,3,4",
                          ",,,",
                          "a,b,c,d",
                          "0x10,0,20,20",
                          "1e,2,3,4",
                          "1;2;3;4",
                          "1 2 3 4",
                          "--1,2,3,4",
                          "%2B-1,2,3,4",
                          "1,2,%2B%2B3,4",
                          "1.2.3,2,3,4",
                          "%E2%88%9E,0,1,1",
                          "-180,-90,-144,-54EPSG:4326"}) {
    expectError(with(k130, "BBOX", bad), ogc::kInvalidParameterValue, "BBOX");
  }
}

TEST(WmsExtremes, BboxAcceptsBoxesBeyondTheGlobeButNotAbsurdOnes) {
  EXPECT_EQ(getMap(with(k130, "BBOX", "170,-100,190,100")).bbox, (Sector{170, -100, 190, 100}));
  EXPECT_EQ(getMap(with(k130, "BBOX", "-540,-270,540,270")).bbox, (Sector{-540, -270, 540, 270}));
  EXPECT_EQ(getMap(with(k130, "BBOX", "-1e6,-1e6,1e6,1e6")).bbox, (Sector{-1e6, -1e6, 1e6, 1e6}));
  expectError(with(k130, "BBOX", "-1e7,-90,180,90"), ogc::kInvalidParameterValue, "BBOX");
  expectError(with(k130, "BBOX", "-180,-90,1e300,90"), ogc::kInvalidParameterValue, "BBOX");
  // Tiny boxes are boxes.
  const GetMapRequest tiny = getMap(with(k130, "BBOX", "0,0,1e-300,1e-300"));
  EXPECT_EQ(tiny.bbox.east, 1e-300);
}

TEST(WmsExtremes, BboxNegativeZeroSpacesAndPlus) {
  const GetMapRequest r = getMap(with(k130, "BBOX", "-0,-0.0,1,1"));
  EXPECT_EQ(r.bbox, (Sector{0, 0, 1, 1}));
  EXPECT_FALSE(std::signbit(r.bbox.west));
  EXPECT_FALSE(std::signbit(r.bbox.south));
  expectError(with(k130, "BBOX", "0,-0,-0,1"), ogc::kInvalidParameterValue, "BBOX"); // empty
  // A '+' decodes to a space: "+1" arrives as " 1"; %2B1 arrives as "+1". Both are read.
  EXPECT_EQ(getMap(with(k130, "BBOX", "-180,+-90,-144,-54")).bbox, kFirstTile);
  EXPECT_EQ(getMap(with(k130, "BBOX", "%2B1,2,3,4")).bbox, (Sector{1, 2, 3, 4}));
  EXPECT_EQ(getMap(with(k130, "BBOX", "1+,+2,3,4")).bbox, (Sector{1, 2, 3, 4}));
  EXPECT_EQ(getMap(with(k130, "BBOX", "-180.000000000000000000001,-90,-144,-54")).bbox, kFirstTile);
}

TEST(WmsExtremes, WidthAndHeightRejectJunk) {
  for (const char* bad : {"0",
                          "-1",
                          "-0",
                          "99999999999",
                          "99999999999999999999999999999",
                          "12abc",
                          "abc",
                          "1e3",
                          "512.0",
                          "0x200",
                          "+512",
                          "%20512",
                          "512%20",
                          "4097",
                          "%EF%BC%95%EF%BC%91%EF%BC%92"}) { // full-width digits
    expectError(with(k130, "WIDTH", bad), ogc::kInvalidParameterValue, "WIDTH");
    expectError(with(k130, "HEIGHT", bad), ogc::kInvalidParameterValue, "HEIGHT");
  }
}

TEST(WmsExtremes, EmptyLayerNames) {
  expectError(with(k130, "LAYERS", ",,"), ogc::kLayerNotDefined, "LAYERS");
  expectError(with(k130, "LAYERS", ","), ogc::kLayerNotDefined, "LAYERS");
  expectError(with(k130, "LAYERS", "a,"), ogc::kLayerNotDefined, "LAYERS");
  expectError(with(k130, "LAYERS", ",a"), ogc::kLayerNotDefined, "LAYERS");
}

TEST(WmsExtremes, UnicodeIsKeptVerbatimAndQuotedShort) {
  const GetMapRequest r =
      getMap(with(with(k130, "LAYERS", "%CE%A9mega,%E5%9C%B0%E5%9B%B3"), "STYLES", ",") +
             "&TIME=%E2%80%8B");
  EXPECT_EQ(r.layers, (std::vector<std::string>{"\xCE\xA9mega", "\xE5\x9C\xB0\xE5\x9B\xB3"}));
  EXPECT_EQ(r.time, "\xE2\x80\x8B");
  // An odd CRS is quoted in the message, cut to a bounded length on a UTF-8 boundary.
  std::string longCrs;
  for (int i = 0; i < 200; ++i)
    longCrs += "%E5%9C%B0";
  const OgcException e = error(with(k130, "CRS", longCrs));
  EXPECT_EQ(e.code, ogc::kInvalidCrs);
  EXPECT_LT(e.message.size(), 150u) << e.message;
  EXPECT_NE(e.message.find("..."), std::string::npos);
  EXPECT_EQ(e.message.find("\xE5\x9C'"), std::string::npos); // no split character
}

TEST(WmsExtremes, HostileValuesNeverParse) {
  expectError(with(k130, "CRS", "EPSG:4326%0A"), ogc::kInvalidCrs, "CRS");
  expectError(with(k130, "CRS", "%20EPSG:4326"), ogc::kInvalidCrs, "CRS");
  expectError(with(k130, "VERSION", "1.3.0%20"), ogc::kInvalidParameterValue, "VERSION");
  expectError(with(k130, "VERSION", "9999999.3.0"), ogc::kInvalidParameterValue, "VERSION");
  expectError(with(k130, "VERSION", "-1.3.0"), ogc::kInvalidParameterValue, "VERSION");
  expectError(with(k130, "REQUEST", "GetMap%20"), ogc::kOperationNotSupported, "REQUEST");
}

// ---- World Wind
// -----------------------------------------------------------------------------------

TEST(WorldWind, TileServiceRequest) {
  const auto q = parseQuery("T=bmng&L=3&X=12&Y=7");
  ASSERT_TRUE(q.has_value());
  const auto r = parseWorldWindTile(*q);
  ASSERT_TRUE(r.has_value()) << r.error();
  EXPECT_EQ(*r, (WorldWindTileRequest{"bmng", 3, 12, 7}));
  const auto lower = parseWorldWindTile(*parseQuery("t=srtm30&l=0&x=0&y=0&firstLevel=0"));
  ASSERT_TRUE(lower.has_value());
  EXPECT_EQ(*lower, (WorldWindTileRequest{"srtm30", 0, 0, 0}));
  const auto deep = parseWorldWindTile(*parseQuery("T=d&L=30&X=19327352831&Y=9663676415"));
  ASSERT_TRUE(deep.has_value());
  EXPECT_EQ(deep->col, 19327352831);
  EXPECT_EQ(deep->row, 9663676415);
}

TEST(WorldWind, MissingParameters) {
  for (const char* q :
       {"L=1&X=1&Y=1", "T=&L=1&X=1&Y=1", "T=a&X=1&Y=1", "T=a&L=1&Y=1", "T=a&L=1&X=1"}) {
    const auto p = parseQuery(q);
    ASSERT_TRUE(p.has_value());
    EXPECT_FALSE(parseWorldWindTile(*p).has_value()) << q;
  }
}

TEST(WorldWindExtremes, NumbersWithoutJunk) {
  for (const char* q : {"T=a&L=31&X=0&Y=0",
                        "T=a&L=-1&X=0&Y=0",
                        "T=a&L=99999999999&X=0&Y=0",
                        "T=a&L=1&X=-1&Y=0",
                        "T=a&L=1&X=%2B1&Y=0",
                        "T=a&L=1&X=1.0&Y=0",
                        "T=a&L=1&X=1&Y=0x10",
                        "T=a&L=1&X=1&Y=1e3",
                        "T=a&L=1&X=+1&Y=0",
                        "T=a&L=1&X=1&Y=",
                        "T=a&L=&X=1&Y=1",
                        "T=a&L=1&X=9223372036854775808&Y=0",
                        "T=a&L=1&X=1&Y=12abc"}) {
    const auto p = parseQuery(q);
    ASSERT_TRUE(p.has_value()) << q;
    EXPECT_FALSE(parseWorldWindTile(*p).has_value()) << q;
  }
  const auto max = parseWorldWindTile(*parseQuery("T=a&L=0&X=9223372036854775807&Y=0"));
  ASSERT_TRUE(max.has_value());
  EXPECT_EQ(max->col, 9223372036854775807);
}

TEST(StaticTilePath, ParsesTheWorldWindLayout) {
  const auto p = parseStaticTilePath("bmng/3/12/12_7.jpg");
  ASSERT_TRUE(p.has_value());
  EXPECT_EQ(*p, (StaticTilePath{"bmng", TileKey{3, 12, 7}, "jpg"}));
  const auto dotted = parseStaticTilePath("Blue.Marble_2004-08/0/0/0_0.png");
  ASSERT_TRUE(dotted.has_value());
  EXPECT_EQ(dotted->layer, "Blue.Marble_2004-08");
  EXPECT_EQ(parseStaticTilePath("e/30/9663676415/9663676415_19327352831.bil")->key,
            (TileKey{30, 9663676415, 19327352831}));
  // A layer's whole polar rows and spans (issue 29): the name as the renderer asks for it.
  EXPECT_EQ(parseStaticTilePath("bmng@caps/3/39/39_0.jpg")->layer, "bmng@caps");
  EXPECT_EQ(parseStaticTilePath("bmng@span16/3/39/39_32.jpg")->layer, "bmng@span16");
}

TEST(StaticTilePathExtremes, RejectsUnsafeOrMalformedPaths) {
  for (const char* bad : {"",
                          "bmng",
                          "bmng/",
                          "/bmng/0/0/0_0.jpg",
                          "./0/0/0_0.jpg",
                          "../0/0/0_0.jpg",
                          "../../etc/0/0/0_0.jpg",
                          "a b/0/0/0_0.jpg",
                          "a%2F/0/0/0_0.jpg",
                          "%2e%2e/0/0/0_0.jpg",
                          "a\\b/0/0/0_0.jpg",
                          "bmng//0/0/0_0.jpg",
                          "bmng/0/0/0_0",
                          "bmng/0/0/0_0.",
                          "bmng/0/0/0_0.jpg/x",
                          "bmng/0/0/0_0.j%70g",
                          "bmng/0/0/0_0.tar.gz",
                          "bmng/0/0/0_0.abcdefghijklmnopq",
                          "bmng/00/0/0_0.jpg",
                          "bmng/0/1/2_0.jpg",
                          "bmng/31/0/0_0.jpg",
                          "bmng/0/-1/-1_0.jpg",
                          "bmng/0/+1/+1_0.jpg",
                          "bmng/0/0/0_-0.jpg", // negative zero: one tile, two paths (fuzz)
                          "bmng/-0/-0/-0_-00.jpg",
                          "bmng/0/99999999999999999999/99999999999999999999_0.jpg",
                          "\xCE\xA9/0/0/0_0.jpg",
                          "bmng@/0/0/0_0.jpg",
                          "@caps/0/0/0_0.jpg",
                          "..@caps/0/0/0_0.jpg",
                          "bmng@caps@caps/0/0/0_0.jpg",
                          "bmng@span3/0/0/0_0.jpg",
                          "bmng@span1/0/0/0_0.jpg",
                          "bmng@span016/0/0/0_0.jpg",
                          "bmng@CAPS/0/0/0_0.jpg",
                          "a b@span2/0/0/0_0.jpg"}) {
    EXPECT_FALSE(parseStaticTilePath(bad).has_value()) << bad;
  }
  EXPECT_TRUE(parseStaticTilePath(std::string(kMaxStaticLayerName, 'a') + "/0/0/0_0.jpg"));
  EXPECT_FALSE(parseStaticTilePath(std::string(kMaxStaticLayerName + 1, 'a') + "/0/0/0_0.jpg"));
  EXPECT_TRUE(parseStaticTilePath(".../0/0/0_0.jpg")); // three dots is a plain name
}

// ---- TIME ------------------------------------------------------------------------------------

namespace {

std::string timeOf(const std::vector<std::string>& values,
                   std::string_view period,
                   std::string_view defaultValue,
                   std::string_view t) {
  const auto r = resolveTimeDimension("l", values, period, defaultValue, t);
  return r ? *r : "!" + r.error().code;
}

const std::string kInvalidTime = "!" + std::string(ogc::kInvalidDimensionValue);

} // namespace

// A period kept as a period: only instants on its grid, and each in one spelling.
TEST(WmsTime, APeriodTakesOnlyInstantsOnItsGrid) {
  const std::string hourly = "2010-01-01T00:00Z/2010-12-31T00:00Z/PT1H";
  const auto at = [&](std::string_view t) { return timeOf({}, hourly, "2010-12-31T00:00Z", t); };
  EXPECT_EQ(at("2010-01-01T05:00Z"), "2010-01-01T05:00Z");
  // Other spellings of the same instant: the period's own.
  EXPECT_EQ(at("2010-01-01T05:00:00Z"), "2010-01-01T05:00Z");
  EXPECT_EQ(at("2010-01-01T05:00:00.000Z"), "2010-01-01T05:00Z");
  EXPECT_EQ(at("2010-01-01T05:00"), "2010-01-01T05:00Z");
  EXPECT_EQ(at("2010-01-01T06:00+01:00"), "2010-01-01T05:00Z");
  EXPECT_EQ(at("2010-01-01T04:30-0030"), "2010-01-01T05:00Z");
  EXPECT_EQ(at("2010-01-01"), "2010-01-01T00:00Z");
  EXPECT_EQ(at(""), "2010-12-31T00:00Z"); // the default
  // Strings of the right length that sort inside, off-grid times, outside, junk: refused.
  for (const char* bad : {"2010-99-99T99:99Z",
                          "2010-02-30T00:00Z",
                          "2010-01-01T24:00Z",
                          "2010-01-01T00:60Z",
                          "2010-01-01T00:30Z",
                          "2010-01-01T05:00:01Z",
                          "2010-01-01T05:00:00.5Z",
                          "2009-12-31T23:00Z",
                          "2010-12-31T01:00Z",
                          "2010/../..",
                          "2010-06-01T00:00Y",
                          "2010-06-01T00:00Z ",
                          " 2010-06-01T00:00Z",
                          "2010-06-01t00:00z",
                          "20100601T0000Z",
                          "current",
                          "2010-06-01T00:00+24:00"}) {
    EXPECT_EQ(at(bad), kInvalidTime) << bad;
  }
  // Lists and ranges: a map is made for one time.
  for (const char* many : {"2010-01-01T00:00Z,2010-01-01T01:00Z",
                           "2010-01-01T00:00Z/2010-01-02T00:00Z",
                           "2010-01-01T00:00Z/2010-01-02T00:00Z/PT1H",
                           ","}) {
    const auto r = resolveTimeDimension("l", {}, hourly, "", many);
    ASSERT_FALSE(r) << many;
    EXPECT_EQ(r.error().code, ogc::kInvalidDimensionValue);
    EXPECT_EQ(r.error().locator, "TIME");
    EXPECT_NE(r.error().message.find("one time"), std::string::npos) << r.error().message;
  }
}

TEST(WmsTime, DaysMonthsYearsAndWeeks) {
  const std::string daily = "2000-02-24/2025-12-31/P1D";
  EXPECT_EQ(timeOf({}, daily, "", "2000-02-24"), "2000-02-24");
  EXPECT_EQ(timeOf({}, daily, "", "2024-02-29"), "2024-02-29");
  EXPECT_EQ(timeOf({}, daily, "", "2024-02-29T00:00:00Z"), "2024-02-29");
  EXPECT_EQ(timeOf({}, daily, "", "2024-02-29T12:00Z"), kInvalidTime);
  EXPECT_EQ(timeOf({}, daily, "", "2023-02-29"), kInvalidTime);
  EXPECT_EQ(timeOf({}, daily, "", "2000-02-23"), kInvalidTime);
  EXPECT_EQ(timeOf({}, daily, "", "2026-01-01"), kInvalidTime);
  // Months on the calendar from the start, the day clamped to the month's end.
  const std::string monthly = "2002-01-31/2024-12-31/P1M";
  EXPECT_EQ(timeOf({}, monthly, "", "2002-02-28"), "2002-02-28");
  EXPECT_EQ(timeOf({}, monthly, "", "2004-02-29"), "2004-02-29");
  EXPECT_EQ(timeOf({}, monthly, "", "2024-12-31"), "2024-12-31");
  EXPECT_EQ(timeOf({}, monthly, "", "2002-03-31"), "2002-03-31");
  EXPECT_EQ(timeOf({}, monthly, "", "2002-03-28"), kInvalidTime);
  EXPECT_EQ(timeOf({}, "2002-07-01/2024-12-01/P3M", "", "2002-10-01"), "2002-10-01");
  EXPECT_EQ(timeOf({}, "2002-07-01/2024-12-01/P3M", "", "2002-09-01"), kInvalidTime);
  EXPECT_EQ(timeOf({}, "2000-01-01/2100-01-01/P1Y", "", "2099-01-01"), "2099-01-01");
  EXPECT_EQ(timeOf({}, "2000-01-01/2100-01-01/P1Y", "", "2099-01-02"), kInvalidTime);
  EXPECT_EQ(timeOf({}, "2024-01-01/2024-12-31/P1W", "", "2024-01-08"), "2024-01-08");
  EXPECT_EQ(timeOf({}, "2024-01-01/2024-12-31/P1W", "", "2024-01-09"), kInvalidTime);
  // Minutes and a date-only start with a time step.
  EXPECT_EQ(timeOf({}, "2024-03-01/2024-03-02/PT6H", "", "2024-03-01T18:00:00Z"),
            "2024-03-01T18:00Z");
  EXPECT_EQ(timeOf({}, "2024-03-01T00:00:00Z/2024-03-02T00:00:00Z/PT10M", "", "2024-03-01T00:50Z"),
            "2024-03-01T00:50:00Z");
  EXPECT_EQ(timeOf({}, "2024-03-01T00:00:00Z/2024-03-02T00:00:00Z/PT10M", "", "2024-03-01T00:55Z"),
            kInvalidTime);
}

TEST(WmsTime, ValuesMatchByInstantAndKeepTheirSpelling) {
  const std::vector<std::string> values{"2024-01-01", "2024-01-02T12:00:00Z", "2004-08"};
  EXPECT_EQ(timeOf(values, "", "", "2024-01-01"), "2024-01-01");
  EXPECT_EQ(timeOf(values, "", "", "2024-01-01T00:00Z"), "2024-01-01");
  EXPECT_EQ(timeOf(values, "", "", "2024-01-02T12:00Z"), "2024-01-02T12:00:00Z");
  EXPECT_EQ(timeOf(values, "", "", "2004-08"), "2004-08"); // listed verbatim
  EXPECT_EQ(timeOf(values, "", "", "2024-01-03"), kInvalidTime);
  EXPECT_EQ(timeOf(values, "", "", "2004-09"), kInvalidTime);
  EXPECT_EQ(timeOf(values, "", "2024-01-01T00:00:00Z", ""), "2024-01-01");
  EXPECT_EQ(timeOf({"a"}, "", "", ""), "!" + std::string(ogc::kMissingDimensionValue));
  // A layer without a dimension ignores TIME.
  EXPECT_EQ(timeOf({}, "", "", "2010-99-99"), "");
  // An expanded period (values and the period): the values' spelling wins.
  EXPECT_EQ(timeOf({"2024-03-01T00:00:00Z", "2024-03-01T06:00:00Z"},
                   "2024-03-01T00:00Z/2024-03-01T06:00Z/PT6H",
                   "",
                   "2024-03-01T06:00Z"),
            "2024-03-01T06:00:00Z");
}
