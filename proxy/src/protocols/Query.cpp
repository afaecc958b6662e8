#include <tellus/proxy/Query.hpp>

#include <cstdint>

namespace tellus {

namespace {

char toLowerAscii(char c) noexcept {
  return (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c;
}

bool equalsIgnoreCase(std::string_view a, std::string_view b) noexcept {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (toLowerAscii(a[i]) != toLowerAscii(b[i])) return false;
  }
  return true;
}

int hexValue(char c) noexcept {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// A key is named in messages only when it is short and printable ASCII; otherwise by position.
std::string describeParam(std::string_view rawKey, std::size_t index) {
  bool printable = !rawKey.empty() && rawKey.size() <= 32;
  for (const char c : rawKey) {
    const auto u = static_cast<unsigned char>(c);
    const bool ok = (u >= 'a' && u <= 'z') || (u >= 'A' && u <= 'Z') || (u >= '0' && u <= '9') ||
                    u == '_' || u == '-' || u == '.';
    if (!ok) printable = false;
  }
  if (printable) return "parameter '" + std::string(rawKey) + "'";
  return "parameter #" + std::to_string(index);
}

// Length of the valid UTF-8 sequence XML accepts at s[i], or 0.
std::size_t validUtf8Length(std::string_view s, std::size_t i) noexcept {
  const auto b0 = static_cast<unsigned char>(s[i]);
  std::size_t len = 0;
  std::uint32_t cp = 0;
  std::uint32_t minCp = 0;
  if (b0 < 0x80) return 1;
  if (b0 >= 0xC2 && b0 <= 0xDF) {
    len = 2;
    cp = b0 & 0x1Fu;
    minCp = 0x80;
  } else if (b0 >= 0xE0 && b0 <= 0xEF) {
    len = 3;
    cp = b0 & 0x0Fu;
    minCp = 0x800;
  } else if (b0 >= 0xF0 && b0 <= 0xF4) {
    len = 4;
    cp = b0 & 0x07u;
    minCp = 0x10000;
  } else {
    return 0;
  }
  if (i + len > s.size()) return 0;
  for (std::size_t k = 1; k < len; ++k) {
    const auto b = static_cast<unsigned char>(s[i + k]);
    if ((b & 0xC0u) != 0x80u) return 0;
    cp = (cp << 6) | (b & 0x3Fu);
  }
  if (cp < minCp || cp > 0x10FFFF) return 0;  // overlong or beyond Unicode
  if (cp >= 0xD800 && cp <= 0xDFFF) return 0; // surrogates
  if (cp == 0xFFFE || cp == 0xFFFF) return 0; // not XML characters
  return len;
}

} // namespace

const QueryParams::Entry* QueryParams::find(std::string_view key) const noexcept {
  for (const Entry& e : entries_) {
    if (equalsIgnoreCase(e.key, key)) return &e;
  }
  return nullptr;
}

std::optional<std::string_view> QueryParams::get(std::string_view lowerKey) const noexcept {
  const Entry* e = find(lowerKey);
  if (e == nullptr) return std::nullopt;
  return std::string_view(e->value);
}

bool QueryParams::isDuplicated(std::string_view lowerKey) const noexcept {
  const Entry* e = find(lowerKey);
  return e != nullptr && e->occurrences > 1;
}

bool QueryParams::isConflicting(std::string_view lowerKey) const noexcept {
  const Entry* e = find(lowerKey);
  return e != nullptr && e->conflicting;
}

bool QueryParams::hasDuplicates() const noexcept {
  for (const Entry& e : entries_) {
    if (e.occurrences > 1) return true;
  }
  return false;
}

void QueryParams::add(std::string_view key, std::string_view value) {
  take(std::string(key), std::string(value));
}

void QueryParams::take(std::string&& key, std::string&& value) {
  for (Entry& e : entries_) {
    if (equalsIgnoreCase(e.key, key)) {
      ++e.occurrences;
      if (value != e.value) e.conflicting = true;
      return;
    }
  }
  for (char& c : key)
    c = toLowerAscii(c);
  if (entries_.empty()) entries_.reserve(16); // a GetMap has about a dozen parameters
  entries_.push_back(Entry{std::move(key), std::move(value), 1});
}

std::expected<std::string, std::string> percentDecode(std::string_view text, bool plusIsSpace) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\0') return std::unexpected("NUL byte at offset " + std::to_string(i));
    if (c == '+' && plusIsSpace) {
      out.push_back(' ');
    } else if (c == '%') {
      if (i + 2 >= text.size()) {
        return std::unexpected("truncated percent escape at offset " + std::to_string(i));
      }
      const int hi = hexValue(text[i + 1]);
      const int lo = hexValue(text[i + 2]);
      if (hi < 0 || lo < 0) {
        return std::unexpected("invalid percent escape at offset " + std::to_string(i));
      }
      const int byte = hi * 16 + lo;
      if (byte == 0) return std::unexpected("encoded NUL (%00) at offset " + std::to_string(i));
      out.push_back(static_cast<char>(static_cast<unsigned char>(byte)));
      i += 2;
    } else {
      out.push_back(c);
    }
  }
  return out;
}

std::expected<QueryParams, std::string>
parseQuery(std::string_view query, std::size_t maxParamBytes, std::size_t maxQueryBytes) {
  if (query.size() > maxQueryBytes) {
    return std::unexpected("query string longer than " + std::to_string(maxQueryBytes) + " bytes");
  }
  if (!query.empty() && query.front() == '?') query.remove_prefix(1);
  QueryParams params;
  std::size_t count = 0;
  std::size_t offset = 0;
  while (offset <= query.size()) {
    const std::size_t amp = query.find('&', offset);
    const std::size_t end = amp == std::string_view::npos ? query.size() : amp;
    const std::string_view segment = query.substr(offset, end - offset);
    offset = end + 1;
    if (segment.empty()) continue;
    if (++count > kMaxQueryParams) {
      return std::unexpected("more than " + std::to_string(kMaxQueryParams) + " query parameters");
    }
    const std::size_t eq = segment.find('=');
    const std::string_view rawKey = segment.substr(0, eq);
    const std::string_view rawValue =
        eq == std::string_view::npos ? std::string_view{} : segment.substr(eq + 1);
    auto key = percentDecode(rawKey);
    if (!key) return std::unexpected(describeParam({}, count) + " name: " + key.error());
    auto value = percentDecode(rawValue);
    if (!value) return std::unexpected(describeParam(*key, count) + " value: " + value.error());
    if (key->size() > maxParamBytes) {
      return std::unexpected(describeParam({}, count) + " name is longer than " +
                             std::to_string(maxParamBytes) + " bytes");
    }
    if (value->size() > maxParamBytes) {
      return std::unexpected(describeParam(*key, count) + " value is longer than " +
                             std::to_string(maxParamBytes) + " bytes");
    }
    if (key->empty()) continue;
    params.take(std::move(*key), std::move(*value));
  }
  return params;
}

std::string xmlEscape(std::string_view text) {
  std::string out;
  out.reserve(text.size() + text.size() / 8);
  std::size_t i = 0;
  while (i < text.size()) {
    const char c = text[i];
    switch (c) {
    case '&':
      out += "&amp;";
      break;
    case '<':
      out += "&lt;";
      break;
    case '>':
      out += "&gt;";
      break;
    case '"':
      out += "&quot;";
      break;
    case '\'':
      out += "&apos;";
      break;
    case '\r':
      out += "&#13;";
      break;
    case '\t':
    case '\n':
      out.push_back(c);
      break;
    default: {
      const auto u = static_cast<unsigned char>(c);
      if (u < 0x20 || u == 0x7F) {
        out.push_back('?');
        break;
      }
      const std::size_t len = validUtf8Length(text, i);
      if (len == 0) {
        out.push_back('?');
        break;
      }
      out.append(text.substr(i, len));
      i += len;
      continue;
    }
    }
    ++i;
  }
  return out;
}

} // namespace tellus
