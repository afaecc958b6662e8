// Configurations at and beyond the limits: huge numbers, deep nesting, giant files, long keys,
// time periods with too many values, odd bytes. Nothing may crash, hang or throw.

#include "../support/TempDir.hpp"

#include <tellus/config/Config.hpp>

#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <string>

using namespace tellus;
namespace fs = std::filesystem;

namespace {

constexpr std::string_view kUpstream = R"(upstreams:
  - name: up
    type: wms
    url: http://example.org/wms
)";

std::string layerWith(std::string_view extra, std::string_view grid = "levels: 1") {
  return std::string(kUpstream) +
         "layers:\n  - name: a\n    upstream: up\n    format: image/png\n" + "    grid: {" +
         std::string(grid) + "}\n" + std::string(extra);
}

std::expected<Config, ConfigError> parse(std::string_view yaml) {
  return parseConfig(yaml, "x.yaml", "/base");
}

} // namespace

TEST(ConfigExtremes, NumbersAtTheEdges) {
  // The deepest grid the cache allows (levels 0..30) is fine; one more is not.
  EXPECT_TRUE(parse(layerWith("", "levels: 31")));
  EXPECT_FALSE(parse(layerWith("", "levels: 32")));
  EXPECT_FALSE(parse(layerWith("", "levels: -1")));
  EXPECT_FALSE(parse(layerWith("", "levels: 2147483648")));
  EXPECT_FALSE(parse(layerWith("", "levels: -9223372036854775809")));
  EXPECT_FALSE(parse(layerWith("", "levels: 0x10")));
  EXPECT_FALSE(parse(layerWith("", "levels: 1e1")));
  EXPECT_FALSE(parse(layerWith("", "levels: ''")));
  EXPECT_TRUE(parse(layerWith("", "levels: +3")));
  EXPECT_TRUE(parse(layerWith("", "levels: 1, tile_size: 65536")));
  EXPECT_FALSE(parse(layerWith("", "levels: 1, tile_size: 65537")));
  EXPECT_FALSE(parse(layerWith("", "levels: 1, tile_size: [512]")));
  EXPECT_FALSE(parse(layerWith("", "levels: 1, tile_size: -512")));
  EXPECT_FALSE(parse(layerWith("", "levels: 1, level_zero_delta: 1e-300")));
  EXPECT_FALSE(parse(layerWith("", "levels: 1, level_zero_delta: 1e999")));
  EXPECT_FALSE(parse(layerWith("", "levels: 1, level_zero_delta: 0")));
  EXPECT_FALSE(parse(layerWith("", "levels: 1, level_zero_delta: 360")));
  EXPECT_TRUE(parse(layerWith("", "levels: 1, level_zero_delta: 180")));
  EXPECT_TRUE(parse(layerWith("", "levels: 1, sector: [-180, -90, 180, 90]")));
  EXPECT_TRUE(parse(layerWith("", "levels: 1, sector: [-0.0, 0, 1e-9, 1e-9]")));
  EXPECT_FALSE(parse(layerWith("", "levels: 1, sector: [-180, -90.0000001, 180, 90]")));
  EXPECT_FALSE(parse(layerWith("", "levels: 1, sector: [.inf, -90, 180, 90]")));
  EXPECT_FALSE(parse(layerWith("", "levels: 1, sector: [.NaN, .NaN, .NaN, .NaN]")));
  EXPECT_FALSE(parse(layerWith("", "levels: 1, sector: [0, 0, 0, 0]")));
  EXPECT_FALSE(parse(layerWith("", "levels: 1, sector: [170, -10, -170, 10]")));
  // first_level + levels must stay within the cache's 31 levels (worldwind only).
  std::string ww(layerWith("", "levels: 11, first_level: 20"));
  ww.replace(ww.find("type: wms"), 9, "type: worldwind");
  EXPECT_TRUE(parse(ww));
  std::string wwDeep(layerWith("", "levels: 11, first_level: 21"));
  wwDeep.replace(wwDeep.find("type: wms"), 9, "type: worldwind");
  const auto deep = parse(wwDeep);
  ASSERT_FALSE(deep);
  EXPECT_EQ(deep.error().key, "layers[0].grid.first_level");
  EXPECT_FALSE(parse(layerWith("", "levels: 1, first_level: -1")));
}

TEST(ConfigExtremes, DurationsAndSizesThatOverflow) {
  EXPECT_TRUE(parseDurationText("106751991167d"));  // still fits 64-bit milliseconds
  EXPECT_FALSE(parseDurationText("106751991168d")); // does not
  EXPECT_FALSE(parseDurationText("99999999999999999999ms"));
  EXPECT_EQ(parseDurationText("9223372036854775807ms"),
            std::chrono::milliseconds(9223372036854775807LL));
  EXPECT_FALSE(parseDurationText("9223372036854775808ms"));
  EXPECT_EQ(parseSizeText("18446744073709551615"), 18446744073709551615ULL);
  EXPECT_FALSE(parseSizeText("18446744073709551616"));
  EXPECT_FALSE(parseSizeText("16777216TiB"));
  EXPECT_TRUE(parseSizeText("16777215TiB"));
  const auto e = parse("cache: {size_limit: 99999999999TiB}\n" + layerWith(""));
  ASSERT_FALSE(e);
  EXPECT_EQ(e.error().key, "cache.size_limit");
  EXPECT_EQ(e.error().line, 1);
  const auto t = parse(layerWith("    cache: {ttl: 999999999999999999d}\n"));
  ASSERT_FALSE(t);
  EXPECT_EQ(t.error().key, "layers[0].cache.ttl");
}

TEST(ConfigExtremes, LimitsOutOfRange) {
  const auto check = [](std::string_view limits, std::string_view key) {
    const auto c = parse("server: {limits: {" + std::string(limits) + "}}\n" + layerWith(""));
    ASSERT_FALSE(c) << limits;
    EXPECT_EQ(c.error().key, key) << limits;
    EXPECT_EQ(c.error().line, 1) << limits;
  };
  check("max_connections: 0", "server.limits.max_connections");
  check("max_header_bytes: 10", "server.limits.max_header_bytes");
  check("max_header_bytes: 2MiB", "server.limits.max_header_bytes");
  check("max_param_bytes: 32KiB", "server.limits.max_param_bytes");
  check("max_width: 0", "server.limits.max_width");
  check("max_height: 70000", "server.limits.max_height");
  check("request_timeout: 0s", "server.limits.request_timeout");
  check("requests_per_second: -1", "server.limits.requests_per_second");
  check("requests_per_second: .inf", "server.limits.requests_per_second");
  const auto ok =
      parse("server: {limits: {max_header_bytes: 1MiB, max_param_bytes: 1MiB}}\n" + layerWith(""));
  EXPECT_TRUE(ok) << ok.error().toString();
}

TEST(ConfigExtremes, ServerThreadsOutOfRange) {
  for (const char* bad : {"-1", "257", "1e9", "two"}) {
    const auto c = parse("server: {threads: " + std::string(bad) + "}\n" + layerWith(""));
    ASSERT_FALSE(c) << bad;
    EXPECT_EQ(c.error().key, "server.threads") << bad;
    EXPECT_EQ(c.error().line, 1) << bad;
  }
  for (const char* good : {"0", "1", "256"}) {
    const auto c = parse("server: {threads: " + std::string(good) + "}\n" + layerWith(""));
    ASSERT_TRUE(c) << good << ": " << c.error().toString();
    EXPECT_EQ(c->server.threads, std::stoi(good));
  }
}

TEST(ConfigExtremes, UpstreamCountsOutOfRange) {
  const auto check = [](std::string_view key, std::string_view value) {
    std::string yaml = layerWith("");
    yaml.insert(yaml.find("layers:"), "    " + std::string(key) + ": " + std::string(value) + "\n");
    const auto c = parse(yaml);
    ASSERT_FALSE(c) << key << " " << value;
    EXPECT_EQ(c.error().key, "upstreams[0]." + std::string(key));
    EXPECT_EQ(c.error().line, 5);
  };
  check("max_connections", "0");
  check("max_connections", "100000");
  check("retries", "-1");
  check("failure_threshold", "0");
  check("connect_timeout", "0s");
  check("timeout", "0");
  check("open_interval", "0ms");
  check("max_retry_after_wait", "-1s");
  check("version", "1.0.0");
  check("crs", "EPSG:3857");
  check("meta_tiles", "0");
  check("meta_tiles", "17");
}

TEST(ConfigExtremes, TimePeriodsWithTooManyValuesStayPeriods) {
  // 10000 values are expanded, 10001 are not (the period alone describes them).
  const auto exact =
      parse(layerWith("    time: {period: 2000-01-01T00:00:00Z/2000-01-07T22:39:00Z/PT1M}\n"));
  ASSERT_TRUE(exact) << exact.error().toString();
  EXPECT_EQ(exact->layers[0].time.values.size(), 10000U);
  const auto over =
      parse(layerWith("    time: {period: 2000-01-01T00:00:00Z/2000-01-07T22:40:00Z/PT1M}\n"));
  ASSERT_TRUE(over) << over.error().toString();
  EXPECT_TRUE(over->layers[0].time.values.empty());
  EXPECT_TRUE(over->layers[0].time.enabled());
  EXPECT_EQ(over->layers[0].time.defaultValue, "2000-01-07T22:40:00Z"); // the end of the period

  // A century in seconds (3 billion values) is neither expanded nor slow.
  const auto start = std::chrono::steady_clock::now();
  const auto century = parse(layerWith("    time:\n      period: 1900-01-01/2099-12-31/PT1S\n      "
                                       "default: 2024-05-01T12:00:00Z\n"));
  ASSERT_TRUE(century) << century.error().toString();
  EXPECT_TRUE(century->layers[0].time.values.empty());
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));

  // Years and months at the ends of the calendar.
  const auto years = parse(layerWith("    time: {period: 0000-02-29/9999-12-31/P1000Y}\n"));
  ASSERT_TRUE(years) << years.error().toString();
  EXPECT_EQ(years->layers[0].time.values.front(), "0000-02-29");
  EXPECT_EQ(years->layers[0].time.values[1], "1000-02-28"); // 1000 is no leap year
  EXPECT_EQ(years->layers[0].time.values.back(), "9000-02-28");
  EXPECT_FALSE(parse(layerWith("    time: {period: 2000-01-01/2001-01-01/P1000001D}\n")));
  EXPECT_FALSE(parse(layerWith("    time: {period: 10000-01-01/10001-01-01/P1D}\n")));
}

TEST(ConfigExtremes, DeepNestingAndAliasesDoNotCrash) {
  const std::string deep = "layers: " + std::string(100000, '[') + std::string(100000, ']') + "\n";
  const auto d = parse(deep);
  ASSERT_FALSE(d);
  EXPECT_EQ(d.error().file, "x.yaml");
  EXPECT_GE(d.error().line, 1);

  // A "billion laughs" document: aliases are not expanded into strings.
  std::string laughs = "x: &a [lol, lol, lol, lol, lol, lol, lol, lol, lol]\n";
  for (char c = 'b'; c <= 'j'; ++c) {
    const char prev = static_cast<char>(c - 1);
    laughs += std::string("y") + c + ": &" + c + " [*" + prev + ", *" + prev + ", *" + prev +
              ", *" + prev + ", *" + prev + ", *" + prev + ", *" + prev + ", *" + prev + ", *" +
              prev + "]\n";
  }
  const auto l = parse(laughs);
  ASSERT_FALSE(l);
  EXPECT_EQ(l.error().key, "x");

  // Aliased layers are the same layer twice.
  const auto twice = parse(std::string(kUpstream) + R"(layers:
  - &l {name: a, upstream: up, format: image/png, grid: {levels: 1}}
  - *l
)");
  ASSERT_FALSE(twice);
  EXPECT_EQ(twice.error().key, "layers[1].name");
  EXPECT_NE(twice.error().message.find("used twice"), std::string::npos);

  // Time values that are lists (through aliases) are a type error, not an explosion.
  const auto values = parse(layerWith("    time: {values: [&v [a, b], *v]}\n"));
  ASSERT_FALSE(values);
  EXPECT_EQ(values.error().key, "layers[0].time.values[0]");
}

// yaml-cpp 0.7 leaves a stray top-level ',' unread and YAML::LoadAll then makes empty documents
// at that place forever, allocating (found by fuzz/FuzzConfig.cpp): a syntax error instead.
TEST(ConfigExtremes, StrayTopLevelCommaIsASyntaxErrorNotAHang) {
  const std::string minimal = layerWith("");
  for (const std::string& text : {std::string(","),
                                  std::string(",\n"),
                                  std::string(" , a, b\nserver:\n  x: 1\n"),
                                  "# comment\n, Layer names\n" + minimal,
                                  minimal + ",\n",
                                  minimal + "---\n,\n"}) {
    const auto c = parse(text);
    ASSERT_FALSE(c) << text;
    EXPECT_EQ(c.error().key, "") << text;
    EXPECT_GE(c.error().line, 1) << text;
    EXPECT_NE(c.error().message.find("YAML syntax"), std::string::npos) << c.error().message;
  }
  const auto first = parse("# comment\n, Layer names\n" + minimal);
  ASSERT_FALSE(first);
  EXPECT_EQ(first.error().line, 2);
  EXPECT_EQ(first.error().column, 1);
  const auto last = parse(minimal + ",\n");
  ASSERT_FALSE(last);
  EXPECT_EQ(last.error().line, 10);
}

TEST(ConfigExtremes, LongKeysNamesAndOddBytes) {
  const auto k = parse(std::string(1000, 'k') + ": 1\n");
  ASSERT_FALSE(k);
  EXPECT_NE(k.error().message.find("unknown key"), std::string::npos);
  EXPECT_NE(k.error().message.find("expected one of"), std::string::npos);
  EXPECT_FALSE(parse(std::string(100000, 'k') + ": 1\n")); // YAML limits implicit keys

  const auto nul = parse(std::string("layers:\0 []\n", 12));
  EXPECT_FALSE(nul);
  const auto bytes = parse("\xff\xfe\x00\x01garbage: [\n");
  EXPECT_FALSE(bytes);
  const auto unicode = parse(std::string(kUpstream) +
                             "layers:\n  - {name: \"m\xc3\xa4p\", upstream: up, format: image/png, "
                             "grid: {levels: 1}}\n");
  ASSERT_FALSE(unicode);
  EXPECT_EQ(unicode.error().key, "layers[0].name");
  const auto slash =
      parse(std::string(kUpstream) + "layers:\n  - {name: ../etc, upstream: up, format: image/png, "
                                     "grid: {levels: 1}}\n");
  ASSERT_FALSE(slash);
  EXPECT_EQ(slash.error().key, "layers[0].name");
  const auto complexKey = parse("? [a, b]\n: 1\n");
  ASSERT_FALSE(complexKey);
  EXPECT_NE(complexKey.error().message.find("plain name"), std::string::npos);
  const auto bom = parse("\xef\xbb\xbf" + layerWith(""));
  EXPECT_TRUE(bom) << bom.error().toString();
  const auto crlf = parse("upstreams:\r\n  - {name: up, type: wms, url: \"http://e.org/\"}\r\n"
                          "layers:\r\n  - {name: a, upstream: up, format: image/png, grid: "
                          "{levels: 1}}\r\n");
  EXPECT_TRUE(crlf) << crlf.error().toString();
}

TEST(ConfigExtremes, ManyLayers) {
  std::string yaml = std::string(kUpstream) + "layers:\n";
  for (int i = 0; i < 2000; ++i)
    yaml += "  - {name: l" + std::to_string(i) +
            ", upstream: up, format: image/png, grid: {levels: 1}}\n";
  const auto c = parse(yaml);
  ASSERT_TRUE(c) << c.error().toString();
  EXPECT_EQ(c->layers.size(), 2000U);
  EXPECT_NE(c->layer("l1999"), nullptr);
}

TEST(ConfigExtremes, GiantFilesAreRefused) {
  const test::TempDir dir("config-giant");
  const fs::path p = dir.path() / "giant.yaml";
  { std::ofstream out(p); }
  fs::resize_file(p, (16U << 20) + 1); // sparse: no 16 MiB written
  const auto c = loadConfig(p);
  ASSERT_FALSE(c);
  EXPECT_NE(c.error().message.find("larger than 16 MiB"), std::string::npos);
}

TEST(ConfigExtremes, LogLevelMustBeKnown) {
  const auto bad = parse("server: {log_level: loud}\n" + layerWith(""));
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error().key, "server.log_level");
  EXPECT_EQ(bad.error().line, 1);
  const auto ok = parse("server: {log_level: debug, access_log: /tmp/a.log}\n" + layerWith(""));
  ASSERT_TRUE(ok) << ok.error().toString();
  EXPECT_EQ(ok->server.logLevel, "debug");
  EXPECT_EQ(ok->server.accessLog, "/tmp/a.log");
}

TEST(ConfigExtremes, CacheIndexIsAPostgresUriWithoutAPassword) {
  const auto ok =
      parse("cache: {index: 'postgresql://tile@db.example:5432/tellus?sslmode=require', "
            "index_password_file: /run/secrets/pg}\n" +
            layerWith(""));
  ASSERT_TRUE(ok) << ok.error().message;
  EXPECT_EQ(ok->cache.index, "postgresql://tile@db.example:5432/tellus?sslmode=require");
  EXPECT_EQ(ok->cache.indexPasswordFile, std::filesystem::path("/run/secrets/pg"));
  EXPECT_TRUE(parse("cache: {}\n" + layerWith(""))->cache.index.empty()); // SQLite, as today
  for (const char* uri :
       {"postgresql://tile:hunter2@db/tellus", "postgres://db/tellus?user=tile&password=hunter2"}) {
    const auto e = parse("cache: {index: '" + std::string(uri) + "'}\n" + layerWith(""));
    ASSERT_FALSE(e) << uri;
    EXPECT_EQ(e.error().key, "cache.index");
    EXPECT_EQ(e.error().message.find("hunter2"), std::string::npos) << e.error().message;
    EXPECT_NE(e.error().message.find("PGPASSWORD"), std::string::npos);
  }
  const auto notPg = parse("cache: {index: 'mysql://db/tellus'}\n" + layerWith(""));
  ASSERT_FALSE(notPg);
  EXPECT_EQ(notPg.error().key, "cache.index");
  const auto fileAlone = parse("cache: {index_password_file: /x}\n" + layerWith(""));
  ASSERT_FALSE(fileAlone);
  EXPECT_EQ(fileAlone.error().key, "cache.index_password_file");
}
