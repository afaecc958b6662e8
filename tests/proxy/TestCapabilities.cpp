#include "../support/WmsSchemas.hpp"

#include <tellus/proxy/Capabilities.hpp>
#include <tellus/proxy/Wms.hpp>

#include <gtest/gtest.h>

#include <charconv>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

using namespace tellus;
namespace fs = std::filesystem;

namespace {

// The golden files live next to the tests (tests/data/golden); the build may point elsewhere.
fs::path goldenDir() {
#ifdef TELLUS_TEST_GOLDEN_DIR
  return fs::path(TELLUS_TEST_GOLDEN_DIR);
#else
  // Absolute (TELLUS_TEST_SOURCE_DIR): __FILE__ is relative to the build tree under Ninja, and
  // ctest runs the tests from another folder.
  return fs::path(TELLUS_TEST_SOURCE_DIR) / "data" / "golden";
#endif
}

std::vector<std::string> splitLines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);)
    lines.push_back(line);
  return lines;
}

// Byte-for-byte comparison with a golden file; TELLUS_UPDATE_GOLDEN=1 rewrites it instead.
void expectMatchesGolden(const std::string& actual, const std::string& name) {
  const fs::path path = goldenDir() / name;
  if (const char* update = std::getenv("TELLUS_UPDATE_GOLDEN"); update && *update == '1') {
    fs::create_directories(path.parent_path());
    std::ofstream(path, std::ios::binary) << actual;
    GTEST_SKIP() << "rewrote " << path;
  }
  std::ifstream in(path, std::ios::binary);
  ASSERT_TRUE(in) << "missing golden file " << path
                  << " (run with TELLUS_UPDATE_GOLDEN=1 to create it)";
  const std::string expected((std::istreambuf_iterator<char>(in)),
                             std::istreambuf_iterator<char>());
  if (actual == expected) return;
  const auto want = splitLines(expected);
  const auto got = splitLines(actual);
  std::size_t i = 0;
  while (i < want.size() && i < got.size() && want[i] == got[i])
    ++i;
  std::ostringstream msg;
  msg << "output differs from " << path << " at line " << (i + 1) << ":\n";
  const std::size_t from = i >= 2 ? i - 2 : 0;
  for (std::size_t k = from; k < i; ++k)
    msg << "    " << want[k] << "\n";
  msg << "  - " << (i < want.size() ? want[i] : "<end of file>") << "\n";
  msg << "  + " << (i < got.size() ? got[i] : "<end of output>") << "\n";
  msg << "(" << want.size() << " expected lines, " << got.size() << " actual; sizes "
      << expected.size() << " / " << actual.size()
      << " bytes; rerun with TELLUS_UPDATE_GOLDEN=1 if the change is intended and review the diff)";
  ADD_FAILURE() << msg.str();
}

// A small well-formedness check: balanced, properly nested tags, quoted attributes, one root, no
// stray '<' or '&' in text. Empty string when fine.
std::string wellFormednessError(const std::string& xml) {
  std::vector<std::string> stack;
  int roots = 0;
  std::size_t i = 0;
  while (i < xml.size()) {
    if (xml[i] == '&') {
      const std::size_t semi = xml.find(';', i);
      if (semi == std::string::npos || semi - i > 8) return "bare '&' at " + std::to_string(i);
      i = semi + 1;
      continue;
    }
    if (xml[i] != '<') {
      if (xml[i] == '>') return "bare '>' at " + std::to_string(i);
      if (stack.empty() && xml[i] != '\n' && xml[i] != ' ')
        return "text outside the root at " + std::to_string(i);
      ++i;
      continue;
    }
    if (xml.compare(i, 2, "<?") == 0 || xml.compare(i, 2, "<!") == 0) {
      const std::size_t end = xml.find('>', i);
      if (end == std::string::npos) return "unterminated declaration";
      i = end + 1;
      continue;
    }
    // A tag: scan to '>' outside quotes.
    std::size_t j = i + 1;
    char quote = 0;
    while (j < xml.size() && (quote != 0 || xml[j] != '>')) {
      if (quote == 0 && xml[j] == '<') return "'<' inside a tag at " + std::to_string(j);
      if (quote == 0 && (xml[j] == '"' || xml[j] == '\'')) {
        quote = xml[j];
      } else if (quote != 0 && xml[j] == quote) {
        quote = 0;
      } else if (quote != 0 && xml[j] == '<') {
        return "'<' inside an attribute at " + std::to_string(j);
      }
      ++j;
    }
    if (j >= xml.size()) return "unterminated tag at " + std::to_string(i);
    const std::string tag = xml.substr(i + 1, j - i - 1);
    const bool closing = !tag.empty() && tag.front() == '/';
    const bool selfClosing = !tag.empty() && tag.back() == '/';
    const std::string body = closing ? tag.substr(1) : tag;
    const std::string name = body.substr(0, body.find_first_of(" \t\n/"));
    if (name.empty()) return "empty tag name at " + std::to_string(i);
    if (closing) {
      if (stack.empty() || stack.back() != name)
        return "</" + name + "> does not close <" + (stack.empty() ? "" : stack.back()) + ">";
      stack.pop_back();
    } else if (!selfClosing) {
      if (stack.empty()) ++roots;
      stack.push_back(name);
    } else if (stack.empty()) {
      ++roots;
    }
    i = j + 1;
  }
  if (!stack.empty()) return "<" + stack.back() + "> is never closed";
  if (roots != 1) return std::to_string(roots) + " root elements";
  return {};
}

bool haveXmllint() {
  return std::system("command -v xmllint >/dev/null 2>&1") == 0;
}

// xmllint's verdict (no network, no DTD loading); true when xmllint is absent.
bool xmllintAccepts(const std::string& xml, bool quiet = false) {
  if (!haveXmllint()) return true;
  FILE* pipe = ::popen(
      quiet ? "xmllint --noout --nonet - >/dev/null 2>&1" : "xmllint --noout --nonet - 2>&1", "w");
  if (pipe == nullptr) return false;
  std::fwrite(xml.data(), 1, xml.size(), pipe);
  return ::pclose(pipe) == 0;
}

CapabilitiesModel fixedModel() {
  CapabilitiesModel m;
  m.title = "tellus test service";
  m.abstract = "Tiles & maps for <World Wind> clients";
  m.onlineResource = "http://localhost:8080/wms?map=demo&";
  m.getMapFormats = {"image/jpeg", "image/png"};
  m.updateSequence = "42";
  m.lastUpdate = "2026-11-23T00:00:00Z";
  m.maxWidth = 4096;
  m.maxHeight = 2048;

  CapabilitiesLayer bmng;
  bmng.name = "bmng";
  bmng.title = "Blue Marble Next Generation";
  bmng.abstract = "NASA Blue Marble, monthly";
  bmng.bbox = Sector{-180, -90, 180, 90};
  bmng.timeValues = {"2004-01", "2004-02", "2004-03"};
  bmng.timeDefault = "2004-03";
  m.layers.push_back(bmng);

  CapabilitiesLayer etopo;
  etopo.name = "etopo";
  etopo.title = "ETOPO \"20\" relief <shaded> & 'coloured'";
  etopo.bbox = Sector{-180, -90, 180, 90};
  etopo.styles = {"default", "shaded"};
  m.layers.push_back(etopo);

  CapabilitiesLayer europe;
  europe.name = "europe_ortho";
  europe.title = "Europe \xCE\xB1\xCF\x81\xCF\x87\xCE\xAE"; // Greek, UTF-8
  europe.bbox = Sector{-10.5, 35.25, 30.125, 71.1};
  europe.timePeriod = "2020-01-01/2024-12-31/P1D";
  europe.timeDefault = "2024-12-31";
  europe.opaque = false;
  m.layers.push_back(europe);
  return m;
}

bool contains(const std::string& text, std::string_view needle) {
  return text.find(needle) != std::string::npos;
}

} // namespace

TEST(Capabilities, Golden111) {
  const std::string xml = capabilitiesXml(WmsVersion::V111, fixedModel());
  EXPECT_EQ(wellFormednessError(xml), "");
  EXPECT_TRUE(xmllintAccepts(xml));
  expectMatchesGolden(xml, "capabilities_111.xml");
}

TEST(Capabilities, Golden130) {
  const std::string xml = capabilitiesXml(WmsVersion::V130, fixedModel());
  EXPECT_EQ(wellFormednessError(xml), "");
  EXPECT_TRUE(xmllintAccepts(xml));
  expectMatchesGolden(xml, "capabilities_130.xml");
}

TEST(Capabilities, Version111Conventions) {
  const std::string xml = capabilitiesXml(WmsVersion::V111, fixedModel());
  EXPECT_TRUE(contains(xml,
                       "<!DOCTYPE WMT_MS_Capabilities SYSTEM "
                       "\"http://schemas.opengis.net/wms/1.1.1/WMS_MS_Capabilities.dtd\">"));
  EXPECT_TRUE(contains(xml, "<WMT_MS_Capabilities version=\"1.1.1\" updateSequence=\"42\">"));
  EXPECT_TRUE(contains(xml, "<Name>OGC:WMS</Name>"));
  EXPECT_TRUE(contains(xml, "<Keyword>LastUpdate=2026-11-23T00:00:00Z</Keyword>"));
  EXPECT_TRUE(contains(xml, "<Format>application/vnd.ogc.wms_xml</Format>"));
  EXPECT_TRUE(contains(xml, "<Format>application/vnd.ogc.se_inimage</Format>"));
  EXPECT_TRUE(contains(xml, "<SRS>EPSG:4326</SRS>"));
  EXPECT_TRUE(contains(xml, "xlink:href=\"http://localhost:8080/wms?map=demo&amp;\""));
  // lon/lat everywhere in 1.1.1.
  EXPECT_TRUE(contains(xml,
                       "<LatLonBoundingBox minx=\"-10.5\" miny=\"35.25\" maxx=\"30.125\" "
                       "maxy=\"71.1\"/>"));
  EXPECT_TRUE(contains(xml,
                       "<BoundingBox SRS=\"EPSG:4326\" minx=\"-10.5\" miny=\"35.25\" "
                       "maxx=\"30.125\" maxy=\"71.1\"/>"));
  EXPECT_TRUE(contains(xml, "<Dimension name=\"time\" units=\"ISO8601\"/>"));
  EXPECT_TRUE(
      contains(xml, "<Extent name=\"time\" default=\"2004-03\">2004-01,2004-02,2004-03</Extent>"));
  EXPECT_FALSE(contains(xml, "MaxWidth"));
  EXPECT_FALSE(contains(xml, "CRS:84"));
}

TEST(Capabilities, Version130Conventions) {
  const std::string xml = capabilitiesXml(WmsVersion::V130, fixedModel());
  EXPECT_TRUE(contains(xml,
                       "<WMS_Capabilities version=\"1.3.0\" updateSequence=\"42\" "
                       "xmlns=\"http://www.opengis.net/wms\""));
  EXPECT_TRUE(contains(xml, "<Name>WMS</Name>"));
  EXPECT_TRUE(contains(xml, "<MaxWidth>4096</MaxWidth>"));
  EXPECT_TRUE(contains(xml, "<MaxHeight>2048</MaxHeight>"));
  EXPECT_TRUE(contains(xml, "<Format>text/xml</Format>"));
  EXPECT_TRUE(contains(xml, "<Format>INIMAGE</Format>"));
  EXPECT_TRUE(contains(xml, "<CRS>EPSG:4326</CRS>"));
  EXPECT_TRUE(contains(xml, "<CRS>CRS:84</CRS>"));
  EXPECT_TRUE(contains(xml, "<westBoundLongitude>-10.5</westBoundLongitude>"));
  EXPECT_TRUE(contains(xml, "<northBoundLatitude>71.1</northBoundLatitude>"));
  EXPECT_TRUE(contains(xml,
                       "<BoundingBox CRS=\"CRS:84\" minx=\"-10.5\" miny=\"35.25\" "
                       "maxx=\"30.125\" maxy=\"71.1\"/>"));
  // The axis-order trap: EPSG:4326 in 1.3.0 is lat/lon.
  EXPECT_TRUE(contains(xml,
                       "<BoundingBox CRS=\"EPSG:4326\" minx=\"35.25\" miny=\"-10.5\" "
                       "maxx=\"71.1\" maxy=\"30.125\"/>"));
  EXPECT_TRUE(contains(xml,
                       "<BoundingBox CRS=\"EPSG:4326\" minx=\"-90\" miny=\"-180\" "
                       "maxx=\"90\" maxy=\"180\"/>"));
  EXPECT_TRUE(contains(xml,
                       "<Dimension name=\"time\" units=\"ISO8601\" default=\"2024-12-31\">"
                       "2020-01-01/2024-12-31/P1D</Dimension>"));
  EXPECT_TRUE(contains(xml, "<Layer queryable=\"0\" opaque=\"0\">"));
  EXPECT_FALSE(contains(xml, "LatLonBoundingBox"));
  EXPECT_FALSE(contains(xml, "<SRS>"));
}

TEST(Capabilities, EscapesNamesAndTitles) {
  for (const WmsVersion v : {WmsVersion::V111, WmsVersion::V130}) {
    const std::string xml = capabilitiesXml(v, fixedModel());
    EXPECT_TRUE(contains(xml,
                         "<Title>ETOPO &quot;20&quot; relief &lt;shaded&gt; &amp; "
                         "&apos;coloured&apos;</Title>"));
    EXPECT_TRUE(contains(xml, "<Abstract>Tiles &amp; maps for &lt;World Wind&gt; clients"));
    EXPECT_TRUE(contains(xml, "<Title>Europe \xCE\xB1\xCF\x81\xCF\x87\xCE\xAE</Title>"));
  }
  CapabilitiesModel hostile = fixedModel();
  hostile.layers[0].name = "a</Name><Evil/>\x01";
  hostile.updateSequence = "\"><x";
  for (const WmsVersion v : {WmsVersion::V111, WmsVersion::V130}) {
    const std::string xml = capabilitiesXml(v, hostile);
    EXPECT_EQ(wellFormednessError(xml), "");
    EXPECT_TRUE(xmllintAccepts(xml));
    EXPECT_FALSE(contains(xml, "<Evil/>"));
    EXPECT_TRUE(contains(xml, "<Name>a&lt;/Name&gt;&lt;Evil/&gt;?</Name>"));
  }
}

TEST(Capabilities, AdvertisedBoxesParseBackToTheSameSector) {
  const CapabilitiesModel m = fixedModel();
  for (const CapabilitiesLayer& layer : m.layers) {
    // What a client copies from the 1.3.0 EPSG:4326 BoundingBox (lat/lon) ...
    const std::string latLon =
        formatCoordinate(layer.bbox.south) + "," + formatCoordinate(layer.bbox.west) + "," +
        formatCoordinate(layer.bbox.north) + "," + formatCoordinate(layer.bbox.east);
    const auto q = parseQuery("SERVICE=WMS&VERSION=1.3.0&REQUEST=GetMap&LAYERS=" + layer.name +
                              "&STYLES=&CRS=EPSG:4326&BBOX=" + latLon +
                              "&WIDTH=256&HEIGHT=256&FORMAT=image/png");
    ASSERT_TRUE(q.has_value());
    const auto r = parseWms(*q);
    ASSERT_TRUE(r.has_value()) << r.error().message;
    // ... reads back as exactly the layer's sector.
    EXPECT_EQ(std::get<GetMapRequest>(*r).bbox, layer.bbox) << layer.name;
  }
}

TEST(Capabilities, NoLayersNoTimeNoOptionalParts) {
  CapabilitiesModel m;
  m.title = "empty";
  m.onlineResource = "http://h/wms?";
  m.getMapFormats = {"image/png"};
  for (const WmsVersion v : {WmsVersion::V111, WmsVersion::V130}) {
    const std::string xml = capabilitiesXml(v, m);
    EXPECT_EQ(wellFormednessError(xml), "");
    EXPECT_TRUE(xmllintAccepts(xml));
    EXPECT_FALSE(contains(xml, "updateSequence"));
    EXPECT_FALSE(contains(xml, "KeywordList"));
    EXPECT_FALSE(contains(xml, "Abstract"));
    EXPECT_FALSE(contains(xml, "Dimension"));
    EXPECT_FALSE(contains(xml, "MaxWidth"));
    EXPECT_FALSE(contains(xml, "<Style>"));
    EXPECT_TRUE(contains(xml, "minx=\"-180\"")); // the globe when there are no layers
  }
  EXPECT_EQ(capabilitiesContentType(WmsVersion::V111), "application/vnd.ogc.wms_xml");
  EXPECT_EQ(capabilitiesContentType(WmsVersion::V130), "text/xml");
}

TEST(Capabilities, RootBoxIsTheUnionOfLayers) {
  CapabilitiesModel m;
  m.title = "two";
  CapabilitiesLayer a;
  a.name = "a";
  a.title = "a";
  a.bbox = Sector{10, -20, 30, 40};
  CapabilitiesLayer b = a;
  b.name = "b";
  b.bbox = Sector{-5, 0, 15, 60};
  m.layers = {a, b};
  const std::string xml = capabilitiesXml(WmsVersion::V111, m);
  EXPECT_TRUE(
      contains(xml, "<LatLonBoundingBox minx=\"-5\" miny=\"-20\" maxx=\"30\" maxy=\"60\"/>"));
}

TEST(Capabilities, WellFormednessChecksCatchBrokenXml) {
  EXPECT_EQ(wellFormednessError("<a><b/></a>"), "");
  EXPECT_NE(wellFormednessError("<a><b></a>"), "");
  EXPECT_NE(wellFormednessError("<a>x & y</a>"), "");
  EXPECT_NE(wellFormednessError("<a x=\"<\"/>"), "");
  EXPECT_NE(wellFormednessError("<a/><b/>"), "");
  EXPECT_NE(wellFormednessError("<a>"), "");
  if (haveXmllint()) {
    EXPECT_TRUE(xmllintAccepts("<a><b/></a>"));
    EXPECT_FALSE(xmllintAccepts("<a><b></a>", true));
  }
}

TEST(Capabilities, CoordinatesPrintShortestRoundTrip) {
  EXPECT_EQ(formatCoordinate(0.1), "0.1");
  EXPECT_EQ(formatCoordinate(-180.0), "-180");
  EXPECT_EQ(formatCoordinate(-0.0), "0");
  EXPECT_EQ(formatCoordinate(71.1), "71.1");
  EXPECT_EQ(formatCoordinate(36.0 / 1024.0), "0.03515625");
  EXPECT_EQ(formatCoordinate(1.0 / 3.0), "0.3333333333333333");
  for (const double v : {0.1, 1.0 / 3.0, -179.99999999999997, 1e-5, 123456.789, 2.0 / 3.0 * 90.0}) {
    const std::string s = formatCoordinate(v);
    double back = 0.0;
    const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), back);
    EXPECT_EQ(ec, std::errc{});
    EXPECT_EQ(ptr, s.data() + s.size());
    EXPECT_EQ(back, v) << s;
  }
}

TEST(Capabilities, LayerLastUpdateKeywordForWorldWindJava) {
  CapabilitiesModel m = fixedModel();
  m.layers[0].lastUpdateMillis = 1795477530123;
  for (const WmsVersion v : {WmsVersion::V111, WmsVersion::V130}) {
    const std::string xml = capabilitiesXml(v, m);
    const auto name = xml.find("<Name>" + m.layers[0].name + "</Name>");
    const auto keyword = xml.find("<Keyword>LastUpdate=1795477530123</Keyword>");
    ASSERT_NE(keyword, std::string::npos);
    EXPECT_GT(keyword, name) << "inside the layer, after its name";
  }
}

namespace {

test::WmsDocument capabilitiesKind(WmsVersion v) {
  return v == WmsVersion::V111 ? test::WmsDocument::Capabilities111
                               : test::WmsDocument::Capabilities130;
}

} // namespace

// Every shape of the document, both versions, valid against the official WMS_MS_Capabilities.dtd
// and capabilities_1_3_0.xsd (tests/data/schemas). The documents a running server writes are
// validated in TestWmsConformance.cpp.
TEST(CapabilitiesSchemas, EveryModelIsValidAgainstTheOfficialSchemas) {
  std::vector<std::pair<std::string, CapabilitiesModel>> models;
  models.emplace_back("fixed", fixedModel());
  CapabilitiesModel empty;
  empty.title = "empty";
  empty.onlineResource = "http://h/wms?";
  empty.getMapFormats = {"image/png"};
  models.emplace_back("no layers", empty);
  CapabilitiesModel hostile = fixedModel();
  hostile.layers[0].name = "a</Name><Evil/>\x01";
  hostile.updateSequence = "\"><x";
  hostile.abstract = "]]> <!-- &";
  models.emplace_back("hostile text", hostile);
  CapabilitiesModel heights = empty;
  heights.getMapFormats = {
      "application/bil16", "image/tiff", "image/png", "image/jpeg", "image/png; mode=8bit"};
  CapabilitiesLayer dem;
  dem.name = "etopo";
  dem.title = "heights";
  dem.bbox = Sector{-180, -90, 180, 90};
  dem.lastUpdateMillis = 1795477530123;
  heights.layers = {dem};
  heights.maxWidth = 4096;
  heights.maxHeight = 4096;
  models.emplace_back("heights", heights);
  CapabilitiesModel timed = heights;
  CapabilitiesLayer daily = dem;
  daily.name = "daily";
  daily.timePeriod = "2000-02-24/2025-12-31/P1D";
  daily.timeDefault = "2025-12-31";
  daily.opaque = false;
  daily.styles = {"default"};
  CapabilitiesLayer monthly = dem;
  monthly.name = "monthly";
  monthly.timeValues = {"2004-01", "2004-02"};
  timed.layers = {daily, monthly, dem};
  models.emplace_back("time", timed);
  CapabilitiesModel legends = fixedModel();
  legends.getFeatureInfoFormats = {"text/plain", "application/json"};
  legends.getLegendGraphicFormats = {"image/png"};
  legends.layers[1].legendStyles = {
      CapabilitiesStyle{"viridis", "Viridis", "http://h/wms?REQUEST=GetLegendGraphic", 256, 56}};
  models.emplace_back("legends", legends);
  for (const auto& [what, model] : models) {
    for (const WmsVersion v : {WmsVersion::V111, WmsVersion::V130}) {
      const std::string xml = capabilitiesXml(v, model);
      const auto verdict = test::validateWms(xml, capabilitiesKind(v));
      EXPECT_TRUE(verdict.valid) << what << " " << toString(v) << "\n" << verdict.output;
    }
  }
}

// The validation can fail: documents that break the schemas are refused.
TEST(CapabilitiesSchemas, TheValidationRefusesBrokenDocuments) {
  for (const WmsVersion v : {WmsVersion::V111, WmsVersion::V130}) {
    const std::string good = capabilitiesXml(v, fixedModel());
    ASSERT_TRUE(test::validateWms(good, capabilitiesKind(v)).valid);
    // A layer's Title before its Name: out of the order both schemas fix.
    std::string swapped = good;
    const std::string nameTitle =
        "<Name>bmng</Name>\n        <Title>Blue Marble Next Generation</Title>";
    const auto at = swapped.find(nameTitle);
    ASSERT_NE(at, std::string::npos) << swapped;
    swapped.replace(at,
                    nameTitle.size(),
                    "<Title>Blue Marble Next Generation</Title>\n        <Name>bmng</Name>");
    const auto verdict = test::validateWms(swapped, capabilitiesKind(v));
    EXPECT_FALSE(verdict.valid) << toString(v);
    EXPECT_NE(verdict.output.find("Name"), std::string::npos) << verdict.output;
    // An element neither schema knows.
    std::string unknown = good;
    unknown.replace(unknown.find("<Fees>"), 6, "<Feez>");
    unknown.replace(unknown.find("</Fees>"), 7, "</Feez>");
    EXPECT_FALSE(test::validateWms(unknown, capabilitiesKind(v)).valid) << toString(v);
  }
  // A 1.1.1 document must name its DTD.
  std::string noDoctype = capabilitiesXml(WmsVersion::V111, fixedModel());
  const auto d = noDoctype.find("<!DOCTYPE");
  noDoctype.erase(d, noDoctype.find('>', d) + 2 - d);
  EXPECT_FALSE(test::validateWms(noDoctype, test::WmsDocument::Capabilities111).valid);
}

namespace {

CapabilitiesModel legendModel() {
  CapabilitiesModel m = fixedModel();
  m.getFeatureInfoFormats = {"text/plain"};
  m.getLegendGraphicFormats = {"image/png"};
  return m;
}

} // namespace

// GetLegendGraphic declared as each version's standard says: 1.1.1 the DTD's element after
// GetFeatureInfo; 1.3.0 SLD 1.1.0's sld:GetLegendGraphic (an _ExtendedOperation), with the sld
// namespace and its schema's location; neither when no format is offered.
TEST(CapabilitiesSchemas, GetLegendGraphicIsDeclaredAsTheStandardsSay) {
  const std::string v111 = capabilitiesXml(WmsVersion::V111, legendModel());
  const auto info111 = v111.find("</GetFeatureInfo>");
  const auto legend111 = v111.find("<GetLegendGraphic>\n        <Format>image/png</Format>");
  ASSERT_NE(legend111, std::string::npos) << v111;
  EXPECT_LT(info111, legend111);
  EXPECT_LT(legend111, v111.find("</Request>"));
  EXPECT_FALSE(contains(v111, "sld:"));
  const auto verdict111 = test::validateWms(v111, test::WmsDocument::Capabilities111);
  EXPECT_TRUE(verdict111.valid) << verdict111.output;

  const std::string v130 = capabilitiesXml(WmsVersion::V130, legendModel());
  EXPECT_TRUE(contains(v130, "xmlns:sld=\"http://www.opengis.net/sld\""));
  EXPECT_TRUE(contains(v130,
                       "http://www.opengis.net/sld "
                       "http://schemas.opengis.net/sld/1.1.0/sld_capabilities.xsd\""));
  const auto legend130 = v130.find("<sld:GetLegendGraphic>\n        <Format>image/png</Format>");
  ASSERT_NE(legend130, std::string::npos) << v130;
  EXPECT_LT(v130.find("</GetFeatureInfo>"), legend130);
  EXPECT_LT(legend130, v130.find("</sld:GetLegendGraphic>\n    </Request>"));
  const auto verdict130 = test::validateWms(v130, test::WmsDocument::Capabilities130);
  EXPECT_TRUE(verdict130.valid) << verdict130.output << "\n" << v130;

  // The validation can fail: the operation in the WMS namespace (1.3.0 has no such element), or
  // before GetMap (both versions fix the order).
  std::string unprefixed = v130;
  for (const std::string tag : {"<sld:GetLegendGraphic>", "</sld:GetLegendGraphic>"}) {
    const auto at = unprefixed.find(tag);
    unprefixed.erase(at + (tag[1] == '/' ? 2 : 1), 4);
  }
  EXPECT_FALSE(test::validateWms(unprefixed, test::WmsDocument::Capabilities130).valid);
  std::string early = v111;
  const std::string block = early.substr(early.find("      <GetLegendGraphic>"),
                                         early.find("</GetLegendGraphic>\n") + 20 -
                                             early.find("      <GetLegendGraphic>"));
  early.erase(early.find(block), block.size());
  early.insert(early.find("      <GetMap>"), block);
  EXPECT_FALSE(test::validateWms(early, test::WmsDocument::Capabilities111).valid) << early;

  // Not offered: not declared, and no sld namespace.
  for (const WmsVersion v : {WmsVersion::V111, WmsVersion::V130}) {
    const std::string plain = capabilitiesXml(v, fixedModel());
    EXPECT_FALSE(contains(plain, "GetLegendGraphic")) << toString(v);
    EXPECT_FALSE(contains(plain, "sld")) << toString(v);
  }
}
