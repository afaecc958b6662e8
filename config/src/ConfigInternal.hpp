#pragma once
// Private to the config module: value syntax helpers (Values.cpp) and the validation that both
// validate() and the YAML parser use (Validate.cpp).

#include <tellus/cache/IsoTime.hpp>
#include <tellus/config/Config.hpp>

#include <cstdint>
#include <expected>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace tellus::detail {

/** A validation problem: key is the dotted YAML path (e.g. "layers[1].upstream"), subject the
 * thing it is about (e.g. "layer 'etopo'"), message what is wrong (without the field). */
struct ValidationIssue {
  std::string key;
  std::string subject;
  std::string message;

  /** "layer 'etopo': upstream: no upstream named 'x'" (validate()'s text). */
  std::string text() const {
    std::string field = key;
    if (key.starts_with("layers[") || key.starts_with("upstreams[")) {
      const auto dot = key.find('.');
      field = dot == std::string::npos ? std::string() : key.substr(dot + 1);
    } else if (key.starts_with(subject + ".")) {
      field = key.substr(subject.size() + 1);
    }
    return subject + ": " + (field.empty() ? "" : field + ": ") + message;
  }
  /** "layer 'etopo': no upstream named 'x'" (a ConfigError's message; its key names the field). */
  std::string withSubject() const { return subject + ": " + message; }
};

/** The first problem of a configuration, or nullopt. checkFiles: local upstream files must exist.
 */
std::optional<ValidationIssue> findIssue(const Config& config, bool checkFiles);

/** renderer.atmosphere's values (also a body's): (key under "atmosphere.", message) of the
 * first bad one (Validate.cpp). */
std::optional<std::pair<std::string, std::string>>
checkAtmosphereSettings(const AtmosphereSettings& a);

/** The bodies section, renderer.body and every layer's body (ValidateBodies.cpp). */
std::optional<ValidationIssue> checkBodies(const Config& config);

/** Layer and upstream names: [A-Za-z0-9_.-]+. */
bool isValidName(std::string_view name) noexcept;

/** Checks an http(s) URL with a host; returns a message on failure. */
std::optional<std::string> checkHttpUrl(std::string_view url);

/** An RFC 7230 token (HTTP header names). */
bool isHttpToken(std::string_view s) noexcept;

/** "host:port" or "[v6]:port" -> host (without brackets) and port. */
std::expected<std::pair<std::string, std::uint16_t>, std::string>
parseListenAddress(std::string_view text);

/** An ISO 8601 "start/end/period" (e.g. 2024-01-01/2024-12-31/P1D). expanded: the values when
 * there are at most maxValues of them, else empty. */
struct TimePeriod {
  iso8601::Instant start; ///< cache/IsoTime.hpp: the one ISO 8601 reader
  iso8601::Instant end;
  std::vector<std::string> expanded;
  std::size_t count = 0; ///< values, or maxValues + 1 when there are more
};
std::expected<TimePeriod, std::string> parseTimePeriod(std::string_view text,
                                                       std::size_t maxValues);

/** The closest of the candidates to a misspelt key, or "" when none is close. */
std::string closestKey(std::string_view key, std::span<const std::string_view> candidates);

/** A value layer's `values` (ValidateValues.cpp): {key under values, message} of the first
 * problem, or nullopt. The key is relative to the layer ("values.range", "format"). */
std::optional<std::pair<std::string, std::string>> checkValueSettings(const LayerConfig& layer);

} // namespace tellus::detail
