#pragma once
/**
 * @file TimeRange.hpp
 * @brief A TIME that names several instants (issue 24: `tellus seed --time A/B/P`, the renderer's
 * `--animate LAYER=A/B/P`): a comma list of items, each
 *
 *   T        one instant (cache/IsoTime.hpp's grammar), kept as written;
 *   A/B/P    every A + k x P (k = 0, 1, ...) up to B, with iso8601::addDuration's calendar
 *            (2024-01-31 + P1M = 2024-02-29, + P2M = 2024-03-31: each from A, never chained);
 *   A/B      the declared instants (a layer's listed TIME values) that lie within [A, B].
 *
 * expanded in order, a later duplicate of an instant dropped. What comes out is a list of
 * instants, not yet checked against any layer: the caller checks each against the layer's TIME
 * dimension (proxy's resolveTimeDimension), which is what refuses an instant off its grid.
 *
 * Refused with a message: an empty item, a range that ends before it starts, a zero step, a
 * fraction of a second, A/B when nothing is declared (write A/B/P) or when no declared instant
 * lies within it, and more than maxInstants instants (the expansion stops counting there, so
 * a range of 9999 years by the second costs maxInstants + 1 steps, not 3e11). Pure functions.
 */

#include <tellus/cache/IsoTime.hpp>

#include <cstddef>
#include <cstdint>
#include <expected>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace tellus::iso8601 {

/** The instants start + k x step (k = 0, 1, ...; addDuration's calendar, each from start, never
 * chained) up to end, in order, as POSIX seconds: the one expansion of a period (the
 * configuration's `layers[].time.period` and expandTimes' A/B/P). It stops after maxInstants + 1,
 * so a result longer than maxInstants means "too many" and a huge period costs no more. */
inline std::vector<std::int64_t> periodInstants(std::int64_t startSeconds,
                                                std::int64_t endSeconds,
                                                const Duration& step,
                                                std::size_t maxInstants) {
  std::vector<std::int64_t> out;
  for (std::int64_t k = 0; out.size() <= maxInstants; ++k) {
    const std::int64_t t = addDuration(startSeconds, step, k);
    if (t > endSeconds) break;
    out.push_back(t);
  }
  return out;
}

/** The instants `text` names (see the file comment); `declared` serves A/B items. */
std::expected<std::vector<std::string>, std::string>
expandTimes(std::string_view text, std::span<const std::string> declared, std::size_t maxInstants);

} // namespace tellus::iso8601
