#pragma once
// The Fetcher's policies as plain functions and values, apart from the loop that applies them
// (Fetcher.cpp) and from the transport (CurlTransport.cpp): what an answer means (classify), the
// circuit breaker, the retry backoff's ceiling, which redirects are followed and which headers
// go to which origin. Nothing here reads a clock or touches the network: times come in as
// arguments.

#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/Transport.hpp>

#include <chrono>
#include <optional>
#include <string>
#include <vector>

namespace tellus::fetch {

using SteadyTime = std::chrono::steady_clock::time_point;
using std::chrono::milliseconds;

/** What a finished fetch means to the breaker. */
enum class Verdict { Success, Failure, Neutral };

/**
 * @brief One upstream's circuit breaker: `failureThreshold` consecutive failed fetches open it;
 * open, every fetch fails at once until `openInterval` has passed; then one probe goes out (half
 * open) and its outcome closes or re-opens it.
 */
struct Breaker {
  BreakerState state = BreakerState::Closed; ///< HalfOpen: the probe is in flight
  int consecutiveFailures = 0;
  SteadyTime openUntil{};

  /** As a new fetch would meet it: open with its interval over reads HalfOpen. */
  BreakerState observed(SteadyTime now) const noexcept;
  /** A fetch arriving now fails at once (open within its interval, or a probe is out). */
  bool refuses(SteadyTime now) const noexcept;
  /** Whether a queued fetch may start now: Go, Probe (the breaker turns half open and this fetch
   * is its probe) or Refuse. */
  enum class Gate { Go, Probe, Refuse };
  Gate gate(SteadyTime now) noexcept;
  /** A finished fetch's verdict; true when the breaker has just opened. A probe's neutral outcome
   * (a bad URL, an odd status) says nothing: the next fetch probes again. */
  bool record(bool probe, Verdict v, SteadyTime now, const UpstreamPolicy& policy) noexcept;
};

/** A transfer's result as the Fetcher sees it. */
struct Classified {
  std::optional<FetchResponse> response; ///< 2xx, 304 or 4xx (not 429)
  FetchError error;                      ///< otherwise
  bool retryable = false;
  Verdict verdict = Verdict::Neutral;
  std::optional<milliseconds> retryAfter; ///< 429/503 with a valid Retry-After
};

/** What `result` means: an answer, or an error that is retried or not and counts for the breaker
 * or not. `maxBodyBytes` is the request's (for the message); `wallNow` dates Retry-After. */
Classified classify(TransferResult&& result,
                    std::size_t maxBodyBytes,
                    std::chrono::system_clock::time_point wallNow);

/** 301, 302, 303, 307, 308. */
bool isRedirect(int status) noexcept;

/** The ceiling of the n-th retry's random wait: base * 2^retry, at most 10 minutes. */
milliseconds backoffCeiling(milliseconds base, int retry) noexcept;

/** Why a redirect from `url` (the fetch asked `askedUrl`) to `location` is not followed ("" when
 * it is), after `hops` redirects. */
std::string redirectRefusal(const UpstreamPolicy& policy,
                            const std::string& askedUrl,
                            const std::string& location,
                            int hops,
                            int status);

/** The header lines of a request to `url` (redirects followed: `hops`): the configured headers
 * only within the origin of `request.url`, then the conditional ones; nullopt when one of them
 * could split the request (CR, LF, a colon in a name). */
std::optional<std::vector<std::string>> requestHeaderLines(const UpstreamPolicy& policy,
                                                           const FetchRequest& request,
                                                           const std::string& url,
                                                           int hops);

} // namespace tellus::fetch
