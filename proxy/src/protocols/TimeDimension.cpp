// The TIME of a GetMap (and of `/tiles/...?time=`, `tellus seed --time`): one ISO 8601 instant
// checked against the layer's values or against its period's grid, and written in one spelling per
// instant, so that no client can make tellus create a dataset (a folder, upstream requests) for a
// time the layer does not have, or a second one for a time it has.

#include <tellus/proxy/Wms.hpp>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>
#include <string_view>

namespace tellus {

namespace {

using std::chrono::day;
using std::chrono::days;
using std::chrono::month;
using std::chrono::sys_days;
using std::chrono::year;
using std::chrono::year_month_day;

constexpr std::int64_t kDay = 86'400;

/** How an instant is written: a date, or a date and time with or without seconds and 'Z'. */
struct Shape {
  bool dateOnly = false;
  bool seconds = false;
  bool zulu = true;
};

struct Instant {
  std::int64_t seconds = 0; ///< UTC, since 1970-01-01T00:00:00Z
  Shape shape;
};

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

/**
 * An ISO 8601 instant in the extended forms clients send: `YYYY-MM-DD`, or
 * `YYYY-MM-DDThh:mm[:ss[.fraction]]` followed by `Z`, an offset `+hh:mm` / `-hh:mm` / `+hhmm`, or
 * nothing (UTC, as the configuration reads periods). Years 0000-9999, a valid calendar date,
 * hh 00-23, mm and ss 00-59. A fraction must be zero (the grids have whole seconds): a non-zero
 * one is no instant of any layer, so it does not parse.
 */
std::optional<Instant> parseInstant(std::string_view s) noexcept {
  if (s.size() < 10 || s.size() > 64) return std::nullopt;
  const auto y = digits(s, 0, 4);
  const auto mo = digits(s, 5, 2);
  const auto d = digits(s, 8, 2);
  if (!y || !mo || !d || s[4] != '-' || s[7] != '-') return std::nullopt;
  const year_month_day ymd{
      year{*y}, month{static_cast<unsigned>(*mo)}, day{static_cast<unsigned>(*d)}};
  if (!ymd.ok()) return std::nullopt;
  Instant r;
  if (s.size() == 10) {
    r.shape.dateOnly = true;
    r.seconds = fromCivil(*y, static_cast<unsigned>(*mo), static_cast<unsigned>(*d), 0);
    return r;
  }
  if (s[10] != 'T') return std::nullopt;
  std::string_view t = s.substr(11);
  const auto hh = digits(t, 0, 2);
  const auto mm = digits(t, 3, 2);
  if (!hh || !mm || t[2] != ':' || *hh > 23 || *mm > 59) return std::nullopt;
  t.remove_prefix(5);
  int ss = 0;
  if (!t.empty() && t.front() == ':') {
    const auto sec = digits(t, 1, 2);
    if (!sec || *sec > 59) return std::nullopt;
    ss = *sec;
    r.shape.seconds = true;
    t.remove_prefix(3);
    if (!t.empty() && (t.front() == '.' || t.front() == ',')) {
      t.remove_prefix(1);
      std::size_t n = 0;
      while (n < t.size() && t[n] >= '0' && t[n] <= '9') {
        if (t[n] != '0') return std::nullopt; // not on a whole second
        ++n;
      }
      if (n == 0) return std::nullopt;
      t.remove_prefix(n);
    }
  }
  std::int64_t offset = 0;
  r.shape.zulu = false;
  if (t == "Z") {
    r.shape.zulu = true;
  } else if (!t.empty()) {
    if (t.front() != '+' && t.front() != '-') return std::nullopt;
    const int sign = t.front() == '-' ? -1 : 1;
    const auto oh = digits(t, 1, 2);
    std::optional<int> om;
    if (t.size() == 6 && t[3] == ':') {
      om = digits(t, 4, 2);
    } else if (t.size() == 5) {
      om = digits(t, 3, 2);
    }
    if (!oh || !om || *oh > 23 || *om > 59) return std::nullopt;
    offset = sign * (std::int64_t{*oh} * 3600 + std::int64_t{*om} * 60);
  }
  r.seconds = fromCivil(*y,
                        static_cast<unsigned>(*mo),
                        static_cast<unsigned>(*d),
                        std::int64_t{*hh} * 3600 + std::int64_t{*mm} * 60 + ss) -
              offset;
  return r;
}

std::string format(std::int64_t seconds, const Shape& shape) {
  const std::int64_t dayCount = floorDiv(seconds, kDay);
  const year_month_day ymd{sys_days{days{dayCount}}};
  const auto s = static_cast<int>(seconds - dayCount * kDay);
  char buf[48];
  if (shape.dateOnly) {
    std::snprintf(buf,
                  sizeof buf,
                  "%04d-%02u-%02u",
                  static_cast<int>(ymd.year()),
                  static_cast<unsigned>(ymd.month()),
                  static_cast<unsigned>(ymd.day()));
  } else {
    std::snprintf(buf,
                  sizeof buf,
                  "%04d-%02u-%02uT%02d:%02d",
                  static_cast<int>(ymd.year()),
                  static_cast<unsigned>(ymd.month()),
                  static_cast<unsigned>(ymd.day()),
                  s / 3600,
                  s / 60 % 60);
    std::string out = buf;
    if (shape.seconds) {
      std::snprintf(buf, sizeof buf, ":%02d", s % 60);
      out += buf;
    }
    if (shape.zulu) out += 'Z';
    return out;
  }
  return buf;
}

/** An ISO 8601 duration P[nY][nM][nW][nD][T[nH][nM][nS]] with whole components. */
struct Duration {
  std::int64_t months = 0;
  std::int64_t days = 0;
  std::int64_t seconds = 0;
};

std::optional<Duration> parseDuration(std::string_view s) noexcept {
  if (s.size() < 3 || s.front() != 'P') return std::nullopt;
  s.remove_prefix(1);
  Duration d;
  bool inTime = false;
  bool any = false;
  bool anyInTime = false;
  while (!s.empty()) {
    if (s.front() == 'T') {
      if (inTime) return std::nullopt;
      inTime = true;
      s.remove_prefix(1);
      continue;
    }
    std::size_t n = 0;
    std::int64_t v = 0;
    while (n < s.size() && s[n] >= '0' && s[n] <= '9' && n < 7) {
      v = v * 10 + (s[n] - '0');
      ++n;
    }
    if (n == 0 || n >= s.size()) return std::nullopt;
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
  if (d.months == 0 && d.days == 0 && d.seconds == 0) return std::nullopt;
  return d;
}

struct Period {
  Instant start;
  Instant end;
  Duration step;
  Shape canonical; ///< how its instants are written
};

std::optional<Period> parsePeriod(std::string_view text) noexcept {
  const auto s1 = text.find('/');
  const auto s2 = s1 == std::string_view::npos ? s1 : text.find('/', s1 + 1);
  if (s2 == std::string_view::npos || text.find('/', s2 + 1) != std::string_view::npos)
    return std::nullopt;
  const auto start = parseInstant(text.substr(0, s1));
  const auto end = parseInstant(text.substr(s1 + 1, s2 - s1 - 1));
  const auto step = parseDuration(text.substr(s2 + 1));
  if (!start || !end || !step || end->seconds < start->seconds) return std::nullopt;
  Period p{*start, *end, *step, start->shape};
  if (p.canonical.dateOnly && step->seconds != 0) {
    // A date-only start with a time step: the instants have times.
    p.canonical = Shape{false, step->seconds % 60 != 0, true};
  } else if (!p.canonical.dateOnly && step->seconds % 60 != 0) {
    p.canonical.seconds = true;
  }
  return p;
}

/** start + k * step, months added on the calendar (the day clamped to the month's end), as the
 * configuration expands a period. */
std::int64_t instantAt(const Period& p, std::int64_t k) noexcept {
  std::int64_t t = p.start.seconds;
  if (p.step.months != 0) {
    const std::int64_t dayCount = floorDiv(t, kDay);
    const year_month_day ymd{sys_days{days{dayCount}}};
    const std::int64_t total = static_cast<std::int64_t>(static_cast<int>(ymd.year())) * 12 +
                               (static_cast<unsigned>(ymd.month()) - 1) + p.step.months * k;
    const std::int64_t y = floorDiv(total, 12);
    if (y > 9999 || y < 0) return y < 0 ? INT64_MIN : INT64_MAX;
    const auto m = static_cast<unsigned>(total - y * 12 + 1);
    const unsigned last = static_cast<unsigned>(std::chrono::year_month_day_last{
        year{static_cast<int>(y)},
        std::chrono::month_day_last{month{m}}}.day());
    const unsigned d = std::min(static_cast<unsigned>(ymd.day()), last);
    t = fromCivil(static_cast<int>(y), m, d, t - dayCount * kDay);
  }
  return t + (p.step.days * kDay + p.step.seconds) * k;
}

/** Whether `t` is start + k * step for a whole k >= 0 and not after the end. */
bool onGrid(const Period& p, std::int64_t t) noexcept {
  if (t < p.start.seconds || t > p.end.seconds) return false;
  const std::int64_t fixed = p.step.days * kDay + p.step.seconds;
  if (p.step.months == 0) return (t - p.start.seconds) % fixed == 0;
  // Calendar months: k from the mean step (a month is 30.436875 days on average; the calendar
  // is never more than a few days off it), then the neighbours checked exactly.
  const double mean = static_cast<double>(p.step.months) * 2'629'746.0 + static_cast<double>(fixed);
  const auto guess = static_cast<std::int64_t>(static_cast<double>(t - p.start.seconds) / mean);
  for (std::int64_t k = std::max<std::int64_t>(0, guess - 2); k <= guess + 2; ++k) {
    if (instantAt(p, k) == t) return true;
  }
  return false;
}

OgcException invalidTime(std::string message) {
  return OgcException{std::string(ogc::kInvalidDimensionValue), "TIME", std::move(message)};
}

std::string shortened(std::string_view s) {
  if (s.size() <= 40) return std::string(s);
  return std::string(s.substr(0, 40)) + "...";
}

/** The layer's own spelling of the instant `t` (the value or period it is one of), if any. */
std::optional<std::string> canonicalTime(const std::vector<std::string>& values,
                                         const std::optional<Period>& period,
                                         std::string_view t) {
  if (std::find(values.begin(), values.end(), t) != values.end()) return std::string(t);
  const auto instant = parseInstant(t);
  if (!instant) return std::nullopt;
  for (const std::string& v : values) {
    const auto vi = parseInstant(v);
    if (vi && vi->seconds == instant->seconds) return v;
  }
  if (period && onGrid(*period, instant->seconds))
    return format(instant->seconds, period->canonical);
  return std::nullopt;
}

} // namespace

std::expected<std::string, OgcException>
resolveTimeDimension(std::string_view layer,
                     const std::vector<std::string>& values,
                     std::string_view periodText,
                     std::string_view defaultValue,
                     std::string_view t) {
  if (values.empty() && periodText.empty()) return std::string(); // no TIME dimension: ignored
  const std::optional<Period> period = periodText.empty() ? std::nullopt : parsePeriod(periodText);
  if (t.empty()) {
    if (defaultValue.empty()) {
      return std::unexpected(OgcException{std::string(ogc::kMissingDimensionValue),
                                          "TIME",
                                          "layer '" + std::string(layer) + "' needs a TIME value"});
    }
    // The default in the layer's own spelling, so that it and the same time asked for share a
    // dataset.
    return canonicalTime(values, period, defaultValue).value_or(std::string(defaultValue));
  }
  if (t.find(',') != std::string_view::npos) {
    return std::unexpected(invalidTime("TIME '" + shortened(t) +
                                       "' is a list; a map is made for one time, ask for one"));
  }
  if (t.find('/') != std::string_view::npos) {
    return std::unexpected(invalidTime("TIME '" + shortened(t) +
                                       "' is a range; a map is made for one time, ask for one"));
  }
  if (auto c = canonicalTime(values, period, t)) return std::move(*c);
  const std::string why = parseInstant(t) ? (period ? "is not on " + std::string(periodText)
                                                    : std::string("is not listed"))
                                          : std::string("is no ISO 8601 date or time");
  return std::unexpected(
      invalidTime("TIME is not one of the layer's times: '" + shortened(t) + "' " + why));
}

} // namespace tellus
