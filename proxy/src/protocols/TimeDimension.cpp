// The TIME of a GetMap (and of `/tiles/...?time=`, `tellus seed --time`): one ISO 8601 instant
// checked against the layer's values or against its period's grid, and written in one spelling per
// instant, so that no client can make tellus create a dataset (a folder, upstream requests) for a
// time the layer does not have, or a second one for a time it has.

#include <tellus/cache/IsoTime.hpp>
#include <tellus/proxy/Wms.hpp>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>
#include <string_view>

namespace tellus {

namespace {

using iso8601::Duration;
using iso8601::Instant;
using iso8601::Shape;

constexpr std::int64_t kDay = 86'400;

/** An instant of a grid (cache/IsoTime.hpp's grammar). A non-zero fraction of a second is no
 * instant of any layer (the grids have whole seconds), so it does not parse. */
std::optional<Instant> parseInstant(std::string_view s) noexcept {
  auto r = iso8601::parseInstant(s);
  if (!r || r->fraction != 0.0) return std::nullopt;
  return r;
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
  const auto step = iso8601::parseDuration(text.substr(s2 + 1));
  if (!start || !end || !step || step->zero() || end->seconds < start->seconds) return std::nullopt;
  Period p{*start, *end, *step, start->shape};
  if (p.canonical.dateOnly && step->seconds != 0) {
    // A date-only start with a time step: the instants have times.
    p.canonical = Shape{false, step->seconds % 60 != 0, true};
  } else if (!p.canonical.dateOnly && step->seconds % 60 != 0) {
    p.canonical.seconds = true;
  }
  return p;
}

/** start + k * step, as the configuration expands a period. */
std::int64_t instantAt(const Period& p, std::int64_t k) noexcept {
  return iso8601::addDuration(p.start.seconds, p.step, k);
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
    return iso8601::formatInstant(instant->seconds, period->canonical);
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
