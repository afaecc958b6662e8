#include <tellus/cache/TilePath.hpp>

#include <charconv>
#include <cstdio>

namespace tellus {

std::uint64_t stableHash64(std::string_view bytes) noexcept {
  std::uint64_t h = 0xcbf29ce484222325ULL;
  for (const char c : bytes) {
    h ^= static_cast<unsigned char>(c);
    h *= 0x100000001b3ULL;
  }
  return h;
}

namespace {

bool keepsAsIs(unsigned char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
         c == '-' || c == '.';
}

void appendHex(std::string& out, std::uint64_t value, int digits) {
  static constexpr char kHex[] = "0123456789abcdef";
  for (int i = digits - 1; i >= 0; --i) {
    out.push_back(kHex[(value >> (4 * i)) & 0xF]);
  }
}

// Parses a non-negative decimal without sign or leading zeros (World Wind paths are unpadded).
// Digits only: from_chars alone would take "-0" (and "-00") as 0.
std::optional<std::int64_t> parseIndex(std::string_view s) {
  if (s.empty() || s[0] < '0' || s[0] > '9' || (s.size() > 1 && s[0] == '0')) return std::nullopt;
  std::int64_t v = 0;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc{} || ptr != s.data() + s.size() || v < 0) return std::nullopt;
  return v;
}

} // namespace

std::string encodeNameComponent(std::string_view name) {
  if (name.empty()) return "%"; // no other name encodes to a lone '%'
  std::string out;
  out.reserve(name.size());
  for (std::size_t i = 0; i < name.size(); ++i) {
    const auto c = static_cast<unsigned char>(name[i]);
    if (keepsAsIs(c) && !(i == 0 && c == '.')) {
      out.push_back(static_cast<char>(c));
    } else {
      out.push_back('%');
      appendHex(out, c, 2);
    }
  }
  if (out.size() > kMaxNameComponent) {
    // Cut without splitting an escape, then make it unique again with a hash of the whole name.
    std::size_t cut = kMaxNameComponent - 17;
    while (cut > 0 && (out[cut - 1] == '%' || (cut > 1 && out[cut - 2] == '%')))
      --cut;
    out.resize(cut);
    out.push_back('~');
    appendHex(out, stableHash64(name), 16);
  }
  return out;
}

std::string tileRelativePath(const TileKey& key, std::string_view extension) {
  std::string out = std::to_string(key.level);
  out += '/';
  out += std::to_string(key.row);
  out += '/';
  out += std::to_string(key.row);
  out += '_';
  out += std::to_string(key.col);
  out += '.';
  out += extension;
  return out;
}

std::optional<TileKey> parseTileRelativePath(std::string_view path, std::string* extension) {
  const auto s1 = path.find('/');
  if (s1 == std::string_view::npos) return std::nullopt;
  const auto s2 = path.find('/', s1 + 1);
  if (s2 == std::string_view::npos) return std::nullopt;
  const std::string_view levelStr = path.substr(0, s1);
  const std::string_view rowDir = path.substr(s1 + 1, s2 - s1 - 1);
  const std::string_view file = path.substr(s2 + 1);
  const auto underscore = file.find('_');
  const auto dot = file.find('.', underscore == std::string_view::npos ? 0 : underscore);
  if (underscore == std::string_view::npos || dot == std::string_view::npos) return std::nullopt;
  const std::string_view ext = file.substr(dot + 1);
  if (ext.empty() || ext.find('/') != std::string_view::npos) return std::nullopt;
  const auto level = parseIndex(levelStr);
  const auto row = parseIndex(rowDir);
  const auto row2 = parseIndex(file.substr(0, underscore));
  const auto col = parseIndex(file.substr(underscore + 1, dot - underscore - 1));
  if (!level || !row || !row2 || !col || *row != *row2 || *level > kMaxLevel) return std::nullopt;
  if (extension) *extension = std::string(ext);
  return TileKey{static_cast<std::int32_t>(*level), *row, *col};
}

} // namespace tellus
