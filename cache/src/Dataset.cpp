#include <tellus/cache/Dataset.hpp>
#include <tellus/cache/TilePath.hpp>

#include <charconv>
#include <cstdio>
#include <cstdlib>
#include <map>

namespace tellus {

namespace {

std::string formatDouble(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

// The fields that make two datasets' tiles differ, in a fixed canonical order.
std::string variantKey(const DatasetSpec& s) {
  const GridSpec& g = s.grid;
  std::string k;
  for (double v :
       {g.sector.west, g.sector.south, g.sector.east, g.sector.north, g.levelZeroDeltaDeg}) {
    k += formatDouble(v);
    k += ',';
  }
  k += std::to_string(g.tileWidth) + ',' + std::to_string(g.tileHeight) + ',';
  k += s.mimeType + '\n' + s.style + '\n' + s.time;
  // The body enters only when it is not the Earth, so that every cache written before bodies
  // existed keeps its folders (issue 26).
  if (!isEarthBody(s.body)) k += "\nbody=" + s.body;
  return k;
}

// Values are single lines: escape backslash and newline.
std::string escapeValue(std::string_view v) {
  std::string out;
  for (const char c : v) {
    if (c == '\\')
      out += "\\\\";
    else if (c == '\n')
      out += "\\n";
    else if (c == '\r')
      out += "\\r";
    else
      out.push_back(c);
  }
  return out;
}

std::string unescapeValue(std::string_view v) {
  std::string out;
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (v[i] == '\\' && i + 1 < v.size()) {
      ++i;
      out.push_back(v[i] == 'n' ? '\n' : v[i] == 'r' ? '\r' : v[i]);
    } else {
      out.push_back(v[i]);
    }
  }
  return out;
}

std::optional<double> toDouble(const std::string& s) {
  if (s.empty()) return std::nullopt;
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (end != s.c_str() + s.size()) return std::nullopt;
  return v;
}

std::optional<std::int32_t> toInt(const std::string& s) {
  std::int32_t v = 0;
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc{} || p != s.data() + s.size()) return std::nullopt;
  return v;
}

} // namespace

bool isEarthBody(std::string_view body) {
  return body == kEarthBody;
}

std::string datasetVariant(const DatasetSpec& spec) {
  char buf[17];
  std::snprintf(
      buf, sizeof buf, "%016llx", static_cast<unsigned long long>(stableHash64(variantKey(spec))));
  return std::string(buf, 8);
}

std::string datasetFolder(const DatasetSpec& spec) {
  return encodeNameComponent(spec.server) + '/' + encodeNameComponent(spec.name) + '-' +
         datasetVariant(spec);
}

std::string serializeDatasetSpec(const DatasetSpec& s) {
  const GridSpec& g = s.grid;
  std::string out = "# tellus dataset descriptor (used to rebuild the index from the tree)\n";
  auto line = [&out](std::string_view k, std::string_view v) {
    out += k;
    out += '=';
    out += escapeValue(v);
    out += '\n';
  };
  line("server", s.server);
  line("name", s.name);
  line("west", formatDouble(g.sector.west));
  line("south", formatDouble(g.sector.south));
  line("east", formatDouble(g.sector.east));
  line("north", formatDouble(g.sector.north));
  line("level_zero_delta", formatDouble(g.levelZeroDeltaDeg));
  line("tile_width", std::to_string(g.tileWidth));
  line("tile_height", std::to_string(g.tileHeight));
  line("num_levels", std::to_string(g.numLevels));
  line("mime_type", s.mimeType);
  line("extension", s.extension);
  line("style", s.style);
  line("time", s.time);
  line("pinned", s.pinned ? "1" : "0");
  if (!isEarthBody(s.body)) line("body", s.body); // absent = the Earth (descriptors before bodies)
  return out;
}

std::optional<DatasetSpec> parseDatasetSpec(std::string_view text) {
  std::map<std::string, std::string, std::less<>> kv;
  std::size_t pos = 0;
  while (pos < text.size()) {
    auto end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view lineText = text.substr(pos, end - pos);
    pos = end + 1;
    if (lineText.empty() || lineText[0] == '#') continue;
    const auto eq = lineText.find('=');
    if (eq == std::string_view::npos) return std::nullopt;
    kv[std::string(lineText.substr(0, eq))] = unescapeValue(lineText.substr(eq + 1));
  }
  auto get = [&kv](const char* k) -> const std::string* {
    const auto it = kv.find(k);
    return it == kv.end() ? nullptr : &it->second;
  };
  for (const char* k : {"server",
                        "name",
                        "west",
                        "south",
                        "east",
                        "north",
                        "level_zero_delta",
                        "tile_width",
                        "tile_height",
                        "num_levels",
                        "mime_type",
                        "extension"}) {
    if (!get(k)) return std::nullopt;
  }
  DatasetSpec s;
  s.server = *get("server");
  s.name = *get("name");
  const auto w = toDouble(*get("west"));
  const auto so = toDouble(*get("south"));
  const auto e = toDouble(*get("east"));
  const auto n = toDouble(*get("north"));
  const auto d = toDouble(*get("level_zero_delta"));
  const auto tw = toInt(*get("tile_width"));
  const auto th = toInt(*get("tile_height"));
  const auto nl = toInt(*get("num_levels"));
  if (!w || !so || !e || !n || !d || !tw || !th || !nl) return std::nullopt;
  s.grid = GridSpec{Sector{*w, *so, *e, *n}, *d, *tw, *th, *nl};
  s.mimeType = *get("mime_type");
  s.extension = *get("extension");
  if (const auto* st = get("style")) s.style = *st;
  if (const auto* t = get("time")) s.time = *t;
  if (const auto* p = get("pinned")) s.pinned = *p == "1";
  if (const auto* b = get("body")) {
    if (b->empty()) return std::nullopt;
    s.body = *b;
  }
  return s;
}

} // namespace tellus
