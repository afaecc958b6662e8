// HTTP dates (RFC 9110 5.6.7) and If-None-Match (HttpDates.hpp).
#include <tellus/proxy/HttpDates.hpp>

#include <ctime>
#include <string>

namespace tellus {

std::string formatHttpDate(std::int64_t unixMillis) {
  const std::time_t t = static_cast<std::time_t>(unixMillis / 1000);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[40];
  std::strftime(buf, sizeof buf, "%a, %d %b %Y %H:%M:%S GMT", &tm);
  return buf;
}

std::optional<std::int64_t> parseHttpDate(std::string_view text) {
  if (text.empty()) return std::nullopt;
  const std::string s(text);
  // IMF-fixdate, RFC 850, asctime (RFC 9110 section 5.6.7); strptime with the C locale's names.
  for (const char* fmt :
       {"%a, %d %b %Y %H:%M:%S GMT", "%A, %d-%b-%y %H:%M:%S GMT", "%a %b %e %H:%M:%S %Y"}) {
    std::tm tm{};
    const char* end = strptime(s.c_str(), fmt, &tm);
    if (end && *end == '\0') return static_cast<std::int64_t>(timegm(&tm)) * 1000;
  }
  return std::nullopt;
}

bool ifNoneMatchHits(std::string_view header, std::string_view etag) {
  auto opaque = [](std::string_view t) {
    if (t.starts_with("W/")) t.remove_prefix(2);
    return t;
  };
  const std::string_view mine = opaque(etag);
  std::size_t pos = 0;
  while (pos < header.size()) {
    const auto comma = header.find(',', pos);
    std::string_view item =
        header.substr(pos, comma == std::string_view::npos ? std::string_view::npos : comma - pos);
    while (!item.empty() && (item.front() == ' ' || item.front() == '\t'))
      item.remove_prefix(1);
    while (!item.empty() && (item.back() == ' ' || item.back() == '\t'))
      item.remove_suffix(1);
    if (item == "*" || (!item.empty() && opaque(item) == mine)) return true;
    if (comma == std::string_view::npos) break;
    pos = comma + 1;
  }
  return false;
}

} // namespace tellus
