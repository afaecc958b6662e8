#include <tellus/planet/Channels.hpp>

#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>
#include <numbers>
#include <set>

namespace tellus::planet {
namespace {

using Json = nlohmann::json;
constexpr double kDeg = std::numbers::pi / 180.0;

std::unexpected<std::string> fail(std::string_view origin, const std::string& what) {
  return std::unexpected(origin.empty() ? what : std::string(origin) + ": " + what);
}

bool validName(const std::string& name) {
  if (name.empty() || name.size() > 64) return false;
  for (const char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '_' || c == '-';
    if (!ok) return false;
  }
  return true;
}

/** A finite number in [lo, hi] (loOpen: lo itself refused), or a message. */
std::string readNumber(const Json& object,
                       const char* key,
                       double& out,
                       double lo,
                       double hi,
                       bool loOpen,
                       bool required = true) {
  const auto it = object.find(key);
  if (it == object.end()) return required ? std::string(key) + ": missing" : std::string();
  if (!it->is_number()) return std::string(key) + ": not a number";
  const double v = it->get<double>();
  if (!std::isfinite(v) || v < lo || v > hi || (loOpen && v == lo)) {
    return std::string(key) + ": " + std::to_string(v) + " is outside " + (loOpen ? "(" : "[") +
           std::to_string(lo) + ", " + std::to_string(hi) + "]";
  }
  out = v;
  return {};
}

std::string readSize(const Json& object, const char* key, int& out) {
  const auto it = object.find(key);
  if (it == object.end()) return std::string(key) + ": missing";
  if (!it->is_number_integer()) return std::string(key) + ": not an integer";
  const auto v = it->get<long long>();
  if (v < 1 || v > 16384) return std::string(key) + ": " + std::to_string(v) + " not in [1, 16384]";
  out = static_cast<int>(v);
  return {};
}

std::string readChannel(const Json& j, Channel& c) {
  if (!j.is_object()) return "not an object";
  static const std::set<std::string> known{"name",
                                           "azimuth",
                                           "elevation",
                                           "hfov",
                                           "vfov",
                                           "roll",
                                           "width",
                                           "height",
                                           "render",
                                           "warp",
                                           "blend"};
  for (const auto& [key, value] : j.items()) {
    (void)value;
    if (!known.contains(key)) return "unknown key \"" + key + "\"";
  }
  const auto name = j.find("name");
  if (name == j.end()) return "name: missing";
  if (!name->is_string() || !validName(name->get<std::string>()))
    return "name: must be 1-64 characters of A-Z a-z 0-9 _ -";
  c.name = name->get<std::string>();
  const double inf = std::numeric_limits<double>::max();
  for (const auto& message : {readNumber(j, "azimuth", c.azimuthDeg, -inf, inf, false),
                              readNumber(j, "elevation", c.elevationDeg, -90.0, 90.0, false),
                              readNumber(j, "hfov", c.hfovDeg, 0.0, 170.0, true),
                              readNumber(j, "vfov", c.vfovDeg, 0.0, 170.0, true),
                              readNumber(j, "roll", c.rollDeg, -inf, inf, false, false),
                              readSize(j, "width", c.width),
                              readSize(j, "height", c.height)}) {
    if (!message.empty()) return message;
  }
  for (const auto& [key, out] : {std::pair{"warp", &c.warp}, std::pair{"blend", &c.blend}}) {
    if (const auto it = j.find(key); it != j.end()) {
      if (!it->is_string() || it->get<std::string>().empty())
        return std::string(key) + ": a file name is required";
      *out = it->get<std::string>();
    }
  }
  if (const auto it = j.find("render"); it != j.end()) {
    if (!it->is_array() || it->size() != 2)
      return "render: [width, height] of the rendered image is required";
    const Json size{{"width", (*it)[0]}, {"height", (*it)[1]}};
    for (const auto& message :
         {readSize(size, "width", c.renderWidth), readSize(size, "height", c.renderHeight)})
      if (!message.empty()) return "render: " + message;
  }
  const double aspect = static_cast<double>(c.renderedWidth()) / c.renderedHeight();
  const double fovAspect = std::tan(c.hfovDeg * kDeg / 2.0) / std::tan(c.vfovDeg * kDeg / 2.0);
  const std::string what = c.renderWidth > 0 ? "render" : "width / height";
  if (std::abs(fovAspect / aspect - 1.0) > 0.01) {
    return "pixels not square: " + what + " is " + std::to_string(aspect) +
           " but tan(hfov / 2) / tan(vfov / 2) is " + std::to_string(fovAspect);
  }
  const double projector = static_cast<double>(c.width) / c.height;
  if (c.warp.empty() && std::abs(projector / aspect - 1.0) > 0.01)
    return "without a warp the projector shows the rendered image scaled: width / height is " +
           std::to_string(projector) + " but render's is " + std::to_string(aspect);
  return {};
}

} // namespace

glm::dvec3 domeDirection(double azimuthDeg, double elevationDeg) noexcept {
  const double az = azimuthDeg * kDeg, el = elevationDeg * kDeg;
  return {std::cos(el) * std::sin(az), std::cos(el) * std::cos(az), -std::sin(el)};
}

ChannelFrame channelFrame(const Channel& channel) noexcept {
  const double az = channel.azimuthDeg * kDeg, el = channel.elevationDeg * kDeg;
  ChannelFrame f;
  f.forward = domeDirection(channel.azimuthDeg, channel.elevationDeg);
  // d(direction)/d(elevation): a unit vector, defined at the zenith too.
  const glm::dvec3 up0{-std::sin(el) * std::sin(az), -std::sin(el) * std::cos(az), -std::cos(el)};
  const glm::dvec3 right0 = glm::cross(f.forward, up0);
  const double r = channel.rollDeg * kDeg;
  f.up = glm::normalize(std::cos(r) * up0 + std::sin(r) * right0);
  f.right = glm::normalize(glm::cross(f.forward, f.up));
  return f;
}

bool projectToChannel(const Channel& channel, const glm::dvec3& domeDir, glm::dvec2& px) noexcept {
  const ChannelFrame f = channelFrame(channel);
  const double z = glm::dot(domeDir, f.forward);
  if (!(z > 1e-9)) return false;
  const double x = glm::dot(domeDir, f.right) / z / std::tan(channel.hfovDeg * kDeg / 2.0);
  const double y = glm::dot(domeDir, f.up) / z / std::tan(channel.vfovDeg * kDeg / 2.0);
  px = {(1.0 + x) * channel.renderedWidth() / 2.0, (1.0 - y) * channel.renderedHeight() / 2.0};
  return true;
}

glm::dvec3 channelPixelDirection(const Channel& channel, const glm::dvec2& px) noexcept {
  const ChannelFrame f = channelFrame(channel);
  const double x =
      (2.0 * px.x / channel.renderedWidth() - 1.0) * std::tan(channel.hfovDeg * kDeg / 2.0);
  const double y =
      (1.0 - 2.0 * px.y / channel.renderedHeight()) * std::tan(channel.vfovDeg * kDeg / 2.0);
  return glm::normalize(f.forward + x * f.right + y * f.up);
}

std::expected<std::vector<Channel>, std::string> parseChannels(std::string_view json,
                                                               std::string_view origin) {
  const Json root = Json::parse(json, nullptr, false);
  if (root.is_discarded()) return fail(origin, "not JSON");
  if (!root.is_object()) return fail(origin, "not a JSON object");
  for (const auto& [key, value] : root.items()) {
    (void)value;
    if (key != "channels") return fail(origin, "unknown key \"" + key + "\"");
  }
  const auto list = root.find("channels");
  if (list == root.end()) return fail(origin, "channels: missing");
  if (!list->is_array() || list->empty()) return fail(origin, "channels: not a non-empty array");
  std::vector<Channel> channels;
  std::set<std::string> names;
  for (std::size_t i = 0; i < list->size(); ++i) {
    Channel c;
    if (const auto message = readChannel((*list)[i], c); !message.empty())
      return fail(origin, "channels[" + std::to_string(i) + "]: " + message);
    if (!names.insert(c.name).second)
      return fail(origin, "channels[" + std::to_string(i) + "]: name \"" + c.name + "\" repeated");
    channels.push_back(std::move(c));
  }
  return channels;
}

std::expected<std::vector<Channel>, std::string> readChannels(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return std::unexpected(file.string() + ": cannot be read");
  const std::string text{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  auto channels = parseChannels(text, file.string());
  if (channels)
    for (Channel& c : *channels)
      for (std::filesystem::path* p : {&c.warp, &c.blend})
        if (!p->empty() && p->is_relative()) *p = file.parent_path() / *p;
  return channels;
}

} // namespace tellus::planet
