// The scene's time as written (ISO 8601 UTC, "now") and as the viewer runs it (SceneClock).
#include <tellus/planet/SceneTime.hpp>

#include <gtest/gtest.h>

namespace {

using namespace tellus::planet;

TEST(SceneTime, ParsesIso8601UtcForms) {
  EXPECT_EQ(parseSceneTime("2024-06-20T12:00:00Z", 0.0).value(), 1718884800.0);
  EXPECT_EQ(parseSceneTime("2024-06-20T12:00Z", 0.0).value(), 1718884800.0);
  EXPECT_EQ(parseSceneTime("2024-06-20T12:00:00", 0.0).value(), 1718884800.0);
  EXPECT_EQ(parseSceneTime("2024-06-20 12:00:00Z", 0.0).value(), 1718884800.0);
  EXPECT_EQ(parseSceneTime("2024-06-20", 0.0).value(), 1718841600.0);
  EXPECT_EQ(parseSceneTime("1970-01-01T00:00:00Z", 0.0).value(), 0.0);
  EXPECT_DOUBLE_EQ(parseSceneTime("2024-06-20T12:00:00.25Z", 0.0).value(), 1718884800.25);
  EXPECT_EQ(parseSceneTime("now", 1234.5).value(), 1234.5);
  // The configuration's renderer.time and a layer's TIME read the same grammar (cache/IsoTime).
  EXPECT_EQ(parseSceneTime("2024-06-20T14:00+02:00", 0.0).value(), 1718884800.0);
  EXPECT_EQ(parseSceneTime("0000-01-01", 0.0).value(), -62167219200.0);
}

TEST(SceneTime, RefusesWhatIsNotAUtcInstant) {
  for (const char* bad : {"",
                          "yesterday",
                          "2024-13-01",
                          "2024-02-30T00:00Z",
                          "2024-06-20T24:00Z",
                          "2024-06-20T12:60Z",
                          "2024-06-20T12:00:61Z",
                          "2024-06-20T12:00:00.Z",
                          "2024-6-20",
                          "NOW"}) {
    const auto t = parseSceneTime(bad, 0.0);
    EXPECT_FALSE(t.has_value()) << bad;
    if (!t) {
      EXPECT_NE(t.error().find("ISO 8601"), std::string::npos);
    }
  }
}

TEST(SceneTime, FormatsAndRoundTrips) {
  EXPECT_EQ(formatSceneTime(1718884800.0), "2024-06-20T12:00:00Z");
  EXPECT_EQ(formatSceneTime(1718884800.9), "2024-06-20T12:00:00Z");
  EXPECT_EQ(formatSceneTime(0.0), "1970-01-01T00:00:00Z");
  for (const char* iso : {"1900-01-01T00:00:00Z",
                          "1969-12-31T23:59:59Z",
                          "2000-02-29T06:07:08Z",
                          "2100-12-31T23:59:59Z"})
    EXPECT_EQ(formatSceneTime(parseSceneTime(iso, 0.0).value()), iso);
  EXPECT_EQ(formatSceneTime(-1.0), "1969-12-31T23:59:59Z") << "negative times round down";
  EXPECT_EQ(formatSceneTime(1e15), "+1000000000000000 s");
}

TEST(SceneTime, ClockRunsFasterSlowerBackwardsAndPauses) {
  SceneClock c(1000.0, 50.0);
  EXPECT_EQ(c.advance(52.0), 1002.0) << "real time";
  c.faster();
  EXPECT_EQ(c.rate(), 10.0);
  EXPECT_EQ(c.advance(53.0), 1012.0);
  c.reverse();
  EXPECT_EQ(c.rate(), -10.0);
  EXPECT_EQ(c.advance(54.0), 1002.0) << "backwards";
  c.faster();
  EXPECT_EQ(c.rate(), -60.0) << "faster keeps the direction";
  c.togglePause();
  EXPECT_TRUE(c.paused());
  EXPECT_EQ(c.rate(), 0.0);
  EXPECT_EQ(c.advance(100.0), 1002.0) << "paused";
  c.togglePause();
  EXPECT_EQ(c.rate(), -60.0) << "the rate survives a pause";
  c.slower();
  c.slower();
  c.slower();
  EXPECT_EQ(c.rate(), -1.0) << "real time is the slowest";
  for (int i = 0; i < 10; ++i)
    c.faster();
  EXPECT_EQ(c.rate(), -86400.0) << "a day a second is the fastest";
  EXPECT_EQ(c.advance(99.0), 1002.0) << "a wall clock going back moves nothing";
  c.set(5.0);
  EXPECT_EQ(c.time(), 5.0);
}

} // namespace
