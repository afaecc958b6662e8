// The one ISO 8601 reader and writer (see IsoTime.hpp for the grammar).
#include <tellus/cache/IsoTime.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <limits>

namespace tellus::iso8601 {
namespace {

using std::chrono::day;
using std::chrono::days;
using std::chrono::month;
using std::chrono::sys_days;
using std::chrono::year;
using std::chrono::year_month_day;

constexpr std::int64_t kDay = 86'400;

/** n digits at pos as a number; nullopt if any is not a digit or the text is too short. */
std::optional<int> digits(std::string_view s, std::size_t pos, std::size_t n) noexcept {
  if (pos + n > s.size()) return std::nullopt;
  int v = 0;
  for (std::size_t i = pos; i < pos + n; ++i) {
    if (s[i] < '0' || s[i] > '9') return std::nullopt;
    v = v * 10 + (s[i] - '0');
  }
  return v;
}

std::int64_t floorDiv(std::int64_t a, std::int64_t b) noexcept {
  std::int64_t q = a / b;
  if ((a % b != 0) && ((a < 0) != (b < 0))) --q;
  return q;
}

std::int64_t fromCivil(int y, unsigned m, unsigned d, std::int64_t secondsOfDay) noexcept {
  const sys_days sd{year_month_day{year{y}, month{m}, day{d}}};
  return static_cast<std::int64_t>(sd.time_since_epoch().count()) * kDay + secondsOfDay;
}

/** ":ss[.fraction]" at the front of t (consumed); false when malformed. */
bool readSeconds(std::string_view& t, Instant& r, int& ss) noexcept {
  const auto sec = digits(t, 1, 2);
  if (!sec || *sec > 59) return false;
  ss = *sec;
  r.shape.seconds = true;
  t.remove_prefix(3);
  if (t.empty() || (t.front() != '.' && t.front() != ',')) return true;
  t.remove_prefix(1);
  std::size_t n = 0;
  double scale = 0.1;
  while (n < t.size() && t[n] >= '0' && t[n] <= '9') {
    r.fraction += (t[n] - '0') * scale;
    scale *= 0.1;
    ++n;
  }
  if (n == 0 || n > 9) return false;
  r.fraction = std::min(r.fraction, 0.999999999);
  t.remove_prefix(n);
  return true;
}

/** The zone (all of t): 'Z', an offset, or nothing; its offset in seconds east of UTC. */
std::optional<std::int64_t> readZone(std::string_view t, Shape& shape) noexcept {
  shape.zulu = t == "Z";
  if (t.empty() || shape.zulu) return 0;
  if (t.front() != '+' && t.front() != '-') return std::nullopt;
  const auto oh = digits(t, 1, 2);
  std::optional<int> om;
  if (t.size() == 6 && t[3] == ':') {
    om = digits(t, 4, 2);
  } else if (t.size() == 5) {
    om = digits(t, 3, 2);
  }
  if (!oh || !om || *oh > 23 || *om > 59) return std::nullopt;
  const std::int64_t sign = t.front() == '-' ? -1 : 1;
  return sign * (std::int64_t{*oh} * 3600 + std::int64_t{*om} * 60);
}

} // namespace

std::optional<Instant> parseInstant(std::string_view s) noexcept {
  if (s.size() < 10 || s.size() > 64) return std::nullopt;
  const auto y = digits(s, 0, 4);
  const auto mo = digits(s, 5, 2);
  const auto d = digits(s, 8, 2);
  if (!y || !mo || !d || s[4] != '-' || s[7] != '-') return std::nullopt;
  const year_month_day ymd{
      year{*y}, month{static_cast<unsigned>(*mo)}, day{static_cast<unsigned>(*d)}};
  if (!ymd.ok()) return std::nullopt;
  const auto mon = static_cast<unsigned>(*mo);
  const auto dd = static_cast<unsigned>(*d);
  Instant r;
  if (s.size() == 10) {
    r.shape.dateOnly = true;
    r.seconds = fromCivil(*y, mon, dd, 0);
    return r;
  }
  if (s[10] != 'T' && s[10] != ' ') return std::nullopt;
  std::string_view t = s.substr(11);
  const auto hh = digits(t, 0, 2);
  const auto mm = digits(t, 3, 2);
  if (!hh || !mm || t[2] != ':' || *hh > 23 || *mm > 59) return std::nullopt;
  t.remove_prefix(5);
  int ss = 0;
  if (!t.empty() && t.front() == ':' && !readSeconds(t, r, ss)) return std::nullopt;
  const auto offset = readZone(t, r.shape);
  if (!offset) return std::nullopt;
  r.seconds =
      fromCivil(*y, mon, dd, std::int64_t{*hh} * 3600 + std::int64_t{*mm} * 60 + ss) - *offset;
  return r;
}

std::optional<Duration> parseDuration(std::string_view s) noexcept {
  if (s.size() < 3 || s.front() != 'P') return std::nullopt;
  s.remove_prefix(1);
  Duration d;
  bool inTime = false;
  bool any = false;
  bool anyInTime = false;
  constexpr std::int64_t kMaxComponent = 1'000'000;
  while (!s.empty()) {
    if (s.front() == 'T') {
      if (inTime) return std::nullopt;
      inTime = true;
      s.remove_prefix(1);
      continue;
    }
    std::size_t n = 0;
    std::int64_t v = 0;
    while (n < s.size() && s[n] >= '0' && s[n] <= '9' && v <= kMaxComponent) {
      v = v * 10 + (s[n] - '0');
      ++n;
    }
    if (n == 0 || n >= s.size() || v > kMaxComponent) return std::nullopt;
    const char unit = s[n];
    s.remove_prefix(n + 1);
    if (!inTime && unit == 'Y') {
      d.months += 12 * v;
    } else if (!inTime && unit == 'M') {
      d.months += v;
    } else if (!inTime && unit == 'W') {
      d.days += 7 * v;
    } else if (!inTime && unit == 'D') {
      d.days += v;
    } else if (inTime && unit == 'H') {
      d.seconds += 3600 * v;
    } else if (inTime && unit == 'M') {
      d.seconds += 60 * v;
    } else if (inTime && unit == 'S') {
      d.seconds += v;
    } else {
      return std::nullopt;
    }
    any = true;
    anyInTime = anyInTime || inTime;
  }
  if (!any || (inTime && !anyInTime)) return std::nullopt;
  return d;
}

std::int64_t addDuration(std::int64_t startSeconds, const Duration& p, std::int64_t k) noexcept {
  constexpr auto kMin = std::numeric_limits<std::int64_t>::min();
  constexpr auto kMax = std::numeric_limits<std::int64_t>::max();
  std::int64_t t = startSeconds;
  if (p.months != 0) {
    const std::int64_t dayCount = floorDiv(t, kDay);
    const year_month_day ymd{sys_days{days{dayCount}}};
    const std::int64_t total = std::int64_t{static_cast<int>(ymd.year())} * 12 +
                               (static_cast<unsigned>(ymd.month()) - 1) + p.months * k;
    const std::int64_t y = floorDiv(total, 12);
    if (y > 9999 || y < 0) return y < 0 ? kMin : kMax;
    const auto m = static_cast<unsigned>(total - y * 12 + 1);
    const auto last = static_cast<unsigned>(std::chrono::year_month_day_last{
        year{static_cast<int>(y)},
        std::chrono::month_day_last{month{m}}}.day());
    const unsigned d = std::min(static_cast<unsigned>(ymd.day()), last);
    t = fromCivil(static_cast<int>(y), m, d, t - dayCount * kDay);
  }
  const std::int64_t r = t + (p.days * kDay + p.seconds) * k;
  if (r < kFirstSecond) return kMin;
  if (r > kLastSecond) return kMax;
  return r;
}

std::string formatInstant(std::int64_t seconds, const Shape& shape) {
  const std::int64_t dayCount = floorDiv(seconds, kDay);
  const year_month_day ymd{sys_days{days{dayCount}}};
  const auto s = static_cast<int>(seconds - dayCount * kDay);
  char buf[64];
  const int y = static_cast<int>(ymd.year());
  const auto m = static_cast<unsigned>(ymd.month());
  const auto d = static_cast<unsigned>(ymd.day());
  if (shape.dateOnly) {
    std::snprintf(buf, sizeof buf, "%04d-%02u-%02u", y, m, d);
    return buf;
  }
  std::snprintf(buf, sizeof buf, "%04d-%02u-%02uT%02d:%02d", y, m, d, s / 3600, s / 60 % 60);
  std::string out = buf;
  if (shape.seconds) {
    std::snprintf(buf, sizeof buf, ":%02d", s % 60);
    out += buf;
  }
  if (shape.zulu) out += 'Z';
  return out;
}

} // namespace tellus::iso8601
