#include <tellus/planet/Camera.hpp>
#include <tellus/planet/FlightBodies.hpp>
#include <tellus/planet/Geodesy.hpp>
#include <tellus/planet/SceneBodies.hpp>
#include <tellus/planet/StarCatalogue.hpp>

#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace tellus::planet {

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

/** An eye in the orbited body's frame. */
struct Eye {
  glm::dvec3 position, forward, up;
};

bool onOrbited(const Keyframe& k, const Body& orbited) {
  return k.body.empty() || k.body == orbited.name;
}

/** The keyframe's body (the orbited one's own shape when it is that body). */
Body bodyOf(const std::string& name, const Body& orbited) {
  return name.empty() || name == orbited.name ? orbited : *builtinBody(name);
}

Eye eyeOver(const CameraPose& pose, const std::string& body, const Body& orbited, double t) {
  const Body b = bodyOf(body, orbited);
  const Geodesy g(b);
  const Camera cam(g, pose, Viewport{64, 64}, 45.0);
  Eye e{cam.position(), cam.forward(), cam.up()};
  if (b.name == orbited.name) return e;
  const BodyPlacement p = placeBody(*sceneBodyOf(orbited), *sceneBodyOf(b), t);
  return {p.centre + p.rotation * e.position, p.rotation * e.forward, p.rotation * e.up};
}

/** The pose over `orbited` of an eye in its frame. */
CameraPose poseOf(const Eye& e, const Body& orbited) {
  const Geodesy g(orbited);
  const Geodetic at = g.fromEcef({e.position.x, e.position.y, e.position.z});
  // Camera.cpp's local frame: up from the geodetic latitude and longitude, east from the
  // longitude; forward = cos(tilt) (-up) + sin(tilt) h, up = sin(tilt) up + cos(tilt) h.
  const double sphi = std::sin(at.latDeg * kDeg), cphi = std::cos(at.latDeg * kDeg);
  const double slam = std::sin(at.lonDeg * kDeg), clam = std::cos(at.lonDeg * kDeg);
  const glm::dvec3 upLocal{cphi * clam, cphi * slam, sphi};
  const glm::dvec3 east{-slam, clam, 0.0};
  const glm::dvec3 north = glm::cross(upLocal, east);
  const double ct = std::clamp(-glm::dot(e.forward, upLocal), -1.0, 1.0);
  const double tilt = std::acos(ct);
  // The heading from the view's horizontal part (sin(tilt) h: exact whatever the roll), or from
  // up's (cos(tilt) h) when the view is straight down or up.
  glm::dvec3 h = e.forward - glm::dot(e.forward, upLocal) * upLocal;
  if (glm::length(h) < 1e-9) {
    h = e.up - glm::dot(e.up, upLocal) * upLocal;
    if (ct < 0.0) h = -h;
  }
  const double heading =
      glm::length(h) > 1e-12 ? std::atan2(glm::dot(h, east), glm::dot(h, north)) / kDeg : 0.0;
  return {at.latDeg, at.lonDeg, at.heightM, heading, tilt / kDeg};
}

/** The eye's axes (right, up, back) as a rotation. */
glm::dquat orientation(const Eye& e) {
  const glm::dvec3 right = glm::normalize(glm::cross(e.forward, e.up));
  const glm::dvec3 up = glm::cross(right, e.forward);
  return glm::quat_cast(glm::dmat3(right, up, -e.forward));
}

double sceneTime(const FlightPath& path, double timeS) {
  return path.sceneTimeAt(timeS).value_or(kJ2000UnixSeconds);
}

} // namespace

std::optional<std::string> flightBodiesProblem(const FlightPath& path, const Body& orbited) {
  bool others = false;
  for (const Keyframe& k : path.keyframes()) {
    if (onOrbited(k, orbited)) continue;
    others = true;
    if (!astro::ephemerisBodyByName(k.body))
      return "the flight names body '" + k.body + "', which has no ephemeris";
  }
  if (others && !sceneBodyOf(orbited))
    return "the flight names other bodies, but '" + orbited.name + "' has no ephemeris";
  return std::nullopt;
}

CameraPose flightPoseOver(const FlightPath& path, double timeS, const Body& orbited) {
  const auto& keys = path.keyframes();
  const bool allOn = std::all_of(
      keys.begin(), keys.end(), [&](const Keyframe& k) { return onOrbited(k, orbited); });
  if (allOn) return path.poseAt(timeS);
  const double t = sceneTime(path, timeS);
  // The segment [a, b] holding timeS (the first or last keyframe outside the path).
  std::size_t b = 0;
  while (b < keys.size() && keys[b].timeS <= timeS)
    ++b;
  if (b == 0 || b == keys.size()) {
    const Keyframe& k = b == 0 ? keys.front() : keys.back();
    return poseOf(eyeOver(k.pose, k.body, orbited, t), orbited);
  }
  const Keyframe& ka = keys[b - 1];
  const Keyframe& kb = keys[b];
  if (bodyOf(ka.body, orbited).name == bodyOf(kb.body, orbited).name) {
    // On one body: FlightPath's interpolation there, then into the orbited body's frame.
    std::vector<Keyframe> two{ka, kb};
    two[0].sceneTimeUnixSeconds.reset();
    two[1].sceneTimeUnixSeconds.reset();
    const auto segment = FlightPath::create(std::move(two));
    return poseOf(eyeOver(segment->poseAt(timeS), ka.body, orbited, t), orbited);
  }
  const Eye ea = eyeOver(ka.pose, ka.body, orbited, t);
  const Eye eb = eyeOver(kb.pose, kb.body, orbited, t);
  const double s = (timeS - ka.timeS) / (kb.timeS - ka.timeS);
  const double w = s * s * (3.0 - 2.0 * s);
  // The view turned by the rotation between the two (quaternion slerp: constant angular speed).
  const glm::dquat q = glm::slerp(orientation(ea), orientation(eb), w);
  const glm::dmat3 r = glm::mat3_cast(q);
  const Eye e{ea.position + (eb.position - ea.position) * w, -r[2], r[1]};
  return poseOf(e, orbited);
}

CameraPose
poseOverOtherBody(const CameraPose& pose, const Body& from, const Body& to, double unixSeconds) {
  if (from.name == to.name) return pose;
  const Geodesy g(from);
  const Camera cam(g, pose, Viewport{64, 64}, 45.0);
  const BodyPlacement p = placeBody(*sceneBodyOf(to), *sceneBodyOf(from), unixSeconds);
  return poseOf(
      {p.centre + p.rotation * cam.position(), p.rotation * cam.forward(), p.rotation * cam.up()},
      to);
}

} // namespace tellus::planet
