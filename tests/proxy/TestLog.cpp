#include "../support/TempDir.hpp"

#include <tellus/proxy/Log.hpp>

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

using namespace tellus;

namespace {

std::vector<std::string> lines(const std::filesystem::path& file) {
  std::ifstream in(file);
  std::vector<std::string> out;
  for (std::string l; std::getline(in, l);)
    out.push_back(l);
  return out;
}

} // namespace

TEST(Log, LogfmtValuesAreBareOrQuotedAndEscaped) {
  EXPECT_EQ(logfmtValue("hit"), "hit");
  EXPECT_EQ(logfmtValue("/wwtile?T=a&L=0"), "\"/wwtile?T=a&L=0\""); // '=' forces quotes
  EXPECT_EQ(logfmtValue(""), "\"\"");
  EXPECT_EQ(logfmtValue("a b"), "\"a b\"");
  EXPECT_EQ(logfmtValue("say \"hi\"\\"), "\"say \\\"hi\\\"\\\\\"");
  EXPECT_EQ(logfmtValue("two\nlines\r\t"), "\"two\\nlines\\r\\t\"");
  EXPECT_EQ(logfmtValue(std::string_view("\x01\x7f", 2)), "\"\\x01\\x7f\"");
}

TEST(Log, LevelsParseAndFilter) {
  EXPECT_EQ(parseLogLevel("warn"), LogLevel::Warn);
  EXPECT_EQ(parseLogLevel("debug"), LogLevel::Debug);
  EXPECT_FALSE(parseLogLevel("WARN"));
  EXPECT_FALSE(parseLogLevel("verbose"));
  test::TempDir dir("log");
  const auto file = dir.path() / "events.log";
  std::FILE* f = std::fopen(file.c_str(), "w");
  ASSERT_NE(f, nullptr);
  Logger log;
  log.setEventStream(f);
  log.setLevel(LogLevel::Warn);
  log.log(LogLevel::Info, "tiles", "not shown");
  log.log(LogLevel::Warn, "fetcher", "upstream slow", {{"upstream", "gibs"}, {"ms", "1234"}});
  log.log(LogLevel::Error, "cache", "disk full", {{"path", "/var/cache/a b"}});
  log.setEventStream(nullptr);
  std::fclose(f);
  const auto got = lines(file);
  ASSERT_EQ(got.size(), 2u);
  EXPECT_TRUE(got[0].starts_with("time=")) << got[0];
  EXPECT_NE(
      got[0].find(" level=warn component=fetcher msg=\"upstream slow\" upstream=gibs ms=1234"),
      std::string::npos)
      << got[0];
  EXPECT_TRUE(
      got[1].ends_with("level=error component=cache msg=\"disk full\" path=\"/var/cache/a b\""))
      << got[1];
}

TEST(Log, AccessLinesFromManyThreadsStayWhole) {
  test::TempDir dir("log");
  const auto file = dir.path() / "access.log";
  Logger log;
  EXPECT_FALSE(log.accessLogEnabled());
  std::string err;
  ASSERT_TRUE(log.openAccessLog(file.string(), &err)) << err;
  EXPECT_TRUE(log.accessLogEnabled());
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&log, t] {
      for (int i = 0; i < 300; ++i) {
        const std::string target = "/wwtile?T=t" + std::to_string(t) + "&L=" + std::to_string(i);
        log.access({{"target", target}, {"status", "200"}});
      }
    });
  }
  for (auto& th : threads)
    th.join();
  ASSERT_TRUE(log.openAccessLog("", &err)); // closes the file
  EXPECT_FALSE(log.accessLogEnabled());
  const auto got = lines(file);
  ASSERT_EQ(got.size(), 1200u);
  for (const auto& l : got) {
    ASSERT_TRUE(l.starts_with("time=")) << l;
    ASSERT_TRUE(l.ends_with(" status=200")) << l;
    ASSERT_EQ(l.find("time=", 1), std::string::npos) << "two lines ran together: " << l;
  }
  EXPECT_FALSE(log.openAccessLog((dir.path() / "no/such/dir/a.log").string(), &err));
  EXPECT_NE(err.find("cannot open the access log"), std::string::npos) << err;
}
