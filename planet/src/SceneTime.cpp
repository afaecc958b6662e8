#include <tellus/cache/IsoTime.hpp>
#include <tellus/planet/SceneTime.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>

namespace tellus::planet {
namespace {

/** The rate sizes faster() and slower() step through (scene seconds per wall second). */
constexpr std::array<double, 6> kRates = {1.0, 10.0, 60.0, 600.0, 3600.0, 86400.0};

} // namespace

std::expected<double, std::string> parseSceneTime(std::string_view text, double nowUnixSeconds) {
  if (text == "now") return nowUnixSeconds;
  if (const auto t = iso8601::parseInstant(text))
    return static_cast<double>(t->seconds) + t->fraction;
  return std::unexpected(
      "expected an ISO 8601 time (YYYY-MM-DDThh:mm:ssZ, YYYY-MM-DD) or now, got '" +
      std::string(text) + "'");
}

std::string formatSceneTime(double unixSeconds) {
  const double whole = std::floor(unixSeconds);
  // 0000-01-01 and 10000-01-01 as POSIX seconds: outside, the calendar form would lie.
  if (!(whole >= static_cast<double>(iso8601::kFirstSecond) &&
        whole <= static_cast<double>(iso8601::kLastSecond))) {
    char buf[48];
    std::snprintf(buf, sizeof buf, "%+.0f s", unixSeconds);
    return buf;
  }
  return iso8601::formatInstant(static_cast<std::int64_t>(whole), {false, true, true});
}

double SceneClock::advance(double wallSeconds) noexcept {
  const double dt = std::max(0.0, wallSeconds - wall_);
  wall_ = std::max(wall_, wallSeconds);
  time_ += rate() * dt;
  return time_;
}

void SceneClock::faster() noexcept {
  const double size = std::abs(rate_);
  const auto next = std::upper_bound(kRates.begin(), kRates.end(), size);
  const double to = next == kRates.end() ? kRates.back() : *next;
  rate_ = rate_ < 0.0 ? -to : to;
}

void SceneClock::slower() noexcept {
  const double size = std::abs(rate_);
  const auto below = std::lower_bound(kRates.begin(), kRates.end(), size);
  const double to = below == kRates.begin() ? kRates.front() : *(below - 1);
  rate_ = rate_ < 0.0 ? -to : to;
}

} // namespace tellus::planet
