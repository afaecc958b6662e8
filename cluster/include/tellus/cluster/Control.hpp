#pragma once
/**
 * @file Control.hpp
 * @brief The master's control API (issue 28, docs/design/cluster.md "The console"): what a show
 * controller asks over HTTP/JSON on loopback, parsed and checked (no socket here: the command
 * serves it), and the status the master reports. A request is the method, the path and the body;
 * a bad one gets its HTTP status and a message.
 *
 *   GET  /status                     the frame, camera, time, path and channels
 *   POST /camera {"lat", "lon", "altitude", "heading", "tilt"}  any of them (the others kept);
 *                                    the path pauses: the console flies the camera
 *   POST /time   {"unix": SECONDS}   the scene's time (UTC, POSIX seconds)
 *   POST /path   {"action": "play", "file": PATH.json}   plays a path from its start
 *                {"action": "play"} | {"action": "pause"} | {"action": "seek", "seconds": S}
 *   POST /layer  {"layer": NAME, "opacity": 0-1, "visible": B, "time": T}  any of the last three:
 *                                    a drawn layer's (the base's time only)
 */

#include <tellus/planet/Camera.hpp>

#include <cstdint>
#include <expected>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace tellus::cluster {

struct StatusQuery {};
struct CameraCommand { ///< the fields given; the others stay as they are
  std::optional<double> latDeg, lonDeg, altitudeM, headingDeg, tiltDeg;
};
struct TimeCommand {
  double unixS = 0.0;
};
struct PathCommand {
  enum class Action { Play, Pause, Seek } action = Action::Play;
  std::string file;     ///< Play: a path file to load ("" resumes the one there is)
  double seconds = 0.0; ///< Seek: from the path's start
};
struct LayerCommand { ///< the fields given; the others stay as they are
  std::string layer;
  std::optional<double> opacity;
  std::optional<bool> visible;
  std::optional<std::string> time;
};
using ControlRequest =
    std::variant<StatusQuery, CameraCommand, TimeCommand, PathCommand, LayerCommand>;

struct ControlError {
  int status = 400; ///< 400 bad body, 404 no such path, 405 the wrong method
  std::string message;
};

/** The request checked: unknown paths, methods, malformed JSON, unknown or missing fields and
 * values out of range are refused with what is wrong. */
std::expected<ControlRequest, ControlError>
parseControl(std::string_view method, std::string_view path, std::string_view body);

/** A camera command applied to a pose. */
planet::CameraPose applyCamera(const CameraCommand& c, planet::CameraPose pose) noexcept;

struct ChannelReport {
  std::string name;
  std::string state; ///< "alive", "lost", "rejoined"
  std::int64_t lastFrame = -1;
};

struct LayerReport {
  std::string name;
  double opacity = 1.0;
  bool visible = true;
  std::string time; ///< "" the layer's own (or its keyframes')
};

struct StatusReport {
  std::int64_t frame = 0;
  planet::CameraPose camera;
  std::optional<double> timeUnixS;
  std::string path; ///< the path file playing or paused; "" none
  bool playing = false;
  double pathSeconds = 0.0;
  std::vector<ChannelReport> channels;
  std::vector<LayerReport> layers;
};

/** GET /status's body. */
std::string statusJson(const StatusReport& s);
/** {"error": message}: a refusal's body. */
std::string errorJson(std::string_view message);

} // namespace tellus::cluster
