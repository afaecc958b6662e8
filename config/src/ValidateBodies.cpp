// The bodies of a configuration (issue 26): the bodies section's entries (names, radii, rotation,
// atmosphere), renderer.body and each layer's body (a built-in or a configured body's name).

#include "ConfigInternal.hpp"

#include <cmath>
#include <set>

namespace tellus::detail {

namespace {

std::string known(const Config& c) {
  std::string s;
  for (const std::string_view b : kBuiltinBodies)
    s += (s.empty() ? "" : ", ") + std::string(b);
  for (const auto& b : c.bodies)
    s += ", " + b.name;
  return s;
}

bool finite(double v) {
  return std::isfinite(v);
}

std::optional<ValidationIssue>
checkBody(const Config& c, std::size_t i, std::set<std::string>& seen) {
  const BodyConfig& b = c.bodies[i];
  const std::string key = "bodies[" + std::to_string(i) + "]";
  const std::string subject = "body '" + b.name + "'";
  const auto issue = [&](const std::string& field, std::string message) {
    return ValidationIssue{key + "." + field, subject, std::move(message)};
  };
  if (!isValidName(b.name)) return issue("name", "must be [A-Za-z0-9_.-]+");
  for (const std::string_view builtin : kBuiltinBodies)
    if (b.name == builtin) return issue("name", "is a built-in body's name; choose another");
  if (!seen.insert(b.name).second) return issue("name", "is configured twice");
  for (const double r : b.radii)
    if (!(r >= 1.0 && r <= 1e9)) return issue("radii", "must be in [1, 1e9] metres");
  if (b.radii[1] > b.radii[0])
    return issue("radii", "[a, b, c]: b (an equatorial radius) must not exceed a");
  for (const double v :
       {b.poleRa, b.poleRaRate, b.poleDec, b.poleDecRate, b.primeMeridian, b.rotationRate})
    if (!finite(v)) return issue("rotation", "every element must be a finite number");
  if (!(b.poleDec >= -90.0 && b.poleDec <= 90.0))
    return issue("rotation.pole_dec", "must be in [-90, 90] degrees");
  if (!(b.reliefBound >= 0.0 && b.reliefBound <= 1e6))
    return issue("relief_bound", "must be in [0, 1e6] metres");
  if (b.atmosphere) {
    if (auto a = checkAtmosphereSettings(*b.atmosphere)) return issue(a->first, a->second);
    const double bottom =
        b.atmosphere->bottomRadius > 0.0 ? b.atmosphere->bottomRadius : b.radii[0];
    if (!(b.atmosphere->topAltitude < bottom))
      return issue("atmosphere.top_altitude", "must be below the body's radius");
  }
  return std::nullopt;
}

} // namespace

std::optional<ValidationIssue> checkBodies(const Config& c) {
  std::set<std::string> seen;
  for (std::size_t i = 0; i < c.bodies.size(); ++i)
    if (auto e = checkBody(c, i, seen)) return e;
  if (!c.knowsBody(c.renderer.body))
    return ValidationIssue{"renderer.body",
                           "renderer",
                           "no body named '" + c.renderer.body + "' (known: " + known(c) + ")"};
  // renderer.bodies: only bodies with an ephemeris can share a scene (planet/SceneBodies.hpp).
  for (std::size_t i = 0; i < c.renderer.bodies.size(); ++i) {
    const std::string& b = c.renderer.bodies[i];
    if (b != "earth" && b != "moon" && b != "mars")
      return ValidationIssue{"renderer.bodies[" + std::to_string(i) + "]",
                             "renderer",
                             "'" + b +
                                 "' cannot share a scene: only earth, moon and mars have an "
                                 "ephemeris"};
    const std::string& orbited = c.renderer.body;
    if (orbited != "earth" && orbited != "moon" && orbited != "mars")
      return ValidationIssue{"renderer.bodies",
                             "renderer",
                             "the body orbited ('" + orbited +
                                 "') has no ephemeris: no other body can join it"};
  }
  for (std::size_t i = 0; i < c.layers.size(); ++i) {
    const LayerConfig& l = c.layers[i];
    if (!c.knowsBody(l.dataset.body))
      return ValidationIssue{"layers[" + std::to_string(i) + "].body",
                             "layer '" + l.name + "'",
                             "no body named '" + l.dataset.body + "' (known: " + known(c) + ")"};
  }
  return std::nullopt;
}

} // namespace tellus::detail
