// TIME lists and ranges (cache/TimeRange.hpp): what `tellus seed --time` and the renderer's
// `--animate` expand before each instant is checked against a layer; calendar steps at month ends
// and leap years, ranges across years, one-instant and empty ranges, and the cap on huge ones.
#include <tellus/cache/TimeRange.hpp>

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace {

using tellus::iso8601::expandTimes;
using Strings = std::vector<std::string>;

Strings expand(std::string_view text, const Strings& declared = {}, std::size_t max = 1000) {
  auto r = expandTimes(text, declared, max);
  EXPECT_TRUE(r.has_value()) << text << ": " << (r ? "" : r.error());
  return r ? *r : Strings{};
}

std::string refused(std::string_view text, const Strings& declared = {}, std::size_t max = 1000) {
  auto r = expandTimes(text, declared, max);
  EXPECT_FALSE(r.has_value()) << text;
  return r ? std::string() : r.error();
}

TEST(TimeRange, OneInstantIsKeptAsWritten) {
  EXPECT_EQ(expand("2024-03-01"), Strings{"2024-03-01"});
  EXPECT_EQ(expand("2024-03-01T06:00Z"), Strings{"2024-03-01T06:00Z"});
}

TEST(TimeRange, MonthlyStepsFromJanuaryThe31stClampToEachMonthsEnd) {
  // Each instant is start + k x P1M (never chained): February clamps, March is the 31st again.
  EXPECT_EQ(expand("2024-01-31/2024-05-31/P1M"),
            (Strings{"2024-01-31", "2024-02-29", "2024-03-31", "2024-04-30", "2024-05-31"}));
  // Not a leap year: the 28th.
  EXPECT_EQ(expand("2023-01-31/2023-03-01/P1M"), (Strings{"2023-01-31", "2023-02-28"}));
  // 2000 is a leap year (divisible by 400), 1900 is not.
  EXPECT_EQ(expand("2000-01-31/2000-02-29/P1M"), (Strings{"2000-01-31", "2000-02-29"}));
  EXPECT_EQ(expand("1900-01-31/1900-02-28/P1M"), (Strings{"1900-01-31", "1900-02-28"}));
  // P1Y from a 29th of February: the 28th in the years between leap years.
  EXPECT_EQ(expand("2024-02-29/2028-02-29/P1Y"),
            (Strings{"2024-02-29", "2025-02-28", "2026-02-28", "2027-02-28", "2028-02-29"}));
}

TEST(TimeRange, DailyStepsCrossTheYearAndTimesOfDayKeepTheirSeconds) {
  EXPECT_EQ(expand("2023-12-30/2024-01-02/P1D"),
            (Strings{"2023-12-30", "2023-12-31", "2024-01-01", "2024-01-02"}));
  EXPECT_EQ(expand("2024-12-31T18:00:00Z/2025-01-01T06:00:00Z/PT6H"),
            (Strings{"2024-12-31T18:00:00Z", "2025-01-01T00:00:00Z", "2025-01-01T06:00:00Z"}));
  // A date with a time step: the instants have times.
  EXPECT_EQ(expand("2024-01-01/2024-01-01T12:00:00Z/PT12H"),
            (Strings{"2024-01-01T00:00:00Z", "2024-01-01T12:00:00Z"}));
  // The end need not be on the grid: the last instant is the last one not after it.
  EXPECT_EQ(expand("2024-01-01/2024-01-05/P2D"),
            (Strings{"2024-01-01", "2024-01-03", "2024-01-05"}));
  EXPECT_EQ(expand("2024-01-01/2024-01-04/P2D"), (Strings{"2024-01-01", "2024-01-03"}));
}

TEST(TimeRange, AOneInstantRangeIsOneInstantAndAnEmptyOneIsRefused) {
  EXPECT_EQ(expand("2024-01-01/2024-01-01/P1D"), Strings{"2024-01-01"});
  EXPECT_EQ(expand("2024-01-01/2024-01-01/P1Y"), Strings{"2024-01-01"});
  EXPECT_NE(refused("2024-01-02/2024-01-01/P1D").find("ends before it starts"), std::string::npos);
  EXPECT_NE(refused("2024-01-01/2024-01-02/P0D").find("zero length"), std::string::npos);
}

TEST(TimeRange, ListsAndRangesMixInOrderWithoutDuplicates) {
  EXPECT_EQ(expand("2024-03-01,2024-01-01/2024-01-03/P1D,2024-01-02T00:00:00Z,2023-01-01"),
            (Strings{"2024-03-01", "2024-01-01", "2024-01-02", "2024-01-03", "2023-01-01"}));
  EXPECT_NE(refused("2024-01-01,,2024-01-02").find("empty item"), std::string::npos);
  EXPECT_NE(refused("2024-01-01,").find("empty item"), std::string::npos);
  EXPECT_NE(refused("").find("empty"), std::string::npos);
  EXPECT_NE(refused("2024-13-01").find("no ISO 8601 instant"), std::string::npos);
  EXPECT_NE(refused("2024-01-01T00:00:00.5Z").find("whole seconds"), std::string::npos);
  EXPECT_NE(refused("2024-01-01/2024-02-01/P1D/x").find("more than two"), std::string::npos);
  EXPECT_NE(refused("2024-01-01/2024-02-01/1D").find("duration"), std::string::npos);
  EXPECT_NE(refused("x/2024-02-01/P1D").find("bad start"), std::string::npos);
  EXPECT_NE(refused("2024-01-01/x/P1D").find("bad end"), std::string::npos);
}

TEST(TimeRange, AStartAndEndWithoutAPeriodTakeTheDeclaredTimesWithin) {
  const Strings declared{"2024-03-01", "2024-01-01", "2024-02-01", "2024-04-01T00:00:00Z"};
  EXPECT_EQ(expand("2024-01-15/2024-03-01", declared), (Strings{"2024-02-01", "2024-03-01"}));
  EXPECT_EQ(expand("2024-01-01/2024-12-31", declared),
            (Strings{"2024-01-01", "2024-02-01", "2024-03-01", "2024-04-01T00:00:00Z"}));
  EXPECT_NE(refused("2025-01-01/2025-12-31", declared).find("none of the layer's times"),
            std::string::npos);
  EXPECT_NE(refused("2024-01-01/2024-12-31").find("write start/end/period"), std::string::npos);
}

TEST(TimeRangeExtremes, HugeRangesStopAtTheCapWithoutWalkingThem) {
  // 9999 years by the second: 3e11 instants; refused after cap + 1 steps.
  const std::string e = refused("0000-01-01T00:00:00Z/9999-12-31T23:59:59Z/PT1S", {}, 1000);
  EXPECT_NE(e.find("more than 1000 instants"), std::string::npos) << e;
  // Exactly at the cap passes; one more does not.
  EXPECT_EQ(expand("2024-01-01T00:00:00Z/2024-01-01T00:16:39Z/PT1S", {}, 1000).size(), 1000u);
  refused("2024-01-01T00:00:00Z/2024-01-01T00:16:40Z/PT1S", {}, 1000);
  // The cap counts a whole list, and duplicates do not count twice.
  refused("2024-01-01/2024-01-10/P1D,2024-02-01", {}, 10);
  EXPECT_EQ(expand("2024-01-01/2024-01-10/P1D,2024-01-05", {}, 10).size(), 10u);
  // Steps that run past year 9999 end the range.
  EXPECT_EQ(expand("9999-12-01/9999-12-31/P1M"), Strings{"9999-12-01"});
  EXPECT_EQ(expand("9990-01-01/9999-12-31/P1000000Y"), Strings{"9990-01-01"});
}

} // namespace
