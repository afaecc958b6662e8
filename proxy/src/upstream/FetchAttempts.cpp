// One attempt of a fetch on the fetcher thread: its request handed to the transport, then its
// outcome: a redirect followed (or refused), a retry scheduled on a timer (backoff, Retry-After),
// or the fetch completed and its callback run; the breaker is told each outcome.
#include "upstream/FetcherImpl.hpp"

#include <tellus/proxy/Log.hpp>

#include <algorithm>

namespace tellus {

void Fetcher::Impl::invoke(Job& job, FetchResult&& result) noexcept {
  if (!job.done) return;
  try {
    job.done(std::move(result));
  } catch (...) {
    // A callback's exception must not cross into the fetcher loop; the fetch is complete.
  }
}

void Fetcher::Impl::complete(JobPtr job, FetchResult result) {
  const auto now = clock_.steady();
  if (result) {
    result->attempts = job->attempts;
    result->elapsed = std::chrono::duration_cast<milliseconds>(now - job->start);
  } else if (result.error().attempts == 0) {
    result.error().attempts = job->attempts;
  }
  if (job->upstream) {
    std::lock_guard lock(mutex_);
    Fetcher::Stats& st = job->upstream->stats;
    --st.inFlight;
    if (!result) {
      ++st.failures;
      const auto code = static_cast<std::size_t>(result.error().code);
      if (code < st.errorsByCode.size()) ++st.errorsByCode[code];
    }
    if (job->attempts > 0) {
      const double s = std::chrono::duration<double>(now - job->start).count();
      for (std::size_t i = 0; i < Fetcher::kLatencyBounds.size(); ++i) {
        if (s <= Fetcher::kLatencyBounds[i]) ++st.latencyBuckets[i];
      }
      ++st.latencyBuckets.back();
      ++st.latencyCount;
      st.latencySumSeconds += s;
    }
  }
  invoke(*job, std::move(result));
}

void Fetcher::Impl::fail(JobPtr job, FetchErrc code, std::string message, int httpStatus) {
  FetchError e{code, std::move(message), httpStatus, job->attempts};
  complete(std::move(job), std::unexpected(std::move(e)));
}

void Fetcher::Impl::circuitOpen(JobPtr job) {
  std::string msg = "upstream '" + job->request.upstream + "' is unreachable (circuit open)";
  FetchError e{FetchErrc::CircuitOpen, std::move(msg), 0, job->attempts};
  complete(std::move(job), std::unexpected(std::move(e)));
}

void Fetcher::Impl::startAttempt(JobPtr job, bool hop) {
  Upstream& up = *job->upstream;
  const UpstreamPolicy& policy = *job->policy;
  auto headers = fetch::requestHeaderLines(policy, job->request, job->url, job->hops);
  if (!headers) return fail(std::move(job), FetchErrc::Unknown, "invalid request header");
  TransferRequest t;
  t.url = job->url;
  t.headerLines = std::move(*headers);
  t.connectTimeout = policy.connectTimeout;
  t.timeout = policy.timeout;
  t.maxBodyBytes = policy.maxBodyBytes;
  t.pool = job->request.upstream;
  t.keepIdle = static_cast<std::size_t>(std::max(1, policy.maxConnections));
  const ITransport::Id id = nextId_++;
  if (auto started = transport_->start(id, t); !started)
    return fail(std::move(job), FetchErrc::Unknown, std::move(started.error()));
  if (!hop) {
    ++job->attempts;
    if (job->attempts > 1) {
      std::lock_guard lock(mutex_);
      ++up.stats.retries;
    }
  }
  ++up.active;
  active_.emplace(id, std::move(job));
}

void Fetcher::Impl::finished(ITransport::Id id, TransferResult&& result) {
  auto it = active_.find(id);
  if (it == active_.end()) return;
  JobPtr job = std::move(it->second);
  active_.erase(it);
  Upstream& up = *job->upstream;
  --up.active;

  const int status = result.status;
  std::string location;
  if (result.failure == TransferFailure::None && fetch::isRedirect(status))
    location = std::move(result.location);
  fetch::Classified c =
      fetch::classify(std::move(result), job->policy->maxBodyBytes, clock_.wallNow());
  bool breakerClosed = false;
  {
    std::lock_guard lock(mutex_);
    breakerClosed = up.breaker.state == BreakerState::Closed;
  }
  if (!location.empty()) return redirect(std::move(job), up, std::move(location), status);
  if (retryLater(job, c, breakerClosed)) return;
  c.error.attempts = job->attempts;
  const bool opened = recordVerdict(up, job->probe, c.verdict);
  if (c.response)
    succeed(std::move(job), std::move(*c.response));
  else
    complete(std::move(job), std::unexpected(std::move(c.error)));
  if (opened) flush(up);
}

bool Fetcher::Impl::retryLater(JobPtr& job, fetch::Classified& c, bool breakerClosed) {
  Upstream& up = *job->upstream;
  const UpstreamPolicy& policy = *job->policy;
  bool waitable = true;
  if (c.retryAfter) {
    const auto asked = std::min<milliseconds>(*c.retryAfter, std::chrono::hours(1));
    std::lock_guard lock(mutex_);
    up.pausedUntil = std::max(up.pausedUntil, clock_.steady() + asked);
    waitable = asked <= policy.maxRetryAfterWait;
    if (!waitable) {
      c.error.message += " (asked to retry after " +
                         std::to_string(std::chrono::ceil<std::chrono::seconds>(asked).count()) +
                         " s)";
    }
  }
  if (c.response || !c.retryable || !waitable || job->probe || job->attempts > policy.retries ||
      !breakerClosed)
    return false;
  c.error.attempts = job->attempts;
  job->lastError = std::move(c.error);
  job->url = job->request.url; // a retry starts from the URL asked, not where it was led
  job->hops = 0;
  auto at = clock_.steady() + backoff(policy.retryBackoff, job->attempts - 1);
  {
    std::lock_guard lock(mutex_);
    at = std::max(at, up.pausedUntil); // never earlier than the upstream asked
  }
  timers_.emplace(at, std::move(job));
  return true;
}

void Fetcher::Impl::succeed(JobPtr job, FetchResponse&& response) {
  response.url = job->url;
  response.redirects = job->hops;
  // The final URL: worth the operator's attention when it is on another origin.
  const LogLevel level = job->hops > 0 && urlOrigin(job->url) != urlOrigin(job->request.url)
                             ? LogLevel::Info
                             : LogLevel::Debug;
  if (job->hops > 0 && logger().enabled(level)) {
    logger().log(level,
                 "fetcher",
                 "fetched through redirects",
                 {{"upstream", job->request.upstream},
                  {"url", job->request.url},
                  {"final_url", job->url},
                  {"redirects", std::to_string(job->hops)}});
  }
  complete(std::move(job), std::move(response));
}

void Fetcher::Impl::redirect(JobPtr job, Upstream& up, std::string location, int status) {
  std::string why =
      fetch::redirectRefusal(*job->policy, job->request.url, location, job->hops, status);
  if (!why.empty()) {
    logger().log(LogLevel::Warn,
                 "fetcher",
                 "redirect refused",
                 {{"upstream", job->request.upstream},
                  {"url", job->url},
                  {"location", location},
                  {"why", why}});
    const bool opened = recordVerdict(up, job->probe, fetch::Verdict::Neutral);
    fail(std::move(job), FetchErrc::Redirect, std::move(why), status);
    if (opened) flush(up);
    return;
  }
  if (logger().enabled(LogLevel::Debug) && urlOrigin(job->request.url) != urlOrigin(location)) {
    logger().log(LogLevel::Debug,
                 "fetcher",
                 "following a redirect to another origin, without the configured headers",
                 {{"upstream", job->request.upstream}, {"url", job->url}, {"location", location}});
  }
  job->url = std::move(location);
  ++job->hops;
  startAttempt(std::move(job), true);
}

std::chrono::milliseconds Fetcher::Impl::backoff(milliseconds base, int retry) {
  std::uniform_int_distribution<std::int64_t> dist(0, fetch::backoffCeiling(base, retry).count());
  return milliseconds(dist(rng_));
}

bool Fetcher::Impl::recordVerdict(Upstream& up, bool probe, fetch::Verdict v) {
  std::lock_guard lock(mutex_);
  return up.breaker.record(probe, v, clock_.steady(), *up.policy);
}

void Fetcher::Impl::flush(Upstream& up) {
  std::deque<JobPtr> queued;
  queued.swap(up.queue);
  for (auto& job : queued)
    circuitOpen(std::move(job));
  std::vector<JobPtr> waiting;
  for (auto it = timers_.begin(); it != timers_.end();) {
    if (it->second->upstream == &up) {
      waiting.push_back(std::move(it->second));
      it = timers_.erase(it);
    } else {
      ++it;
    }
  }
  for (auto& job : waiting) {
    FetchError e = job->lastError;
    complete(std::move(job), std::unexpected(std::move(e)));
  }
}

} // namespace tellus
