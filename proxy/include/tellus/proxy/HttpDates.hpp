#pragma once
/**
 * @file HttpDates.hpp
 * @brief HTTP dates (RFC 9110 5.6.7) and If-None-Match: what the front end, the page and the
 * Fetcher (Retry-After) read and write. Source: proxy/src/http/HttpDates.cpp.
 */

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace tellus {

/** "Sun, 06 Nov 1994 08:49:37 GMT" for a Unix time in milliseconds (whole seconds). */
std::string formatHttpDate(std::int64_t unixMillis);
/** Parses an IMF-fixdate (also RFC 850 and asctime forms); milliseconds since the epoch. */
std::optional<std::int64_t> parseHttpDate(std::string_view text);
/** RFC 9110 If-None-Match: `*`, or a list of (weak or strong) tags compared weakly with `etag`. */
bool ifNoneMatchHits(std::string_view ifNoneMatch, std::string_view etag);

} // namespace tellus
