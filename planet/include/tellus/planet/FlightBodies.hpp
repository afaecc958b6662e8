#pragma once
/**
 * @file FlightBodies.hpp
 * @brief Flights between bodies (issue 26): the pose of a flight whose keyframes name the body
 * their coordinates refer to (Keyframe::body), over the body the renderer orbits.
 *
 * Each keyframe's eye (position, view direction and up, from its pose on its own body through
 * Camera) is put into the orbited body's fixed frame by the ephemeris at the flight's scene time
 * at that moment (FlightPath::sceneTimeAt; none: J2000.0) with placeBody (SceneBodies.hpp), all in
 * double. Between two keyframes on the same body the pose is FlightPath's own interpolation on
 * that body, then put into the frame; between keyframes on different bodies the eye's position
 * moves along the straight line between them eased in and out (smoothstep: no jump in speed at
 * either end), its view turned by the same weight (quaternion slerp of the two views).
 * The result is given back as a pose over the orbited body (its geodetic latitude, longitude and
 * altitude; heading and tilt from the view), which the renderer draws with the other bodies as
 * scene bodies (RendererOptions::sceneBodies). A flight whose keyframes all lie on the orbited
 * body is FlightPath::poseAt's, bit for bit. The pose cannot roll: a blended view whose up points
 * below the local horizon is drawn with the nearest pose that keeps its direction.
 */

#include <tellus/planet/Body.hpp>
#include <tellus/planet/FlightPath.hpp>

#include <optional>
#include <string>

namespace tellus::planet {

/** What keeps the flight from being flown over `orbited`: a keyframe's body without an ephemeris
 * or an orbited body without one while keyframes name others; nullopt when it can be. */
std::optional<std::string> flightBodiesProblem(const FlightPath& path, const Body& orbited);

/** The pose at `timeS` over `orbited` (see the file comment; the path must pass
 * flightBodiesProblem). */
CameraPose flightPoseOver(const FlightPath& path, double timeS, const Body& orbited);

/** The same eye (position and view) as `pose` over `from`, as a pose over `to`, at a UTC instant
 * (POSIX seconds): `view`'s key that changes the body orbited. Both need an ephemeris. */
CameraPose
poseOverOtherBody(const CameraPose& pose, const Body& from, const Body& to, double unixSeconds);

} // namespace tellus::planet
