// The HttpHandler of `tellus serve`: each request counted (/metrics) and, when the access log is
// on, logged; refused requests and OPTIONS answered here; the rest routed to its front end (WMS,
// World Wind and static tiles, WMTS, the page and /metrics: FrontEnd.hpp). Nothing escapes a
// handler.
#include "frontend/FrontEnd.hpp"

#include <tellus/proxy/Log.hpp>
#include <tellus/proxy/WebPage.hpp>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>

namespace tellus {

namespace {

Protocol protocolOf(const HttpRequest& req) {
  const bool wms =
      req.path == "/wms" || req.path == "/wms/" || (req.path == "/" && !req.query.empty());
  return wms                                                     ? Protocol::Wms
         : req.path == "/wwtile"                                 ? Protocol::WorldWind
         : req.path.starts_with("/tiles/")                       ? Protocol::Static
         : req.path == "/wmts" || req.path.starts_with("/wmts/") ? Protocol::Wmts
         : isWebPagePath(req.path)                               ? Protocol::Page
         : req.path == "/metrics"                                ? Protocol::Metrics
                                                                 : Protocol::Other;
}

/** A header list such as Access-Control-Request-Headers asks for: tokens (RFC 9110) separated by
 * commas and blanks, not too long. */
bool tokenList(std::string_view v) {
  if (v.empty() || v.size() > 1024) return false;
  return std::all_of(v.begin(), v.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) ||
           std::string_view("!#$%&'*+-.^_`|~, \t").find(c) != std::string_view::npos;
  });
}

/** The access log's fields of one request. */
struct Access {
  std::chrono::steady_clock::time_point start;
  std::string remote, method, target;
};

void logAccess(const Access& access,
               Protocol protocol,
               const HttpResponse& r,
               std::uint64_t bytes) {
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - access.start)
          .count();
  char msText[32];
  std::snprintf(msText, sizeof msText, "%.3f", ms);
  std::string_view cache = "-";
  for (const auto& [k, v] : r.headers) {
    if (k == "X-Cache") cache = v;
  }
  const std::string status = std::to_string(r.status);
  const std::string size = std::to_string(bytes);
  logger().access({{"remote", access.remote},
                   {"method", access.method},
                   {"target", access.target},
                   {"status", status},
                   {"bytes", size},
                   {"ms", msText},
                   {"cache", cache},
                   {"protocol", toString(protocol)}});
}

} // namespace

struct ProxyFrontEnd::Impl {
  // The front ends first: destroyed after `fe`, whose composer's queued maps still answer
  // through the WMS front end while it stops.
  WmsFrontEnd wms{fe};
  TileFrontEnd tiles{fe};
  WmtsFrontEnd wmts{fe};
  PagesFrontEnd pages{fe};
  FrontEnd fe;

  Impl(TileService& t, FrontEndOptions o) : fe(t, std::move(o)) {}

  /** What the HTTP server refused (HttpRequest::refusal): answered here like any other request,
   * so that it is counted and logged. */
  HttpResponse refusalResponse(const HttpRequest& req) const {
    switch (req.refusal) {
    case HttpRefusal::BadRequest:
      return fe.errorText(400, "bad request: malformed request line or header");
    case HttpRefusal::MethodNotAllowed: {
      auto r = fe.errorText(405, "only GET, HEAD and OPTIONS");
      r.setHeader("Allow", FrontEnd::kAllowedMethods);
      return r;
    }
    case HttpRefusal::BodyTooLarge:
      return fe.errorText(413, "request body too large");
    case HttpRefusal::TooManyRequests: {
      auto r = fe.errorText(429, "too many requests");
      FrontEnd::markTemporary(r, FrontEnd::Temporary{429, 1});
      return r;
    }
    case HttpRefusal::HeaderTooLarge:
      return fe.errorText(431, "request header fields too large");
    case HttpRefusal::None:
      break;
    }
    return fe.errorText(500, "internal error");
  }

  /** OPTIONS: a CORS preflight (Origin and Access-Control-Request-Method) gets 204 with what a
   * browser needs to send the real request (the headers it asked for are allowed: tellus
   * ignores them, an Authorization or a Cesium Resource header included); a plain OPTIONS gets
   * 204 with Allow. */
  HttpResponse optionsResponse(const HttpRequest& req) const {
    HttpResponse r;
    r.status = 204;
    r.setHeader("Allow", FrontEnd::kAllowedMethods);
    const bool preflight =
        !req.header("origin").empty() && !req.header("access-control-request-method").empty();
    if (!preflight || fe.options.cors.empty()) return r;
    r.setHeader("Access-Control-Allow-Origin", fe.options.cors);
    r.setHeader("Access-Control-Allow-Methods", FrontEnd::kAllowedMethods);
    const std::string_view asked = req.header("access-control-request-headers");
    r.setHeader("Access-Control-Allow-Headers",
                tokenList(asked) ? std::string(asked)
                                 : std::string("Authorization, X-Requested-With, If-None-Match, "
                                               "If-Modified-Since, Cache-Control"));
    r.setHeader("Access-Control-Max-Age", "86400");
    r.setHeader("Vary", "Origin, Access-Control-Request-Method, Access-Control-Request-Headers");
    return r;
  }

  /** `respond`, after counting the answer (and logging it when the access log is on). */
  Responder counting(const HttpRequest& req, Protocol protocol, Responder respond) {
    fe.metrics.requestStarted(protocol);
    // The access log's fields, only when it is on (it costs a few copies per request).
    std::optional<Access> access;
    if (logger().accessLogEnabled())
      access = Access{std::chrono::steady_clock::now(), req.remoteAddress, req.method, req.target};
    return [fe = &fe, protocol, access = std::move(access), respond = std::move(respond)](
               HttpResponse&& r) {
      fe->finishCaching(r); // an error is never kept, whoever made it
      ProxyMetrics* metrics = &fe->metrics;
      const auto bytes = r.file ? static_cast<std::uint64_t>(r.file->size) : r.body.size();
      metrics->requestFinished(protocol, r.status, bytes);
      if (access) logAccess(*access, protocol, r, bytes);
      respond(std::move(r));
    };
  }

  void route(const HttpRequest& req, Protocol protocol, const Responder& respond) {
    if (req.refusal != HttpRefusal::None) return respond(refusalResponse(req));
    if (req.method == "OPTIONS") return respond(optionsResponse(req));
    switch (protocol) {
    case Protocol::Wms:
      return wms.handle(req, respond);
    case Protocol::WorldWind:
      return tiles.worldWind(req, respond);
    case Protocol::Static:
      return tiles.staticTile(req, respond);
    case Protocol::Wmts:
      return wmts.handle(req, respond);
    case Protocol::Page:
      return pages.index(req, respond);
    case Protocol::Metrics:
      return pages.metrics(respond);
    case Protocol::Other:
      break;
    }
    respond(fe.plain(404, "not found\n"));
  }
};

ProxyFrontEnd::ProxyFrontEnd(TileService& tiles, FrontEndOptions options)
    : impl_(std::make_unique<Impl>(tiles, std::move(options))) {}

ProxyFrontEnd::~ProxyFrontEnd() = default;

void ProxyFrontEnd::handle(HttpRequest&& req, Responder respond) {
  const Protocol protocol = protocolOf(req);
  const Responder counted = impl_->counting(req, protocol, std::move(respond));
  try {
    impl_->route(req, protocol, counted);
  } catch (const std::exception&) {
    // Last line of defence: nothing may escape an HTTP handler (this is a bug if it happens).
    counted(HttpResponse::text(500, "text/plain", "internal error\n"));
  }
}

} // namespace tellus
