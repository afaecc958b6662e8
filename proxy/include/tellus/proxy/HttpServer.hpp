#pragma once
/**
 * @file HttpServer.hpp
 * @brief The event-driven HTTP/1.1 server adapter (Boost.Beast over Asio, kept private to
 * proxy/src).
 *
 * A fixed set of threads, each running its own event loop (HttpServerOptions::threads); a
 * connection lives on one loop for its whole life, so its handlers need no strand. A handler gets
 * the parsed request and a Responder it may call later from any thread (the proxy answers misses
 * after an upstream fetch without ever blocking the loop). Limits: header bytes, request time
 * (slow clients are cut off), keep-alive idle time, connection count. GET, HEAD and OPTIONS
 * are served; what the server refuses (another method, a malformed request, oversized headers or
 * body, a client over its rate) reaches the handler too, flagged with an HttpRefusal, so that it
 * is answered, counted and logged in one place.
 */

#include <tellus/cache/Clock.hpp>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace tellus {

/** Why the server refuses a request before it is served; the handler answers it (the front end
 * makes the status and the body, counts it and logs it like any other request). */
enum class HttpRefusal : std::uint8_t {
  None,             ///< a request to serve
  BadRequest,       ///< malformed: request line (a raw space or control byte in the target),
                    ///< header or body framing; the connection closes after the answer
  MethodNotAllowed, ///< a method other than GET, HEAD and OPTIONS (and POST: acceptPost)
  BodyTooLarge,     ///< a body over 8 KiB; the connection closes after the answer
  TooManyRequests,  ///< over HttpServerOptions::requestsPerSecond for its address
  HeaderTooLarge,   ///< request line and headers over maxHeaderBytes; closes after the answer
};
/** "bad-request", "method-not-allowed", ... ("none" for None). */
const char* toString(HttpRefusal refusal) noexcept;

struct HttpRequest {
  std::string method; ///< "GET", "HEAD", ...
  std::string target; ///< as sent: path and query
  std::string path;   ///< percent-encoded path, without the query
  std::string query;  ///< raw query string without '?', "" if none
  std::vector<std::pair<std::string, std::string>> headers; ///< names in lower case
  std::string remoteAddress;
  /// Not None: the server refuses this request and the handler must answer it with a 4xx (any
  /// other answer is replaced by a 500). method and target are what could be read of the request
  /// line ("" when nothing could), headers only when they were parsed.
  HttpRefusal refusal = HttpRefusal::None;
  std::string body; ///< a POST's (HttpServerOptions::acceptPost), at most 8 KiB

  /** First header with this lower-case name, or "". */
  std::string_view header(std::string_view lowerName) const noexcept;
};

/** A body sent straight from a file with sendfile(2): no copy through user space. */
struct HttpFileBody {
  int fd = -1;                       ///< read-only, positioned reads only (never seeked)
  std::int64_t size = 0;             ///< bytes from offset 0; the file must not shrink
  std::shared_ptr<const void> owner; ///< keeps `fd` open until the response is sent
};

struct HttpResponse {
  int status = 200;
  std::vector<std::pair<std::string, std::string>> headers; ///< Content-Type etc.
  std::vector<std::byte> body;
  std::optional<HttpFileBody> file; ///< instead of `body`

  void setHeader(std::string name, std::string value);
  static HttpResponse text(int status, std::string_view contentType, std::string_view body);
};

/** Call exactly once, from any thread. */
using Responder = std::function<void(HttpResponse&&)>;
/** Must not throw; may keep the Responder and call it later. Also called for refused requests
 * (HttpRequest::refusal), which it must answer with a 4xx. */
using HttpHandler = std::function<void(HttpRequest&&, Responder)>;

struct HttpServerOptions {
  std::string host = "127.0.0.1";
  std::uint16_t port = 0; ///< 0: any free port (read it back with port())
  int threads = 0;        ///< event loops; 0: one per core but one (at least one), see start()
  std::size_t maxConnections = 4096;
  std::size_t maxHeaderBytes = 16384;
  std::chrono::milliseconds requestTimeout{10000};
  std::chrono::milliseconds keepAliveTimeout{60000};
  std::string serverName = "tellus";
  /// Per client address: sustained requests per second (0 = unlimited) with a burst of twice that;
  /// requests beyond it reach the handler as HttpRefusal::TooManyRequests.
  double requestsPerSecond = 0;
  /// The rate limit's time; null: the system's (tests inject a ManualClock, which outlives the
  /// server). Connection timeouts are Asio's timers on the real clock.
  const Clock* clock = nullptr;
  /// POST reaches the handler with its body (`tellus cluster`'s control API); otherwise it is
  /// refused as MethodNotAllowed, as the tile server refuses it.
  bool acceptPost = false;
};

class HttpServer {
public:
  HttpServer(HttpServerOptions options, HttpHandler handler);
  ~HttpServer();
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  /** Binds, listens and starts the threads. The error names the address. */
  std::expected<void, std::string> start();
  /** The bound port (after start). */
  std::uint16_t port() const noexcept;
  /** Stops accepting, closes connections, joins the threads. Idempotent. */
  void stop();

  /** Connections open now. */
  std::size_t connections() const noexcept;

  struct Impl; ///< implementation detail (public only so that the connection type can name it)

private:
  std::shared_ptr<Impl> impl_;
};

} // namespace tellus
