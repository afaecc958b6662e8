// layers[].values (issue 24): value layers (kind: values) and the colouring of elevation layers,
// parsed, defaulted and validated; unknown keys and bad ranges refused with the key's path.

#include <tellus/config/Config.hpp>

#include <gtest/gtest.h>

#include <string>

using namespace tellus;

namespace {

constexpr std::string_view kHead = R"(upstreams:
  - name: up
    type: wms
    url: http://example.org/wms
layers:
)";

std::string layer(std::string_view format, std::string_view kind, std::string_view values) {
  std::string s(kHead);
  s += "  - name: sst\n    upstream: up\n    format: " + std::string(format) +
       "\n    grid:\n      levels: 3\n";
  if (!kind.empty()) s += "    kind: " + std::string(kind) + "\n";
  if (!values.empty()) s += "    values:\n" + std::string(values);
  return s;
}

std::expected<Config, ConfigError> parse(const std::string& yaml) {
  return parseConfig(yaml, "test.yaml", "/base");
}

ConfigError errorOf(const std::string& yaml) {
  auto c = parse(yaml);
  EXPECT_FALSE(c) << "parsed although it should not:\n" << yaml;
  return c ? ConfigError{} : c.error();
}

TEST(ConfigValues, EveryKeyOfAValueLayer) {
  auto c = parse(layer("image/tiff",
                       "values",
                       "      encoding: float32\n"
                       "      scale: 0.01\n"
                       "      offset: -273.15\n"
                       "      no_data: -9999\n"
                       "      unit: \"°C\"\n"
                       "      colour_map: turbo\n"
                       "      styles: [turbo, coolwarm]\n"
                       "      range: [-2, 32]\n"
                       "      scaling: linear\n"
                       "      out_of_range: transparent\n"));
  ASSERT_TRUE(c) << c.error().toString();
  const LayerConfig& l = c->layers[0];
  EXPECT_EQ(l.kind, LayerKind::Values);
  EXPECT_TRUE(l.isValueLayer());
  const ValueSettings& v = l.values;
  EXPECT_EQ(v.format.container, values::Container::Tiff);
  EXPECT_EQ(v.format.encoding, values::Encoding::Float32);
  EXPECT_DOUBLE_EQ(v.format.scale, 0.01);
  EXPECT_DOUBLE_EQ(v.format.offset, -273.15);
  EXPECT_EQ(v.format.noData, -9999.0);
  EXPECT_EQ(v.format.unit, "°C");
  EXPECT_EQ(v.colourMap, "turbo");
  EXPECT_EQ(v.styles, (std::vector<std::string>{"turbo", "coolwarm"}));
  EXPECT_FALSE(v.rangeFromData);
  EXPECT_EQ(v.min, -2.0);
  EXPECT_EQ(v.max, 32.0);
  EXPECT_EQ(v.outOfRange, values::OutOfRange::Transparent);
}

TEST(ConfigValues, DefaultsAndRangeFromData) {
  auto c = parse(layer("application/bil16",
                       "values",
                       "      encoding: uint16\n      byte_order: big\n      range: data\n"
                       "      percentiles: [2, 98]\n      scaling: log\n"));
  ASSERT_TRUE(c) << c.error().toString();
  const ValueSettings& v = c->layers[0].values;
  EXPECT_EQ(v.format.container, values::Container::Bil);
  EXPECT_EQ(v.format.byteOrder, values::ByteOrder::Big);
  EXPECT_FALSE(v.format.noData);
  EXPECT_EQ(v.colourMap, "viridis");
  EXPECT_TRUE(v.styles.empty()); // all maps
  EXPECT_TRUE(v.rangeFromData);
  EXPECT_EQ(v.lowPercent, 2.0);
  EXPECT_EQ(v.highPercent, 98.0);
  EXPECT_EQ(v.scaling, values::Scaling::Log);
}

TEST(ConfigValues, ElevationLayersAreValueLayersInMetres) {
  auto plain = parse(layer("application/bil16", "", ""));
  ASSERT_TRUE(plain) << plain.error().toString();
  const LayerConfig& e = plain->layers[0];
  EXPECT_EQ(e.kind, LayerKind::Elevation);
  EXPECT_TRUE(e.isValueLayer());
  EXPECT_EQ(e.values.format.unit, "m");
  EXPECT_EQ(e.values.format.noData, -32768.0);
  EXPECT_EQ(e.values.colourMap, "terrain");
  EXPECT_EQ(e.values.min, -8000.0);
  auto styled =
      parse(layer("image/png", "elevation", "      colour_map: cividis\n      range: [0, 5000]\n"));
  ASSERT_TRUE(styled) << styled.error().toString();
  EXPECT_EQ(styled->layers[0].values.colourMap, "cividis");
  const values::ValueFormat& png = styled->layers[0].values.format;
  EXPECT_EQ(png.container, values::Container::Png);
  // tellus's 16-bit PNG heights are height + 32768.
  EXPECT_EQ(png.encoding, values::Encoding::UInt16);
  EXPECT_EQ(png.offset, -32768.0);
  EXPECT_EQ(png.noData, 0.0);
  EXPECT_EQ(styled->layers[0].values.max, 5000.0);
}

TEST(ConfigValues, ImageryIsNoValueLayer) {
  auto c = parse(layer("image/jpeg", "", ""));
  ASSERT_TRUE(c);
  EXPECT_FALSE(c->layers[0].isValueLayer());
  const auto e = errorOf(layer("image/jpeg", "", "      range: [0, 1]\n"));
  EXPECT_EQ(e.key, "layers[0].values");
  EXPECT_NE(e.message.find("value and elevation layers only"), std::string::npos) << e.message;
}

TEST(ConfigValues, MistakesAreRefusedWithTheirKey) {
  struct Case {
    std::string format, kind, values, key, words;
  };
  const std::vector<Case> cases = {
      {"image/tiff", "values", "", "layers[0].values", "needs 'values'"},
      {"image/tiff", "values", "      unit: m\n", "layers[0].values.range", "needs range"},
      {"image/tiff", "values", "      range: [1, 1]\n", "layers[0].values.range", "less than"},
      {"image/tiff", "values", "      range: [0, 1, 2]\n", "layers[0].values.range", "[min, max]"},
      {"image/tiff", "values", "      range: all\n", "layers[0].values.range", "'data'"},
      {"image/tiff",
       "values",
       "      range: [0, 10]\n      scaling: log\n",
       "layers[0].values.range",
       "above 0"},
      {"image/tiff",
       "values",
       "      range: [0, 1]\n      percentiles: [2, 98]\n",
       "layers[0].values.percentiles",
       "range: data"},
      {"image/tiff",
       "values",
       "      range: data\n      percentiles: [50, 20]\n",
       "layers[0].values.percentiles",
       "low < high"},
      {"image/tiff",
       "values",
       "      range: [0, 1]\n      colour_map: jet\n",
       "layers[0].values.colour_map",
       "unknown colour map 'jet' (known: viridis, magma"},
      {"image/tiff",
       "values",
       "      range: [0, 1]\n      styles: [magma]\n",
       "layers[0].values.styles",
       "must be one of the styles"},
      {"image/tiff",
       "values",
       "      range: [0, 1]\n      styles: [viridis, viridis]\n",
       "layers[0].values.styles[1]",
       "twice"},
      {"image/tiff",
       "values",
       "      range: [0, 1]\n      colour: red\n",
       "layers[0].values.colour",
       ""},
      {"image/tiff",
       "values",
       "      range: [0, 1]\n      scale: 0\n",
       "layers[0].values.scale",
       "not be 0"},
      {"image/tiff",
       "values",
       "      range: [0, 1]\n      encoding: int32\n",
       "layers[0].values.encoding",
       ""},
      {"image/tiff",
       "values",
       "      range: [0, 1]\n      out_of_range: wrap\n",
       "layers[0].values.out_of_range",
       ""},
      {"image/jpeg", "values", "      range: [0, 1]\n", "layers[0].format", "needs application"},
      {"image/png",
       "values",
       "      range: [0, 1]\n      encoding: float32\n",
       "layers[0].values.encoding",
       "image/tiff only"},
      {"application/bil16",
       "elevation",
       "      unit: ft\n",
       "layers[0].values.unit",
       "under 'elevation'"},
  };
  for (const Case& k : cases) {
    SCOPED_TRACE(k.values);
    const ConfigError e = errorOf(layer(k.format, k.kind, k.values));
    EXPECT_EQ(e.key, k.key) << e.toString();
    EXPECT_NE(e.message.find(k.words), std::string::npos) << e.toString();
    EXPECT_GT(e.line, 0) << e.toString();
  }
}

TEST(ConfigValues, ValidateChecksConfigurationsBuiltInCode) {
  auto c = parse(layer("image/tiff", "values", "      range: [0, 1]\n"));
  ASSERT_TRUE(c);
  Config bad = *c;
  bad.layers[0].values.min = 2.0;
  auto r = validate(bad);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("values.range"), std::string::npos) << r.error();
  bad = *c;
  bad.layers[0].values.colourMap = "nope";
  EXPECT_FALSE(validate(bad));
  bad = *c;
  bad.layers[0].values.format.unit = "a\nb";
  EXPECT_FALSE(validate(bad));
}

} // namespace
