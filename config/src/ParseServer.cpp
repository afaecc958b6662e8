// The server section of the configuration: listen address, limits (ParseSections.hpp).

#include "ParseSections.hpp"

#include <array>

namespace tellus::detail::yaml {

namespace {

/** server.limits: the sizes, timeouts and rates a client may use. */
void readLimits(Reader& r, const Map& server, ServerLimits& lim) {
  const auto [ln, lwhere] = server.child("limits");
  const Map l(r,
              ln,
              server.path("limits"),
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

/** A duration in whole seconds (server.cdn's). */
std::chrono::seconds wholeSeconds(Reader& r, const YAML::Node& v, const std::string& path) {
  const auto d = duration(r, v, path);
  if (d.count() % 1000 != 0)
    r.fail(v.Mark(), path, "must be whole seconds, got '" + v.Scalar() + "'");
  return std::chrono::duration_cast<std::chrono::seconds>(d);
}

/** server.cdn: the headers shared caches are told, and the purge endpoints. */
void readCdn(Reader& r, const Map& server, CdnSettings& c) {
  const auto [cn, cwhere] = server.child("cdn");
  const Map m(r,
              cn,
              server.path("cdn"),
              cwhere,
              {"s_maxage",
               "stale_while_revalidate",
               "stale_if_error",
               "short_max_age",
               "key_header",
               "purge"});
  if (auto v = m.get("s_maxage")) c.sMaxAge = wholeSeconds(r, *v, m.path("s_maxage"));
  if (auto v = m.get("stale_while_revalidate"))
    c.staleWhileRevalidate = wholeSeconds(r, *v, m.path("stale_while_revalidate"));
  if (auto v = m.get("stale_if_error"))
    c.staleIfError = wholeSeconds(r, *v, m.path("stale_if_error"));
  if (auto v = m.get("short_max_age")) c.shortMaxAge = wholeSeconds(r, *v, m.path("short_max_age"));
  if (auto v = m.get("key_header")) c.keyHeader = text(r, *v, m.path("key_header"));
  if (auto v = m.get("purge")) {
    std::size_t i = 0;
    for (const auto& e : list(r, *v, m.path("purge")))
      c.purge.push_back(text(r, e, m.path("purge") + "[" + std::to_string(i++) + "]"));
  }
}

} // namespace

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
               "limits",
               "cdn"});
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

  readLimits(r, m, s.limits);
  readCdn(r, m, s.cdn);
}

} // namespace tellus::detail::yaml
