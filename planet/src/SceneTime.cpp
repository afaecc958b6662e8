#include <tellus/planet/SceneTime.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>

namespace tellus::planet {
namespace {

using namespace std::chrono;

constexpr double kDay = 86400.0;

/** n digits at pos as a number; nullopt if any is not a digit or the text is too short. */
std::optional<int> digits(std::string_view s, std::size_t pos, std::size_t n) {
  if (pos + n > s.size()) return std::nullopt;
  int v = 0;
  for (std::size_t i = pos; i < pos + n; ++i) {
    if (s[i] < '0' || s[i] > '9') return std::nullopt;
    v = v * 10 + (s[i] - '0');
  }
  return v;
}

/** "hh:mm[:ss[.fff]]" from pos to the end (a Z stripped before): seconds of the day. */
std::optional<double> timeOfDay(std::string_view s, std::size_t pos) {
  const auto h = digits(s, pos, 2), m = digits(s, pos + 3, 2);
  if (!h || !m || s.size() < pos + 5 || s[pos + 2] != ':' || *h > 23 || *m > 59)
    return std::nullopt;
  double sec = 0.0;
  std::size_t at = pos + 5;
  if (at < s.size()) {
    const auto ss = digits(s, at + 1, 2);
    if (s[at] != ':' || !ss || *ss > 59) return std::nullopt;
    sec = *ss;
    at += 3;
    if (at < s.size()) { // a fraction: '.' and at least one digit
      if (s[at] != '.' || at + 1 == s.size()) return std::nullopt;
      double scale = 0.1;
      for (std::size_t i = at + 1; i < s.size(); ++i, scale *= 0.1) {
        if (s[i] < '0' || s[i] > '9') return std::nullopt;
        sec += (s[i] - '0') * scale;
      }
    }
  }
  return *h * 3600.0 + *m * 60.0 + sec;
}

std::optional<double> parseIso(std::string_view s) {
  if (!s.empty() && (s.back() == 'Z' || s.back() == 'z')) s.remove_suffix(1);
  const auto y = digits(s, 0, 4), mo = digits(s, 5, 2), d = digits(s, 8, 2);
  if (!y || !mo || !d || s[4] != '-' || s[7] != '-' || *y < 1) return std::nullopt;
  const year_month_day ymd{
      year{*y}, month{static_cast<unsigned>(*mo)}, day{static_cast<unsigned>(*d)}};
  if (!ymd.ok()) return std::nullopt;
  const double days = static_cast<double>(sys_days{ymd}.time_since_epoch().count());
  if (s.size() == 10) return days * kDay;
  if (s[10] != 'T' && s[10] != 't' && s[10] != ' ') return std::nullopt;
  const auto tod = timeOfDay(s, 11);
  if (!tod) return std::nullopt;
  return days * kDay + *tod;
}

/** The rate sizes faster() and slower() step through (scene seconds per wall second). */
constexpr std::array<double, 6> kRates = {1.0, 10.0, 60.0, 600.0, 3600.0, 86400.0};

} // namespace

std::expected<double, std::string> parseSceneTime(std::string_view text, double nowUnixSeconds) {
  if (text == "now") return nowUnixSeconds;
  if (const auto t = parseIso(text)) return *t;
  return std::unexpected("expected an ISO 8601 UTC time (YYYY-MM-DDThh:mm:ssZ, YYYY-MM-DD) or "
                         "now, got '" +
                         std::string(text) + "'");
}

std::string formatSceneTime(double unixSeconds) {
  const double whole = std::floor(unixSeconds);
  // 0001-01-01 and 10000-01-01 as POSIX seconds: outside, the calendar form would lie.
  if (!(whole >= -62135596800.0 && whole < 253402300800.0)) {
    char buf[48];
    std::snprintf(buf, sizeof buf, "%+.0f s", unixSeconds);
    return buf;
  }
  const auto secs = static_cast<long long>(whole);
  const long long dayCount = secs >= 0 ? secs / 86400 : -((-secs + 86399) / 86400);
  const long long tod = secs - dayCount * 86400;
  const year_month_day ymd{sys_days{days{dayCount}}};
  char buf[96];
  std::snprintf(buf,
                sizeof buf,
                "%04d-%02u-%02uT%02lld:%02lld:%02lldZ",
                static_cast<int>(ymd.year()),
                static_cast<unsigned>(ymd.month()),
                static_cast<unsigned>(ymd.day()),
                tod / 3600,
                tod / 60 % 60,
                tod % 60);
  return buf;
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
