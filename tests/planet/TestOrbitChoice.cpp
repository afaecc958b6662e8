// Which body the camera orbits along a flight (issue 26; planet/OrbitChoice.hpp), GL-free: the
// rule in radii with its hysteresis; an Earth-to-Moon flight of 1,000 steps that switches once,
// at the rule's distance, with the eye kept; an eye wandering about the point of equal apparent
// size that never flips.

#include <tellus/planet/Camera.hpp>
#include <tellus/planet/FlightBodies.hpp>
#include <tellus/planet/Geodesy.hpp>
#include <tellus/planet/OrbitChoice.hpp>
#include <tellus/planet/SceneBodies.hpp>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <array>
#include <stdexcept>
#include <string>

using namespace tellus;
using namespace tellus::planet;

namespace {

constexpr double kUtcS = 1705549920.0; // 2024-01-18 03:52 UTC

glm::dvec3 eyeOf(const Body& body, const CameraPose& pose) {
  const Geodesy g(body);
  return Camera(g, pose, Viewport{64, 64}, 45.0).position();
}

} // namespace

TEST(OrbitChoice, TheBodyNearerInRadiiIsTakenPastTheHysteresis) {
  // The Earth at 10 radii, the Moon at 6: nearer, but not by 2x; at 4.9 it is.
  std::array<OrbitCandidate, 2> c{{{10.0 * 6378137.0, 6378137.0}, {6.0 * 1737400.0, 1737400.0}}};
  EXPECT_EQ(chooseOrbited(c, 0), 0u);
  c[1].distanceM = 4.9 * 1737400.0;
  EXPECT_EQ(chooseOrbited(c, 0), 1u);
  // Once on the Moon, the Earth at 10 radii against the Moon's 4.9 does not take it back.
  EXPECT_EQ(chooseOrbited(c, 1), 1u);
  c[0].distanceM = 2.4 * 6378137.0;
  EXPECT_EQ(chooseOrbited(c, 1), 0u);
  // Of several, the nearest in radii; hysteresis 1 would flip at equality, 1.5 is between.
  const std::array<OrbitCandidate, 3> three{{{100.0, 1.0}, {20.0, 1.0}, {30.0, 2.0}}};
  EXPECT_EQ(chooseOrbited(three, 0), 2u);
  EXPECT_EQ(chooseOrbited(three, 1, 1.5), 1u);
  EXPECT_THROW((void)chooseOrbited(three, 3), std::invalid_argument);
  Body vesta = moonBody();
  vesta.name = "vesta";
  EXPECT_THROW(OrbitSwitcher({earthBody(), vesta}), std::invalid_argument);
  EXPECT_THROW(OrbitSwitcher({earthBody()}, 1), std::invalid_argument);
  EXPECT_NO_THROW(OrbitSwitcher({vesta})); // one body: nothing to place
}

TEST(OrbitChoice, AFlightFromTheEarthToTheMoonSwitchesOnce) {
  auto p = FlightPath::parse(
      "[{\"time\": 0, \"body\": \"earth\", \"lat\": 11, \"lon\": -150, \"alt\": 2e6, \"tilt\": "
      "120, \"utc\": \"2024-01-18T03:52:00Z\"}, {\"time\": 10, \"body\": \"moon\", \"lat\": 0, "
      "\"lon\": 0, \"alt\": 5e5, \"utc\": \"2024-01-18T03:52:00Z\"}]");
  ASSERT_TRUE(p) << p.error();
  OrbitSwitcher orbit({earthBody(), moonBody()});
  const BodyPlacement moonInEarth =
      placeBody(astro::EphemerisBody::earth, astro::EphemerisBody::moon, kUtcS);
  int switches = 0;
  for (int i = 0; i <= 1000; ++i) {
    const double t = i * 0.01;
    const std::size_t before = orbit.current();
    const CameraPose pose = flightPoseOver(*p, t, orbit.body(before));
    const glm::dvec3 eye = eyeOf(orbit.body(before), pose);
    const std::size_t now = orbit.update(eye, kUtcS);
    if (now == before) continue;
    ++switches;
    EXPECT_EQ(now, 1u);
    // At the rule's distance: the Moon looks twice as big as the Earth (in radii), just so.
    const glm::dvec3 eyeInEarth = eyeOf(earthBody(), flightPoseOver(*p, t, earthBody()));
    const double dEarth = glm::length(eyeInEarth) / earthBody().radiusA;
    const double dMoon = glm::length(eyeInEarth - moonInEarth.centre) / moonBody().radiusA;
    EXPECT_LT(dMoon, dEarth / 2.0) << i;
    EXPECT_GT(dMoon, dEarth / 2.2) << i;               // the step before had not crossed yet
    EXPECT_GT(dMoon * moonBody().radiusA, 3.0e7) << i; // far from the Moon: about 46,000 km
    // The same eye over the Moon as it was over the Earth (the pose re-expressed, in double).
    const glm::dvec3 overMoon = eyeOf(moonBody(), flightPoseOver(*p, t, moonBody()));
    const BodyPlacement earthInMoon =
        placeBody(astro::EphemerisBody::moon, astro::EphemerisBody::earth, kUtcS);
    EXPECT_LT(glm::length(overMoon - (earthInMoon.centre + earthInMoon.rotation * eye)), 1e-2);
  }
  EXPECT_EQ(switches, 1);
  EXPECT_EQ(orbit.current(), 1u);
  // flightPose does the same in one call: the Earth's pose first, the Moon's at the end (its
  // keyframe's own, 500 km over the Moon), one switch on the way.
  OrbitSwitcher again({earthBody(), moonBody()});
  EXPECT_NEAR(again.flightPose(*p, 0.0).altitudeM, 2e6, 1e-3);
  int changes = 0;
  std::size_t last = again.current();
  for (int i = 1; i <= 1000; ++i) {
    const CameraPose pose = again.flightPose(*p, i * 0.01);
    changes += again.current() != last ? 1 : 0;
    last = again.current();
    if (i == 1000) {
      EXPECT_NEAR(pose.altitudeM, 5e5, 1e-3);
    }
  }
  EXPECT_EQ(changes, 1);
}

TEST(OrbitChoice, AnEyeAboutThePointOfEqualSizeDoesNotFlip) {
  // Along the line from the Earth to the Moon: where both look alike (in radii), then 10% either
  // side, 100 times; the Earth is kept. Past the Moon's crossing it switches once; back at the
  // middle it stays on the Moon.
  const BodyPlacement m = placeBody(astro::EphemerisBody::earth, astro::EphemerisBody::moon, kUtcS);
  const double d = glm::length(m.centre);
  const double rE = earthBody().radiusA, rM = moonBody().radiusA;
  const double equal = d * rE / (rE + rM); // from the Earth
  const glm::dvec3 dir = m.centre / d;
  OrbitSwitcher orbit({earthBody(), moonBody()});
  for (int i = 0; i < 100; ++i)
    EXPECT_EQ(orbit.update(dir * (equal * (i % 2 == 0 ? 0.9 : 1.1)), kUtcS), 0u) << i;
  const double moonCrossing = d - d * rM / (rM + 2.0 * rE); // the Moon twice the Earth's size
  EXPECT_EQ(orbit.update(dir * (moonCrossing * 0.999), kUtcS), 0u);
  EXPECT_EQ(orbit.update(dir * (moonCrossing * 1.001), kUtcS), 1u);
  // Now positions are in the Moon's frame: the Earth at its centre.
  const BodyPlacement e = placeBody(astro::EphemerisBody::moon, astro::EphemerisBody::earth, kUtcS);
  const glm::dvec3 toEarth = glm::normalize(e.centre);
  for (int i = 0; i < 100; ++i) {
    const double fromMoon = d - equal * (i % 2 == 0 ? 0.9 : 1.1);
    EXPECT_EQ(orbit.update(toEarth * fromMoon, kUtcS), 1u) << i;
  }
  const double earthCrossing = d * rE / (rE + 2.0 * rM); // the Earth twice the Moon's size
  EXPECT_EQ(orbit.update(toEarth * (d - earthCrossing * 1.001), kUtcS), 1u);
  EXPECT_EQ(orbit.update(toEarth * (d - earthCrossing * 0.999), kUtcS), 0u);
}
