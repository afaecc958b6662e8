#include <tellus/planet/Body.hpp>
#include <tellus/planet/FlightPath.hpp>
#include <tellus/planet/SceneTime.hpp>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <iterator>
#include <sstream>
#include <utility>

namespace tellus::planet {
namespace {

using Json = nlohmann::json;

/** Accepts every event and remembers the first syntax error: where parse() says what is wrong
 * with text that is not JSON (nlohmann's own parser, run without exceptions, only says that). */
class SyntaxErrorFinder final : public nlohmann::json_sax<Json> {
public:
  std::string message = "not JSON";

  bool null() override { return true; }
  bool boolean(bool) override { return true; }
  bool number_integer(number_integer_t) override { return true; }
  bool number_unsigned(number_unsigned_t) override { return true; }
  bool number_float(number_float_t, const string_t&) override { return true; }
  bool string(string_t&) override { return true; }
  bool binary(binary_t&) override { return true; }
  bool start_object(std::size_t) override { return true; }
  bool key(string_t&) override { return true; }
  bool end_object() override { return true; }
  bool start_array(std::size_t) override { return true; }
  bool end_array() override { return true; }
  bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception& e) override {
    // "[json.exception.parse_error.101] parse error at line 1, column 5: ...": without the tag.
    message = e.what();
    if (const auto tag = message.find("] "); message.starts_with("[json.") && tag != message.npos)
      message.erase(0, tag + 2);
    return false;
  }
};

std::string syntaxError(std::string_view text) {
  SyntaxErrorFinder finder;
  Json::sax_parse(text, &finder);
  return finder.message;
}

std::unexpected<std::string> keyframeError(std::size_t index, const std::string& what) {
  return std::unexpected("keyframe " + std::to_string(index) + ": " + what);
}

/** "times": {"layer": "TIME", ...}. */
bool readLayerTimes(const Json& value, std::map<std::string, std::string>& out) {
  if (!value.is_object()) return false;
  for (const auto& [layer, time] : value.items()) {
    if (!time.is_string()) return false;
    out[layer] = time.get<std::string>();
  }
  return true;
}

/** One keyframe object: its numbers and layer times, or what is wrong with it. */
std::expected<Keyframe, std::string> readKeyframe(const Json& object, std::size_t index) {
  if (!object.is_object()) return keyframeError(index, "expected a keyframe object");
  Keyframe k;
  static constexpr std::array<std::string_view, 6> names = {
      "time", "lat", "lon", "alt", "heading", "tilt"};
  const std::array<double*, 6> fields = {&k.timeS,
                                         &k.pose.latDeg,
                                         &k.pose.lonDeg,
                                         &k.pose.altitudeM,
                                         &k.pose.headingDeg,
                                         &k.pose.tiltDeg};
  std::array<bool, 6> seen{};
  for (const auto& [key, value] : object.items()) {
    if (key == "utc") {
      if (value.is_number()) {
        k.sceneTimeUnixSeconds = value.get<double>();
      } else if (value.is_string() && value.get<std::string>() != "now") {
        auto t = parseSceneTime(value.get<std::string>(), 0.0);
        if (!t) return keyframeError(index, "\"utc\": " + t.error());
        k.sceneTimeUnixSeconds = *t;
      } else {
        return keyframeError(index, "expected \"utc\": an ISO 8601 UTC time or POSIX seconds");
      }
      continue;
    }
    if (key == "body") {
      if (!value.is_string() || !builtinBody(value.get<std::string>()))
        return keyframeError(index, "expected \"body\": earth, moon or mars");
      k.body = value.get<std::string>();
      continue;
    }
    if (key == "times") {
      if (!readLayerTimes(value, k.layerTimes))
        return keyframeError(index, "expected \"times\": {\"layer\": \"TIME\", ...}");
      continue;
    }
    const auto at = std::find(names.begin(), names.end(), key);
    if (at == names.end()) return keyframeError(index, "unknown key '" + key + "'");
    if (!value.is_number()) return keyframeError(index, "expected \"" + key + "\": number");
    const auto i = static_cast<std::size_t>(at - names.begin());
    *fields[i] = value.get<double>();
    seen[i] = true;
  }
  if (!seen[0] || !seen[1] || !seen[2] || !seen[3])
    return keyframeError(index, "a keyframe needs time, lat, lon and alt");
  return k;
}

} // namespace

std::expected<FlightPath, std::string> FlightPath::create(std::vector<Keyframe> keyframes) {
  if (keyframes.empty()) return std::unexpected("no keyframes");
  for (std::size_t i = 0; i < keyframes.size(); ++i) {
    const Keyframe& k = keyframes[i];
    const CameraPose& p = k.pose;
    for (const double v : {k.timeS, p.latDeg, p.lonDeg, p.altitudeM, p.headingDeg, p.tiltDeg})
      if (!std::isfinite(v)) return keyframeError(i, "every number must be finite");
    if (k.sceneTimeUnixSeconds && !std::isfinite(*k.sceneTimeUnixSeconds))
      return keyframeError(i, "every number must be finite");
    if (p.latDeg < -90.0 || p.latDeg > 90.0 || p.altitudeM < -11000.0 || p.altitudeM > 1e10 ||
        p.tiltDeg < 0.0 || p.tiltDeg > 180.0)
      return keyframeError(i, "out of range (lat [-90, 90], alt [-11000, 1e10], tilt [0, 180])");
    if (i > 0 && !(k.timeS > keyframes[i - 1].timeS))
      return keyframeError(i, "times must increase");
  }
  return FlightPath(std::move(keyframes));
}

std::expected<FlightPath, std::string> FlightPath::parse(std::string_view json) {
  const Json doc = Json::parse(json, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded()) return std::unexpected(syntaxError(json));
  const Json* list = &doc;
  if (doc.is_object()) {
    if (doc.size() != 1 || !doc.contains("keyframes"))
      return std::unexpected("expected [keyframes] or {\"keyframes\": [...]}");
    list = &doc["keyframes"];
  }
  if (!list->is_array()) return std::unexpected("expected an array of keyframes");
  std::vector<Keyframe> keys;
  keys.reserve(list->size());
  for (const Json& object : *list) {
    auto k = readKeyframe(object, keys.size());
    if (!k) return std::unexpected(k.error());
    keys.push_back(std::move(*k));
  }
  return create(std::move(keys));
}

std::expected<FlightPath, std::string> FlightPath::read(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return std::unexpected("cannot open " + file.string());
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) return std::unexpected("cannot read " + file.string());
  auto path = parse(text.str());
  if (!path) return std::unexpected(file.string() + ": " + path.error());
  return path;
}

CameraPose FlightPath::poseAt(double t) const {
  const std::vector<Keyframe>& keys = keys_;
  if (t <= keys.front().timeS) return keys.front().pose;
  if (t >= keys.back().timeS) return keys.back().pose;
  std::size_t k = 0;
  while (keys[k + 1].timeS < t)
    ++k;
  const CameraPose& a = keys[k].pose;
  const CameraPose& b = keys[k + 1].pose;
  const double u = (t - keys[k].timeS) / (keys[k + 1].timeS - keys[k].timeS);
  auto lerp = [u](double x, double y) { return x + (y - x) * u; };
  auto angle = [u](double x, double y) {
    const double d = std::remainder(y - x, 360.0);
    return x + d * u;
  };
  CameraPose p;
  p.latDeg = std::clamp(lerp(a.latDeg, b.latDeg), -90.0, 90.0);
  p.lonDeg = angle(a.lonDeg, b.lonDeg);
  p.altitudeM = a.altitudeM > 0.0 && b.altitudeM > 0.0
                    ? std::exp(lerp(std::log(a.altitudeM), std::log(b.altitudeM)))
                    : lerp(a.altitudeM, b.altitudeM);
  p.headingDeg = angle(a.headingDeg, b.headingDeg);
  p.tiltDeg = lerp(a.tiltDeg, b.tiltDeg);
  return p;
}

std::map<std::string, std::string> FlightPath::layerTimesAt(double timeS) const {
  std::map<std::string, std::string> now;
  for (const Keyframe& k : keys_)
    if (k.timeS <= timeS + 1e-9)
      for (const auto& [name, value] : k.layerTimes)
        now[name] = value;
  return now;
}

std::optional<double> FlightPath::sceneTimeAt(double timeS) const {
  const Keyframe* before = nullptr; // the last keyframe with a scene time at or before timeS
  const Keyframe* after = nullptr;  // the first one after it
  for (const Keyframe& k : keys_) {
    if (!k.sceneTimeUnixSeconds) continue;
    if (k.timeS <= timeS) {
      before = &k;
    } else {
      after = &k;
      break;
    }
  }
  if (before == nullptr && after == nullptr) return std::nullopt;
  if (before == nullptr) return after->sceneTimeUnixSeconds;
  if (after == nullptr) return before->sceneTimeUnixSeconds;
  const double u = (timeS - before->timeS) / (after->timeS - before->timeS);
  const double a = *before->sceneTimeUnixSeconds, b = *after->sceneTimeUnixSeconds;
  return a + (b - a) * u;
}

std::int64_t FlightPath::frameCount(double fps) const {
  return static_cast<std::int64_t>(std::floor((endS() - startS()) * fps + 1e-9)) + 1;
}

double FlightPath::frameTimeS(std::int64_t index, double fps) const {
  return startS() + static_cast<double>(index) / fps;
}

} // namespace tellus::planet
