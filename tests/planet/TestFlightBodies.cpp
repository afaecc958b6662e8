// Flights between bodies (issue 26; planet/FlightBodies.hpp), GL-free: keyframes naming their
// body, read and refused; a flight on the orbited body unchanged; a keyframe over the Moon drawn
// from the Earth's frame at the Moon's place; an Earth-to-Moon flight continuous in the common
// frame, arriving at the Moon keyframe's eye.

#include <tellus/planet/Camera.hpp>
#include <tellus/planet/FlightBodies.hpp>
#include <tellus/planet/Geodesy.hpp>
#include <tellus/planet/SceneBodies.hpp>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <string>

using namespace tellus;
using namespace tellus::planet;

namespace {

constexpr const char* kUtc = "\"utc\": \"2024-01-18T03:52:00Z\"";
constexpr double kUtcS = 1705549920.0;

FlightPath parse(const std::string& json) {
  auto p = FlightPath::parse(json);
  EXPECT_TRUE(p) << (p ? "" : p.error());
  return std::move(*p);
}

glm::dvec3 eyeOf(const Body& body, const CameraPose& pose) {
  const Geodesy g(body);
  return Camera(g, pose, Viewport{64, 64}, 45.0).position();
}

} // namespace

TEST(FlightBodies, KeyframesNameTheirBody) {
  const FlightPath p = parse(std::string("[{\"time\": 0, \"lat\": 1, \"lon\": 2, \"alt\": 3e6, "
                                         "\"body\": \"moon\", ") +
                             kUtc + "}, {\"time\": 1, \"lat\": 1, \"lon\": 2, \"alt\": 3e6}]");
  EXPECT_EQ(p.keyframes()[0].body, "moon");
  EXPECT_EQ(p.keyframes()[1].body, "");
  for (const char* bad : {"\"pluto\"", "3", "\"\""}) {
    const auto r = FlightPath::parse(
        std::string("[{\"time\": 0, \"lat\": 1, \"lon\": 2, \"alt\": 3e6, \"body\": ") + bad +
        "}]");
    ASSERT_FALSE(r) << bad;
    EXPECT_NE(r.error().find("\"body\": earth, moon or mars"), std::string::npos) << r.error();
  }
  EXPECT_FALSE(flightBodiesProblem(p, earthBody()));
  Body vesta = moonBody();
  vesta.name = "vesta";
  ASSERT_TRUE(flightBodiesProblem(p, vesta));
  EXPECT_NE(flightBodiesProblem(p, vesta)->find("no ephemeris"), std::string::npos);
}

TEST(FlightBodies, AFlightOnTheOrbitedBodyIsUnchanged) {
  const FlightPath p =
      parse("[{\"time\": 0, \"lat\": 10, \"lon\": 170, \"alt\": 1e9, \"tilt\": 20, "
            "\"body\": \"earth\"}, {\"time\": 4, \"lat\": -5, \"lon\": -170, "
            "\"alt\": 1, \"heading\": 90}]");
  for (double t = -1.0; t <= 5.0; t += 0.25) {
    const CameraPose a = flightPoseOver(p, t, earthBody()), b = p.poseAt(t);
    EXPECT_EQ(a.latDeg, b.latDeg);
    EXPECT_EQ(a.lonDeg, b.lonDeg);
    EXPECT_EQ(a.altitudeM, b.altitudeM);
    EXPECT_EQ(a.headingDeg, b.headingDeg);
    EXPECT_EQ(a.tiltDeg, b.tiltDeg);
  }
}

TEST(FlightBodies, AKeyframeOverTheMoonIsWhereTheMoonIs) {
  // 1,000 km over the Moon's (10 N, 20 E), looking straight down: from the Earth's frame the eye
  // is the Moon's centre plus that point turned, and it looks at the Moon.
  const CameraPose onMoon{10.0, 20.0, 1.0e6, 30.0, 0.0};
  const FlightPath p = parse(std::string("[{\"time\": 0, \"lat\": 10, \"lon\": 20, \"alt\": 1e6, "
                                         "\"heading\": 30, \"body\": \"moon\", ") +
                             kUtc + "}]");
  const CameraPose over = flightPoseOver(p, 0.0, earthBody());
  const BodyPlacement m = placeBody(astro::EphemerisBody::earth, astro::EphemerisBody::moon, kUtcS);
  const glm::dvec3 want = m.centre + m.rotation * eyeOf(moonBody(), onMoon);
  const Geodesy earth(earthBody());
  const Camera cam(earth, over, Viewport{64, 64}, 45.0);
  EXPECT_LT(glm::length(cam.position() - want), 1e-3);
  const glm::dvec3 toMoon = glm::normalize(m.centre - cam.position());
  EXPECT_GT(glm::dot(cam.forward(), toMoon), std::cos(1.0e-6)); // straight at its centre
}

TEST(FlightBodies, AFlightFromTheEarthToTheMoonIsContinuousInTheCommonFrame) {
  const FlightPath p = parse(
      std::string("[{\"time\": 0, \"lat\": 11, \"lon\": -150, \"alt\": 2e6, \"tilt\": 150, ") +
      kUtc +
      "}, {\"time\": 10, \"lat\": 0, \"lon\": 0, \"alt\": 5e5, \"body\": \"moon\", \"heading\": "
      "90, \"tilt\": 60, " +
      kUtc + "}]");
  const Geodesy earth(earthBody());
  const auto eye = [&](double t) {
    return Camera(earth, flightPoseOver(p, t, earthBody()), Viewport{64, 64}, 45.0);
  };
  const glm::dvec3 start = eyeOf(earthBody(), p.keyframes()[0].pose);
  const BodyPlacement m = placeBody(astro::EphemerisBody::earth, astro::EphemerisBody::moon, kUtcS);
  const glm::dvec3 end = m.centre + m.rotation * eyeOf(moonBody(), p.keyframes()[1].pose);
  EXPECT_LT(glm::length(eye(0.0).position() - start), 1e-3);
  EXPECT_LT(glm::length(eye(10.0).position() - end), 1e-3);
  // 1,000 steps: no step longer than smoothstep's steepest (1.5 x the mean), the view turning
  // smoothly (no flip as the eye passes from near the Earth to near the Moon).
  const double mean = glm::length(end - start) / 1000.0;
  Camera last = eye(0.0);
  for (int i = 1; i <= 1000; ++i) {
    const Camera c = eye(i * 0.01);
    EXPECT_LT(glm::length(c.position() - last.position()), 1.5 * mean + 1e-3) << i;
    EXPECT_GT(glm::dot(c.forward(), last.forward()), std::cos(0.02)) << i;
    last = c;
  }
  // At the end the view is the Moon keyframe's, turned into the Earth's frame.
  const Geodesy moon(moonBody());
  const Camera atMoon(moon, p.keyframes()[1].pose, Viewport{64, 64}, 45.0);
  EXPECT_GT(glm::dot(eye(10.0).forward(), m.rotation * atMoon.forward()), std::cos(1e-6));
}

TEST(FlightBodies, ChangingTheBodyOrbitedKeepsTheEye) {
  // view's B: 20,000 km over the Earth, then over the Moon, then back: the same eye each time.
  const CameraPose start{20.0, 10.0, 2.0e7, 30.0, 40.0};
  const CameraPose onMoon = poseOverOtherBody(start, earthBody(), moonBody(), kUtcS);
  const BodyPlacement e = placeBody(astro::EphemerisBody::moon, astro::EphemerisBody::earth, kUtcS);
  EXPECT_LT(
      glm::length(eyeOf(moonBody(), onMoon) - (e.centre + e.rotation * eyeOf(earthBody(), start))),
      1e-3);
  const CameraPose back = poseOverOtherBody(onMoon, moonBody(), earthBody(), kUtcS);
  EXPECT_NEAR(back.latDeg, start.latDeg, 1e-9);
  EXPECT_NEAR(back.lonDeg, start.lonDeg, 1e-9);
  EXPECT_NEAR(back.altitudeM, start.altitudeM, 1e-4);
  EXPECT_NEAR(back.headingDeg, start.headingDeg, 1e-7);
  EXPECT_NEAR(back.tiltDeg, start.tiltDeg, 1e-7);
}
