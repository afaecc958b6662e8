#include "S3Keys.hpp"

#include <tellus/cache/TilePath.hpp>

#include <cstdio>
#include <ctime>

namespace tellus::s3 {

namespace {

constexpr std::string_view kDescriptor = "dataset.txt";

std::string xmlUnescape(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] != '&') {
      out += s[i];
      continue;
    }
    static constexpr std::pair<std::string_view, char> kEntities[] = {
        {"&amp;", '&'}, {"&lt;", '<'}, {"&gt;", '>'}, {"&quot;", '"'}, {"&apos;", '\''}};
    bool done = false;
    for (const auto& [name, ch] : kEntities) {
      if (s.substr(i, name.size()) == name) {
        out += ch;
        i += name.size() - 1;
        done = true;
        break;
      }
    }
    if (!done) out += '&';
  }
  return out;
}

/** The text between `<tag>` and `</tag>` from `from` on; advances `from` past it. */
std::optional<std::string_view>
nextField(std::string_view xml, std::string_view tag, std::size_t& from, std::size_t end) {
  const std::string open = "<" + std::string(tag) + ">";
  const std::string close = "</" + std::string(tag) + ">";
  const auto a = xml.find(open, from);
  if (a == std::string_view::npos || a >= end) return std::nullopt;
  const auto b = xml.find(close, a);
  if (b == std::string_view::npos || b > end) return std::nullopt;
  from = b + close.size();
  return xml.substr(a + open.size(), b - a - open.size());
}

} // namespace

KeyLayout::KeyLayout(std::string prefix) : root_(prefix.empty() ? "" : prefix + "/") {}

std::string KeyLayout::spread(std::string_view folder, const TileKey& key) {
  const std::string what = std::string(folder) + "/" + std::to_string(key.level) + "/" +
                           std::to_string(key.row) + "/" + std::to_string(key.col);
  char hex[8];
  std::snprintf(hex, sizeof hex, "%04x", static_cast<unsigned>(stableHash64(what) & 0xffffu));
  return hex;
}

std::string KeyLayout::tile(const TileLocation& at) const {
  return root_ + std::string(at.folder) + "/" + spread(at.folder, at.key) + "/" +
         tileRelativePath(at.key, at.extension);
}

std::string KeyLayout::descriptor(std::string_view folder) const {
  return root_ + std::string(folder) + "/" + std::string(kDescriptor);
}

std::string KeyLayout::folder(std::string_view folder) const {
  return folder.empty() ? root_ : root_ + std::string(folder) + "/";
}

std::string KeyLayout::entryPath(std::string_view folder, std::string_view rest) {
  if (rest.size() > 5 && rest[4] == '/') {
    const std::string_view tail = rest.substr(5);
    if (const auto key = parseTileRelativePath(tail);
        key && spread(folder, *key) == rest.substr(0, 4))
      return std::string(tail);
  }
  return std::string(rest);
}

std::string KeyLayout::keyOfEntry(std::string_view folder, std::string_view path) const {
  if (path != kDescriptor) {
    if (const auto key = parseTileRelativePath(path))
      return root_ + std::string(folder) + "/" + spread(folder, *key) + "/" + std::string(path);
  }
  return root_ + std::string(folder) + "/" + std::string(path);
}

UnixMillis parseIsoMillis(std::string_view text) {
  int y = 0, mo = 0, d = 0, h = 0, mi = 0, s = 0, ms = 0;
  const std::string t(text);
  const int n =
      std::sscanf(t.c_str(), "%4d-%2d-%2dT%2d:%2d:%2d.%3d", &y, &mo, &d, &h, &mi, &s, &ms);
  if (n < 6) return 0;
  std::tm tm{};
  tm.tm_year = y - 1900;
  tm.tm_mon = mo - 1;
  tm.tm_mday = d;
  tm.tm_hour = h;
  tm.tm_min = mi;
  tm.tm_sec = s;
  return static_cast<UnixMillis>(::timegm(&tm)) * 1000 + (n == 7 ? ms : 0);
}

std::optional<ListPage> parseListPage(std::string_view xml) {
  if (xml.find("<ListBucketResult") == std::string_view::npos) return std::nullopt;
  ListPage page;
  std::size_t at = 0;
  while (true) {
    const auto a = xml.find("<Contents>", at);
    if (a == std::string_view::npos) break;
    const auto b = xml.find("</Contents>", a);
    if (b == std::string_view::npos) return std::nullopt;
    std::size_t f = a;
    ListedObject o;
    if (const auto k = nextField(xml, "Key", f, b)) o.key = xmlUnescape(*k);
    f = a;
    if (const auto sz = nextField(xml, "Size", f, b)) o.size = std::stoll(std::string(*sz));
    f = a;
    if (const auto m = nextField(xml, "LastModified", f, b)) o.modified = parseIsoMillis(*m);
    page.objects.push_back(std::move(o));
    at = b;
  }
  at = 0;
  while (true) {
    const auto a = xml.find("<CommonPrefixes>", at);
    if (a == std::string_view::npos) break;
    const auto b = xml.find("</CommonPrefixes>", a);
    if (b == std::string_view::npos) return std::nullopt;
    std::size_t f = a;
    if (const auto p = nextField(xml, "Prefix", f, b))
      page.commonPrefixes.push_back(xmlUnescape(*p));
    at = b;
  }
  std::size_t f = 0;
  const auto truncated = nextField(xml, "IsTruncated", f, xml.size());
  f = 0;
  const auto token = nextField(xml, "NextContinuationToken", f, xml.size());
  if (truncated && *truncated == "true" && token) page.nextToken = xmlUnescape(*token);
  return page;
}

} // namespace tellus::s3
