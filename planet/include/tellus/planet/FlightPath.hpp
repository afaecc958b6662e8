#pragma once
/**
 * @file FlightPath.hpp
 * @brief A camera flight (`tellus render --path PATH.json`): keyframes at increasing times, the
 * pose between them, the layer times they switch to, and the frames of the flight at a frame
 * rate.
 *
 * PATH.json is an array of keyframe objects, or an object {"keyframes": [...]}:
 *
 *     [{"time": 0, "lat": 46.5, "lon": 7.5, "alt": 2e6, "heading": 0, "tilt": 0,
 *       "utc": "2024-06-20T18:00:00Z", "times": {"LAYER": "TIME"}}, ...]
 *
 * time (seconds), lat, lon (degrees) and alt (metres above the model's surface) are required;
 * heading and tilt (degrees) are 0 when left out; "times" and "utc" are optional. "utc" is the
 * scene's time (issue 23: the sun, the stars) at that keyframe, an ISO 8601 UTC string
 * (SceneTime.hpp; not "now": a flight is reproducible) or POSIX seconds; "time" is already the
 * flight's own clock, hence the other name. "body" (optional) names the built-in body the
 * keyframe's lat, lon and alt refer to (FlightBodies.hpp). Any other key is an error,
 * as is a value out of range (lat [-90, 90], alt [-11000, 1e10], tilt [0, 180]) or a time that
 * does not increase.
 *
 * Between keyframes the pose is interpolated linearly in latitude and tilt, the short way round in
 * longitude and heading (so a flight from 170 E to 170 W crosses the antimeridian, and the
 * longitude it gives may leave [-180, 180]: 185 is 175 W), and geometrically in altitude when both
 * altitudes are positive (a descent from 1e9 m to 1 m slows down as it nears the ground), else
 * linearly. Latitude is not a great circle: a flight between two points beyond a pole goes round
 * the pole along the parallels between them, never over it; a keyframe at the pole itself is
 * flown through. The scene's time is interpolated linearly between the keyframes that have one
 * (a day in a few seconds of flight runs the sun round the globe), held before the first and after
 * the last; a path without any leaves the scene's time to --time.
 */

#include <tellus/planet/Camera.hpp>

#include <cstdint>
#include <expected>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace tellus::planet {

/** One keyframe of a flight. */
struct Keyframe {
  double timeS = 0.0; ///< seconds; strictly increasing along a path; finite
  CameraPose pose;
  /** "times": {"layer": "TIME", ...}: from this keyframe on, the layer shows that time (it swaps
   * once the new time's tiles are all there; with --wait-complete every frame waits for it). */
  std::map<std::string, std::string> layerTimes;
  /** "utc": the scene's time at this keyframe, UTC as POSIX seconds; nullopt: none given. */
  std::optional<double> sceneTimeUnixSeconds;
  /** "body": the built-in body ("earth", "moon", "mars") the pose's coordinates refer to; "": the
   * body the flight is rendered over (issue 26; FlightBodies.hpp flies between bodies). */
  std::string body;
};

class FlightPath {
public:
  /** A path of at least one keyframe with finite values in range and strictly increasing times;
   * else why not ("keyframe 2: times must increase", counting from 0). */
  static std::expected<FlightPath, std::string> create(std::vector<Keyframe> keyframes);
  /** PATH.json's text (see the file comment); else why not: where the JSON is malformed (line
   * and column), or which keyframe is wrong and how. */
  static std::expected<FlightPath, std::string> parse(std::string_view json);
  /** parse() of a file's contents; errors begin with the file name. */
  static std::expected<FlightPath, std::string> read(const std::filesystem::path& file);

  const std::vector<Keyframe>& keyframes() const noexcept { return keys_; }
  double startS() const noexcept { return keys_.front().timeS; }
  double endS() const noexcept { return keys_.back().timeS; }

  /** The pose at `timeS` (see the file comment); the first keyframe's before the start, the last
   * one's after the end, a keyframe's own pose at its time. */
  CameraPose poseAt(double timeS) const;
  /** The time each layer named by a keyframe at or before `timeS` (within 1e-9 s) shows: the
   * latest such keyframe's; layers no keyframe names so far are not in the map. */
  std::map<std::string, std::string> layerTimesAt(double timeS) const;
  /** The scene's time (UTC, POSIX seconds) at `timeS` (see the file comment); nullopt when no
   * keyframe has "utc". */
  std::optional<double> sceneTimeAt(double timeS) const;
  /** Frames of the flight at `fps` (> 0): one at the start and one every 1 / fps seconds up to
   * the end (within 1e-9 of a frame): floor(duration x fps) + 1, 1 for a single keyframe. */
  std::int64_t frameCount(double fps) const;
  /** When frame `index` (0-based) of the flight at `fps` is: start + index / fps. */
  double frameTimeS(std::int64_t index, double fps) const;

private:
  explicit FlightPath(std::vector<Keyframe> keys) : keys_(std::move(keys)) {}
  std::vector<Keyframe> keys_; ///< never empty
};

} // namespace tellus::planet
