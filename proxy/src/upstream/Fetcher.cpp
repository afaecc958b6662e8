// The Fetcher's public face and its thread's loop: fetch() hands a job to the fetcher thread,
// which admits it (breaker, Retry-After pause), queues it under its upstream's connection cap,
// starts transfers on the transport, fires retry timers and waits in the transport's poll().
// One attempt's life is in FetchAttempts.cpp, the policies in FetchPolicy.cpp.
#include "upstream/FetcherImpl.hpp"

#include <algorithm>
#include <limits>

namespace tellus {

Fetcher::Impl::Impl(std::unique_ptr<ITransport> transport, const Clock& clock, std::size_t maxTotal)
    : clock_(clock), transport_(std::move(transport)),
      maxTotal_(std::max<std::size_t>(1, maxTotal)) {
  std::random_device seed;
  rng_.seed((static_cast<std::uint64_t>(seed()) << 32) ^ seed());
  thread_ = std::thread([this] { run(); });
}

Fetcher::Impl::~Impl() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    transport_->wake();
  }
  thread_.join();
}

// ---- any thread ---------------------------------------------------------------------------------

Fetcher::Impl::Upstream& Fetcher::Impl::upstreamLocked(const std::string& name) {
  auto it = upstreams_.find(name);
  if (it == upstreams_.end()) it = upstreams_.emplace(name, std::make_unique<Upstream>()).first;
  return *it->second;
}

const Fetcher::Impl::Upstream* Fetcher::Impl::findLocked(const std::string& name) const {
  auto it = upstreams_.find(name);
  return it == upstreams_.end() ? nullptr : it->second.get();
}

void Fetcher::Impl::setPolicy(const std::string& name, UpstreamPolicy policy) {
  policy.maxConnections = std::max(1, policy.maxConnections);
  policy.retries = std::max(0, policy.retries);
  policy.failureThreshold = std::max(1, policy.failureThreshold);
  std::lock_guard lock(mutex_);
  upstreamLocked(name).policy = std::make_shared<const UpstreamPolicy>(std::move(policy));
  transport_->wake(); // a raised cap may let queued jobs start
}

void Fetcher::Impl::fetch(FetchRequest request, std::function<void(FetchResult&&)> done) {
  auto job = std::make_unique<Job>();
  job->request = std::move(request);
  job->url = job->request.url;
  job->done = std::move(done);
  job->start = clock_.steady();
  {
    std::lock_guard lock(mutex_);
    if (!closed_) {
      Upstream& up = upstreamLocked(job->request.upstream);
      job->upstream = &up;
      job->policy = up.policy;
      job->seq = nextSeq_++;
      ++up.stats.requests;
      ++up.stats.inFlight;
      incoming_.push_back(std::move(job));
      transport_->wake();
      return;
    }
  }
  // Only reachable from a callback after shutdown finished: nothing will ever run it.
  invoke(*job, std::unexpected(FetchError{FetchErrc::Cancelled, "fetcher stopped", 0, 0}));
}

BreakerState Fetcher::Impl::breaker(const std::string& name) const {
  std::lock_guard lock(mutex_);
  const Upstream* up = findLocked(name);
  return up ? up->breaker.observed(clock_.steady()) : BreakerState::Closed;
}

std::chrono::milliseconds Fetcher::Impl::unavailableFor(const std::string& name) const {
  std::lock_guard lock(mutex_);
  const Upstream* up = findLocked(name);
  if (!up) return milliseconds(0);
  const auto now = clock_.steady();
  auto until = up->pausedUntil;
  if (up->breaker.state != BreakerState::Closed) until = std::max(until, up->breaker.openUntil);
  return until > now ? std::chrono::ceil<milliseconds>(until - now) : milliseconds(0);
}

Fetcher::Stats Fetcher::Impl::stats(const std::string& name) const {
  Fetcher::Stats s;
  {
    std::lock_guard lock(mutex_);
    const Upstream* up = findLocked(name);
    if (!up) return s;
    s = up->stats;
  }
  s.breaker = breaker(name);
  return s;
}

std::vector<std::string> Fetcher::Impl::upstreamNames() const {
  std::lock_guard lock(mutex_);
  std::vector<std::string> out;
  for (const auto& [name, up] : upstreams_)
    out.push_back(name);
  return out;
}

// ---- the fetcher thread's loop ------------------------------------------------------------------

void Fetcher::Impl::run() {
  for (;;) {
    std::vector<JobPtr> incoming;
    {
      std::lock_guard lock(mutex_);
      if (stopping_) break;
      incoming.swap(incoming_);
    }
    try {
      for (auto& job : incoming)
        admit(std::move(job));
      incoming.clear();
      fireTimers();
      startTransfers();
      for (auto& [id, result] : transport_->perform())
        finished(id, std::move(result));
      startTransfers();
    } catch (...) {
      // Only allocation failures can get here; fail what was being admitted and go on.
      for (auto& job : incoming) {
        if (job) fail(std::move(job), FetchErrc::Unknown, "internal error");
      }
    }
    transport_->poll(milliseconds(pollTimeoutMs()));
  }
  shutdown();
}

void Fetcher::Impl::admit(JobPtr job) {
  Upstream& up = *job->upstream;
  if (!up.known) {
    up.known = true;
    known_.push_back(&up);
  }
  bool reject = false;
  bool paused = false;
  {
    std::lock_guard lock(mutex_);
    const auto now = clock_.steady();
    reject = up.breaker.refuses(now);
    paused = now < up.pausedUntil;
  }
  if (reject) return circuitOpen(std::move(job));
  if (paused) {
    return fail(std::move(job),
                FetchErrc::Throttled,
                "upstream '" + job->request.upstream + "' asked for a pause (Retry-After)");
  }
  up.queue.push_back(std::move(job));
}

int Fetcher::Impl::pollTimeoutMs() const {
  if (timers_.empty()) return 1000;
  const auto wait = timers_.begin()->first - clock_.steady();
  const auto ms = std::chrono::ceil<milliseconds>(wait).count();
  return static_cast<int>(std::clamp<std::int64_t>(ms, 0, 1000));
}

void Fetcher::Impl::fireTimers() {
  const auto now = clock_.steady();
  while (!timers_.empty() && timers_.begin()->first <= now) {
    JobPtr job = std::move(timers_.begin()->second);
    timers_.erase(timers_.begin());
    bool closed = false;
    {
      std::lock_guard lock(mutex_);
      closed = job->upstream->breaker.state == BreakerState::Closed;
    }
    if (closed) {
      job->upstream->queue.push_front(std::move(job)); // it was ahead of everything queued
    } else {
      FetchError e = job->lastError;
      complete(std::move(job), std::unexpected(std::move(e)));
    }
  }
}

void Fetcher::Impl::startTransfers() {
  while (active_.size() < maxTotal_) {
    // The oldest queued job among the upstreams below their cap.
    Upstream* best = nullptr;
    {
      std::lock_guard lock(mutex_);
      for (Upstream* up : known_) {
        if (up->queue.empty() || up->active >= up->policy->maxConnections) continue;
        if (!best || up->queue.front()->seq < best->queue.front()->seq) best = up;
      }
    }
    if (!best) return;
    JobPtr job = std::move(best->queue.front());
    best->queue.pop_front();
    fetch::Breaker::Gate gate = fetch::Breaker::Gate::Go;
    {
      std::lock_guard lock(mutex_);
      gate = best->breaker.gate(clock_.steady());
    }
    if (gate == fetch::Breaker::Gate::Refuse) {
      circuitOpen(std::move(job));
      continue;
    }
    job->probe = gate == fetch::Breaker::Gate::Probe;
    startAttempt(std::move(job));
  }
}

void Fetcher::Impl::shutdown() {
  std::vector<JobPtr> cancelled;
  transport_->abandonAll();
  for (auto& [id, job] : active_) {
    --job->upstream->active;
    cancelled.push_back(std::move(job));
  }
  active_.clear();
  for (auto& [due, job] : timers_)
    cancelled.push_back(std::move(job));
  timers_.clear();
  for (Upstream* up : known_) {
    for (auto& job : up->queue)
      cancelled.push_back(std::move(job));
    up->queue.clear();
  }
  for (;;) {
    for (auto& job : cancelled)
      fail(std::move(job), FetchErrc::Cancelled, "fetcher stopped");
    cancelled.clear();
    // Callbacks may have queued more; those are cancelled too, then fetch() stops queueing.
    std::lock_guard lock(mutex_);
    if (incoming_.empty()) {
      closed_ = true;
      break;
    }
    cancelled.swap(incoming_);
  }
}

// ---- Fetcher
// --------------------------------------------------------------------------------------

Fetcher::Fetcher(std::size_t maxTotalConnections)
    : Fetcher(makeCurlTransport(std::max<std::size_t>(1, maxTotalConnections)),
              Clock::system(),
              maxTotalConnections) {}

Fetcher::Fetcher(std::unique_ptr<ITransport> transport,
                 const Clock& clock,
                 std::size_t maxTotalConnections)
    : impl_(std::make_unique<Impl>(std::move(transport), clock, maxTotalConnections)) {}

Fetcher::~Fetcher() = default;

void Fetcher::setPolicy(const std::string& upstream, UpstreamPolicy policy) {
  impl_->setPolicy(upstream, std::move(policy));
}

void Fetcher::fetch(FetchRequest request, std::function<void(FetchResult&&)> done) {
  impl_->fetch(std::move(request), std::move(done));
}

BreakerState Fetcher::breaker(const std::string& upstream) const {
  return impl_->breaker(upstream);
}

bool Fetcher::reachable(const std::string& upstream) const {
  return impl_->breaker(upstream) != BreakerState::Open;
}

std::chrono::milliseconds Fetcher::unavailableFor(const std::string& upstream) const {
  return impl_->unavailableFor(upstream);
}

Fetcher::Stats Fetcher::stats(const std::string& upstream) const {
  return impl_->stats(upstream);
}

std::vector<std::string> Fetcher::upstreams() const {
  return impl_->upstreamNames();
}

} // namespace tellus

static_assert(static_cast<std::size_t>(tellus::FetchErrc::Unknown) + 1 ==
                  std::tuple_size_v<decltype(tellus::Fetcher::Stats::errorsByCode)>,
              "Fetcher::Stats::errorsByCode needs one slot per FetchErrc");
