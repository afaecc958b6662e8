// The one ISO 8601 reader (cache/IsoTime.hpp): the forms ISO 8601's extended format allows and
// the ones it does not, calendar arithmetic at month ends and leap years, and the extremes of the
// years 0000-9999.
#include <tellus/cache/IsoTime.hpp>

#include <gtest/gtest.h>

#include <limits>
#include <string>

namespace {

using namespace tellus::iso8601;

constexpr std::int64_t k20240620Noon = 1'718'884'800;

TEST(IsoTime, ReadsEveryExtendedForm) {
  struct Case {
    const char* text;
    std::int64_t seconds;
    double fraction;
  };
  for (const Case& c : {Case{"2024-06-20T12:00:00Z", k20240620Noon, 0.0},
                        Case{"2024-06-20T12:00Z", k20240620Noon, 0.0},
                        Case{"2024-06-20T12:00:00", k20240620Noon, 0.0},
                        Case{"2024-06-20 12:00:00Z", k20240620Noon, 0.0},
                        Case{"2024-06-20T14:00:00+02:00", k20240620Noon, 0.0},
                        Case{"2024-06-20T09:30-0230", k20240620Noon, 0.0},
                        Case{"2024-06-20T12:00:00.5Z", k20240620Noon, 0.5},
                        Case{"2024-06-20T12:00:00,25Z", k20240620Noon, 0.25},
                        Case{"2024-06-20T12:00:00.000000001Z", k20240620Noon, 1e-9},
                        Case{"2024-06-20", k20240620Noon - 43'200, 0.0},
                        Case{"1970-01-01T00:00:00Z", 0, 0.0},
                        Case{"1969-12-31T23:59:59Z", -1, 0.0},
                        Case{"2000-02-29", 951'782'400, 0.0}}) {
    const auto t = parseInstant(c.text);
    ASSERT_TRUE(t.has_value()) << c.text;
    EXPECT_EQ(t->seconds, c.seconds) << c.text;
    EXPECT_NEAR(t->fraction, c.fraction, 1e-12) << c.text;
  }
}

TEST(IsoTime, RemembersHowAnInstantWasWritten) {
  EXPECT_TRUE(parseInstant("2024-06-20")->shape.dateOnly);
  const auto noSeconds = parseInstant("2024-06-20T12:00Z").value();
  EXPECT_FALSE(noSeconds.shape.dateOnly);
  EXPECT_FALSE(noSeconds.shape.seconds);
  EXPECT_TRUE(noSeconds.shape.zulu);
  EXPECT_TRUE(parseInstant("2024-06-20T12:00:00Z")->shape.seconds);
  EXPECT_FALSE(parseInstant("2024-06-20T12:00:00")->shape.zulu);
  EXPECT_FALSE(parseInstant("2024-06-20T12:00:00+01:00")->shape.zulu);
}

TEST(IsoTime, RefusesWhatIsNoInstant) {
  for (const char* bad : {"",
                          "now",
                          "yesterday",
                          "2024-13-01",
                          "2024-00-10",
                          "2023-02-29",
                          "2024-02-30T00:00Z",
                          "2024-06-20T24:00Z",
                          "2024-06-20T12:60Z",
                          "2024-06-20T12:00:60Z",
                          "2024-06-20T12:00:00.Z",
                          "2024-06-20T12:00:00.1234567890Z",
                          "2024-06-20T12:00:00ZZ",
                          "2024-06-20t12:00:00Z",
                          "2024-06-20T12:00:00z",
                          "2024-06-20T12:00+24:00",
                          "2024-06-20T12:00+02:60",
                          "2024-06-20T12:00+2",
                          "2024-06-20T12",
                          "2024-06-20T1200",
                          "2024-06-20X12:00Z",
                          "2024-6-20",
                          "+2024-06-20",
                          "20240620",
                          "2024-06-20T12:00:00Z and more text that makes it far too long"}) {
    EXPECT_FALSE(parseInstant(bad).has_value()) << bad;
  }
}

TEST(IsoTime, ReadsDurations) {
  const auto d = parseDuration("P1Y2M3W4DT5H6M7S").value();
  EXPECT_EQ(d.months, 14);
  EXPECT_EQ(d.days, 25);
  EXPECT_EQ(d.seconds, 5 * 3600 + 6 * 60 + 7);
  EXPECT_EQ(parseDuration("PT6H")->seconds, 6 * 3600);
  EXPECT_EQ(parseDuration("P1M")->months, 1);
  EXPECT_EQ(parseDuration("PT1M")->seconds, 60) << "M after T is minutes";
  EXPECT_TRUE(parseDuration("P0D")->zero());
  for (const char* bad : {"",
                          "P",
                          "PT",
                          "P1DT",
                          "1D",
                          "P1H",
                          "PT1D",
                          "P1.5D",
                          "P-1D",
                          "P1D2",
                          "PT1H1T",
                          "P1000001D",
                          "P99999999999999999999D"})
    EXPECT_FALSE(parseDuration(bad).has_value()) << bad;
}

TEST(IsoTime, AddsMonthsOnTheCalendar) {
  const auto jan31 = parseInstant("2024-01-31T06:00:00Z")->seconds;
  const Duration month{1, 0, 0};
  EXPECT_EQ(formatInstant(addDuration(jan31, month, 1), {false, true, true}),
            "2024-02-29T06:00:00Z")
      << "clamped to the month's end in a leap year";
  EXPECT_EQ(formatInstant(addDuration(jan31, month, 13), {false, true, true}),
            "2025-02-28T06:00:00Z");
  EXPECT_EQ(formatInstant(addDuration(jan31, Duration{0, 1, 3600}, 2), {false, true, true}),
            "2024-02-02T08:00:00Z");
  EXPECT_EQ(addDuration(jan31, month, 0), jan31);
}

TEST(IsoTimeExtremes, YearsZeroToNineThousandNineHundredNinetyNine) {
  EXPECT_EQ(parseInstant("0000-01-01T00:00:00Z")->seconds, kFirstSecond);
  EXPECT_EQ(parseInstant("9999-12-31T23:59:59Z")->seconds, kLastSecond);
  EXPECT_EQ(formatInstant(kFirstSecond, {true, false, true}), "0000-01-01");
  EXPECT_EQ(formatInstant(kLastSecond, {false, true, true}), "9999-12-31T23:59:59Z");
  EXPECT_EQ(parseInstant("0000-02-29")->seconds, kFirstSecond + 59 * 86'400)
      << "year 0 is a leap year in the proleptic Gregorian calendar";
  // Past the calendar's ends: before or after every instant, never a wrapped value.
  constexpr auto kMax = std::numeric_limits<std::int64_t>::max();
  constexpr auto kMin = std::numeric_limits<std::int64_t>::min();
  EXPECT_EQ(addDuration(kLastSecond, Duration{1, 0, 0}, 1), kMax);
  EXPECT_EQ(addDuration(kLastSecond, Duration{0, 0, 1}, 1), kMax);
  EXPECT_EQ(addDuration(kFirstSecond, Duration{1, 0, 0}, -1), kMin);
  EXPECT_EQ(addDuration(kFirstSecond, Duration{0, 1, 0}, -1), kMin);
  // An offset can carry an instant across a year's end both ways.
  EXPECT_EQ(formatInstant(parseInstant("2024-12-31T23:30:00-01:00")->seconds, {false, true, true}),
            "2025-01-01T00:30:00Z");
  EXPECT_EQ(formatInstant(parseInstant("2025-01-01T00:30:00+01:00")->seconds, {false, true, true}),
            "2024-12-31T23:30:00Z");
}

TEST(IsoTime, FormatsInEachShape) {
  EXPECT_EQ(formatInstant(k20240620Noon, {true, false, true}), "2024-06-20");
  EXPECT_EQ(formatInstant(k20240620Noon, {false, false, true}), "2024-06-20T12:00Z");
  EXPECT_EQ(formatInstant(k20240620Noon, {false, true, false}), "2024-06-20T12:00:00");
  for (const char* iso : {"1900-01-01T00:00:00Z", "1969-12-31T23:59:59Z", "2100-12-31T23:59:59Z"})
    EXPECT_EQ(formatInstant(parseInstant(iso)->seconds, {false, true, true}), iso);
}

} // namespace
