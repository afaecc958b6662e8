// Several times of one layer (tools/tellus/cli LayerTimes.hpp): what `tellus seed --time` and
// `--animate` accept. Each instant of a list or range is checked against the layer's declared TIME
// dimension with the proxy's rule, spelt as the layer spells it, and the first one it does not
// declare is refused by name.

#include <tellus/cli/LayerTimes.hpp>

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace tellus::cli {
namespace {

using Strings = std::vector<std::string>;

LayerConfig monthly() { // a period the configuration expanded, as ParseLayers does
  LayerConfig l;
  l.name = "sst";
  l.time.period = "2024-01-01/2024-12-01/P1M";
  for (int m = 1; m <= 12; ++m) {
    l.time.values.push_back("2024-" + std::string(m < 10 ? "0" : "") + std::to_string(m) + "-01");
  }
  l.time.defaultValue = "2024-12-01";
  return l;
}

LayerConfig listed() {
  LayerConfig l;
  l.name = "modis";
  l.time.values = {"2024-06-01", "2024-06-09", "2024-06-17T00:00:00Z"};
  l.time.defaultValue = "2024-06-17T00:00:00Z";
  return l;
}

TEST(LayerTimes, ARangeOnTheGridGivesTheLayersOwnSpelling) {
  EXPECT_EQ(*layerTimes(monthly(), "2024-02-01/2024-04-01/P1M"),
            (Strings{"2024-02-01", "2024-03-01", "2024-04-01"}));
  // Another spelling of the same instants: the layer's.
  EXPECT_EQ(*layerTimes(monthly(), "2024-02-01T00:00:00Z/2024-03-01T00:00:00Z/P1M"),
            (Strings{"2024-02-01", "2024-03-01"}));
  EXPECT_EQ(*layerTimes(monthly(), "2024-05-01,2024-01-01"), (Strings{"2024-05-01", "2024-01-01"}));
  // A/B: the declared times within.
  EXPECT_EQ(*layerTimes(listed(), "2024-06-05/2024-06-30"),
            (Strings{"2024-06-09", "2024-06-17T00:00:00Z"}));
  EXPECT_EQ(layerTimes(monthly(), "2024-01-01/2024-12-31")->size(), 12u);
}

TEST(LayerTimes, AnInstantTheLayerDoesNotDeclareIsRefusedByName) {
  // P1D over a monthly layer: 2024-01-02 is the first instant off its grid.
  const auto daily = layerTimes(monthly(), "2024-01-01/2024-01-05/P1D");
  ASSERT_FALSE(daily.has_value());
  EXPECT_NE(daily.error().find("does not declare 2024-01-02"), std::string::npos) << daily.error();
  const auto outside = layerTimes(monthly(), "2025-01-01");
  ASSERT_FALSE(outside.has_value());
  EXPECT_NE(outside.error().find("2025-01-01"), std::string::npos);
  const auto unlisted = layerTimes(listed(), "2024-06-01/2024-06-17/P8D,2024-06-25");
  ASSERT_FALSE(unlisted.has_value());
  EXPECT_NE(unlisted.error().find("does not declare 2024-06-25"), std::string::npos)
      << unlisted.error();
}

TEST(LayerTimes, ALayerWithoutTimeAndTooManyInstantsAreRefused) {
  LayerConfig plain;
  plain.name = "bluemarble";
  const auto none = layerTimes(plain, "2024-01-01");
  ASSERT_FALSE(none.has_value());
  EXPECT_NE(none.error().find("no TIME dimension"), std::string::npos);
  LayerConfig hourly;
  hourly.name = "model";
  hourly.time.period = "2000-01-01T00:00:00Z/2030-01-01T00:00:00Z/PT1H"; // too long to list
  hourly.time.defaultValue = "2030-01-01T00:00:00Z";
  EXPECT_EQ(layerTimes(hourly, "2024-01-01T00:00:00Z/2024-01-01T02:00:00Z/PT1H")->size(), 3u);
  const auto year = layerTimes(hourly, "2024-01-01T00:00:00Z/2024-12-31T00:00:00Z/PT1H");
  ASSERT_FALSE(year.has_value());
  EXPECT_NE(year.error().find("more than 1000 instants"), std::string::npos) << year.error();
  const auto day = layerTimes(hourly, "2024-01-01T00:00:00Z/2024-01-02T00:00:00Z/PT1H", 10);
  ASSERT_FALSE(day.has_value());
  EXPECT_NE(day.error().find("more than 10 instants"), std::string::npos) << day.error();
}

} // namespace
} // namespace tellus::cli
