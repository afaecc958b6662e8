// The syntax of configuration values that YAML does not know: durations, sizes, listen addresses,
// URLs, ISO 8601 times and periods; and the "did you mean" for misspelt keys.

#include "ConfigInternal.hpp"

#include <tellus/cache/IsoTime.hpp>
#include <tellus/cache/TimeRange.hpp>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cstdio>
#include <limits>

namespace tellus {

namespace {

/** Leading decimal digits as an unsigned 64-bit number; nullopt when there are none or on overflow.
 * Advances text past them. */
std::optional<std::uint64_t> takeDigits(std::string_view& text) noexcept {
  std::size_t n = 0;
  while (n < text.size() && text[n] >= '0' && text[n] <= '9')
    ++n;
  if (n == 0) return std::nullopt;
  std::uint64_t v = 0;
  const auto r = std::from_chars(text.data(), text.data() + n, v);
  if (r.ec != std::errc{} || r.ptr != text.data() + n) return std::nullopt;
  text.remove_prefix(n);
  return v;
}

} // namespace

std::optional<std::chrono::milliseconds> parseDurationText(std::string_view text) noexcept {
  const auto n = takeDigits(text);
  if (!n) return std::nullopt;
  std::uint64_t factor = 0;
  if (text.empty()) {
    if (*n != 0) return std::nullopt; // "30" alone: seconds or milliseconds? Say which.
    factor = 1;
  } else if (text == "ms") {
    factor = 1;
  } else if (text == "s") {
    factor = 1000;
  } else if (text == "m") {
    factor = 60'000;
  } else if (text == "h") {
    factor = 3'600'000;
  } else if (text == "d") {
    factor = 86'400'000;
  } else {
    return std::nullopt;
  }
  constexpr auto kMax = static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max());
  if (*n > kMax / factor) return std::nullopt;
  return std::chrono::milliseconds(static_cast<std::int64_t>(*n * factor));
}

std::optional<std::uint64_t> parseSizeText(std::string_view text) noexcept {
  const auto n = takeDigits(text);
  if (!n) return std::nullopt;
  while (!text.empty() && text.front() == ' ')
    text.remove_prefix(1);
  struct Unit {
    std::string_view name;
    std::uint64_t factor;
  };
  static constexpr Unit kUnits[] = {
      {"", 1},
      {"B", 1},
      {"KB", 1000ULL},
      {"kB", 1000ULL},
      {"MB", 1000ULL * 1000},
      {"GB", 1000ULL * 1000 * 1000},
      {"TB", 1000ULL * 1000 * 1000 * 1000},
      {"KiB", 1ULL << 10},
      {"MiB", 1ULL << 20},
      {"GiB", 1ULL << 30},
      {"TiB", 1ULL << 40},
  };
  for (const auto& u : kUnits) {
    if (text != u.name) continue;
    if (*n > std::numeric_limits<std::uint64_t>::max() / u.factor) return std::nullopt;
    return *n * u.factor;
  }
  return std::nullopt;
}

namespace detail {

bool isValidName(std::string_view name) noexcept {
  if (name.empty()) return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '.' || c == '-';
  });
}

bool isHttpToken(std::string_view s) noexcept {
  if (s.empty()) return false;
  constexpr std::string_view kSpecial = "!#$%&'*+-.^_`|~";
  return std::all_of(s.begin(), s.end(), [&](char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
           kSpecial.find(c) != std::string_view::npos;
  });
}

namespace {

bool startsWithNoCase(std::string_view s, std::string_view prefix) noexcept {
  if (s.size() < prefix.size()) return false;
  for (std::size_t i = 0; i < prefix.size(); ++i) {
    char c = s[i];
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
    if (c != prefix[i]) return false;
  }
  return true;
}

std::optional<std::uint16_t> parsePort(std::string_view s) noexcept {
  if (s.empty() || s.size() > 5) return std::nullopt;
  unsigned v = 0;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  if (r.ec != std::errc{} || r.ptr != s.data() + s.size() || v > 65535) return std::nullopt;
  return static_cast<std::uint16_t>(v);
}

bool isHostChar(char c) noexcept {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-' ||
         c == '.' || c == '_' || c == '~' || c == '%';
}

bool isV6Char(char c) noexcept {
  return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f') || (c >= 'A' && c <= 'F') || c == ':' ||
         c == '.';
}

} // namespace

std::optional<std::string> checkHttpUrl(std::string_view url) {
  std::string_view rest;
  if (startsWithNoCase(url, "http://")) {
    rest = url.substr(7);
  } else if (startsWithNoCase(url, "https://")) {
    rest = url.substr(8);
  } else {
    return "'" + std::string(url) + "' is not an http:// or https:// URL";
  }
  for (const char c : url) {
    const auto u = static_cast<unsigned char>(c);
    if (u <= 0x20 || u >= 0x7f)
      return "URL '" + std::string(url) +
             "' contains a space, a control or a non-ASCII character (percent-encode it)";
  }
  if (url.find('#') != std::string_view::npos)
    return "URL '" + std::string(url) + "' has a fragment (#...), which is never sent";
  const std::string_view authority = rest.substr(0, rest.find_first_of("/?"));
  if (authority.find('@') != std::string_view::npos)
    return "URL '" + std::string(url) +
           "' carries credentials; send them as a header (headers: {Authorization: ...})";
  std::string_view host = authority;
  std::string_view port;
  if (host.starts_with('[')) {
    const auto close = host.find(']');
    if (close == std::string_view::npos) return "URL '" + std::string(url) + "' has no ']'";
    const std::string_view v6 = host.substr(1, close - 1);
    if (v6.empty() || !std::all_of(v6.begin(), v6.end(), isV6Char))
      return "URL '" + std::string(url) + "' has a bad IPv6 address";
    const std::string_view after = host.substr(close + 1);
    if (!after.empty()) {
      if (after.front() != ':') return "URL '" + std::string(url) + "' has junk after ']'";
      port = after.substr(1);
      if (port.empty()) return "URL '" + std::string(url) + "' has an empty port";
    }
    host = v6;
  } else {
    if (const auto colon = host.find(':'); colon != std::string_view::npos) {
      port = host.substr(colon + 1);
      host = host.substr(0, colon);
      if (port.empty()) return "URL '" + std::string(url) + "' has an empty port";
    }
    if (host.empty()) return "URL '" + std::string(url) + "' has no host";
    if (!std::all_of(host.begin(), host.end(), isHostChar))
      return "URL '" + std::string(url) + "' has a bad host name '" + std::string(host) + "'";
  }
  if (!port.empty()) {
    const auto p = parsePort(port);
    if (!p || *p == 0)
      return "URL '" + std::string(url) + "' has a bad port '" + std::string(port) + "'";
  }
  return std::nullopt;
}

std::expected<std::pair<std::string, std::uint16_t>, std::string>
parseListenAddress(std::string_view text) {
  const auto bad = [&](std::string why) {
    return std::unexpected("'" + std::string(text) + "' " + why +
                           " (write host:port, e.g. 127.0.0.1:8080 or [::1]:8080)");
  };
  std::string_view host;
  std::string_view port;
  if (text.starts_with('[')) {
    const auto close = text.find(']');
    if (close == std::string_view::npos || close + 1 >= text.size() || text[close + 1] != ':')
      return bad("is not [IPv6]:port");
    host = text.substr(1, close - 1);
    port = text.substr(close + 2);
    if (host.empty() || !std::all_of(host.begin(), host.end(), isV6Char))
      return bad("has a bad IPv6 address");
  } else {
    const auto colon = text.rfind(':');
    if (colon == std::string_view::npos) return bad("has no port");
    host = text.substr(0, colon);
    port = text.substr(colon + 1);
    if (host.find(':') != std::string_view::npos) return bad("is IPv6 without brackets");
    if (host.empty()) return bad("has no host");
    if (!std::all_of(host.begin(), host.end(), isHostChar)) return bad("has a bad host name");
  }
  const auto p = parsePort(port);
  if (!p) return bad("has a bad port (0-65535; 0 = any free port)");
  return std::pair{std::string(host), *p};
}

std::expected<TimePeriod, std::string> parseTimePeriod(std::string_view text,
                                                       std::size_t maxValues) {
  const auto bad = [&](std::string why) {
    return std::unexpected("period '" + std::string(text) + "' " + why +
                           " (write start/end/period, e.g. 2024-01-01/2024-12-31/P1D)");
  };
  const auto s1 = text.find('/');
  const auto s2 = s1 == std::string_view::npos ? s1 : text.find('/', s1 + 1);
  if (s2 == std::string_view::npos || text.find('/', s2 + 1) != std::string_view::npos)
    return bad("is not start/end/period");
  const auto start = iso8601::parseInstant(text.substr(0, s1));
  const auto end = iso8601::parseInstant(text.substr(s1 + 1, s2 - s1 - 1));
  const auto step = iso8601::parseDuration(text.substr(s2 + 1));
  if (!start) return bad("has a bad start (YYYY-MM-DD or YYYY-MM-DDThh:mm:ssZ)");
  if (!end) return bad("has a bad end (YYYY-MM-DD or YYYY-MM-DDThh:mm:ssZ)");
  if (start->fraction != 0.0 || end->fraction != 0.0)
    return bad("has a fraction of a second (a period's times are whole seconds)");
  if (!step) return bad("has a bad ISO 8601 duration (e.g. P1D, P1M, PT6H)");
  if (step->zero()) return bad("has a period of zero length");
  if (end->seconds < start->seconds) return bad("ends before it starts");
  const bool dateOnly = start->shape.dateOnly && end->shape.dateOnly && step->seconds == 0;
  const iso8601::Shape shape{dateOnly, true, true};
  TimePeriod r{*start, *end, {}, 0};
  const auto instants = iso8601::periodInstants(start->seconds, end->seconds, *step, maxValues);
  r.count = instants.size();
  if (r.count > maxValues) return r; // too many: counted to maxValues + 1, none kept
  for (const std::int64_t t : instants)
    r.expanded.push_back(iso8601::formatInstant(t, shape));
  return r;
}

std::string closestKey(std::string_view key, std::span<const std::string_view> candidates) {
  const auto normal = [](std::string_view s) {
    std::string o;
    for (char c : s) {
      if (c == '_' || c == '-') continue;
      if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
      o += c;
    }
    return o;
  };
  // Optimal string alignment distance (an adjacent transposition costs 1).
  const auto distance = [](std::string_view a, std::string_view b) {
    std::vector<std::vector<std::size_t>> d(a.size() + 1, std::vector<std::size_t>(b.size() + 1));
    for (std::size_t i = 0; i <= a.size(); ++i)
      d[i][0] = i;
    for (std::size_t j = 0; j <= b.size(); ++j)
      d[0][j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
      for (std::size_t j = 1; j <= b.size(); ++j) {
        const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
        d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
        if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
          d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
      }
    }
    return d[a.size()][b.size()];
  };
  if (key.size() > 64) return {};
  const std::string k = normal(key);
  std::string best;
  std::size_t bestDistance = k.size() <= 4 ? 1 : 2;
  for (const auto c : candidates) {
    const std::size_t dist = distance(k, normal(c));
    if (dist == 0) return std::string(c);
    if (dist <= bestDistance && (best.empty() || dist < bestDistance)) {
      best = std::string(c);
      bestDistance = dist;
    }
  }
  return best;
}

} // namespace detail
} // namespace tellus
