#pragma once
/**
 * @file IsoTime.hpp
 * @brief The one reader and writer of ISO 8601 times in tellus: instants, durations and the
 * calendar arithmetic of periods. The configuration (layer TIME values and periods,
 * `renderer.time`), the WMS TIME dimension (GetMap, /tiles/, `tellus seed --time`) and the
 * renderer's scene time (`--time`, flight-path keyframes) all read times here, so that a time one
 * of them accepts is accepted by all (before, three parsers disagreed: `--time` took a fraction of
 * a second that `renderer.time` refused).
 *
 * Instants (parseInstant), ISO 8601's extended format as clients and people write it:
 *   YYYY-MM-DD                                  (00:00 UTC; dateOnly)
 *   YYYY-MM-DD<T>hh:mm[:ss[<.>fraction]][<zone>]
 * where <T> is 'T' or a space (RFC 3339's allowance), <.> is '.' or ',', the fraction has 1-9
 * digits and <zone> is 'Z', "+hh:mm", "-hh:mm", "+hhmm", "-hhmm" or nothing (UTC). Lower-case
 * 't' and 'z' are refused (ISO 8601 writes them upper-case; the WMS TIME tests refuse them). Years
 * 0000-9999 of the proleptic Gregorian calendar, a valid calendar date, hh 00-23, mm 00-59, ss
 * 00-59 (no leap second: POSIX time has none). At most 64 characters.
 *
 * Durations (parseDuration): P[nY][nM][nW][nD][T[nH][nM][nS]] with whole components of at most
 * 1,000,000 each, at least one component, and a component after a T. A zero duration parses (the
 * caller refuses it where a step is meant).
 *
 * Times are POSIX seconds (UTC, leap seconds not counted) as std::int64_t, with the fraction of
 * a second apart (a double in [0, 1)) so that whole-second grids compare exactly. Pure functions.
 */

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace tellus::iso8601 {

/** How an instant was (or is to be) written. */
struct Shape {
  bool dateOnly = false; ///< YYYY-MM-DD
  bool seconds = false;  ///< :ss written
  bool zulu = true;      ///< ends with Z (false: an offset, or no zone at all)
};

struct Instant {
  std::int64_t seconds = 0; ///< UTC, whole seconds since 1970-01-01T00:00:00Z (the zone applied)
  double fraction = 0.0;    ///< the fraction of a second, [0, 1)
  Shape shape;
};

/** An instant as described in the file comment; nullopt when it is not one. */
std::optional<Instant> parseInstant(std::string_view text) noexcept;

/** An ISO 8601 duration: calendar months, days and seconds kept apart. */
struct Duration {
  std::int64_t months = 0;
  std::int64_t days = 0;
  std::int64_t seconds = 0;
  bool zero() const noexcept { return months == 0 && days == 0 && seconds == 0; }
};

/** A duration as described in the file comment; nullopt when it is not one. */
std::optional<Duration> parseDuration(std::string_view text) noexcept;

/**
 * start + k x step: months added on the calendar with the day clamped to the month's end
 * (2024-01-31 + P1M = 2024-02-29), then days and seconds. A year outside 0000-9999 gives
 * INT64_MIN or INT64_MAX (before or after every instant).
 */
std::int64_t addDuration(std::int64_t startSeconds, const Duration& step, std::int64_t k) noexcept;

/** Whole seconds as written in `shape`: "YYYY-MM-DD", "YYYY-MM-DDThh:mm[:ss][Z]". Years outside
 * 0000-9999 are not representable: the caller keeps to them. */
std::string formatInstant(std::int64_t seconds, const Shape& shape);

/** The first and last instants ISO 8601 years 0000-9999 allow, as POSIX seconds. */
inline constexpr std::int64_t kFirstSecond = -62'167'219'200; // 0000-01-01T00:00:00Z
inline constexpr std::int64_t kLastSecond = 253'402'300'799;  // 9999-12-31T23:59:59Z

} // namespace tellus::iso8601
