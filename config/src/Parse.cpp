// YAML -> Config. yaml-cpp stays inside this file; its exceptions and ours (Failure) never leave
// parseDocument(): every problem becomes a ConfigError with the file, the line, the column and
// the dotted key.

#include "ConfigInternal.hpp"
#include "EmbeddedDefaultYaml.hpp"

#include <yaml-cpp/depthguard.h>
#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

namespace tellus {

namespace {

namespace fs = std::filesystem;

constexpr std::string_view kEmbeddedName = "<embedded default.yaml>";
constexpr std::uintmax_t kMaxFileBytes = 16U << 20;

/** Thrown inside this file only; caught in parseDocument. */
struct Failure {
  ConfigError error;
};

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

/** Where the values came from: the file's name and the mark of every key path read so far. */
class Reader {
public:
  explicit Reader(std::string file) : file_(std::move(file)) {}

  [[noreturn]] void fail(const YAML::Mark& m, std::string key, std::string message) const {
    ConfigError e;
    e.file = file_;
    if (!m.is_null()) {
      e.line = m.line + 1;
      e.column = m.column + 1;
    }
    e.key = std::move(key);
    e.message = std::move(message);
    throw Failure{std::move(e)};
  }

  void remember(const std::string& key, const YAML::Mark& m) { marks_.insert_or_assign(key, m); }

  /** The mark of the key, or of its nearest parent that was read. */
  YAML::Mark markFor(std::string key) const {
    for (;;) {
      if (const auto it = marks_.find(key); it != marks_.end()) return it->second;
      if (key.empty()) return YAML::Mark::null_mark();
      const auto cut = key.find_last_of(".[");
      key = cut == std::string::npos ? std::string() : key.substr(0, cut);
    }
  }

private:
  std::string file_;
  std::map<std::string, YAML::Mark> marks_;
};

std::string childPath(const std::string& parent, std::string_view key) {
  return parent.empty() ? std::string(key) : parent + "." + std::string(key);
}

std::string indexPath(const std::string& parent, std::size_t i) {
  return parent + "[" + std::to_string(i) + "]";
}

/** A mapping with a fixed set of keys: unknown and repeated keys are errors. */
class Map {
public:
  Map(Reader& r,
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

  const std::string& path() const noexcept { return path_; }
  const YAML::Mark& mark() const noexcept { return mark_; }
  std::string path(std::string_view key) const { return childPath(path_, key); }

  bool has(std::string_view key) const { return find(key) != nullptr; }

  /** The value of a key that is present and not null; remembers its mark. */
  std::optional<YAML::Node> get(std::string_view key) const {
    const Entry* e = find(key);
    if (!e) return std::nullopt;
    if (e->value.IsNull()) {
      r_.remember(path(key), e->keyMark);
      return std::nullopt;
    }
    r_.remember(path(key), e->value.Mark());
    return e->value;
  }

  /** The value of a required key. */
  YAML::Node need(std::string_view key) const {
    if (auto v = get(key)) return *v;
    if (const Entry* e = find(key))
      r_.fail(e->keyMark, path(key), "'" + std::string(key) + "' needs a value");
    r_.fail(mark_, path(key), "required key '" + std::string(key) + "' is missing");
  }

  /** Where a key is written (the key itself), for errors about keys that do not apply. */
  YAML::Mark keyMark(std::string_view key) const {
    const Entry* e = find(key);
    return e ? e->keyMark : mark_;
  }

  /** The value of a key for nested mappings: the node (may be null) and where to point. */
  std::pair<YAML::Node, YAML::Mark> child(std::string_view key) const {
    const Entry* e = find(key);
    if (!e) return {YAML::Node(YAML::NodeType::Null), mark_};
    return {e->value, e->keyMark};
  }

private:
  struct Entry {
    std::string key;
    YAML::Mark keyMark;
    YAML::Node value;
  };
  const Entry* find(std::string_view key) const {
    for (const auto& e : entries_) {
      if (e.key == key) return &e;
    }
    return nullptr;
  }

  Reader& r_;
  std::string path_;
  YAML::Mark mark_;
  std::vector<Entry> entries_;
};

// ---- scalars ------------------------------------------------------------------------------------

std::string text(Reader& r,
                 const YAML::Node& n,
                 const std::string& path,
                 std::string_view expected = "a string") {
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

/** A number; YAML's .nan / .inf are read as such, and rejected unless allowNonFinite. */
double
number(Reader& r, const YAML::Node& n, const std::string& path, bool allowNonFinite = false) {
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

/** The elements of a list (null = none). */
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

// ---- sections -----------------------------------------------------------------------------------

void readServer(Reader& r, const Map& root, ServerSettings& s) {
  const auto [node, where] = root.child("server");
  const Map m(r,
              node,
              root.path("server"),
              where,
              {"listen",
               "public_url",
               "cors",
               "exceptions_http_status",
               "offline_response",
               "offline",
               "threads",
               "log_level",
               "access_log",
               "jpeg_quality",
               "limits"});
  if (auto v = m.get("listen")) {
    auto a = detail::parseListenAddress(text(r, *v, m.path("listen")));
    if (!a) r.fail(v->Mark(), m.path("listen"), a.error());
    s.listenHost = a->first;
    s.listenPort = a->second;
  }
  if (auto v = m.get("public_url")) s.publicUrl = text(r, *v, m.path("public_url"));
  if (auto v = m.get("cors")) s.cors = text(r, *v, m.path("cors"));
  if (auto v = m.get("exceptions_http_status"))
    s.exceptionsHttpStatus = boolean(r, *v, m.path("exceptions_http_status"));
  if (auto v = m.get("offline_response"))
    s.offlineResponse = choice(r, *v, m.path("offline_response"), {"exception", "blank"}) == 0
                            ? OfflineResponse::Exception
                            : OfflineResponse::Blank;
  if (auto v = m.get("offline")) s.offline = boolean(r, *v, m.path("offline"));
  if (auto v = m.get("threads")) s.threads = int32(r, *v, m.path("threads"));
  if (auto v = m.get("log_level"))
    s.logLevel = std::array{"error", "warn", "info", "debug"}[static_cast<std::size_t>(
        choice(r, *v, m.path("log_level"), {"error", "warn", "info", "debug"}))];
  if (auto v = m.get("access_log")) s.accessLog = text(r, *v, m.path("access_log"));
  if (auto v = m.get("jpeg_quality"))
    s.jpegQuality = static_cast<int>(integer(r, *v, m.path("jpeg_quality"), 1, 100));

  const auto [ln, lwhere] = m.child("limits");
  const Map l(r,
              ln,
              m.path("limits"),
              lwhere,
              {"max_connections",
               "max_header_bytes",
               "max_param_bytes",
               "max_width",
               "max_height",
               "request_timeout",
               "keepalive_timeout",
               "requests_per_second",
               "fetches_per_client_per_minute",
               "max_map_pixels",
               "max_tiles_per_map",
               "decoded_tile_cache"});
  ServerLimits& lim = s.limits;
  if (auto v = l.get("max_connections"))
    lim.maxConnections = int32(r, *v, l.path("max_connections"));
  if (auto v = l.get("max_header_bytes"))
    lim.maxHeaderBytes = static_cast<std::size_t>(size(r, *v, l.path("max_header_bytes")));
  if (auto v = l.get("max_param_bytes"))
    lim.maxParamBytes = static_cast<std::size_t>(size(r, *v, l.path("max_param_bytes")));
  if (auto v = l.get("max_width")) lim.maxWidth = int32(r, *v, l.path("max_width"));
  if (auto v = l.get("max_height")) lim.maxHeight = int32(r, *v, l.path("max_height"));
  if (auto v = l.get("request_timeout"))
    lim.requestTimeout = duration(r, *v, l.path("request_timeout"));
  if (auto v = l.get("keepalive_timeout"))
    lim.keepaliveTimeout = duration(r, *v, l.path("keepalive_timeout"));
  if (auto v = l.get("requests_per_second"))
    lim.requestsPerSecond = number(r, *v, l.path("requests_per_second"));
  if (auto v = l.get("fetches_per_client_per_minute"))
    lim.fetchesPerClientPerMinute = number(r, *v, l.path("fetches_per_client_per_minute"));
  if (auto v = l.get("max_map_pixels"))
    lim.maxMapPixels = integer(r, *v, l.path("max_map_pixels"), 1, std::int64_t{1} << 40);
  if (auto v = l.get("decoded_tile_cache"))
    lim.decodedTileCache = size(r, *v, l.path("decoded_tile_cache"));
  if (auto v = l.get("max_tiles_per_map"))
    lim.maxTilesPerMap =
        static_cast<std::int32_t>(integer(r, *v, l.path("max_tiles_per_map"), 1, 1 << 20));
}

void readRenderer(Reader& r, const Map& root, RendererSettings& g) {
  const auto [node, where] = root.child("renderer");
  const Map m(r,
              node,
              root.path("renderer"),
              where,
              {"lod_threshold",
               "mesh_size",
               "fov",
               "texture_budget",
               "upload_per_frame",
               "max_in_flight",
               "max_splits_per_frame",
               "decode_threads",
               "terrain",
               "dome",
               "earth",
               "geoid",
               "layers",
               "overlays_per_pass"});
  if (auto v = m.get("lod_threshold")) g.lodThreshold = number(r, *v, m.path("lod_threshold"));
  if (auto v = m.get("mesh_size")) g.meshSize = int32(r, *v, m.path("mesh_size"));
  if (auto v = m.get("fov")) g.fovDeg = number(r, *v, m.path("fov"));
  if (auto v = m.get("texture_budget")) g.textureBudget = size(r, *v, m.path("texture_budget"));
  if (auto v = m.get("upload_per_frame"))
    g.uploadPerFrame = size(r, *v, m.path("upload_per_frame"));
  if (auto v = m.get("max_in_flight")) g.maxInFlight = int32(r, *v, m.path("max_in_flight"));
  if (auto v = m.get("max_splits_per_frame"))
    g.maxSplitsPerFrame = int32(r, *v, m.path("max_splits_per_frame"));
  if (auto v = m.get("decode_threads")) g.decodeThreads = int32(r, *v, m.path("decode_threads"));
  const auto [tnode, twhere] = m.child("terrain");
  const Map t(
      r,
      tnode,
      m.path("terrain"),
      twhere,
      {"enabled", "layer", "exaggeration", "clearance", "sun", "regional", "min_relief_px"});
  TerrainSettings& ts = g.terrain;
  if (auto v = t.get("enabled")) ts.enabled = boolean(r, *v, t.path("enabled"));
  if (auto v = t.get("layer")) ts.layer = text(r, *v, t.path("layer"));
  if (auto v = t.get("exaggeration")) ts.exaggeration = number(r, *v, t.path("exaggeration"));
  if (auto v = t.get("clearance")) ts.clearanceM = number(r, *v, t.path("clearance"));
  if (auto v = t.get("min_relief_px")) ts.minReliefPx = number(r, *v, t.path("min_relief_px"));
  if (auto v = t.get("sun")) {
    const std::string sp = t.path("sun");
    const auto items = list(r, *v, sp);
    if (items.size() != 2)
      r.fail(v->Mark(), sp, "expected 2 numbers [lat, lon], got " + std::to_string(items.size()));
    ts.sun = std::array<double, 2>{number(r, items[0], indexPath(sp, 0)),
                                   number(r, items[1], indexPath(sp, 1))};
  }
  if (auto v = t.get("regional")) {
    const std::string rp = t.path("regional");
    const auto items = list(r, *v, rp);
    for (std::size_t i = 0; i < items.size(); ++i)
      ts.regional.push_back(text(r, items[i], indexPath(rp, i)));
  }
  if (auto v = m.get("layers")) {
    const std::string lp = m.path("layers");
    const auto items = list(r, *v, lp);
    for (std::size_t i = 0; i < items.size(); ++i) {
      const std::string ip = indexPath(lp, i);
      const Map e(r,
                  items[i],
                  ip,
                  items[i].Mark(),
                  {"layer", "regional", "opacity", "visible", "max_level", "time"});
      RenderLayerSettings l;
      if (auto x = e.get("layer"))
        l.layer = text(r, *x, e.path("layer"));
      else
        r.fail(items[i].Mark(), ip, "needs 'layer' (an imagery layer's name)");
      if (auto x = e.get("regional")) {
        const std::string rp = e.path("regional");
        const auto names = list(r, *x, rp);
        for (std::size_t j = 0; j < names.size(); ++j)
          l.regional.push_back(text(r, names[j], indexPath(rp, j)));
      }
      if (auto x = e.get("opacity")) l.opacity = number(r, *x, e.path("opacity"));
      if (auto x = e.get("visible")) l.visible = boolean(r, *x, e.path("visible"));
      if (auto x = e.get("max_level")) l.maxLevel = int32(r, *x, e.path("max_level"));
      if (auto x = e.get("time")) l.time = text(r, *x, e.path("time"));
      g.layers.push_back(std::move(l));
    }
  }
  const auto [dnode, dwhere] = m.child("dome");
  const Map d(r,
              dnode,
              m.path("dome"),
              dwhere,
              {"enabled", "fov", "tilt", "face_scale", "method", "direct_max_error"});
  if (auto v = d.get("enabled")) g.dome.enabled = boolean(r, *v, d.path("enabled"));
  if (auto v = d.get("fov")) g.dome.fovDeg = number(r, *v, d.path("fov"));
  if (auto v = d.get("tilt")) g.dome.tiltDeg = number(r, *v, d.path("tilt"));
  if (auto v = d.get("face_scale")) g.dome.faceScale = number(r, *v, d.path("face_scale"));
  if (auto v = d.get("method"))
    g.dome.method = choice(r, *v, d.path("method"), {"direct", "cube"}) == 0
                        ? DomeSettings::Method::Direct
                        : DomeSettings::Method::Cube;
  if (auto v = d.get("direct_max_error"))
    g.dome.directMaxErrorPx = number(r, *v, d.path("direct_max_error"));
  if (auto v = m.get("earth"))
    g.earth = choice(r, *v, m.path("earth"), {"wgs84", "sphere"}) == 0 ? EarthShape::Wgs84
                                                                       : EarthShape::Sphere;
  if (auto v = m.get("geoid")) g.geoid = boolean(r, *v, m.path("geoid"));
  if (auto v = m.get("overlays_per_pass"))
    g.overlaysPerPass = int32(r, *v, m.path("overlays_per_pass"));
}

void readCache(Reader& r, const Map& root, const fs::path& baseDir, CacheSettings& c) {
  const auto [node, where] = root.child("cache");
  const Map m(r, node, root.path("cache"), where, {"root", "size_limit"});
  std::string rootText;
  if (auto v = m.get("root")) rootText = text(r, *v, m.path("root"));
  c.root = rootText.empty() ? defaultCacheRoot() : resolvePath(rootText, baseDir);
  if (auto v = m.get("size_limit")) c.sizeLimitBytes = size(r, *v, m.path("size_limit"));
}

UpstreamConfig
readUpstream(Reader& r, const YAML::Node& node, std::string path, const fs::path& dataDir) {
  const Map m(r,
              node,
              std::move(path),
              node.Mark(),
              {"name",
               "type",
               "path",
               "url",
               "version",
               "crs",
               "connect_timeout",
               "timeout",
               "max_connections",
               "retries",
               "retry_backoff",
               "failure_threshold",
               "open_interval",
               "max_retry_after_wait",
               "headers",
               "redirects",
               "meta_tiles"});
  if (node.IsNull())
    r.fail(node.Mark(), m.path(), "expected a mapping (name, type, ...), got nothing");
  UpstreamConfig u;
  u.name = text(r, m.need("name"), m.path("name"));
  const auto t = m.need("type");
  switch (choice(r, t, m.path("type"), {"local", "wms", "worldwind"})) {
  case 0:
    u.type = UpstreamConfig::Type::Local;
    break;
  case 1:
    u.type = UpstreamConfig::Type::Wms;
    break;
  default:
    u.type = UpstreamConfig::Type::WorldWind;
    break;
  }
  const auto notFor = [&](std::string_view key, const char* which) {
    if (m.has(key))
      r.fail(m.keyMark(key),
             m.path(key),
             "'" + std::string(key) + "' applies to " + which + " upstreams only");
  };
  if (u.type == UpstreamConfig::Type::Local) {
    for (const auto key : {"url",
                           "connect_timeout",
                           "timeout",
                           "max_connections",
                           "retries",
                           "retry_backoff",
                           "failure_threshold",
                           "open_interval",
                           "max_retry_after_wait",
                           "headers",
                           "redirects"})
      notFor(key, "wms and worldwind");
    notFor("version", "wms");
    notFor("crs", "wms");
    notFor("meta_tiles", "wms");
    u.path = resolvePath(text(r, m.need("path"), m.path("path")), dataDir);
    return u;
  }
  notFor("path", "local");
  if (u.type == UpstreamConfig::Type::WorldWind) {
    notFor("version", "wms");
    notFor("crs", "wms");
    notFor("meta_tiles", "wms");
  }
  u.url = text(r, m.need("url"), m.path("url"));
  if (auto v = m.get("version"))
    u.wmsVersion =
        std::string(choice(r, *v, m.path("version"), {"1.1.1", "1.3.0"}) == 0 ? "1.1.1" : "1.3.0");
  if (auto v = m.get("crs"))
    u.crs = std::string(choice(r, *v, m.path("crs"), {"EPSG:4326", "CRS:84"}) == 0 ? "EPSG:4326"
                                                                                   : "CRS:84");
  if (auto v = m.get("connect_timeout"))
    u.connectTimeout = duration(r, *v, m.path("connect_timeout"));
  if (auto v = m.get("timeout")) u.timeout = duration(r, *v, m.path("timeout"));
  if (auto v = m.get("retry_backoff")) u.retryBackoff = duration(r, *v, m.path("retry_backoff"));
  if (auto v = m.get("open_interval")) u.openInterval = duration(r, *v, m.path("open_interval"));
  if (auto v = m.get("max_retry_after_wait"))
    u.maxRetryAfterWait = duration(r, *v, m.path("max_retry_after_wait"));
  if (auto v = m.get("max_connections")) u.maxConnections = int32(r, *v, m.path("max_connections"));
  if (auto v = m.get("retries")) u.retries = int32(r, *v, m.path("retries"));
  if (auto v = m.get("meta_tiles")) u.metaTiles = int32(r, *v, m.path("meta_tiles"));
  if (auto v = m.get("failure_threshold"))
    u.failureThreshold = int32(r, *v, m.path("failure_threshold"));
  if (auto v = m.get("redirects")) {
    switch (choice(r, *v, m.path("redirects"), {"same-origin", "any", "none"})) {
    case 0:
      u.redirects = RedirectPolicy::SameOrigin;
      break;
    case 1:
      u.redirects = RedirectPolicy::Any;
      break;
    default:
      u.redirects = RedirectPolicy::None;
      break;
    }
  }
  if (auto v = m.get("headers")) {
    const std::string hp = m.path("headers");
    if (!v->IsMap())
      r.fail(v->Mark(), hp, "expected a mapping of header names to values, got " + describe(*v));
    if (v->size() > 100) r.fail(v->Mark(), hp, "more than 100 headers");
    for (const auto& kv : *v) {
      const YAML::Node hk = kv.first;
      const YAML::Node hv = kv.second;
      if (!hk.IsScalar())
        r.fail(hk.Mark(), hp, "a header name must be a string, got " + describe(hk));
      const std::string name = hk.Scalar();
      const std::string key = childPath(hp, name);
      r.remember(key, hv.IsNull() ? hk.Mark() : hv.Mark());
      const auto sameName = [&](const auto& h) {
        return std::equal(
            h.first.begin(), h.first.end(), name.begin(), name.end(), [](char a, char b) {
              const auto lo = [](char c) {
                return (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c;
              };
              return lo(a) == lo(b);
            });
      };
      if (std::any_of(u.headers.begin(), u.headers.end(), sameName))
        r.fail(hk.Mark(), key, "header '" + name + "' is given twice");
      const std::string value = hv.IsNull() ? std::string() : text(r, hv, key);
      u.headers.emplace_back(name, value);
    }
  }
  return u;
}

/** The file suffix for a format ("" for an unknown one; validation reports it). */
std::string extensionFor(const std::string& format) {
  if (format == "image/jpeg") return "jpg";
  if (format == "image/png") return "png";
  if (format == "application/bil16") return "bil";
  if (format == "image/tiff") return "tif";
  return {};
}

void readGrid(Reader& r, const Map& layer, LayerConfig& l) {
  const auto [node, where] = layer.child("grid");
  if (node.IsNull()) layer.need("grid");
  const Map g(r,
              node,
              layer.path("grid"),
              where,
              {"sector", "level_zero_delta", "tile_size", "levels", "first_level"});
  GridSpec& spec = l.dataset.grid;
  if (auto v = g.get("sector")) {
    const std::string sp = g.path("sector");
    const auto items = list(r, *v, sp);
    if (items.size() != 4)
      r.fail(v->Mark(),
             sp,
             "expected 4 numbers [west, south, east, north], got " + std::to_string(items.size()));
    double e[4];
    for (std::size_t i = 0; i < 4; ++i) {
      const std::string ip = indexPath(sp, i);
      r.remember(ip, items[i].Mark());
      e[i] = number(r, items[i], ip);
    }
    spec.sector = Sector{e[0], e[1], e[2], e[3]};
  }
  if (auto v = g.get("level_zero_delta"))
    spec.levelZeroDeltaDeg = number(r, *v, g.path("level_zero_delta"));
  if (auto v = g.get("tile_size")) {
    const std::string tp = g.path("tile_size");
    if (v->IsSequence()) {
      const auto items = list(r, *v, tp);
      if (items.size() != 2)
        r.fail(v->Mark(),
               tp,
               "expected a size or [width, height], got " + std::to_string(items.size()) +
                   " numbers");
      spec.tileWidth = int32(r, items[0], indexPath(tp, 0));
      spec.tileHeight = int32(r, items[1], indexPath(tp, 1));
    } else {
      spec.tileWidth = spec.tileHeight = int32(r, *v, tp);
    }
  }
  spec.numLevels = int32(r, g.need("levels"), g.path("levels"));
  if (auto v = g.get("first_level")) l.firstLevel = int32(r, *v, g.path("first_level"));
}

void readTime(Reader& r, const Map& layer, TimeDimension& t) {
  const auto [node, where] = layer.child("time");
  if (node.IsNull()) return;
  const Map m(r, node, layer.path("time"), where, {"values", "period", "default"});
  const auto values = m.get("values");
  const auto period = m.get("period");
  if (values && period)
    r.fail(m.keyMark("period"), m.path("period"), "give either values or a period, not both");
  if (!values && !period)
    r.fail(m.mark(), m.path(), "a time dimension needs values (a list) or a period");
  if (values) {
    const std::string vp = m.path("values");
    const auto items = list(r, *values, vp);
    if (items.empty()) r.fail(values->Mark(), vp, "the list of values is empty");
    for (std::size_t i = 0; i < items.size(); ++i) {
      const std::string ip = indexPath(vp, i);
      r.remember(ip, items[i].Mark());
      t.values.push_back(text(r, items[i], ip));
    }
  } else {
    t.period = text(r, *period, m.path("period"));
    auto p = detail::parseTimePeriod(t.period, TimeDimension::kMaxExpandedValues);
    if (!p) r.fail(period->Mark(), m.path("period"), p.error());
    t.values = std::move(p->expanded);
  }
  if (auto v = m.get("default")) {
    t.defaultValue = text(r, *v, m.path("default"));
  } else if (!t.values.empty()) {
    t.defaultValue = t.values.back();
  } else {
    const auto first = t.period.find('/');
    t.defaultValue = t.period.substr(first + 1, t.period.find('/', first + 1) - first - 1);
  }
}

LayerConfig readLayer(Reader& r, const YAML::Node& node, std::string path) {
  const Map m(r,
              node,
              std::move(path),
              node.Mark(),
              {"name",
               "title",
               "abstract",
               "upstream",
               "upstream_layer",
               "style",
               "format",
               "kind",
               "grid",
               "elevation",
               "time",
               "cache",
               "opacity"});
  if (node.IsNull())
    r.fail(node.Mark(), m.path(), "expected a mapping (name, upstream, ...), got nothing");
  LayerConfig l;
  l.name = text(r, m.need("name"), m.path("name"));
  l.title = l.name;
  if (auto v = m.get("title")) l.title = text(r, *v, m.path("title"));
  if (auto v = m.get("abstract")) l.abstract = text(r, *v, m.path("abstract"));
  l.upstream = text(r, m.need("upstream"), m.path("upstream"));
  l.upstreamLayer = l.name;
  if (auto v = m.get("upstream_layer")) l.upstreamLayer = text(r, *v, m.path("upstream_layer"));
  if (auto v = m.get("opacity")) {
    l.opacity = number(r, *v, m.path("opacity"));
    if (!(l.opacity >= 0.0 && l.opacity <= 1.0))
      r.fail(v->Mark(), m.path("opacity"), "an opacity is a number from 0 to 1");
  }
  if (auto v = m.get("style")) l.dataset.style = text(r, *v, m.path("style"));
  l.dataset.mimeType = text(r, m.need("format"), m.path("format"));
  l.dataset.extension = extensionFor(l.dataset.mimeType);
  l.dataset.server = l.upstream;
  l.dataset.name = l.name;
  const bool heights =
      l.dataset.mimeType == "application/bil16" || l.dataset.mimeType == "image/tiff";
  l.kind = heights ? LayerKind::Elevation : LayerKind::Imagery;
  if (auto v = m.get("kind"))
    l.kind = choice(r, *v, m.path("kind"), {"imagery", "elevation"}) == 0 ? LayerKind::Imagery
                                                                          : LayerKind::Elevation;
  readGrid(r, m, l);

  if (l.dataset.mimeType == "image/tiff") l.elevation.encoding = ElevationEncoding::Int16Tiff;
  if (l.dataset.mimeType == "image/png") l.elevation.encoding = ElevationEncoding::Png16;
  if (m.has("elevation")) {
    if (l.kind != LayerKind::Elevation)
      r.fail(m.keyMark("elevation"),
             m.path("elevation"),
             "'elevation' applies to elevation layers only (kind: elevation)");
    const auto [en, ewhere] = m.child("elevation");
    const Map e(r, en, m.path("elevation"), ewhere, {"encoding", "scale", "offset", "no_data"});
    if (auto v = e.get("encoding")) {
      switch (choice(r, *v, e.path("encoding"), {"bil16", "int16-tiff", "png16"})) {
      case 0:
        l.elevation.encoding = ElevationEncoding::Bil16;
        break;
      case 1:
        l.elevation.encoding = ElevationEncoding::Int16Tiff;
        break;
      default:
        l.elevation.encoding = ElevationEncoding::Png16;
        break;
      }
    }
    if (auto v = e.get("scale")) l.elevation.scale = number(r, *v, e.path("scale"));
    if (auto v = e.get("offset")) l.elevation.offset = number(r, *v, e.path("offset"));
    if (auto v = e.get("no_data")) l.elevation.noData = number(r, *v, e.path("no_data"));
  }
  readTime(r, m, l.time);

  const auto [cn, cwhere] = m.child("cache");
  const Map cm(r, cn, m.path("cache"), cwhere, {"ttl", "pinned", "max_age"});
  if (auto v = cm.get("ttl")) l.ttl = duration(r, *v, cm.path("ttl"));
  if (auto v = cm.get("pinned")) l.dataset.pinned = boolean(r, *v, cm.path("pinned"));
  if (auto v = cm.get("max_age")) {
    const auto d = duration(r, *v, cm.path("max_age"));
    if (d.count() % 1000 != 0)
      r.fail(v->Mark(),
             cm.path("max_age"),
             "max_age must be whole seconds, got '" + v->Scalar() + "'");
    l.maxAge = std::chrono::duration_cast<std::chrono::seconds>(d);
  }
  return l;
}

struct ParseOptions {
  bool checkFiles = true;
  const fs::path* dataDirOverride = nullptr; ///< the embedded default: its data_dir
};

Config build(Reader& r, const YAML::Node& doc, const fs::path& baseDir, const ParseOptions& o) {
  if (doc.IsNull())
    r.fail(doc.Mark().is_null() ? YAML::Mark() : doc.Mark(),
           "",
           "the document is empty: it needs at least 'upstreams' and 'layers'");
  if (!doc.IsMap())
    r.fail(doc.Mark(),
           "",
           "the top level must be a mapping (server, cache, data_dir, upstreams, layers), got " +
               describe(doc));
  const Map root(
      r, doc, "", doc.Mark(), {"server", "cache", "renderer", "data_dir", "upstreams", "layers"});
  Config c;
  readServer(r, root, c.server);
  readCache(r, root, baseDir, c.cache);
  readRenderer(r, root, c.renderer);

  fs::path dataDir = baseDir;
  if (auto v = root.get("data_dir")) dataDir = resolvePath(text(r, *v, "data_dir"), baseDir);
  if (o.dataDirOverride) dataDir = *o.dataDirOverride;

  const auto upstreams = list(r, root.need("upstreams"), "upstreams");
  for (std::size_t i = 0; i < upstreams.size(); ++i) {
    const std::string p = indexPath("upstreams", i);
    r.remember(p, upstreams[i].Mark());
    c.upstreams.push_back(readUpstream(r, upstreams[i], p, dataDir));
  }
  const YAML::Node layersNode = root.need("layers");
  const auto layers = list(r, layersNode, "layers");
  if (layers.empty()) r.fail(layersNode.Mark(), "layers", "the list of layers is empty");
  for (std::size_t i = 0; i < layers.size(); ++i) {
    const std::string p = indexPath("layers", i);
    r.remember(p, layers[i].Mark());
    c.layers.push_back(readLayer(r, layers[i], p));
  }
  if (auto issue = detail::findIssue(c, o.checkFiles))
    r.fail(r.markFor(issue->key), issue->key, issue->withSubject());
  return c;
}

/** A document of a YAML stream: where it starts (its first token) and where its root node is. */
struct DocumentMarks {
  YAML::Mark start;
  YAML::Mark root;
};

/** The documents of a YAML stream, up to the first one that starts where the one before it did.
 *
 * yaml-cpp 0.7 (Debian 12) does not consume a token that cannot start a node at the top level (a
 * stray ',' as in ", a" or "a: 1\n,\n"): it reports an empty document and leaves the token, so the
 * next document starts at the same place, and YAML::LoadAll loops forever, allocating until the
 * memory is gone (yaml-cpp issue #1040, fixed after 0.7; found by fuzz/FuzzConfig.cpp). Two
 * documents starting at the same position mean exactly that. */
std::vector<DocumentMarks> documentMarks(const std::string& text) {
  class Handler final : public YAML::EventHandler {
  public:
    std::vector<DocumentMarks> docs;
    void OnDocumentStart(const YAML::Mark& m) override {
      docs.push_back({m, m});
      nodes_ = 0;
    }
    void OnDocumentEnd() override {}
    void OnNull(const YAML::Mark& m, YAML::anchor_t) override { node(m); }
    void OnAlias(const YAML::Mark& m, YAML::anchor_t) override { node(m); }
    void
    OnScalar(const YAML::Mark& m, const std::string&, YAML::anchor_t, const std::string&) override {
      node(m);
    }
    void OnSequenceStart(const YAML::Mark& m,
                         const std::string&,
                         YAML::anchor_t,
                         YAML::EmitterStyle::value) override {
      node(m);
    }
    void OnSequenceEnd() override {}
    void OnMapStart(const YAML::Mark& m,
                    const std::string&,
                    YAML::anchor_t,
                    YAML::EmitterStyle::value) override {
      node(m);
    }
    void OnMapEnd() override {}

  private:
    void node(const YAML::Mark& m) {
      if (nodes_++ == 0 && !docs.empty()) docs.back().root = m;
    }
    std::size_t nodes_ = 0; // of the current document; the first is its root
  };
  Handler h;
  std::istringstream in(text);
  YAML::Parser parser(in);
  // Every other document consumes at least one token, so this ends.
  while (parser.HandleNextDocument(h)) {
    const auto& d = h.docs;
    if (d.size() >= 2 && d[d.size() - 1].start.pos == d[d.size() - 2].start.pos) break;
  }
  return std::move(h.docs);
}

std::expected<Config, ConfigError> parseDocument(std::string_view yamlText,
                                                 std::string_view sourceName,
                                                 const fs::path& baseDir,
                                                 const ParseOptions& o) {
  Reader r{std::string(sourceName)};
  try {
    YAML::Node doc;
    try {
      const std::string text(yamlText);
      // One document: counted first (YAML::LoadAll can loop forever, see documentMarks), then
      // loaded with YAML::Load, which reads only the first.
      const std::vector<DocumentMarks> docs = documentMarks(text);
      if (docs.empty())
        r.fail(YAML::Mark(), "", "the file is empty: it needs at least 'upstreams' and 'layers'");
      if (docs.size() >= 2 && docs.back().start.pos == docs[docs.size() - 2].start.pos)
        r.fail(docs.back().start, "", "YAML syntax: unexpected character here (a stray ','?)");
      if (docs.size() > 1)
        r.fail(docs[1].root, "", "more than one YAML document (---): put everything in one");
      doc = YAML::Load(text);
    } catch (const YAML::DeepRecursion& e) {
      r.fail(e.mark, "", "YAML syntax: nested too deeply");
    } catch (const YAML::Exception& e) {
      // yaml-cpp says "bad file" when its scanner gives up, e.g. on thousands of nested brackets.
      r.fail(e.mark,
             "",
             e.msg == "bad file" ? "YAML syntax: cannot parse this (nested too deeply?)"
                                 : "YAML syntax: " + e.msg);
    }
    Config c = build(r, doc, baseDir, o);
    c.sourceFile = fs::path(sourceName);
    return c;
  } catch (const Failure& f) {
    return std::unexpected(f.error);
  } catch (const YAML::Exception& e) {
    ConfigError err{std::string(sourceName), e.mark.line + 1, e.mark.column + 1, "", e.msg};
    return std::unexpected(std::move(err));
  } catch (const std::exception& e) {
    return std::unexpected(ConfigError{std::string(sourceName), 0, 0, "", e.what()});
  }
}

} // namespace

std::expected<Config, ConfigError>
parseConfig(std::string_view yamlText, std::string_view sourceName, const fs::path& baseDir) {
  return parseDocument(yamlText, sourceName, baseDir, ParseOptions{});
}

std::expected<Config, ConfigError> loadConfig(const fs::path& file) {
  const auto error = [&](std::string message) {
    return std::unexpected(ConfigError{file.string(), 0, 0, "", std::move(message)});
  };
  std::error_code ec;
  const auto st = fs::status(file, ec);
  if (!fs::exists(st)) return error("cannot read the configuration: no such file");
  if (fs::is_directory(st)) return error("cannot read the configuration: it is a directory");
  const auto bytes = fs::file_size(file, ec);
  if (!ec && bytes > kMaxFileBytes)
    return error("the configuration is larger than 16 MiB (" + std::to_string(bytes) + " bytes)");
  std::ifstream in(file, std::ios::binary);
  if (!in) return error("cannot open the configuration for reading");
  std::string yaml;
  char buf[65536];
  while (in.read(buf, sizeof buf) || in.gcount() > 0) {
    yaml.append(buf, static_cast<std::size_t>(in.gcount()));
    if (yaml.size() > kMaxFileBytes) return error("the configuration is larger than 16 MiB");
  }
  if (in.bad()) return error("reading the configuration failed");
  fs::path base = fs::absolute(file, ec).parent_path();
  if (ec) base = file.parent_path();
  return parseDocument(yaml, file.string(), base, ParseOptions{});
}

std::string_view embeddedDefaultYaml() noexcept {
  return detail::kEmbeddedDefaultYaml;
}

Config embeddedDefault(const fs::path& dataDir, const fs::path& cacheRoot) {
  ParseOptions o;
  o.checkFiles = false;
  o.dataDirOverride = &dataDir;
  auto c = parseDocument(detail::kEmbeddedDefaultYaml, kEmbeddedName, dataDir, o);
  if (!c) {
    // A build defect (tests parse the same text): no configuration can come out of it.
    std::fprintf(stderr,
                 "tellus: the embedded default configuration is broken: %s\n",
                 c.error().toString().c_str());
    std::abort();
  }
  if (!cacheRoot.empty()) c->cache.root = cacheRoot;
  return std::move(*c);
}

} // namespace tellus
