#include <tellus/planet/Camera.hpp>
#include <tellus/planet/FlightBodies.hpp>
#include <tellus/planet/Geodesy.hpp>
#include <tellus/planet/OrbitChoice.hpp>
#include <tellus/planet/SceneBodies.hpp>
#include <tellus/planet/StarCatalogue.hpp>

#include <glm/geometric.hpp>

#include <stdexcept>

namespace tellus::planet {

std::size_t
chooseOrbited(std::span<const OrbitCandidate> bodies, std::size_t current, double hysteresis) {
  if (current >= bodies.size()) throw std::invalid_argument("chooseOrbited: no such body");
  const auto inRadii = [](const OrbitCandidate& c) { return c.distanceM / c.radiusM; };
  const double limit = inRadii(bodies[current]) / hysteresis;
  std::size_t best = current;
  double bestRadii = limit;
  for (std::size_t i = 0; i < bodies.size(); ++i)
    if (i != current && inRadii(bodies[i]) < bestRadii) {
      best = i;
      bestRadii = inRadii(bodies[i]);
    }
  return best;
}

OrbitSwitcher::OrbitSwitcher(std::vector<Body> bodies, std::size_t start, double hysteresis)
    : bodies_(std::move(bodies)), current_(start), hysteresis_(hysteresis) {
  if (bodies_.empty() || start >= bodies_.size() || !(hysteresis > 1.0))
    throw std::invalid_argument("OrbitSwitcher: bodies, a start among them, hysteresis > 1");
  if (bodies_.size() > 1)
    for (const Body& b : bodies_)
      if (!sceneBodyOf(b))
        throw std::invalid_argument("OrbitSwitcher: '" + b.name + "' has no ephemeris");
}

std::size_t OrbitSwitcher::update(const glm::dvec3& eye, double unixSeconds) {
  if (bodies_.size() < 2) return current_;
  const auto frame = *sceneBodyOf(bodies_[current_]);
  std::vector<OrbitCandidate> c;
  c.reserve(bodies_.size());
  for (std::size_t i = 0; i < bodies_.size(); ++i) {
    const glm::dvec3 centre = i == current_
                                  ? glm::dvec3(0.0)
                                  : placeBody(frame, *sceneBodyOf(bodies_[i]), unixSeconds).centre;
    c.push_back({glm::length(eye - centre), bodies_[i].radiusA});
  }
  current_ = chooseOrbited(c, current_, hysteresis_);
  return current_;
}

CameraPose OrbitSwitcher::flightPose(const FlightPath& path, double timeS) {
  const std::size_t before = current_;
  const CameraPose pose = flightPoseOver(path, timeS, bodies_[before]);
  if (bodies_.size() < 2) return pose;
  const Geodesy g(bodies_[before]);
  const glm::dvec3 eye = Camera(g, pose, Viewport{64, 64}, 45.0).position();
  if (update(eye, path.sceneTimeAt(timeS).value_or(kJ2000UnixSeconds)) == before) return pose;
  return flightPoseOver(path, timeS, bodies_[current_]);
}

} // namespace tellus::planet
