#pragma once
/**
 * @file Transport.hpp
 * @brief The Fetcher's seam to the network: an ITransport runs HTTP GETs and reports what came
 * back, and nothing else. Which answers are retried and when, the circuit breaker, Retry-After,
 * per-upstream connection caps and which redirects are followed are the Fetcher's (Fetcher.hpp),
 * decided on what a transport reports. makeCurlTransport() is the implementation (libcurl multi;
 * the only code in tellus that sees libcurl's transfer API); tests give the Fetcher a fake one
 * (tests/support/FakeTransport.hpp) and a ManualClock (Clock.hpp).
 */

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace tellus {

/** One GET as the Fetcher hands it to a transport: one request, no redirect followed. */
struct TransferRequest {
  std::string url;                      ///< http or https (the transport refuses the rest)
  std::vector<std::string> headerLines; ///< "Name: value", already checked by the Fetcher
  std::chrono::milliseconds connectTimeout{5000};
  std::chrono::milliseconds timeout{30000}; ///< the whole transfer, connect included
  std::size_t maxBodyBytes = 64 << 20;      ///< more is TransferFailure::TooLarge
  /// Transfers of one pool (the Fetcher: one upstream) may reuse each other's handles; at most
  /// `keepIdle` idle ones are kept per pool.
  std::string pool;
  std::size_t keepIdle = 4;
};

/** Why a transfer has no complete answer. */
enum class TransferFailure : std::uint8_t {
  None,             ///< an answer, whatever its status
  Timeout,          ///< connect or transfer timeout
  Connect,          ///< refused, DNS, reset, nothing received, TLS handshake, HTTP/2 stream
  Tls,              ///< the peer's certificate or ours: retrying will not help
  Truncated,        ///< the body ended before its announced length
  TooLarge,         ///< the body is larger than maxBodyBytes
  OutOfMemory,      ///< the body or a header could not be stored
  TooManyRedirects, ///< (not followed by the transport; kept for completeness)
  Other             ///< bad URL, unsupported protocol, anything else
};

/** What a transfer got: an HTTP answer (failure None), or a failure with what was received. */
struct TransferResult {
  TransferFailure failure = TransferFailure::None;
  std::string detail; ///< the failure in words (for logs and FetchError::message)
  int status = 0;     ///< the last response's HTTP status; 0 when none came
  std::string contentType, etag, lastModified, cacheControl, expires, retryAfter;
  /// A 3xx answer's Location, made absolute against the request's URL; "" when none.
  std::string location;
  std::vector<std::byte> body;
};

/**
 * @brief Runs transfers for one thread (the Fetcher's): start() them, then perform() and poll() in
 * a loop; wake() may be called from any thread and makes a poll() return early.
 */
class ITransport {
public:
  using Id = std::uint64_t;
  virtual ~ITransport() = default;
  /** Starts a transfer, or says why it cannot (nothing was sent then). `id` names it in
   * perform()'s results; ids of running transfers are unique. */
  virtual std::expected<void, std::string> start(Id id, const TransferRequest& request) = 0;
  /** Moves the running transfers on without waiting; returns those that have finished. */
  virtual std::vector<std::pair<Id, TransferResult>> perform() = 0;
  /** Waits at most `timeout` for network activity, a finished transfer or wake(). */
  virtual void poll(std::chrono::milliseconds timeout) = 0;
  /** Makes a poll() under way (or the next one) return at once. Any thread. */
  virtual void wake() = 0;
  /** Drops every running transfer without an answer (the Fetcher is stopping). */
  virtual void abandonAll() = 0;
};

/** The libcurl transport: one multi handle, at most `maxConnections` connections kept for reuse.
 * Throws std::runtime_error only if libcurl cannot initialise. */
std::unique_ptr<ITransport> makeCurlTransport(std::size_t maxConnections);

} // namespace tellus
