#pragma once
/**
 * @file OrbitChoice.hpp
 * @brief Which body the camera orbits along a flight between bodies (issue 26,
 * docs/design/bodies.md "Flying between bodies"): the renderer draws the orbited body with its
 * quadtree, layers and terrain and every other body as a coarse globe, so the camera should orbit
 * the body it is near.
 *
 * The rule: each body's distance from the eye in units of its equatorial radius (d / a, the
 * body's apparent size: a body at 10 radii looks as big, whatever its size); the camera keeps the
 * body it orbits until another is nearer than that by the factor `hysteresis` (2 by default):
 * switch to B when d_B / a_B < (d_A / a_A) / hysteresis. Between the two crossings nothing changes,
 * so an eye that wanders about the point of equal apparent size never flips. From the Earth to the
 * Moon (384,400 km apart) the camera takes the Moon 46,000 km before its centre (the Moon then 4.3
 * degrees wide, the Earth 2.2), and the Earth back about 250,000 km before the Earth.
 *
 * Pure, GL-free; positions in the orbited body's fixed frame (SceneBodies.hpp), in double.
 */

#include <tellus/planet/Body.hpp>
#include <tellus/planet/FlightPath.hpp>

#include <glm/vec3.hpp>

#include <cstddef>
#include <span>
#include <vector>

namespace tellus::planet {

/** The factor by which another body must look bigger than the orbited one to be taken. */
inline constexpr double kOrbitHysteresis = 2.0;

/** A body as the rule sees it: the eye's distance from its centre and its equatorial radius. */
struct OrbitCandidate {
  double distanceM = 0.0;
  double radiusM = 1.0;
};

/** The index of the body to orbit: `current`, unless another's distance in radii is under the
 * current one's divided by `hysteresis` (> 1); of several such, the one nearest in radii. */
std::size_t chooseOrbited(std::span<const OrbitCandidate> bodies,
                          std::size_t current,
                          double hysteresis = kOrbitHysteresis);

/** The rule along a flight: the bodies (each with an ephemeris: sceneBodyOf) and the one orbited
 * now, which update() changes. */
class OrbitSwitcher {
public:
  /** `bodies` must not be empty and `start` must index it. */
  OrbitSwitcher(std::vector<Body> bodies,
                std::size_t start = 0,
                double hysteresis = kOrbitHysteresis);

  /** The body to orbit for an eye at `eye` in the fixed frame of the body orbited now, at a UTC
   * instant (POSIX seconds): the rule applied, the choice kept. */
  std::size_t update(const glm::dvec3& eye, double unixSeconds);

  /** The flight's pose at `timeS` (FlightBodies.hpp's flightPoseOver) over the body to orbit
   * then: the pose over the body orbited now, its eye through update() at the flight's scene
   * time (none: J2000.0), and, when that changed the body, the pose over the new one. */
  CameraPose flightPose(const FlightPath& path, double timeS);

  std::size_t current() const noexcept { return current_; }
  const Body& body(std::size_t i) const { return bodies_.at(i); }
  const std::vector<Body>& bodies() const noexcept { return bodies_; }

private:
  std::vector<Body> bodies_;
  std::size_t current_;
  double hysteresis_;
};

} // namespace tellus::planet
