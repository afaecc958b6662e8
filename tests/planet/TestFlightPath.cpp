// Flights of `tellus render --path PATH.json`: the file read strictly, the pose between keyframes
// (the short way round the antimeridian, through a pole, geometric in altitude from 1 m to 1e9 m),
// the layer times the keyframes switch to, and the frames at a frame rate.

#include <tellus/planet/Camera.hpp>
#include <tellus/planet/FlightPath.hpp>
#include <tellus/planet/Geodesy.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace tellus::planet {
namespace {

FlightPath path(const std::string& json) {
  auto p = FlightPath::parse(json);
  EXPECT_TRUE(p.has_value()) << json << ": " << (p ? "" : p.error());
  return p ? std::move(*p) : *FlightPath::parse(R"([{"time":0,"lat":0,"lon":0,"alt":1}])");
}

Keyframe key(double t, double lat, double lon, double alt, double heading = 0, double tilt = 0) {
  return {t, {lat, lon, alt, heading, tilt}, {}, std::nullopt, {}};
}

FlightPath flight(std::vector<Keyframe> keys) {
  auto p = FlightPath::create(std::move(keys));
  EXPECT_TRUE(p.has_value()) << (p ? "" : p.error());
  return std::move(*p);
}

TEST(FlightPath, ReadsAnArrayOfKeyframesWithHeadingAndTiltOptional) {
  const FlightPath p = path(R"([
    {"time": 0, "lat": 46.5, "lon": 7.5, "alt": 2e6},
    {"time": 2.5, "lat": -10, "lon": -170, "alt": 500, "heading": 30, "tilt": 60,
     "times": {"sst": "2024-01-02", "clouds": "t1"}}
  ])");
  ASSERT_EQ(p.keyframes().size(), 2u);
  const Keyframe& a = p.keyframes()[0];
  EXPECT_EQ(a.timeS, 0.0);
  EXPECT_EQ(a.pose.latDeg, 46.5);
  EXPECT_EQ(a.pose.lonDeg, 7.5);
  EXPECT_EQ(a.pose.altitudeM, 2e6);
  EXPECT_EQ(a.pose.headingDeg, 0.0);
  EXPECT_EQ(a.pose.tiltDeg, 0.0);
  EXPECT_TRUE(a.layerTimes.empty());
  const Keyframe& b = p.keyframes()[1];
  EXPECT_EQ(b.timeS, 2.5);
  EXPECT_EQ(b.pose.headingDeg, 30.0);
  EXPECT_EQ(b.pose.tiltDeg, 60.0);
  EXPECT_EQ(b.layerTimes,
            (std::map<std::string, std::string>{{"sst", "2024-01-02"}, {"clouds", "t1"}}));
  EXPECT_EQ(p.startS(), 0.0);
  EXPECT_EQ(p.endS(), 2.5);
}

TEST(FlightPath, ReadsTheKeyframesObject) {
  const FlightPath p = path(R"({"keyframes": [{"time": 1, "lat": 0, "lon": 0, "alt": 1e7}]})");
  ASSERT_EQ(p.keyframes().size(), 1u);
  EXPECT_EQ(p.keyframes()[0].timeS, 1.0);
}

TEST(FlightPath, RefusesTextThatIsNotJsonSayingWhere) {
  const auto p = FlightPath::parse("[{\"time\": 0,\n \"lat\": }]");
  ASSERT_FALSE(p);
  EXPECT_NE(p.error().find("parse error at line 2, column"), std::string::npos) << p.error();
  EXPECT_EQ(p.error().find("[json.exception"), std::string::npos) << p.error();
  EXPECT_FALSE(FlightPath::parse(""));
  EXPECT_FALSE(FlightPath::parse("[{\"time\": 0, \"lat\": 0, \"lon\": 0, \"alt\": 1}] x"));
}

TEST(FlightPath, RefusesBadInputNamingTheKeyframeAndWhatIsWrong) {
  const std::string ok = R"("time": 0, "lat": 0, "lon": 0, "alt": 1)";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"{}", "expected [keyframes] or {\"keyframes\": [...]}"},
      {"{\"keyframes\": [{" + ok + "}], \"x\": 1}", "expected [keyframes] or"},
      {"{\"frames\": []}", "expected [keyframes] or"},
      {"{\"keyframes\": 3}", "expected an array of keyframes"},
      {"3", "expected an array of keyframes"},
      {"\"path\"", "expected an array of keyframes"},
      {"[]", "no keyframes"},
      {"{\"keyframes\": []}", "no keyframes"},
      {"[3]", "keyframe 0: expected a keyframe object"},
      {"[{" + ok + "}, []]", "keyframe 1: expected a keyframe object"},
      {R"([{"time": 0, "lat": 0, "lon": 0}])",
       "keyframe 0: a keyframe needs time, lat, lon and alt"},
      {R"([{"lat": 0, "lon": 0, "alt": 1}])", "a keyframe needs time, lat, lon and alt"},
      {"[{" + ok + ", \"altitude\": 3}]", "keyframe 0: unknown key 'altitude'"},
      {R"([{"time": 0, "lat": "0", "lon": 0, "alt": 1}])", "keyframe 0: expected \"lat\": number"},
      {R"([{"time": 0, "lat": null, "lon": 0, "alt": 1}])", "expected \"lat\": number"},
      {R"([{"time": true, "lat": 0, "lon": 0, "alt": 1}])", "expected \"time\": number"},
      {"[{" + ok + ", \"times\": 3}]",
       "keyframe 0: expected \"times\": {\"layer\": \"TIME\", ...}"},
      {"[{" + ok + ", \"times\": {\"sst\": 3}}]", "expected \"times\": {\"layer\""},
      {"[{" + ok + ", \"times\": [\"sst\"]}]", "expected \"times\": {\"layer\""},
      {"[{" + ok + "}, {" + ok + "}]", "keyframe 1: times must increase"},
      {R"([{"time": 2, "lat": 0, "lon": 0, "alt": 1}, {"time": 1, "lat": 0, "lon": 0, "alt": 1}])",
       "keyframe 1: times must increase"},
      {R"([{"time": 0, "lat": 90.001, "lon": 0, "alt": 1}])", "keyframe 0: out of range"},
      {R"([{"time": 0, "lat": -91, "lon": 0, "alt": 1}])", "out of range (lat [-90, 90]"},
      {R"([{"time": 0, "lat": 0, "lon": 0, "alt": -11001}])", "out of range"},
      {R"([{"time": 0, "lat": 0, "lon": 0, "alt": 1.1e10}])", "out of range"},
      {"[{" + ok + ", \"tilt\": -1}]", "out of range"},
      {"[{" + ok + ", \"tilt\": 180.5}]", "out of range"},
      {R"([{"time": 0, "lat": 0, "lon": 1e999, "alt": 1}])", ""},
  };
  for (const auto& [json, want] : cases) {
    const auto p = FlightPath::parse(json);
    ASSERT_FALSE(p) << json;
    EXPECT_NE(p.error().find(want), std::string::npos) << json << ": " << p.error();
  }
}

TEST(FlightPath, AcceptsTheLimitsOfEveryRange) {
  const FlightPath p = path(R"([
    {"time": -5, "lat": -90, "lon": -1e6, "alt": -11000, "heading": -720, "tilt": 0},
    {"time": 1e9, "lat": 90, "lon": 1e6, "alt": 1e10, "heading": 720, "tilt": 180}])");
  EXPECT_EQ(p.keyframes().size(), 2u);
}

TEST(FlightPath, CreateRefusesWhatTheFileCannotSay) {
  EXPECT_FALSE(FlightPath::create({}));
  const double nan = std::nan("");
  const double inf = std::numeric_limits<double>::infinity();
  for (const Keyframe& k : {key(nan, 0, 0, 1),
                            key(0, nan, 0, 1),
                            key(0, 0, inf, 1),
                            key(0, 0, 0, nan),
                            key(0, 0, 0, 1, -inf),
                            key(0, 0, 0, 1, 0, nan)}) {
    const auto p = FlightPath::create({k});
    ASSERT_FALSE(p);
    EXPECT_EQ(p.error(), "keyframe 0: every number must be finite");
  }
}

TEST(FlightPath, ReadNamesTheFile) {
  const std::filesystem::path dir = TELLUS_TEST_TMP_DIR;
  const std::filesystem::path file = dir / "flight-path-test.json";
  std::ofstream(file) << R"([{"time": 1, "lat": 0, "lon": 0, "alt": 1},
                            {"time": 1, "lat": 0, "lon": 0, "alt": 1}])";
  const auto bad = FlightPath::read(file);
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error(), file.string() + ": keyframe 1: times must increase");
  std::ofstream(file) << R"({"keyframes": [{"time": 1, "lat": 0, "lon": 0, "alt": 1}]})";
  EXPECT_TRUE(FlightPath::read(file));
  std::filesystem::remove(file);
  const auto missing = FlightPath::read(file);
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error(), "cannot open " + file.string());
}

TEST(FlightPath, PoseIsTheKeyframesOwnAtItsTimeAndBeyondTheEnds) {
  const FlightPath p = flight({key(1, 10, 20, 1000, 5, 10), key(3, 30, 40, 4000, 15, 30)});
  for (const double t : {-1e9, 0.0, 1.0}) {
    const CameraPose q = p.poseAt(t);
    EXPECT_EQ(q.latDeg, 10.0);
    EXPECT_EQ(q.altitudeM, 1000.0);
    EXPECT_EQ(q.tiltDeg, 10.0);
  }
  for (const double t : {3.0, 4.0, 1e9}) {
    const CameraPose q = p.poseAt(t);
    EXPECT_EQ(q.lonDeg, 40.0);
    EXPECT_EQ(q.altitudeM, 4000.0);
    EXPECT_EQ(q.headingDeg, 15.0);
  }
}

TEST(FlightPath, MidwayIsLinearInLatitudeAndTiltAndGeometricInAltitude) {
  const FlightPath p = flight({key(0, 10, 20, 1000, 5, 10), key(2, 30, 40, 4000, 15, 30)});
  const CameraPose q = p.poseAt(1.0);
  EXPECT_DOUBLE_EQ(q.latDeg, 20.0);
  EXPECT_DOUBLE_EQ(q.lonDeg, 30.0);
  EXPECT_DOUBLE_EQ(q.altitudeM, 2000.0); // sqrt(1000 x 4000)
  EXPECT_DOUBLE_EQ(q.headingDeg, 10.0);
  EXPECT_DOUBLE_EQ(q.tiltDeg, 20.0);
  // An inner keyframe is met at its time (up to rounding in the altitude's logarithms).
  const FlightPath three = flight({key(0, 0, 0, 10), key(1, 5, 5, 1e5), key(2, 0, 0, 10)});
  EXPECT_DOUBLE_EQ(three.poseAt(1.0).latDeg, 5.0);
  EXPECT_NEAR(three.poseAt(1.0).altitudeM, 1e5, 1e-6);
}

TEST(FlightPath, HeadingTurnsTheShortWay) {
  const FlightPath p = flight({key(0, 0, 0, 1, 350), key(1, 0, 0, 1, 10)});
  EXPECT_DOUBLE_EQ(p.poseAt(0.5).headingDeg, 360.0);
  EXPECT_DOUBLE_EQ(p.poseAt(0.25).headingDeg, 355.0);
  const FlightPath back = flight({key(0, 0, 0, 1, 10), key(1, 0, 0, 1, 350)});
  EXPECT_DOUBLE_EQ(back.poseAt(0.5).headingDeg, 0.0);
}

TEST(FlightPath, LayerTimesHoldFromTheirKeyframeOn) {
  FlightPath p = [] {
    std::vector<Keyframe> keys = {key(0, 0, 0, 1), key(2, 0, 0, 1), key(4, 0, 0, 1)};
    keys[0].layerTimes = {{"sst", "day1"}};
    keys[1].layerTimes = {{"sst", "day2"}, {"clouds", "t"}};
    return flight(std::move(keys));
  }();
  using Times = std::map<std::string, std::string>;
  EXPECT_EQ(p.layerTimesAt(-1.0), Times{});
  EXPECT_EQ(p.layerTimesAt(0.0), (Times{{"sst", "day1"}}));
  EXPECT_EQ(p.layerTimesAt(1.999), (Times{{"sst", "day1"}}));
  EXPECT_EQ(p.layerTimesAt(2.0 - 1e-10), (Times{{"sst", "day2"}, {"clouds", "t"}}));
  EXPECT_EQ(p.layerTimesAt(1e9), (Times{{"sst", "day2"}, {"clouds", "t"}}));
}

TEST(FlightPath, FramesAtAFrameRate) {
  const FlightPath p = flight({key(0.5, 0, 0, 1), key(1.5, 0, 0, 1)});
  EXPECT_EQ(p.frameCount(2.0), 3);
  EXPECT_EQ(p.frameCount(25.0), 26);
  EXPECT_EQ(p.frameCount(0.5), 1);
  EXPECT_DOUBLE_EQ(p.frameTimeS(0, 2.0), 0.5);
  EXPECT_DOUBLE_EQ(p.frameTimeS(2, 2.0), 1.5);
  // A duration a rounding error short of a whole frame still ends on that frame.
  // (0.29 s x 100 fps is 28.999999999999996.)
  const FlightPath short29 = flight({key(0, 0, 0, 1), key(0.29, 0, 0, 1)});
  EXPECT_EQ(short29.frameCount(100.0), 30);
  EXPECT_EQ(flight({key(7, 0, 0, 1)}).frameCount(25.0), 1);
}

TEST(FlightPathExtremes, AcrossTheAntimeridianTheShortWayFromEitherSide) {
  const FlightPath east = flight({key(0, 0, 170, 1e6), key(1, 0, -170, 1e6)});
  EXPECT_DOUBLE_EQ(east.poseAt(0.25).lonDeg, 175.0);
  EXPECT_DOUBLE_EQ(east.poseAt(0.5).lonDeg, 180.0);
  EXPECT_DOUBLE_EQ(east.poseAt(0.75).lonDeg, 185.0); // = 175 W
  const FlightPath west = flight({key(0, 0, -170, 1e6), key(1, 0, 170, 1e6)});
  EXPECT_DOUBLE_EQ(west.poseAt(0.5).lonDeg, -180.0);
  EXPECT_DOUBLE_EQ(west.poseAt(0.75).lonDeg, -185.0);
  // Every step is the same 20 / 1000 degrees: never the long way round through Greenwich.
  double previous = east.poseAt(0.0).lonDeg;
  for (int i = 1; i <= 1000; ++i) {
    const double lon = east.poseAt(i / 1000.0).lonDeg;
    EXPECT_NEAR(std::remainder(lon - previous, 360.0), 0.02, 1e-9) << i;
    previous = lon;
  }
  EXPECT_DOUBLE_EQ(std::remainder(previous, 360.0), -170.0);
  // Exactly opposite (180 degrees apart): one way, consistently.
  const FlightPath half = flight({key(0, 0, 0, 1e6), key(1, 0, 180, 1e6)});
  EXPECT_DOUBLE_EQ(half.poseAt(0.5).lonDeg, 90.0);
}

TEST(FlightPathExtremes, ThroughAPoleAndRoundIt) {
  const Geodesy wgs84(EarthModel::Wgs84);
  // Up to the north pole on the prime meridian, down the other side along 180.
  const FlightPath over = flight({key(0, 80, 0, 1e6), key(1, 90, 0, 1e6), key(2, 80, 180, 1e6)});
  for (int i = 0; i <= 200; ++i) {
    const double t = i / 100.0;
    const CameraPose q = over.poseAt(t);
    EXPECT_LE(q.latDeg, 90.0) << t;
    EXPECT_DOUBLE_EQ(q.latDeg, 90.0 - 10.0 * std::abs(t - 1.0)) << t;
    EXPECT_NO_THROW((void)Camera(wgs84, q, {64, 48}, 60.0)) << t;
  }
  EXPECT_EQ(over.poseAt(1.0).latDeg, 90.0);
  // Both keyframes at the pole: the latitude stays exactly 90 whatever the longitudes.
  const FlightPath atPole = flight({key(0, 90, -120, 1e6, 0, 45), key(1, 90, 60, 1e6, 90, 45)});
  EXPECT_EQ(atPole.poseAt(0.37).latDeg, 90.0);
  const FlightPath south = flight({key(0, -90, 0, 1e6), key(1, -90, 180, 1e6)});
  EXPECT_EQ(south.poseAt(0.5).latDeg, -90.0);
  // Two points beyond the pole: round it along the parallels, never over it.
  const FlightPath round = flight({key(0, 85, 0, 1e6), key(1, 85, 180, 1e6)});
  EXPECT_EQ(round.poseAt(0.5).latDeg, 85.0);
  EXPECT_DOUBLE_EQ(round.poseAt(0.5).lonDeg, 90.0);
}

TEST(FlightPathExtremes, AltitudeFromOneMetreToABillionMetresIsGeometric) {
  const FlightPath descent = flight({key(0, 0, 0, 1e9), key(9, 0, 0, 1)});
  EXPECT_EQ(descent.poseAt(0).altitudeM, 1e9);
  EXPECT_EQ(descent.poseAt(9).altitudeM, 1.0);
  // One decade a second, every step the same ratio, strictly down to the ground.
  for (int s = 0; s <= 9; ++s)
    EXPECT_NEAR(descent.poseAt(s).altitudeM / std::pow(10.0, 9 - s), 1.0, 1e-12) << s;
  double previous = descent.poseAt(0).altitudeM;
  for (int i = 1; i <= 900; ++i) {
    const double alt = descent.poseAt(i / 100.0).altitudeM;
    EXPECT_LT(alt, previous) << i;
    EXPECT_NEAR(previous / alt, std::pow(10.0, 0.01), 1e-9) << i;
    previous = alt;
  }
  EXPECT_NEAR(descent.poseAt(4.5).altitudeM, std::sqrt(1e9), 1e-6);
  // The same climb: the same altitudes backwards.
  const FlightPath climb = flight({key(0, 0, 0, 1), key(9, 0, 0, 1e9)});
  EXPECT_NEAR(climb.poseAt(2.0).altitudeM, 100.0, 1e-10);
  // Ground level or below at either end: linear (a logarithm needs both positive).
  const FlightPath toSea = flight({key(0, 0, 0, 1e9), key(1, 0, 0, 0)});
  EXPECT_DOUBLE_EQ(toSea.poseAt(0.5).altitudeM, 5e8);
  const FlightPath underwater = flight({key(0, 0, 0, -11000), key(1, 0, 0, 1e10)});
  EXPECT_DOUBLE_EQ(underwater.poseAt(0.5).altitudeM, (1e10 - 11000) / 2);
}

} // namespace
} // namespace tellus::planet

namespace tellus::planet {
namespace {

TEST(FlightPath, SceneTimeIsInterpolatedBetweenTheKeyframesThatHaveOne) {
  const FlightPath p = path(R"([
    {"time": 0, "lat": 0, "lon": 0, "alt": 1, "utc": "2024-06-20T12:00:00Z"},
    {"time": 2, "lat": 0, "lon": 0, "alt": 1},
    {"time": 4, "lat": 0, "lon": 0, "alt": 1, "utc": 1718971200},
    {"time": 6, "lat": 0, "lon": 0, "alt": 1}])");
  EXPECT_EQ(p.keyframes()[0].sceneTimeUnixSeconds, 1718884800.0);
  EXPECT_EQ(p.keyframes()[1].sceneTimeUnixSeconds, std::nullopt);
  EXPECT_EQ(p.sceneTimeAt(-5.0), 1718884800.0) << "held before the first";
  EXPECT_EQ(p.sceneTimeAt(0.0), 1718884800.0);
  EXPECT_DOUBLE_EQ(*p.sceneTimeAt(1.0), 1718884800.0 + 21600.0) << "a quarter of a day";
  EXPECT_DOUBLE_EQ(*p.sceneTimeAt(3.0), 1718884800.0 + 64800.0) << "across a keyframe without";
  EXPECT_EQ(p.sceneTimeAt(4.0), 1718971200.0);
  EXPECT_EQ(p.sceneTimeAt(6.0), 1718971200.0) << "held after the last";
  EXPECT_EQ(path(R"([{"time":0,"lat":0,"lon":0,"alt":1}])").sceneTimeAt(0.0), std::nullopt);
}

TEST(FlightPath, SceneTimeCanRunBackwardsAndBeforeTheUnixEpoch) {
  const FlightPath p = path(R"([
    {"time": 0, "lat": 0, "lon": 0, "alt": 1, "utc": "1969-12-31T00:00:00Z"},
    {"time": 10, "lat": 0, "lon": 0, "alt": 1, "utc": "1900-01-01"}])");
  EXPECT_EQ(p.sceneTimeAt(0.0), -86400.0);
  EXPECT_LT(*p.sceneTimeAt(5.0), -86400.0);
  EXPECT_EQ(p.sceneTimeAt(10.0), -2208988800.0);
}

TEST(FlightPath, RefusesABadSceneTime) {
  for (const char* bad : {R"([{"time":0,"lat":0,"lon":0,"alt":1,"utc":"now"}])",
                          R"([{"time":0,"lat":0,"lon":0,"alt":1,"utc":"2024-02-30"}])",
                          R"([{"time":0,"lat":0,"lon":0,"alt":1,"utc":true}])"}) {
    const auto p = FlightPath::parse(bad);
    ASSERT_FALSE(p.has_value()) << bad;
    EXPECT_NE(p.error().find("keyframe 0"), std::string::npos) << p.error();
    EXPECT_NE(p.error().find("utc"), std::string::npos) << p.error();
  }
}

} // namespace
} // namespace tellus::planet
