// The values of tellus's options (tools/tellus/cli): the whole text or nothing, at the edges of
// each range; and sizes in bytes as printed.

#include <tellus/cli/Values.hpp>

#include <gtest/gtest.h>

#include <chrono>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

namespace tellus::cli {
namespace {

using namespace std::chrono_literals;
using Levels = std::pair<int, int>;

TEST(Values, Levels) {
  EXPECT_EQ(parseLevels("0"), (Levels{0, 0}));
  EXPECT_EQ(parseLevels("5"), (Levels{5, 5}));
  EXPECT_EQ(parseLevels("0-3"), (Levels{0, 3}));
  EXPECT_EQ(parseLevels("3-3"), (Levels{3, 3}));
  EXPECT_EQ(parseLevels("2147483647"), (Levels{2147483647, 2147483647}));
  for (const char* bad : {"",
                          "-",
                          "-1",
                          "3-1",
                          "1-",
                          "-3",
                          "a",
                          "1-b",
                          "1 -2",
                          " 1",
                          "1-2-3",
                          "0x3",
                          "1.5",
                          "2147483648",
                          "+1"})
    EXPECT_FALSE(parseLevels(bad)) << bad;
}

TEST(Values, Bbox) {
  EXPECT_EQ(parseBbox("-10,-5,10,5"), (Sector{-10, -5, 10, 5}));
  EXPECT_EQ(parseBbox("170,-90,-170,90"), (Sector{170, -90, -170, 90})); // across the antimeridian
  EXPECT_EQ(parseBbox("1e1,0,2.5,.5"), (Sector{10, 0, 2.5, 0.5}));
  for (const char* bad : {"",
                          "1,2,3",
                          "1,2,3,4,",
                          "1,2,3,4,5",
                          "1,,3,4",
                          "a,2,3,4",
                          "1,2,3,4 ",
                          "inf,0,1,1",
                          "0,nan,1,1",
                          "1;2;3;4",
                          "1e999,0,1,1"})
    EXPECT_FALSE(parseBbox(bad)) << bad;
}

TEST(Values, Durations) {
  EXPECT_EQ(parseDuration("45s"), std::chrono::milliseconds(45s));
  EXPECT_EQ(parseDuration("15m"), std::chrono::milliseconds(15min));
  EXPECT_EQ(parseDuration("12h"), std::chrono::milliseconds(12h));
  EXPECT_EQ(parseDuration("30d"), std::chrono::milliseconds(720h));
  EXPECT_EQ(parseDuration("0s"), std::chrono::milliseconds(0));
  for (const char* bad :
       {"", "s", "5", "30", "-1d", "1.5h", "5ms", "5w", "d5", "5 d", " 5d", "+5d", "0"})
    EXPECT_FALSE(parseDuration(bad)) << bad;
  // Past what milliseconds hold: refused, not wrapped (24 * n and n * 1000 overflowed before).
  for (const char* huge : {"9223372036854775807d",
                           "9223372036854775807s",
                           "106751991167301d",
                           "99999999999999999999999s"})
    EXPECT_FALSE(parseDuration(huge)) << huge;
  EXPECT_EQ(parseDuration("106751991166d"), std::chrono::milliseconds(106751991166LL * 86400000));
}

TEST(Values, Numbers) {
  EXPECT_EQ(parseNumbers("1", 1, 1), std::vector<double>{1.0});
  EXPECT_EQ(parseNumbers("-33.5,151,1e6", 3, 5), (std::vector<double>{-33.5, 151, 1e6}));
  EXPECT_EQ(parseNumbers("1,2,3,4,5", 3, 5)->size(), 5u);
  for (const auto& [text, lo, hi] :
       std::vector<std::tuple<std::string, std::size_t, std::size_t>>{{"", 1, 1},
                                                                      {"1,2", 1, 1},
                                                                      {"1,2", 3, 5},
                                                                      {"1,2,3,4,5,6", 3, 5},
                                                                      {"1,", 1, 2},
                                                                      {",1", 1, 2},
                                                                      {"1,,2", 1, 3},
                                                                      {"1 ", 1, 1},
                                                                      {" 1", 1, 1},
                                                                      {"+1", 1, 1},
                                                                      {"inf", 1, 1},
                                                                      {"nan", 1, 1},
                                                                      {"1e999", 1, 1},
                                                                      {"0x10", 1, 1},
                                                                      {"1;2", 1, 2}})
    EXPECT_FALSE(parseNumbers(text, lo, hi)) << text;
}

TEST(Values, Sizes) {
  EXPECT_EQ(parseSize("1024x768"), (std::pair{1024, 768}));
  EXPECT_EQ(parseSize("1x1"), (std::pair{1, 1}));
  EXPECT_EQ(parseSize("16384x16384"), (std::pair{16384, 16384}));
  for (const char* bad : {"",
                          "x",
                          "1024",
                          "1024x",
                          "x768",
                          "0x10",
                          "10x0",
                          "16385x1",
                          "1x16385",
                          "-1x5",
                          "10X10",
                          "10x10x10",
                          "10 x10",
                          "1e3x10",
                          "10x10 "})
    EXPECT_FALSE(parseSize(bad)) << bad;
}

TEST(Values, HumanBytes) {
  EXPECT_EQ(humanBytes(0), "0 B");
  EXPECT_EQ(humanBytes(1023), "1023 B");
  EXPECT_EQ(humanBytes(1024), "1.0 KiB");
  EXPECT_EQ(humanBytes(1536), "1.5 KiB");
  EXPECT_EQ(humanBytes((1 << 20) - 1), "1024.0 KiB");
  EXPECT_EQ(humanBytes(1 << 20), "1.0 MiB");
  EXPECT_EQ(humanBytes(std::int64_t{3} << 30), "3.0 GiB");
  EXPECT_EQ(humanBytes(std::int64_t{5} << 40), "5120.0 GiB");
  EXPECT_EQ(humanBytes(-5), "-5 B");
}

} // namespace
} // namespace tellus::cli
