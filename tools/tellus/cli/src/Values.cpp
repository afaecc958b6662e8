#include <tellus/cli/Values.hpp>
#include <tellus/config/Config.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace tellus::cli {

std::optional<std::pair<int, int>> parseLevels(std::string_view s) {
  int a = 0;
  int b = 0;
  const auto dash = s.find('-');
  const std::string_view first = s.substr(0, dash);
  auto r1 = std::from_chars(first.data(), first.data() + first.size(), a);
  if (r1.ec != std::errc{} || r1.ptr != first.data() + first.size()) return std::nullopt;
  if (dash == std::string_view::npos) return std::pair{a, a};
  const std::string_view second = s.substr(dash + 1);
  auto r2 = std::from_chars(second.data(), second.data() + second.size(), b);
  if (r2.ec != std::errc{} || r2.ptr != second.data() + second.size() || b < a || a < 0)
    return std::nullopt;
  return std::pair{a, b};
}

std::optional<Sector> parseBbox(const std::string& s) {
  double v[4];
  const char* p = s.c_str();
  for (int i = 0; i < 4; ++i) {
    char* end = nullptr;
    v[i] = std::strtod(p, &end);
    if (end == p || !std::isfinite(v[i])) return std::nullopt;
    p = end;
    if (i < 3) {
      if (*p != ',') return std::nullopt;
      ++p;
    }
  }
  if (*p != '\0') return std::nullopt;
  return Sector{v[0], v[1], v[2], v[3]};
}

std::optional<std::chrono::milliseconds> parseDuration(std::string_view s) {
  // The configuration's reader, less its bare "0" and its milliseconds (not options' units).
  if (s.empty() || s.back() < 'a' || s.ends_with("ms")) return std::nullopt;
  return tellus::parseDurationText(s);
}

std::optional<std::vector<double>>
parseNumbers(const std::string& s, std::size_t minCount, std::size_t maxCount) {
  std::vector<double> v;
  std::size_t pos = 0;
  while (pos <= s.size()) {
    const auto comma = std::min(s.find(',', pos), s.size());
    const std::string part = s.substr(pos, comma - pos);
    double d = 0.0;
    auto [ptr, ec] = std::from_chars(part.data(), part.data() + part.size(), d);
    if (part.empty() || ec != std::errc{} || ptr != part.data() + part.size() || !std::isfinite(d))
      return std::nullopt;
    v.push_back(d);
    pos = comma + 1;
  }
  if (v.size() < minCount || v.size() > maxCount) return std::nullopt;
  return v;
}

std::optional<std::pair<int, int>> parseSize(const std::string& size) {
  const auto x = size.find('x');
  if (x == std::string::npos) return std::nullopt;
  int w = 0, h = 0;
  auto r1 = std::from_chars(size.data(), size.data() + x, w);
  auto r2 = std::from_chars(size.data() + x + 1, size.data() + size.size(), h);
  if (r1.ec != std::errc{} || r1.ptr != size.data() + x || r2.ec != std::errc{} ||
      r2.ptr != size.data() + size.size() || w < 1 || h < 1 || w > 16384 || h > 16384)
    return std::nullopt;
  return std::pair{w, h};
}

std::string humanBytes(std::int64_t b) {
  char buf[32];
  if (b >= 1LL << 30)
    std::snprintf(buf, sizeof buf, "%.1f GiB", static_cast<double>(b) / (1LL << 30));
  else if (b >= 1LL << 20)
    std::snprintf(buf, sizeof buf, "%.1f MiB", static_cast<double>(b) / (1LL << 20));
  else if (b >= 1LL << 10)
    std::snprintf(buf, sizeof buf, "%.1f KiB", static_cast<double>(b) / (1LL << 10));
  else
    std::snprintf(buf, sizeof buf, "%lld B", static_cast<long long>(b));
  return buf;
}

} // namespace tellus::cli
