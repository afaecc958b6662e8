#include "../support/WmsSchemas.hpp"

#include <tellus/proxy/OgcExceptionFormat.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>

using namespace tellus;

namespace {

bool haveXmllint() {
  return std::system("command -v xmllint >/dev/null 2>&1") == 0;
}

// xmllint's well-formedness verdict (no network); true when xmllint is absent.
bool xmllintAccepts(const std::string& xml) {
  if (!haveXmllint()) return true;
  FILE* pipe = ::popen("xmllint --noout --nonet - 2>&1", "w");
  if (pipe == nullptr) return false;
  std::fwrite(xml.data(), 1, xml.size(), pipe);
  return ::pclose(pipe) == 0;
}

// Exactly one <ServiceException ...>...</ServiceException> and nothing that looks like markup in
// the message.
void expectOneException(const std::string& body) {
  const std::size_t open = body.find("<ServiceException ");
  ASSERT_NE(open, std::string::npos) << body;
  EXPECT_EQ(body.find("<ServiceException ", open + 1), std::string::npos) << body;
  const std::size_t close = body.find("</ServiceException>");
  ASSERT_NE(close, std::string::npos) << body;
  EXPECT_EQ(body.find("</ServiceException>", close + 1), std::string::npos) << body;
  const std::size_t textStart = body.find('>', open) + 1;
  const std::string text = body.substr(textStart, close - textStart);
  EXPECT_EQ(text.find('<'), std::string::npos) << text;
}

const OgcException kLayer{std::string(ogc::kLayerNotDefined), "LAYERS", "no layer 'x<y>'"};

} // namespace

TEST(OgcException, Version130Report) {
  const FormattedResponse r = formatWmsException(WmsVersion::V130, kLayer, false);
  EXPECT_EQ(r.httpStatus, 200);
  EXPECT_EQ(r.contentType, "text/xml");
  EXPECT_EQ(r.body,
            "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
            "<ServiceExceptionReport version=\"1.3.0\" xmlns=\"http://www.opengis.net/ogc\" "
            "xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\" "
            "xsi:schemaLocation=\"http://www.opengis.net/ogc "
            "http://schemas.opengis.net/wms/1.3.0/exceptions_1_3_0.xsd\">\n"
            "  <ServiceException code=\"LayerNotDefined\" locator=\"LAYERS\">no layer "
            "&apos;x&lt;y&gt;&apos;</ServiceException>\n"
            "</ServiceExceptionReport>\n");
  EXPECT_TRUE(xmllintAccepts(r.body));
}

TEST(OgcException, Version111Report) {
  const OgcException e{std::string(ogc::kInvalidSrs), "SRS", "SRS 'EPSG:3857' is not supported"};
  const FormattedResponse r = formatWmsException(WmsVersion::V111, e, false);
  EXPECT_EQ(r.httpStatus, 200);
  EXPECT_EQ(r.contentType, "application/vnd.ogc.se_xml");
  EXPECT_EQ(r.body,
            "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
            "<!DOCTYPE ServiceExceptionReport SYSTEM "
            "\"http://schemas.opengis.net/wms/1.1.1/WMS_exception_1_1_1.dtd\">\n"
            "<ServiceExceptionReport version=\"1.1.1\">\n"
            "  <ServiceException code=\"InvalidSRS\">SRS &apos;EPSG:3857&apos; "
            "is not supported</ServiceException>\n"
            "</ServiceExceptionReport>\n");
  EXPECT_TRUE(xmllintAccepts(r.body));
}

TEST(OgcException, EmptyCodeAndLocatorAreOmitted) {
  const FormattedResponse r =
      formatWmsException(WmsVersion::V130, OgcException{"", "", "something failed"}, false);
  EXPECT_NE(r.body.find("<ServiceException>something failed</ServiceException>"), std::string::npos)
      << r.body;
  EXPECT_EQ(r.httpStatus, 200);
  EXPECT_EQ(formatWmsException(WmsVersion::V130, OgcException{"", "", "x"}, true).httpStatus, 500);
}

TEST(OgcException, OptInHttpStatusCodes) {
  for (const std::string_view code : {ogc::kLayerNotDefined,
                                      ogc::kInvalidCrs,
                                      ogc::kInvalidSrs,
                                      ogc::kInvalidFormat,
                                      ogc::kStyleNotDefined,
                                      ogc::kMissingDimensionValue,
                                      ogc::kInvalidDimensionValue,
                                      ogc::kMissingParameterValue,
                                      ogc::kInvalidParameterValue,
                                      ogc::kInvalidUpdateSequence,
                                      ogc::kCurrentUpdateSequence}) {
    const OgcException e{std::string(code), "X", "m"};
    EXPECT_EQ(formatWmsException(WmsVersion::V130, e, true).httpStatus, 400) << code;
    EXPECT_EQ(formatWmsException(WmsVersion::V111, e, false).httpStatus, 200) << code;
  }
  EXPECT_EQ(formatWmsException(
                WmsVersion::V130, {std::string(ogc::kOperationNotSupported), "REQUEST", "m"}, true)
                .httpStatus,
            501);
  EXPECT_EQ(
      formatWmsException(WmsVersion::V111, {std::string(ogc::kNoApplicableCode), "", "m"}, true)
          .httpStatus,
      500);
  EXPECT_EQ(wmsExceptionHttpStatus("SomethingElse"), 500);
}

TEST(OgcException, SanitizeRemovesUrlsAndPaths) {
  EXPECT_EQ(sanitizeForClient("curl failed to request url "
                              "http://127.0.0.1:8081/cgi-bin/mapserv?map=/srv/w.map&x=1: timeout"),
            "curl failed to request url [url]: timeout");
  EXPECT_EQ(sanitizeForClient("cannot open /var/cache/tellus/bmng-1a2b/0/0/0_0.jpg."),
            "cannot open [path].");
  EXPECT_EQ(sanitizeForClient("upstream HTTPS://Example.com/wms said no"),
            "upstream [url] said no");
  EXPECT_EQ(sanitizeForClient("see (/etc/tellus.yaml) and '/tmp/x'"), "see ([path]) and '[path]'");
  EXPECT_EQ(sanitizeForClient("file=/tmp/x,y"), "file=[path]");
  EXPECT_EQ(sanitizeForClient("at C:\\data\\world.tif and D:/x"), "at [path] and [path]");
  EXPECT_EQ(sanitizeForClient("~/secret/key"), "[path]");
  EXPECT_EQ(sanitizeForClient("\\\\server\\share\\x"), "[path]");
  EXPECT_EQ(sanitizeForClient("file:///etc/passwd"), "[url]");
  EXPECT_EQ(sanitizeForClient("file:/etc/passwd"), "file:[path]");
  EXPECT_EQ(sanitizeForClient("s3+https://bucket/key x"), "[url] x");
  // Not paths or URLs.
  for (const char* keep : {"FORMAT image/png is not offered",
                           "1/2 of the tiles",
                           "a / b",
                           "EPSG:4326 and CRS:84",
                           "BBOX must be minx,miny,maxx,maxy",
                           "ratio 3/4",
                           "no:colon//slashes",
                           ""}) {
    EXPECT_EQ(sanitizeForClient(keep), keep);
  }
}

TEST(OgcException, FormattedMessagesAreSanitized) {
  const OgcException e{std::string(ogc::kNoApplicableCode),
                       "",
                       "upstream http://10.0.0.7:8081/wms?key=SECRET failed; cached file "
                       "/var/cache/tellus/a/b.png unreadable"};
  for (const WmsVersion v : {WmsVersion::V111, WmsVersion::V130}) {
    const FormattedResponse r = formatWmsException(v, e, false);
    EXPECT_EQ(r.body.find("10.0.0.7"), std::string::npos) << r.body;
    EXPECT_EQ(r.body.find("SECRET"), std::string::npos) << r.body;
    EXPECT_EQ(r.body.find("/var/cache"), std::string::npos) << r.body;
    EXPECT_NE(r.body.find("upstream [url] failed; cached file [path] unreadable"),
              std::string::npos)
        << r.body;
  }
  const FormattedResponse loc =
      formatWmsException(WmsVersion::V130,
                         OgcException{std::string(ogc::kLayerNotDefined), "/etc/passwd", "m"},
                         false);
  EXPECT_NE(loc.body.find("locator=\"[path]\""), std::string::npos) << loc.body;
}

TEST(OgcExceptionExtremes, HostileMessagesStayInsideOneElement) {
  const std::string injection =
      "x</ServiceException><ServiceException code=\"Evil\">y]]><!-- \"'&amp;\x01\x02\xFF\xC0\xAF";
  for (const WmsVersion v : {WmsVersion::V111, WmsVersion::V130}) {
    const FormattedResponse r =
        formatWmsException(v, OgcException{"Code\"<>", "LOC\"<", injection}, false);
    expectOneException(r.body);
    EXPECT_TRUE(xmllintAccepts(r.body)) << r.body;
    EXPECT_EQ(r.body.find("code=\"Evil\""), std::string::npos);
  }
}

TEST(OgcExceptionExtremes, HugeMessagesAreCut) {
  std::string huge;
  for (int i = 0; i < 5000; ++i)
    huge += "\xE5\x9C\xB0"; // 15000 bytes of a 3-byte character
  const FormattedResponse r =
      formatWmsException(WmsVersion::V130, OgcException{"NoApplicableCode", "", huge}, false);
  EXPECT_LT(r.body.size(), kMaxClientMessageBytes + 600);
  EXPECT_NE(r.body.find("...</ServiceException>"), std::string::npos);
  // No character was split into '?' replacements: the only '?' are the XML declaration's.
  EXPECT_EQ(std::count(r.body.begin(), r.body.end(), '?'), 2);
  EXPECT_TRUE(xmllintAccepts(r.body));
  const std::string longLocator(5000, 'L');
  const FormattedResponse l =
      formatWmsException(WmsVersion::V111, OgcException{"X", longLocator, "m"}, false);
  EXPECT_LT(l.body.size(), 600u);
}

TEST(OgcExceptionExtremes, SanitizeHandlesEdgeInputs) {
  EXPECT_EQ(sanitizeForClient("/"), "/");
  EXPECT_EQ(sanitizeForClient("/x"), "[path]");
  EXPECT_EQ(sanitizeForClient("http://"), "[url]");
  EXPECT_EQ(sanitizeForClient("://"), ":[path]"); // over-removal is harmless
  EXPECT_EQ(sanitizeForClient("a:"), "a:");
  EXPECT_EQ(sanitizeForClient("~"), "~");
  EXPECT_EQ(sanitizeForClient(std::string(10000, 'a') + "://x"), "[url]");
  EXPECT_EQ(sanitizeForClient(std::string(3, '/')), "[path]");
  const std::string many = [] {
    std::string s;
    for (int i = 0; i < 2000; ++i)
      s += " /p" + std::to_string(i);
    return s;
  }();
  const std::string out = sanitizeForClient(many);
  EXPECT_EQ(out.find("/p"), std::string::npos);
}

// Every code tellus may send, in both versions, valid against the official DTD / XSD
// (WMS_exception_1_1_1.dtd declares no locator attribute; exceptions_1_3_0.xsd does).
TEST(OgcExceptionSchemas, EveryCodeOfBothVersionsIsValid) {
  for (const std::string_view code : {ogc::kLayerNotDefined,
                                      ogc::kInvalidCrs,
                                      ogc::kInvalidSrs,
                                      ogc::kInvalidFormat,
                                      ogc::kStyleNotDefined,
                                      ogc::kLayerNotQueryable,
                                      ogc::kInvalidPoint,
                                      ogc::kMissingDimensionValue,
                                      ogc::kInvalidDimensionValue,
                                      ogc::kOperationNotSupported,
                                      ogc::kMissingParameterValue,
                                      ogc::kInvalidParameterValue,
                                      ogc::kInvalidUpdateSequence,
                                      ogc::kCurrentUpdateSequence,
                                      ogc::kNoApplicableCode,
                                      std::string_view()}) {
    for (const std::string_view locator : {std::string_view("LAYERS"), std::string_view()}) {
      const OgcException e{std::string(code), std::string(locator), "x < y & \"z\" 'w'"};
      const auto v111 = test::validateWms(formatWmsException(WmsVersion::V111, e, false).body,
                                          test::WmsDocument::Exception111);
      EXPECT_TRUE(v111.valid) << code << " " << locator << "\n" << v111.output;
      const auto v130 = test::validateWms(formatWmsException(WmsVersion::V130, e, true).body,
                                          test::WmsDocument::Exception130);
      EXPECT_TRUE(v130.valid) << code << " " << locator << "\n" << v130.output;
    }
  }
}

// The validation can fail: what the 1.1.1 DTD does not declare, or a 1.3.0 report in the wrong
// namespace, is refused.
TEST(OgcExceptionSchemas, TheValidationRefusesWhatTheSchemasDoNotAllow) {
  const std::string withLocator =
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<!DOCTYPE ServiceExceptionReport SYSTEM "
      "\"http://schemas.opengis.net/wms/1.1.1/WMS_exception_1_1_1.dtd\">\n"
      "<ServiceExceptionReport version=\"1.1.1\">\n"
      "  <ServiceException code=\"LayerNotDefined\" locator=\"LAYERS\">m</ServiceException>\n"
      "</ServiceExceptionReport>\n";
  const auto refused = test::validateWms(withLocator, test::WmsDocument::Exception111);
  EXPECT_FALSE(refused.valid);
  EXPECT_NE(refused.output.find("locator"), std::string::npos) << refused.output;
  std::string withoutLocator = withLocator;
  withoutLocator.erase(withoutLocator.find(" locator=\"LAYERS\""), 17);
  const auto accepted = test::validateWms(withoutLocator, test::WmsDocument::Exception111);
  EXPECT_TRUE(accepted.valid) << accepted.output;
  // Version 1.1.1 is fixed by the DTD.
  std::string wrongVersion = withoutLocator;
  wrongVersion.replace(wrongVersion.find("version=\"1.1.1\""), 15, "version=\"1.3.0\"");
  EXPECT_FALSE(test::validateWms(wrongVersion, test::WmsDocument::Exception111).valid);
  // A 1.3.0 report outside the http://www.opengis.net/ogc namespace.
  std::string v130 = formatWmsException(WmsVersion::V130, kLayer, false).body;
  EXPECT_TRUE(test::validateWms(v130, test::WmsDocument::Exception130).valid);
  v130.replace(v130.find("xmlns=\"http://www.opengis.net/ogc\""), 35, "xmlns=\"urn:x\"");
  EXPECT_FALSE(test::validateWms(v130, test::WmsDocument::Exception130).valid);
}
