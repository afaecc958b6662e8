// The page at / (proxy/src/web/WebPage.cpp): the embedded files, their HTTP caching and
// compression, and /layers.json. The page in a browser is tests/web/test_page.mjs.
#include <tellus/proxy/WebPage.hpp>

#include <gtest/gtest.h>

#include <string>
#include <string_view>
#include <vector>

using namespace tellus;

namespace {

HttpRequest get(std::string path, std::vector<std::pair<std::string, std::string>> headers = {}) {
  HttpRequest r;
  r.method = "GET";
  r.target = path;
  r.path = std::move(path);
  r.headers = std::move(headers);
  return r;
}

std::string header(const HttpResponse& r, std::string_view name) {
  for (const auto& [k, v] : r.headers) {
    if (k == name) return v;
  }
  return "";
}

std::string body(const HttpResponse& r) {
  return std::string(reinterpret_cast<const char*>(r.body.data()), r.body.size());
}

} // namespace

TEST(WebPage, PathsOfThePage) {
  for (const char* p : {"/", "/app.js", "/app.css", "/licenses.txt", "/layers.json", "/index.txt"})
    EXPECT_TRUE(isWebPagePath(p)) << p;
  for (const char* p : {"", "/index.html", "/app.js/", "/wms", "/tiles/a/0/0/0_0.jpg", "/metrics"})
    EXPECT_FALSE(isWebPagePath(p)) << p;
}

TEST(WebPage, EmbeddedFilesWithTypeValidatorAndCaching) {
  if (!webPageEmbedded()) GTEST_SKIP() << "built with TELLUS_WEB_PAGE=OFF";
  const auto html = webAssetResponse(get("/"));
  ASSERT_TRUE(html);
  EXPECT_EQ(html->status, 200);
  EXPECT_EQ(header(*html, "Content-Type"), "text/html; charset=utf-8");
  EXPECT_EQ(header(*html, "Cache-Control"), "no-cache");
  EXPECT_EQ(header(*html, "Content-Encoding"), "");
  const std::string page = body(*html);
  EXPECT_TRUE(page.starts_with("<!doctype html>")) << page.substr(0, 40);
  // The bundle is named with its content hash (build.mjs), so it may be kept a day.
  EXPECT_NE(page.find("app.js?v="), std::string::npos);
  EXPECT_NE(page.find("app.css?v="), std::string::npos);
  // Nothing from the internet.
  EXPECT_EQ(page.find("http://"), std::string::npos);
  EXPECT_EQ(page.find("https://"), std::string::npos);

  const auto js = webAssetResponse(get("/app.js"));
  ASSERT_TRUE(js);
  EXPECT_EQ(header(*js, "Content-Type"), "text/javascript; charset=utf-8");
  EXPECT_EQ(header(*js, "Cache-Control"), "public, max-age=86400");
  EXPECT_GT(js->body.size(), 50000u) << "OpenLayers is in the bundle";
  const auto css = webAssetResponse(get("/app.css"));
  ASSERT_TRUE(css);
  EXPECT_EQ(header(*css, "Content-Type"), "text/css; charset=utf-8");
  EXPECT_NE(body(*css).find(".ol-"), std::string::npos) << "ol.css is in the bundle";
  const auto licenses = webAssetResponse(get("/licenses.txt"));
  ASSERT_TRUE(licenses);
  EXPECT_NE(body(*licenses).find("==== ol "), std::string::npos);

  EXPECT_FALSE(webAssetResponse(get("/layers.json"))) << "not a file: made per request";
  EXPECT_FALSE(webAssetResponse(get("/index.txt")));
  EXPECT_FALSE(webAssetResponse(get("/nothing")));
}

TEST(WebPage, RevalidationAndGzip) {
  if (!webPageEmbedded()) GTEST_SKIP() << "built with TELLUS_WEB_PAGE=OFF";
  const auto plain = webAssetResponse(get("/app.js"));
  ASSERT_TRUE(plain);
  const std::string etag = header(*plain, "ETag");
  ASSERT_EQ(etag.size(), 18u) << etag;
  EXPECT_EQ(header(*plain, "Vary"), "Accept-Encoding");

  const auto again = webAssetResponse(get("/app.js", {{"if-none-match", etag}}));
  ASSERT_TRUE(again);
  EXPECT_EQ(again->status, 304);
  EXPECT_TRUE(again->body.empty());

  const auto gz = webAssetResponse(get("/app.js", {{"accept-encoding", "br, gzip;q=0.8"}}));
  ASSERT_TRUE(gz);
  EXPECT_EQ(gz->status, 200);
  EXPECT_EQ(header(*gz, "Content-Encoding"), "gzip");
  ASSERT_GT(gz->body.size(), 2u);
  EXPECT_EQ(gz->body[0], std::byte{0x1f}); // gzip magic
  EXPECT_EQ(gz->body[1], std::byte{0x8b});
  EXPECT_LT(gz->body.size(), plain->body.size() / 2);
  EXPECT_NE(header(*gz, "ETag"), etag) << "each encoding has its own strong validator";
  // The other encoding's validator does not make a 304.
  EXPECT_EQ(webAssetResponse(get("/app.js", {{"if-none-match", etag}, {"accept-encoding", "gzip"}}))
                ->status,
            200);

  for (const char* refused : {"gzip;q=0", "gzip; q=0.000", "identity", "deflate, br", ""}) {
    const auto r = webAssetResponse(get("/app.js", {{"accept-encoding", refused}}));
    ASSERT_TRUE(r);
    EXPECT_EQ(header(*r, "Content-Encoding"), "") << refused;
  }
  for (const char* accepted : {"GZIP", "x-gzip", "*", "deflate, gzip;q=0.5"}) {
    const auto r = webAssetResponse(get("/app.js", {{"accept-encoding", accepted}}));
    ASSERT_TRUE(r);
    EXPECT_EQ(header(*r, "Content-Encoding"), "gzip") << accepted;
  }
}

TEST(WebPage, LayersJsonDescribesEachGridAndEscapesStrings) {
  LayerSpec a;
  a.name = "bluemarble";
  a.title = "Blue \"Marble\"\n\\ \x01 m\xc3\xa4p";
  a.dataset.mimeType = "image/jpeg";
  a.dataset.extension = "jpg";
  a.dataset.grid = GridSpec{Sector{-180, -90, 180, 90}, 36.0, 512, 512, 3};
  LayerSpec e;
  e.name = "etopo";
  e.elevation = true;
  e.firstLevel = 1;
  e.dataset.mimeType = "application/bil16";
  e.dataset.extension = "bil";
  e.dataset.grid = GridSpec{Sector{-10.5, -20, 30.25, 40}, 22.5, 150, 150, 5};
  const std::vector<LayerSpec> layers{a, e};
  const std::string j = layersJson("my \"cache\"", layers);
  EXPECT_EQ(
      j,
      "{\"title\":\"my \\\"cache\\\"\",\"layers\":[\n"
      "{\"name\":\"bluemarble\",\"title\":\"Blue \\\"Marble\\\"\\n\\\\ \\u0001 m\xc3\xa4p\","
      "\"format\":\"image/jpeg\",\"extension\":\"jpg\",\"elevation\":false,\"body\":\"earth\","
      "\"levelZeroDelta\":36,\"tileWidth\":512,\"tileHeight\":512,\"levels\":3,"
      "\"firstLevel\":0,\"sector\":{\"west\":-180,\"south\":-90,\"east\":180,\"north\":90}},\n"
      "{\"name\":\"etopo\",\"title\":\"etopo\",\"format\":\"application/bil16\","
      "\"extension\":\"bil\",\"elevation\":true,\"body\":\"earth\",\"levelZeroDelta\":22.5,"
      "\"tileWidth\":150,"
      "\"tileHeight\":150,\"levels\":5,\"firstLevel\":1,"
      "\"sector\":{\"west\":-10.5,\"south\":-20,\"east\":30.25,\"north\":40}}\n"
      "]}\n");
  EXPECT_EQ(layersJson("t", {}), "{\"title\":\"t\",\"layers\":[\n]}\n");

  const HttpResponse r = layersJsonResponse(get("/layers.json"), "my \"cache\"", layers);
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(header(r, "Content-Type"), "application/json");
  EXPECT_EQ(header(r, "Cache-Control"), "no-cache");
  EXPECT_EQ(body(r), j);
  const HttpResponse again = layersJsonResponse(
      get("/layers.json", {{"if-none-match", header(r, "ETag")}}), "my \"cache\"", layers);
  EXPECT_EQ(again.status, 304);
}
