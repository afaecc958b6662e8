#pragma once
/**
 * @file Fetcher.hpp
 * @brief The upstream fetcher: HTTP(S) GETs on one thread, with per-upstream concurrency caps,
 * retries with jittered exponential backoff, Retry-After, a circuit breaker per upstream and its
 * own redirect policy. The network is an ITransport (Transport.hpp: libcurl in production, a fake
 * in tests) and time a Clock (Clock.hpp), so that the policies are tested without sockets or
 * sleeps. Source: proxy/src/upstream/ (Fetcher.cpp the loop, FetchAttempts.cpp one attempt,
 * FetchPolicy.cpp the policies, CurlTransport.cpp the only user of libcurl's transfer API).
 */

#include <tellus/cache/Clock.hpp>
#include <tellus/proxy/Transport.hpp>

#include <array>
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

/** How one upstream (a named server) is talked to. */
struct UpstreamPolicy {
  int maxConnections = 4; ///< concurrent transfers to this upstream; the rest wait FIFO
  std::chrono::milliseconds connectTimeout{5000};
  std::chrono::milliseconds timeout{30000}; ///< one attempt, connect included
  int retries = 3; ///< extra attempts for 5xx, timeouts, connect, truncation
  std::chrono::milliseconds retryBackoff{200}; ///< base: retry n waits random(0, base * 2^n)
  int failureThreshold = 5; ///< consecutive failed fetches (after retries) that open the breaker
  std::chrono::milliseconds openInterval{30000}; ///< open breaker: no traffic for this long
  /// 429 or 503 with Retry-After: a wait up to this long is waited out within the fetch (the retry
  /// goes no earlier than asked); a longer one fails the fetch at once and pauses the upstream
  /// for the time asked (at most an hour): fetches meanwhile fail with Throttled, no network.
  std::chrono::milliseconds maxRetryAfterWait{10000};
  std::size_t maxBodyBytes = 64 << 20;
  /// Sent with every request to the upstream's own origin (the scheme, host and port of the URL
  /// asked), never to another one a redirect leads to.
  std::vector<std::pair<std::string, std::string>> headers;
  /// Redirects (301, 302, 303, 307, 308 with a Location) are followed by the fetcher itself:
  /// within the origin of the URL asked only (SameOrigin), to any http(s) URL (Any), or not at all
  /// (None). A redirect refused, or more than maxRedirects of them, fails the fetch with
  /// FetchErrc::Redirect.
  enum class Redirects : std::uint8_t { SameOrigin, Any, None };
  Redirects redirects = Redirects::SameOrigin;
  int maxRedirects = 5;
};

struct FetchRequest {
  std::string upstream; ///< the unit of concurrency caps and circuit breaking
  std::string url;      ///< http or https only
  std::string ifNoneMatch;
  std::string ifModifiedSince;
};

/** An HTTP answer: 2xx, 304, or any 4xx (the caller decides: 304 revalidated, 404 absent). */
struct FetchResponse {
  int status = 0;
  std::string contentType;
  std::vector<std::byte> body;
  std::string etag;
  std::string lastModified;
  std::string cacheControl;
  std::string expires;
  int attempts = 0;
  std::chrono::milliseconds elapsed{0}; ///< from fetch() to completion, retries included
  std::string url;   ///< where the answer came from: the URL asked, or where redirects led
  int redirects = 0; ///< redirects followed to get there
};

enum class FetchErrc {
  Timeout,     ///< an attempt ran past its timeout (after retries)
  Connect,     ///< refused, DNS failure, reset, nothing received, TLS handshake (after retries)
  CircuitOpen, ///< the upstream's breaker is open: no network was touched
  HttpError,   ///< 5xx after retries, or another status that is not 2xx/304/4xx (3xx loops)
  Truncated,   ///< the body ended before its announced length (after retries)
  TooLarge,    ///< the body exceeds UpstreamPolicy::maxBodyBytes (not retried)
  Cancelled,   ///< the fetcher was destroyed first
  Throttled,   ///< the upstream asked for a pause (Retry-After) that has not ended: no network
  Redirect,    ///< a redirect the policy refuses (UpstreamPolicy::redirects), or too many
  Unknown      ///< bad URL, unsupported protocol, invalid header, internal failure
};

struct FetchError {
  FetchErrc code = FetchErrc::Unknown;
  std::string message;
  int httpStatus = 0; ///< for HttpError
  int attempts = 0;   ///< 0 when no request was sent (CircuitOpen, Cancelled before start)
};

using FetchResult = std::expected<FetchResponse, FetchError>;

/** An HTTP Retry-After value (RFC 9110 10.2.3): delay-seconds or an HTTP-date, as the wait from
 * `now` (0 for a date in the past); nullopt when it is neither. */
std::optional<std::chrono::milliseconds> parseRetryAfter(std::string_view value,
                                                         std::chrono::system_clock::time_point now);

enum class BreakerState { Closed, Open, HalfOpen };

/** "scheme://host:port" of a URL (scheme and host in lower case, the scheme's default port
 * filled in; libcurl's URL parser); nullopt when it cannot be parsed. Two URLs are of one origin
 * when these agree. */
std::optional<std::string> urlOrigin(std::string_view url);

/** A short name for logs: "timeout", "connect", "circuit-open", ... */
const char* toString(FetchErrc code) noexcept;

/**
 * @brief Fetches URLs on one background thread, which drives an ITransport (libcurl multi:
 * curl_multi_perform and curl_multi_poll) and the retry timers.
 *
 * Thread safety: every method may be called from any thread. `done` callbacks run on the fetcher
 * thread, exactly once per fetch(), and must not block for long; they may call fetch(). An
 * exception thrown by a callback is swallowed (it never crosses into the fetcher thread's loop).
 *
 * Retries: 5xx, timeouts, connection failures and truncated bodies are retried up to
 * `retries` times after random(0, retryBackoff * 2^n) (timers on the fetcher thread against the
 * clock, nothing sleeps). 304 and 4xx are answers, not failures, and are never retried.
 *
 * Circuit breaker: `failureThreshold` consecutive failed fetches (transport failures, 5xx; after
 * retries) open it; fetches then fail at once with CircuitOpen until `openInterval` has passed;
 * then one probe fetch (a single attempt) goes through (HalfOpen) while others still fail fast;
 * the probe's success closes the breaker, its failure re-opens it for another interval.
 */
class Fetcher {
public:
  /** Starts the fetcher thread on libcurl (makeCurlTransport) and the system's clocks.
   * `maxTotalConnections` caps transfers over all upstreams (and sizes libcurl's connection
   * cache). Throws std::runtime_error only if libcurl cannot initialise. */
  explicit Fetcher(std::size_t maxTotalConnections = 64);
  /** Starts the fetcher thread on `transport`, reading time from `clock` (which outlives the
   * fetcher): retry timers, the breaker's interval, Retry-After pauses, FetchResponse::elapsed
   * and the latency histogram. */
  Fetcher(std::unique_ptr<ITransport> transport,
          const Clock& clock,
          std::size_t maxTotalConnections = 64);
  /** Stops the thread; pending, waiting and running fetches complete with Cancelled. */
  ~Fetcher();
  Fetcher(const Fetcher&) = delete;
  Fetcher& operator=(const Fetcher&) = delete;

  /** Sets an upstream's policy (upstreams without one use the defaults). Applies to fetches
   * issued afterwards; the concurrency cap applies at once. */
  void setPolicy(const std::string& upstream, UpstreamPolicy policy);

  /** Queues a GET; never blocks. `done` runs on the fetcher thread exactly once. */
  void fetch(FetchRequest request, std::function<void(FetchResult&&)> done);

  /** The breaker as a new fetch would meet it: an open breaker whose interval has passed reads
   * HalfOpen (the next fetch is the probe). */
  BreakerState breaker(const std::string& upstream) const;
  /** False while the breaker is open and its interval has not passed (fetches fail with
   * CircuitOpen); true when closed or when a half-open probe may go or is going. */
  bool reachable(const std::string& upstream) const;
  /** How long fetches from this upstream will fail without touching the network: the rest of an
   * open breaker's interval or of a pause the upstream asked for (Retry-After); 0 when neither. */
  std::chrono::milliseconds unavailableFor(const std::string& upstream) const;

  /// Upper bounds (seconds) of the latency histogram buckets; the last bucket is +Inf.
  static constexpr std::array<double, 11> kLatencyBounds{
      0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 5.0, 10.0};
  struct Stats {
    std::uint64_t requests = 0; ///< fetch() calls
    std::uint64_t retries = 0;  ///< extra attempts started
    std::uint64_t failures = 0; ///< fetches that completed with an error (CircuitOpen included)
    std::uint64_t inFlight = 0; ///< fetches accepted and not yet completed (queued included)
    /// Completed fetches that reached the network (attempts > 0), by time from fetch() to the end:
    /// cumulative counts per bound of kLatencyBounds, then +Inf (= latencyCount).
    std::array<std::uint64_t, kLatencyBounds.size() + 1> latencyBuckets{};
    std::uint64_t latencyCount = 0;
    double latencySumSeconds = 0.0;
    /// Failed fetches by FetchErrc (index = the enum's value).
    std::array<std::uint64_t, 10> errorsByCode{};
    BreakerState breaker = BreakerState::Closed;
  };
  Stats stats(const std::string& upstream) const;
  /** Names of the upstreams that have a policy or have been fetched from. */
  std::vector<std::string> upstreams() const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

} // namespace tellus
