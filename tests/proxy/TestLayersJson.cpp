// /layers.json both ways, through nlohmann-json: written by the page (WebPage.hpp, layersJson) and
// read by a remote renderer (RemoteTileSource.hpp, parseLayersJson). What one writes the other
// reads back to the same values, hostile strings included; hostile documents (deep nesting, huge
// numbers, invalid UTF-8, raw control characters, truncation) are refused with a message.
#include <tellus/proxy/RemoteTileSource.hpp>
#include <tellus/proxy/WebPage.hpp>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <string>
#include <vector>

using namespace tellus;

namespace {

LayerSpec layer(std::string name, GridSpec grid, std::string title = {}) {
  LayerSpec l;
  l.name = std::move(name);
  l.title = std::move(title);
  l.dataset.mimeType = "image/jpeg";
  l.dataset.extension = "jpg";
  l.dataset.grid = grid;
  return l;
}

std::vector<LayerSpec> someLayers() {
  LayerSpec heights = layer("etopo", GridSpec{Sector{-10.5, -20, 30.25, 40}, 22.5, 150, 150, 5});
  heights.elevation = true;
  heights.dataset.body = "moon"; // issue 26: the body travels; absent, the Earth
  heights.firstLevel = 2;
  heights.dataset.mimeType = "application/bil16";
  heights.dataset.extension = "bil";
  // Degrees that are not short in decimal: written shortest round-trip, read back exactly.
  const double third = 180.0 / 3.0 / 7.0;
  LayerSpec odd =
      layer("odd", GridSpec{Sector{-179.9999999, -89.123456789, 0.1, 0.3}, third, 7, 9, 2});
  return {layer("bluemarble", GridSpec{Sector{}, 36.0, 512, 512, 3}, "Blue Marble"), heights, odd};
}

const std::string kValid =
    R"({"title":"t","layers":[{"name":"a","title":"x","format":"image/png",)"
    R"("extension":"png","elevation":true,"levelZeroDelta":45,"tileWidth":256,)"
    R"("tileHeight":128,"levels":3,"firstLevel":0,)"
    R"("sector":{"west":-180,"south":-90,"east":180,"north":90}}]})";

/** kValid with the first `from` replaced by `to`. */
std::string withReplaced(const std::string& from, const std::string& to) {
  std::string s = kValid;
  s.replace(s.find(from), from.size(), to);
  return s;
}

} // namespace

TEST(LayersJson, WhatThePageWritesARemoteReadsBack) {
  const std::vector<LayerSpec> layers = someLayers();
  // The first layer's polar rows and spans given whole (issue 29), the others' not.
  const auto whole = [&](const LayerSpec& l) { return l.name == layers.front().name; };
  const std::string json = layersJson("my cache", layers, whole);
  EXPECT_EQ(json.find("\"wholeRows\":true"), json.rfind("\"wholeRows\":true"));
  EXPECT_EQ(layersJson("my cache", layers).find("wholeRows"), std::string::npos);
  const auto read = parseLayersJson(json, "host:8080");
  ASSERT_TRUE(read) << read.error();
  ASSERT_EQ(read->size(), layers.size());
  for (std::size_t i = 0; i < layers.size(); ++i) {
    SCOPED_TRACE(layers[i].name);
    const RemoteLayer& r = (*read)[i];
    EXPECT_EQ(r.name, layers[i].name);
    EXPECT_EQ(r.elevation, layers[i].elevation);
    EXPECT_EQ(r.wholeRows, i == 0);
    EXPECT_EQ(r.dataset.body, layers[i].dataset.body);
    EXPECT_EQ(r.dataset.server, "host:8080");
    EXPECT_EQ(r.dataset.name, layers[i].name);
    EXPECT_EQ(r.dataset.mimeType, layers[i].dataset.mimeType);
    EXPECT_EQ(r.dataset.extension, layers[i].dataset.extension);
    EXPECT_EQ(r.dataset.grid, layers[i].dataset.grid); // every double bit for bit
  }
}

TEST(LayersJson, EveryByteOfATitleIsValidJsonAndReadsBack) {
  // Each byte value once (NUL and the other controls, quote, backslash, DEL, and the bytes >= 0x80
  // that are not UTF-8 alone), then valid UTF-8 of every length.
  std::string title;
  for (int b = 0; b < 256; ++b)
    title += static_cast<char>(b);
  const std::string utf8 = "m\xc3\xa4p \xe2\x82\xac \xf0\x9f\x8c\x8d";
  const std::vector<LayerSpec> layers{layer("a", GridSpec{Sector{}, 36.0, 8, 8, 1}, title + utf8)};
  const std::string text = layersJson(title + utf8, layers);
  const auto doc = nlohmann::json::parse(text, nullptr, false);
  ASSERT_FALSE(doc.is_discarded()) << "not JSON: " << text;
  const std::string back = doc["title"].get<std::string>();
  EXPECT_EQ(doc["layers"][0]["title"], back);
  // ASCII as it was, the bytes that are not UTF-8 replaced by U+FFFD each, UTF-8 as it was.
  EXPECT_EQ(back.substr(0, 128), title.substr(0, 128));
  std::string replaced;
  for (int b = 128; b < 256; ++b)
    replaced += "\xef\xbf\xbd";
  EXPECT_EQ(back.substr(128), replaced + utf8);
  // Controls are escaped: no raw byte below 0x20 in the document but the line breaks of its layout.
  for (const char c : text)
    EXPECT_TRUE(static_cast<unsigned char>(c) >= 0x20 || c == '\n') << static_cast<int>(c);
  EXPECT_TRUE(parseLayersJson(text, "s")) << "the reader takes what the writer wrote";
}

TEST(LayersJson, HostileDocumentsAreRefusedWithAMessage) {
  ASSERT_TRUE(parseLayersJson(kValid, "s"));
  const auto refused = [](const std::string& text) {
    const auto r = parseLayersJson(text, "s");
    EXPECT_FALSE(r) << text.substr(0, 200);
    return r ? std::string() : r.error();
  };
  // Deep nesting: refused before anything is built (a million levels, no stack, no memory).
  EXPECT_NE(refused(std::string(1'000'000, '[')).find("deep"), std::string::npos);
  EXPECT_NE(refused(std::string(100'000, '{')).find("offset"), std::string::npos);
  std::string deepButClosed = std::string(40, '[') + std::string(40, ']');
  EXPECT_NE(refused(deepButClosed).find("deep"), std::string::npos);
  EXPECT_NE(
      refused(withReplaced("\"x\"", std::string(33, '[') + std::string(33, ']'))).find("deep"),
      std::string::npos);
  // Huge numbers: beyond double (infinite) or beyond the grid's ranges.
  refused(withReplaced("45", "1e999"));
  refused(withReplaced("45", "-1e999"));
  refused(withReplaced("256", "18446744073709551616"));
  refused(withReplaced("256", "1e300"));
  refused(withReplaced("\"levels\":3", "\"levels\":99999999999999999999999"));
  refused(withReplaced("-180", "1e400"));
  refused(withReplaced("256", "256.5"));
  // Invalid UTF-8 and raw control characters inside strings; bad escapes; lone surrogates.
  refused(withReplaced("\"a\"", "\"a\xff\""));
  refused(withReplaced("\"a\"", "\"a\xc3\""));
  refused(withReplaced("\"a\"", "\"\xed\xa0\x80\"")); // a surrogate encoded in UTF-8
  refused(withReplaced("\"x\"", "\"\x01\""));
  refused(withReplaced("\"x\"", "\"a\nb\""));
  refused(withReplaced("\"x\"", "\"\\q\""));
  refused(withReplaced("\"x\"", "\"\\ud800\""));
  refused(withReplaced("\"x\"", "\"\\u12\""));
  // Not JSON around the values: numbers JSON does not have, trailing text, NUL.
  refused(withReplaced("45", "045"));
  refused(withReplaced("45", "+45"));
  refused(withReplaced("45", ".5"));
  refused(withReplaced("45", "NaN"));
  refused(kValid + "x");
  refused(kValid + std::string(1, '\0'));
  refused(kValid + std::string(1, '\0') + "garbage");
  refused(withReplaced("\"x\"", std::string("\"\0\"", 3)));
  // Wrong types.
  refused(withReplaced("\"a\"", "1"));
  refused(withReplaced("45", "\"45\""));
  refused(withReplaced(R"({"west":-180,"south":-90,"east":180,"north":90})", "[-180,-90,180,90]"));
  refused(R"({"layers":{}})");
  refused(R"({"layers":[[]]})");
  // Every truncation of a valid document is refused, and syntax errors say where.
  for (std::size_t n = 0; n < kValid.size(); ++n) {
    const std::string error = refused(kValid.substr(0, n));
    EXPECT_NE(error.find("offset " + std::to_string(n)), std::string::npos) << n << ": " << error;
  }
}

TEST(LayersJson, TheReaderIgnoresWhatItDoesNotNeed) {
  // Members in any order, unknown members, whitespace, escapes: the same layer.
  const std::string text =
      " {\n \"extra\": [1, {\"x\": null}],\r\n\t\"layers\": [{\"sector\": {\"north\": 90, "
      "\"east\": 180, \"south\": -90, \"west\": -180}, \"levels\": 3.0, \"tileHeight\": 128, "
      "\"tileWidth\": 2.56e2, \"levelZeroDelta\": 45, \"extension\": \"png\", \"format\": "
      "\"image\\/png\", \"name\": \"\\u0061\\ud83c\\udf0d\", \"future\": true}]} ";
  const auto r = parseLayersJson(text, "s");
  ASSERT_TRUE(r) << r.error();
  ASSERT_EQ(r->size(), 1u);
  EXPECT_EQ((*r)[0].name, "a\xf0\x9f\x8c\x8d");
  EXPECT_EQ((*r)[0].dataset.mimeType, "image/png");
  EXPECT_FALSE((*r)[0].elevation);
  // "elevation" of another type is not an elevation layer (as before).
  const auto text2 = parseLayersJson(withReplaced("true", "\"true\""), "s");
  ASSERT_TRUE(text2) << text2.error();
  EXPECT_FALSE((*text2)[0].elevation);
  EXPECT_EQ((*r)[0].dataset.grid, (GridSpec{Sector{-180, -90, 180, 90}, 45.0, 256, 128, 3}));
  // A repeated member: the last one counts (as JSON.parse does).
  const auto twice =
      parseLayersJson(withReplaced("\"levels\":3", "\"levels\":1,\"levels\":2"), "s");
  ASSERT_TRUE(twice) << twice.error();
  EXPECT_EQ((*twice)[0].dataset.grid.numLevels, 2);
  const auto none = parseLayersJson(R"({"layers":[]})", "s");
  ASSERT_TRUE(none);
  EXPECT_TRUE(none->empty());
}
