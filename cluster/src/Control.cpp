#include <tellus/cluster/Control.hpp>

#include <nlohmann/json.hpp>

#include <cmath>
#include <initializer_list>

namespace tellus::cluster {
namespace {

using nlohmann::json;

std::unexpected<ControlError> bad(std::string message, int status = 400) {
  return std::unexpected(ControlError{status, std::move(message)});
}

/** The body as a JSON object whose keys are all among `known`; else why not. */
std::expected<json, ControlError> object(std::string_view body,
                                         std::initializer_list<std::string_view> known) {
  json j = json::parse(body, nullptr, false);
  if (j.is_discarded()) return bad("the body is not JSON");
  if (!j.is_object()) return bad("the body must be a JSON object");
  for (const auto& [key, value] : j.items()) {
    bool ok = false;
    for (const std::string_view k : known)
      ok = ok || key == k;
    if (!ok) return bad("unknown field \"" + key + "\"");
  }
  return j;
}

/** A finite number field in [lo, hi]; nullopt when absent. */
std::expected<std::optional<double>, ControlError>
number(const json& j, const char* key, double lo, double hi) {
  if (!j.contains(key)) return std::optional<double>{};
  const json& v = j[key];
  if (!v.is_number()) return bad(std::string(key) + " must be a number");
  const double x = v.get<double>();
  if (!std::isfinite(x) || x < lo || x > hi)
    return bad(std::string(key) + " must be in [" + std::to_string(lo) + ", " + std::to_string(hi) +
               "]");
  return std::optional<double>{x};
}

std::expected<ControlRequest, ControlError> camera(std::string_view body) {
  auto j = object(body, {"lat", "lon", "altitude", "heading", "tilt"});
  if (!j) return std::unexpected(j.error());
  if (j->empty()) return bad("no field: lat, lon, altitude, heading, tilt");
  CameraCommand c;
  struct Field {
    const char* key;
    double lo, hi;
    std::optional<double>* out;
  };
  for (const Field& f : {Field{"lat", -90.0, 90.0, &c.latDeg},
                         Field{"lon", -360.0, 360.0, &c.lonDeg},
                         Field{"altitude", 1.0, 1e12, &c.altitudeM},
                         Field{"heading", -360.0, 360.0, &c.headingDeg},
                         Field{"tilt", 0.0, 180.0, &c.tiltDeg}}) {
    auto v = number(*j, f.key, f.lo, f.hi);
    if (!v) return std::unexpected(v.error());
    *f.out = *v;
  }
  return c;
}

std::expected<ControlRequest, ControlError> time(std::string_view body) {
  auto j = object(body, {"unix"});
  if (!j) return std::unexpected(j.error());
  auto v = number(*j, "unix", -1e11, 1e11);
  if (!v) return std::unexpected(v.error());
  if (!*v) return bad("unix (the scene's time, POSIX seconds) is required");
  return TimeCommand{**v};
}

std::expected<ControlRequest, ControlError> path(std::string_view body) {
  auto j = object(body, {"action", "file", "seconds"});
  if (!j) return std::unexpected(j.error());
  if (!j->contains("action") || !(*j)["action"].is_string())
    return bad("action must be \"play\", \"pause\" or \"seek\"");
  const std::string action = (*j)["action"].get<std::string>();
  PathCommand p;
  if (action == "play") {
    p.action = PathCommand::Action::Play;
    if (j->contains("seconds")) return bad("seconds goes with \"seek\"");
    if (j->contains("file")) {
      if (!(*j)["file"].is_string() || (*j)["file"].get<std::string>().empty())
        return bad("file must be a path file's name");
      p.file = (*j)["file"].get<std::string>();
    }
  } else if (action == "pause" || action == "seek") {
    if (j->contains("file")) return bad("file goes with \"play\"");
    p.action = action == "pause" ? PathCommand::Action::Pause : PathCommand::Action::Seek;
    auto s = number(*j, "seconds", 0.0, 1e9);
    if (!s) return std::unexpected(s.error());
    if (p.action == PathCommand::Action::Pause && *s) return bad("seconds goes with \"seek\"");
    if (p.action == PathCommand::Action::Seek) {
      if (!*s) return bad("seek needs seconds");
      p.seconds = **s;
    }
  } else {
    return bad("action must be \"play\", \"pause\" or \"seek\": " + action);
  }
  return p;
}

std::expected<ControlRequest, ControlError> layer(std::string_view body) {
  auto j = object(body, {"layer", "opacity", "visible", "time"});
  if (!j) return std::unexpected(j.error());
  if (!j->contains("layer") || !(*j)["layer"].is_string() ||
      (*j)["layer"].get<std::string>().empty())
    return bad("layer (a drawn layer's name) is required");
  LayerCommand c;
  c.layer = (*j)["layer"].get<std::string>();
  auto o = number(*j, "opacity", 0.0, 1.0);
  if (!o) return std::unexpected(o.error());
  c.opacity = *o;
  if (j->contains("visible")) {
    if (!(*j)["visible"].is_boolean()) return bad("visible must be true or false");
    c.visible = (*j)["visible"].get<bool>();
  }
  if (j->contains("time")) {
    if (!(*j)["time"].is_string() || (*j)["time"].get<std::string>().empty())
      return bad("time must be one of the layer's times (a string)");
    c.time = (*j)["time"].get<std::string>();
  }
  if (!c.opacity && !c.visible && !c.time) return bad("no field: opacity, visible, time");
  return c;
}

} // namespace

std::expected<ControlRequest, ControlError>
parseControl(std::string_view method, std::string_view target, std::string_view body) {
  const bool get = method == "GET", post = method == "POST";
  if (target == "/status") {
    if (!get) return bad("GET /status", 405);
    return StatusQuery{};
  }
  if (target != "/camera" && target != "/time" && target != "/path" && target != "/layer")
    return bad("no such path: GET /status, POST /camera, /time, /path, /layer", 404);
  if (!post) return bad("POST " + std::string(target), 405);
  if (target == "/camera") return camera(body);
  if (target == "/time") return time(body);
  if (target == "/layer") return layer(body);
  return path(body);
}

planet::CameraPose applyCamera(const CameraCommand& c, planet::CameraPose p) noexcept {
  p.latDeg = c.latDeg.value_or(p.latDeg);
  p.lonDeg = c.lonDeg.value_or(p.lonDeg);
  p.altitudeM = c.altitudeM.value_or(p.altitudeM);
  p.headingDeg = c.headingDeg.value_or(p.headingDeg);
  p.tiltDeg = c.tiltDeg.value_or(p.tiltDeg);
  return p;
}

std::string statusJson(const StatusReport& s) {
  json channels = json::array();
  for (const ChannelReport& c : s.channels)
    channels.push_back({{"name", c.name}, {"state", c.state}, {"last_frame", c.lastFrame}});
  json layers = json::array();
  for (const LayerReport& l : s.layers)
    layers.push_back(
        {{"name", l.name}, {"opacity", l.opacity}, {"visible", l.visible}, {"time", l.time}});
  json j = {{"frame", s.frame},
            {"camera",
             {{"lat", s.camera.latDeg},
              {"lon", s.camera.lonDeg},
              {"altitude", s.camera.altitudeM},
              {"heading", s.camera.headingDeg},
              {"tilt", s.camera.tiltDeg}}},
            {"time", s.timeUnixS ? json(*s.timeUnixS) : json(nullptr)},
            {"path", {{"file", s.path}, {"playing", s.playing}, {"seconds", s.pathSeconds}}},
            {"channels", channels},
            {"layers", layers}};
  return j.dump() + "\n";
}

std::string errorJson(std::string_view message) {
  return json{{"error", std::string(message)}}.dump() + "\n";
}

} // namespace tellus::cluster
