#pragma once
// The Fetcher's state and its two halves: what any thread may call (Fetcher.cpp: fetch(),
// policies, the breaker's and the stats' reads) and the fetcher thread's loop (Fetcher.cpp: admit,
// timers, per-upstream queues; FetchAttempts.cpp: one attempt from its request to its outcome).
// The network is an ITransport (CurlTransport.cpp in production), time a Clock.

#include "upstream/FetchPolicy.hpp"

#include <tellus/cache/Clock.hpp>
#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/Transport.hpp>

#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

namespace tellus {

struct Fetcher::Impl {
  using SteadyTime = std::chrono::steady_clock::time_point;
  using milliseconds = std::chrono::milliseconds;
  struct Upstream;

  /** One fetch(), from its call to its callback. */
  struct Job {
    FetchRequest request;
    std::function<void(FetchResult&&)> done;
    std::shared_ptr<const UpstreamPolicy> policy; ///< the policy when fetch() was called
    Upstream* upstream = nullptr;
    SteadyTime start{};
    std::uint64_t seq = 0;
    int attempts = 0;
    bool probe = false; ///< the half-open probe: one attempt, its outcome decides the breaker
    FetchError lastError{};
    std::string url; ///< this attempt's: the request's, or where its redirects led
    int hops = 0;    ///< redirects followed in this attempt
  };
  using JobPtr = std::unique_ptr<Job>;

  struct Upstream {
    // Guarded by Impl::mutex_.
    std::shared_ptr<const UpstreamPolicy> policy = std::make_shared<const UpstreamPolicy>();
    fetch::Breaker breaker;
    SteadyTime pausedUntil{}; ///< Retry-After: no requests before this
    Fetcher::Stats stats{};
    // Fetcher thread only.
    bool known = false;
    std::deque<JobPtr> queue; ///< waiting for a connection under the upstream's cap
    int active = 0;
  };

  Impl(std::unique_ptr<ITransport> transport, const Clock& clock, std::size_t maxTotal);
  ~Impl();

  // ---- any thread (Fetcher.cpp) ----
  Upstream& upstreamLocked(const std::string& name);
  const Upstream* findLocked(const std::string& name) const;
  void setPolicy(const std::string& name, UpstreamPolicy policy);
  void fetch(FetchRequest request, std::function<void(FetchResult&&)> done);
  BreakerState breaker(const std::string& name) const;
  milliseconds unavailableFor(const std::string& name) const;
  Fetcher::Stats stats(const std::string& name) const;
  std::vector<std::string> upstreamNames() const;

  // ---- the fetcher thread's loop (Fetcher.cpp) ----
  void run();
  void admit(JobPtr job);
  int pollTimeoutMs() const;
  void fireTimers();
  void startTransfers();
  void shutdown();

  // ---- one attempt (FetchAttempts.cpp), fetcher thread ----
  static void invoke(Job& job, FetchResult&& result) noexcept;
  void complete(JobPtr job, FetchResult result);
  void fail(JobPtr job, FetchErrc code, std::string message, int httpStatus = 0);
  void circuitOpen(JobPtr job);
  /** Starts a transfer: a new attempt, or (`hop`) the next request of one whose answer was a
   * redirect that is followed. */
  void startAttempt(JobPtr job, bool hop = false);
  /** A transfer has finished: redirect, retry later, or complete. */
  void finished(ITransport::Id id, TransferResult&& result);
  /** Schedules another attempt when `c` is worth one; false (job untouched) when it is not. */
  bool retryLater(JobPtr& job, fetch::Classified& c, bool breakerClosed);
  /** A redirect to `location`: followed at once when the policy allows it (same origin, or any
   * with `Any`; at most maxRedirects), else the fetch fails with FetchErrc::Redirect. The hop is
   * no new attempt: a retry after a failure starts again from the URL asked. */
  void redirect(JobPtr job, Upstream& up, std::string location, int status);
  void succeed(JobPtr job, FetchResponse&& response);
  milliseconds backoff(milliseconds base, int retry);
  /** Updates the breaker with a finished fetch; true when it has just opened. */
  bool recordVerdict(Upstream& up, bool probe, fetch::Verdict v);
  /** The breaker opened: queued fetches fail now, retries waiting for a timer give up now. */
  void flush(Upstream& up);

  const Clock& clock_;
  const std::unique_ptr<ITransport> transport_;
  const std::size_t maxTotal_;

  mutable std::mutex mutex_;
  // Guarded by mutex_.
  std::map<std::string, std::unique_ptr<Upstream>, std::less<>> upstreams_;
  std::vector<JobPtr> incoming_;
  std::uint64_t nextSeq_ = 0;
  bool stopping_ = false;
  bool closed_ = false;

  // Fetcher thread only.
  std::vector<Upstream*> known_;
  std::unordered_map<ITransport::Id, JobPtr> active_;
  ITransport::Id nextId_ = 1;
  std::multimap<SteadyTime, JobPtr> timers_;
  std::mt19937_64 rng_;

  std::thread thread_; // last: started when everything else is
};

} // namespace tellus
