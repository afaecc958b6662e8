// One entry of the configuration's upstreams: local, wms or worldwind (ParseSections.hpp).

#include "ParseSections.hpp"

#include <algorithm>
#include <string>
#include <utility>
#include <vector>

namespace tellus::detail::yaml {

namespace {

UpstreamConfig::Type readType(Reader& r, const Map& m) {
  const auto t = m.need("type");
  switch (choice(r, t, m.path("type"), {"local", "wms", "worldwind", "wmts"})) {
  case 0:
    return UpstreamConfig::Type::Local;
  case 1:
    return UpstreamConfig::Type::Wms;
  case 2:
    return UpstreamConfig::Type::WorldWind;
  default:
    return UpstreamConfig::Type::Wmts;
  }
}

/** The keys of the other types are errors (a local upstream has no url, a remote one no path,
 * only wms has version, crs and meta_tiles, only wmts has encoding). */
void refuseOtherTypesKeys(Reader& r, const Map& m, UpstreamConfig::Type type) {
  const auto notFor = [&](std::string_view key, const char* which) {
    if (m.has(key))
      r.fail(m.keyMark(key),
             m.path(key),
             "'" + std::string(key) + "' applies to " + which + " upstreams only");
  };
  if (type == UpstreamConfig::Type::Local) {
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
      notFor(key, "wms, worldwind and wmts");
    notFor("encoding", "wmts");
    notFor("version", "wms");
    notFor("crs", "wms");
    notFor("meta_tiles", "wms");
    return;
  }
  notFor("path", "local");
  if (type != UpstreamConfig::Type::Wmts) notFor("encoding", "wmts");
  if (type == UpstreamConfig::Type::WorldWind || type == UpstreamConfig::Type::Wmts) {
    notFor("version", "wms");
    notFor("crs", "wms");
    notFor("meta_tiles", "wms");
  }
}

RedirectPolicy readRedirects(Reader& r, const YAML::Node& v, const std::string& path) {
  switch (choice(r, v, path, {"same-origin", "any", "none"})) {
  case 0:
    return RedirectPolicy::SameOrigin;
  case 1:
    return RedirectPolicy::Any;
  default:
    return RedirectPolicy::None;
  }
}

/** headers: a mapping of names to values (null: empty), a name given once whatever its case. */
void readHeaders(Reader& r,
                 const YAML::Node& v,
                 const std::string& hp,
                 std::vector<std::pair<std::string, std::string>>& headers) {
  if (!v.IsMap())
    r.fail(v.Mark(), hp, "expected a mapping of header names to values, got " + describe(v));
  if (v.size() > 100) r.fail(v.Mark(), hp, "more than 100 headers");
  for (const auto& kv : v) {
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
    if (std::any_of(headers.begin(), headers.end(), sameName))
      r.fail(hk.Mark(), key, "header '" + name + "' is given twice");
    const std::string value = hv.IsNull() ? std::string() : text(r, hv, key);
    headers.emplace_back(name, value);
  }
}

/** What a wms or worldwind upstream is fetched with: url, protocol, timeouts, retries, breaker,
 * redirects, headers. */
void readRemote(Reader& r, const Map& m, UpstreamConfig& u) {
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
  if (auto v = m.get("redirects")) u.redirects = readRedirects(r, *v, m.path("redirects"));
  if (auto v = m.get("headers")) readHeaders(r, *v, m.path("headers"), u.headers);
  if (auto v = m.get("encoding")) {
    constexpr UpstreamConfig::Encoding kEncodings[] = {UpstreamConfig::Encoding::Auto,
                                                       UpstreamConfig::Encoding::Rest,
                                                       UpstreamConfig::Encoding::Kvp};
    u.encoding = kEncodings[choice(r, *v, m.path("encoding"), {"auto", "rest", "kvp"})];
  }
}

} // namespace

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
               "meta_tiles",
               "encoding"});
  if (node.IsNull())
    r.fail(node.Mark(), m.path(), "expected a mapping (name, type, ...), got nothing");
  UpstreamConfig u;
  u.name = text(r, m.need("name"), m.path("name"));
  u.type = readType(r, m);
  refuseOtherTypesKeys(r, m, u.type);
  if (u.type == UpstreamConfig::Type::Local)
    u.path = resolvePath(text(r, m.need("path"), m.path("path")), dataDir);
  else
    readRemote(r, m, u);
  return u;
}

} // namespace tellus::detail::yaml
