// The shared YAML readers of the configuration parser (YamlReader.hpp).

#include "YamlReader.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <limits>

namespace tellus::detail::yaml {

std::string describe(const YAML::Node& n) {
  switch (n.Type()) {
  case YAML::NodeType::Map:
    return "a mapping";
  case YAML::NodeType::Sequence:
    return "a list";
  case YAML::NodeType::Scalar:
    return "'" + n.Scalar() + "'";
  case YAML::NodeType::Null:
  case YAML::NodeType::Undefined:
    break;
  }
  return "nothing";
}

std::string join(std::initializer_list<std::string_view> names) {
  std::string s;
  for (const auto n : names)
    s += (s.empty() ? "" : ", ") + std::string(n);
  return s;
}

std::string childPath(const std::string& parent, std::string_view key) {
  return parent.empty() ? std::string(key) : parent + "." + std::string(key);
}

std::string indexPath(const std::string& parent, std::size_t i) {
  return parent + "[" + std::to_string(i) + "]";
}

Map::Map(Reader& r,
         const YAML::Node& node,
         std::string path,
         const YAML::Mark& where,
         std::initializer_list<std::string_view> allowed)
    : r_(r), path_(std::move(path)), mark_(node.IsNull() ? where : node.Mark()) {
  r_.remember(path_, mark_);
  if (node.IsNull()) return;
  if (!node.IsMap())
    r_.fail(mark_, path_, "expected a mapping (" + join(allowed) + "), got " + describe(node));
  for (const auto& kv : node) { // yaml-cpp iterators yield pairs by value: copy the nodes
    const YAML::Node k = kv.first;
    if (!k.IsScalar()) r_.fail(k.Mark(), path_, "a key must be a plain name, got " + describe(k));
    const std::string& name = k.Scalar();
    if (std::find(allowed.begin(), allowed.end(), name) == allowed.end()) {
      const std::string close = detail::closestKey(
          name, std::span<const std::string_view>(allowed.begin(), allowed.size()));
      r_.fail(k.Mark(),
              childPath(path_, name),
              "unknown key '" + name + "' " +
                  (close.empty() ? "(expected one of: " + join(allowed) + ")"
                                 : "(did you mean '" + close + "'?)"));
    }
    for (const auto& e : entries_) {
      if (e.key == name)
        r_.fail(k.Mark(),
                childPath(path_, name),
                "key '" + name + "' is given twice (first on line " +
                    std::to_string(e.keyMark.line + 1) + ")");
    }
    entries_.push_back({name, k.Mark(), kv.second});
  }
}

std::optional<YAML::Node> Map::get(std::string_view key) const {
  const Entry* e = find(key);
  if (!e) return std::nullopt;
  if (e->value.IsNull()) {
    r_.remember(path(key), e->keyMark);
    return std::nullopt;
  }
  r_.remember(path(key), e->value.Mark());
  return e->value;
}

YAML::Node Map::need(std::string_view key) const {
  if (auto v = get(key)) return *v;
  if (const Entry* e = find(key))
    r_.fail(e->keyMark, path(key), "'" + std::string(key) + "' needs a value");
  r_.fail(mark_, path(key), "required key '" + std::string(key) + "' is missing");
}

std::string
text(Reader& r, const YAML::Node& n, const std::string& path, std::string_view expected) {
  if (!n.IsScalar())
    r.fail(n.Mark(), path, "expected " + std::string(expected) + ", got " + describe(n));
  return n.Scalar();
}

std::int64_t integer(
    Reader& r, const YAML::Node& n, const std::string& path, std::int64_t min, std::int64_t max) {
  std::string s = text(r, n, path, "a whole number");
  std::string_view v = s;
  if (v.starts_with('+')) v.remove_prefix(1);
  std::int64_t x = 0;
  const auto res = std::from_chars(v.data(), v.data() + v.size(), x);
  const bool digitsOnly = !v.empty() && std::all_of(v.begin() + (v.front() == '-' ? 1 : 0),
                                                    v.end(),
                                                    [](char c) { return c >= '0' && c <= '9'; });
  if (!digitsOnly || (res.ec != std::errc{} && res.ec != std::errc::result_out_of_range) ||
      res.ptr != v.data() + v.size())
    r.fail(n.Mark(), path, "expected a whole number, got '" + s + "'");
  if (res.ec == std::errc::result_out_of_range || x < min || x > max)
    r.fail(n.Mark(),
           path,
           "'" + s + "' is out of range [" + std::to_string(min) + ", " + std::to_string(max) +
               "]");
  return x;
}

std::int32_t int32(Reader& r, const YAML::Node& n, const std::string& path) {
  return static_cast<std::int32_t>(integer(r,
                                           n,
                                           path,
                                           std::numeric_limits<std::int32_t>::min(),
                                           std::numeric_limits<std::int32_t>::max()));
}

double number(Reader& r, const YAML::Node& n, const std::string& path, bool allowNonFinite) {
  const std::string s = text(r, n, path, "a number");
  std::string lower;
  for (char c : s)
    lower += (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c;
  double x = 0.0;
  if (lower == ".nan") {
    x = std::numeric_limits<double>::quiet_NaN();
  } else if (lower == ".inf" || lower == "+.inf") {
    x = std::numeric_limits<double>::infinity();
  } else if (lower == "-.inf") {
    x = -std::numeric_limits<double>::infinity();
  } else {
    std::string_view v = s;
    if (v.starts_with('+')) v.remove_prefix(1);
    const auto res = std::from_chars(v.data(), v.data() + v.size(), x);
    if (v.empty() || res.ec == std::errc::invalid_argument || res.ptr != v.data() + v.size())
      r.fail(n.Mark(), path, "expected a number, got '" + s + "'");
    if (res.ec == std::errc::result_out_of_range)
      r.fail(n.Mark(), path, "'" + s + "' is out of the range of a double");
  }
  if (!allowNonFinite && !std::isfinite(x))
    r.fail(n.Mark(), path, "must be a finite number, got '" + s + "'");
  return x;
}

bool boolean(Reader& r, const YAML::Node& n, const std::string& path) {
  const std::string s = text(r, n, path, "true or false");
  std::string lower;
  for (char c : s)
    lower += (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c;
  if (lower == "true" || lower == "yes" || lower == "on") return true;
  if (lower == "false" || lower == "no" || lower == "off") return false;
  r.fail(n.Mark(), path, "expected true or false, got '" + s + "'");
}

std::chrono::milliseconds duration(Reader& r, const YAML::Node& n, const std::string& path) {
  const std::string s = text(r, n, path, "a duration (e.g. 30s)");
  const auto d = parseDurationText(s);
  if (!d)
    r.fail(n.Mark(),
           path,
           "'" + s +
               "' is not a duration (a whole number and ms, s, m, h or d: 500ms, 30s, 5m, "
               "12h, 30d)");
  return *d;
}

std::uint64_t size(Reader& r, const YAML::Node& n, const std::string& path) {
  const std::string s = text(r, n, path, "a size (e.g. 512MiB)");
  const auto v = parseSizeText(s);
  if (!v)
    r.fail(n.Mark(),
           path,
           "'" + s +
               "' is not a size (bytes, or with KiB, MiB, GiB, TiB, KB, MB, GB, TB: "
               "512MiB, 10GiB)");
  return *v;
}

std::size_t choice(Reader& r,
                   const YAML::Node& n,
                   const std::string& path,
                   std::initializer_list<std::string_view> names) {
  const std::string s = text(r, n, path, "one of " + join(names));
  const auto it = std::find(names.begin(), names.end(), s);
  if (it == names.end()) r.fail(n.Mark(), path, "'" + s + "' is not one of " + join(names));
  return static_cast<std::size_t>(it - names.begin());
}

std::vector<YAML::Node> list(Reader& r, const YAML::Node& n, const std::string& path) {
  std::vector<YAML::Node> v;
  if (n.IsNull()) return v;
  if (!n.IsSequence()) r.fail(n.Mark(), path, "expected a list, got " + describe(n));
  for (const auto& e : n)
    v.push_back(e);
  return v;
}

fs::path resolvePath(const std::string& text, const fs::path& base) {
  fs::path p = text;
  if (text == "~" || text.starts_with("~/")) {
    if (const char* h = std::getenv("HOME"); h && *h)
      p = fs::path(h) / (text.size() > 2 ? text.substr(2) : std::string());
  }
  if (p.is_relative()) p = base / p;
  return p.lexically_normal();
}

} // namespace tellus::detail::yaml
