// What `tellus cache stats --json` prints (tools/tellus/cli/StatsJson.hpp): the same bytes as the
// printf writer it replaced for every string that needs no short escape, valid JSON for any bytes,
// and the values read back.

#include <tellus/cli/StatsJson.hpp>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace tellus::cli {
namespace {

DatasetStats dataset(std::int64_t id, std::string name, bool pinned) {
  DatasetStats d;
  d.dataset.id = id;
  d.dataset.spec.server = "local";
  d.dataset.spec.name = std::move(name);
  d.dataset.spec.mimeType = "image/jpeg";
  d.dataset.folder = "local/" + d.dataset.spec.name + "-0123abcd";
  d.dataset.spec.pinned = pinned;
  return d;
}

TEST(StatsJson, TheLayoutScriptsRead) {
  DatasetStats a = dataset(1, "bluemarble", true);
  a.tiles = 16;
  a.bytes = 123456;
  a.levels = {{0, 4, 0, 40000}, {1, 12, 2, 83456}};
  DatasetStats b = dataset(7, "sst", false);
  b.dataset.spec.time = "2024-01-01";
  b.dataset.spec.body = "mars";
  b.tiles = 1;
  b.bytes = 9;
  b.levels = {{3, 1, 0, 9}};
  EXPECT_EQ(
      cacheStatsJson("/var/cache/tellus", std::vector<DatasetStats>{a, b}),
      R"({"root":"/var/cache/tellus","tiles":17,"bytes":123465,"datasets":[)"
      R"({"id":1,"server":"local","name":"bluemarble","folder":"local/bluemarble-0123abcd",)"
      R"("format":"image/jpeg","time":"","pinned":true,"body":"earth","tiles":16,"bytes":123456,)"
      R"("levels":[)"
      R"({"level":0,"tiles":4,"absent":0,"bytes":40000},{"level":1,"tiles":12,"absent":2,)"
      R"("bytes":83456}]},{"id":7,"server":"local","name":"sst","folder":"local/sst-0123abcd",)"
      R"("format":"image/jpeg","time":"2024-01-01","pinned":false,"body":"mars","tiles":1,)"
      R"("bytes":9,"levels":[)"
      R"({"level":3,"tiles":1,"absent":0,"bytes":9}]}]})"
      "\n");
  EXPECT_EQ(cacheStatsJson("c", {}), "{\"root\":\"c\",\"tiles\":0,\"bytes\":0,\"datasets\":[]}\n");
}

TEST(StatsJson, StringsAreEscapedAndNumbersExact) {
  // Quote, backslash, controls without a short escape and DEL: as the printf writer had them.
  DatasetStats d = dataset(std::numeric_limits<std::int64_t>::max(), "a\"b\\c\x01\x1f\x7f", false);
  d.levels = {{-1, std::numeric_limits<std::int64_t>::min(), -1, 0}};
  const std::string text = cacheStatsJson("/r", std::vector<DatasetStats>{d});
  EXPECT_NE(text.find(R"("name":"a\"b\\c\u0001\u001f)"
                      "\x7f\""),
            std::string::npos)
      << text;
  EXPECT_NE(text.find(R"("id":9223372036854775807)"), std::string::npos) << text;
  EXPECT_NE(text.find(R"({"level":-1,"tiles":-9223372036854775808,"absent":-1,"bytes":0})"),
            std::string::npos)
      << text;
}

TEST(StatsJson, AnyBytesGiveJsonThatReadsBack) {
  // Every byte value in the root (a path may hold any byte but NUL and '/'; here NUL too),
  // valid UTF-8 in a name: the output is JSON, and reads back to the same values (the bytes
  // that are not UTF-8 replaced by U+FFFD each).
  std::string root;
  for (int c = 0; c < 256; ++c)
    root += static_cast<char>(c);
  DatasetStats d = dataset(3, "m\xc3\xa4p \xe2\x82\xac \xf0\x9f\x8c\x8d\n\t", true);
  d.tiles = 5;
  d.bytes = 50;
  d.levels = {{2, 5, 1, 50}};
  const std::string text = cacheStatsJson(root, std::vector<DatasetStats>{d, d});
  ASSERT_TRUE(text.ends_with("}\n"));
  EXPECT_EQ(text.find('\n'), text.size() - 1) << "one line";
  const auto j = nlohmann::json::parse(text, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << text;
  std::string replaced = root.substr(0, 128);
  for (int c = 128; c < 256; ++c)
    replaced += "\xef\xbf\xbd";
  EXPECT_EQ(j["root"], replaced);
  EXPECT_EQ(j["tiles"], 10);
  EXPECT_EQ(j["bytes"], 100);
  ASSERT_EQ(j["datasets"].size(), 2u);
  const auto& back = j["datasets"][1];
  EXPECT_EQ(back["id"], 3);
  EXPECT_EQ(back["name"], d.dataset.spec.name);
  EXPECT_EQ(back["folder"], d.dataset.folder);
  EXPECT_EQ(back["pinned"], true);
  EXPECT_EQ(back["levels"][0]["absent"], 1);
}

} // namespace
} // namespace tellus::cli
