#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/Log.hpp>
#include <tellus/proxy/ProxyFrontEnd.hpp> // parseHttpDate

#include <curl/curl.h>

#include <algorithm>
#include <cstring>
#include <deque>
#include <limits>
#include <map>
#include <mutex>
#include <optional>
#include <random>
#include <stdexcept>
#include <string_view>
#include <thread>
#include <unordered_map>

namespace tellus {

std::optional<std::chrono::milliseconds>
parseRetryAfter(std::string_view value, std::chrono::system_clock::time_point now) {
  if (value.empty()) return std::nullopt;
  if (std::all_of(value.begin(), value.end(), [](char c) { return c >= '0' && c <= '9'; })) {
    if (value.size() > 9) return std::chrono::hours(24 * 365); // absurdly long: capped by callers
    std::int64_t s = 0;
    for (char c : value)
      s = s * 10 + (c - '0');
    return std::chrono::seconds(s);
  }
  const auto at = parseHttpDate(value);
  if (!at) return std::nullopt;
  const auto nowMs =
      std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count();
  return std::chrono::milliseconds(std::max<std::int64_t>(0, *at - nowMs));
}

const char* toString(FetchErrc code) noexcept {
  switch (code) {
  case FetchErrc::Timeout:
    return "timeout";
  case FetchErrc::Connect:
    return "connect";
  case FetchErrc::CircuitOpen:
    return "circuit-open";
  case FetchErrc::HttpError:
    return "http-error";
  case FetchErrc::Truncated:
    return "truncated";
  case FetchErrc::TooLarge:
    return "too-large";
  case FetchErrc::Cancelled:
    return "cancelled";
  case FetchErrc::Throttled:
    return "throttled";
  case FetchErrc::Redirect:
    return "redirect";
  case FetchErrc::Unknown:
    return "unknown";
  }
  return "unknown";
}

std::optional<std::string> urlOrigin(std::string_view url) {
  CURLU* h = curl_url();
  if (!h) return std::nullopt;
  std::optional<std::string> out;
  const std::string u(url);
  if (curl_url_set(h, CURLUPART_URL, u.c_str(), 0) == CURLUE_OK) {
    char* scheme = nullptr;
    char* host = nullptr;
    char* port = nullptr;
    if (curl_url_get(h, CURLUPART_SCHEME, &scheme, 0) == CURLUE_OK &&
        curl_url_get(h, CURLUPART_HOST, &host, 0) == CURLUE_OK &&
        curl_url_get(h, CURLUPART_PORT, &port, CURLU_DEFAULT_PORT) == CURLUE_OK) {
      std::string o = std::string(scheme) + "://" + host + ":" + port;
      std::transform(o.begin(), o.end(), o.begin(), [](unsigned char c) {
        return static_cast<char>(std::tolower(c));
      });
      out = std::move(o);
    }
    curl_free(scheme);
    curl_free(host);
    curl_free(port);
  }
  curl_url_cleanup(h);
  return out;
}

namespace {

using std::chrono::milliseconds;

/// What a finished fetch means to the breaker.
enum class Verdict { Success, Failure, Neutral };

char lower(char c) noexcept {
  return (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c;
}

bool iequals(std::string_view a, std::string_view b) noexcept {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (lower(a[i]) != lower(b[i])) return false;
  }
  return true;
}

std::string_view trim(std::string_view s) noexcept {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t'))
    s.remove_prefix(1);
  while (!s.empty() &&
         (s.back() == ' ' || s.back() == '\t' || s.back() == '\r' || s.back() == '\n'))
    s.remove_suffix(1);
  return s;
}

bool validHeaderPart(std::string_view s) noexcept {
  return s.find_first_of("\r\n") == std::string_view::npos;
}

long toLongMs(milliseconds ms) noexcept {
  return static_cast<long>(
      std::clamp<std::int64_t>(ms.count(), 1, std::numeric_limits<int>::max()));
}

void globalInit() {
  // Once per process, before any easy or multi handle exists.
  static const CURLcode rc = curl_global_init(CURL_GLOBAL_DEFAULT);
  if (rc != CURLE_OK) throw std::runtime_error("curl_global_init failed");
}

} // namespace

struct Fetcher::Impl {
  using Clock = std::chrono::steady_clock; // here: tellus::Clock is the cache's injected clock
  struct Upstream;

  struct Job {
    FetchRequest request;
    std::function<void(FetchResult&&)> done;
    std::shared_ptr<const UpstreamPolicy> policy; ///< the policy when fetch() was called
    Upstream* upstream = nullptr;
    Clock::time_point start{};
    std::uint64_t seq = 0;
    int attempts = 0;
    bool probe = false; ///< the half-open probe: one attempt, its outcome decides the breaker
    FetchError lastError{};
    std::string url; ///< this attempt's: the request's, or where its redirects led
    int hops = 0;    ///< redirects followed in this attempt
  };
  using JobPtr = std::unique_ptr<Job>;

  struct Upstream {
    // Guarded by Impl::mutex.
    std::shared_ptr<const UpstreamPolicy> policy = std::make_shared<const UpstreamPolicy>();
    BreakerState state = BreakerState::Closed; ///< HalfOpen: the probe is in flight
    int consecutiveFailures = 0;
    Clock::time_point openUntil{};
    Clock::time_point pausedUntil{}; ///< Retry-After: no requests before this
    Fetcher::Stats stats{};
    // Fetcher thread only.
    bool known = false;
    std::deque<JobPtr> queue;
    int active = 0;
    std::vector<CURL*> idle; ///< easy handles kept for reuse
  };

  struct Transfer {
    JobPtr job;
    CURL* easy = nullptr;
    curl_slist* headers = nullptr;
    std::vector<std::byte> body;
    std::size_t maxBody = 0;
    bool tooLarge = false;
    bool outOfMemory = false;
    std::string contentType, etag, lastModified, cacheControl, expires, retryAfter;
    char errbuf[CURL_ERROR_SIZE] = {};
    Transfer() = default;
    Transfer(const Transfer&) = delete;
    Transfer& operator=(const Transfer&) = delete;
    ~Transfer() { curl_slist_free_all(headers); }
  };

  explicit Impl(std::size_t maxTotal) : maxTotal_(std::max<std::size_t>(1, maxTotal)) {
    globalInit();
    multi_ = curl_multi_init();
    if (!multi_) throw std::runtime_error("curl_multi_init failed");
    curl_multi_setopt(
        multi_,
        CURLMOPT_MAXCONNECTS,
        static_cast<long>(std::min<std::size_t>(maxTotal_, std::numeric_limits<int>::max())));
    std::random_device seed;
    rng_.seed((static_cast<std::uint64_t>(seed()) << 32) ^ seed());
    thread_ = std::thread([this] { run(); });
  }

  ~Impl() {
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
      curl_multi_wakeup(multi_);
    }
    thread_.join();
    curl_multi_cleanup(multi_);
  }

  // ---- any thread -------------------------------------------------------------------------------

  Upstream& upstreamLocked(const std::string& name) {
    auto it = upstreams_.find(name);
    if (it == upstreams_.end()) it = upstreams_.emplace(name, std::make_unique<Upstream>()).first;
    return *it->second;
  }

  const Upstream* findLocked(const std::string& name) const {
    auto it = upstreams_.find(name);
    return it == upstreams_.end() ? nullptr : it->second.get();
  }

  void setPolicy(const std::string& name, UpstreamPolicy policy) {
    policy.maxConnections = std::max(1, policy.maxConnections);
    policy.retries = std::max(0, policy.retries);
    policy.failureThreshold = std::max(1, policy.failureThreshold);
    std::lock_guard lock(mutex_);
    upstreamLocked(name).policy = std::make_shared<const UpstreamPolicy>(std::move(policy));
    curl_multi_wakeup(multi_); // a raised cap may let queued jobs start
  }

  void fetch(FetchRequest request, std::function<void(FetchResult&&)> done) {
    auto job = std::make_unique<Job>();
    job->request = std::move(request);
    job->url = job->request.url;
    job->done = std::move(done);
    job->start = Clock::now();
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
        curl_multi_wakeup(multi_);
        return;
      }
    }
    // Only reachable from a callback after shutdown finished: nothing will ever run it.
    invoke(*job, std::unexpected(FetchError{FetchErrc::Cancelled, "fetcher stopped", 0, 0}));
  }

  BreakerState breaker(const std::string& name) const {
    std::lock_guard lock(mutex_);
    const Upstream* up = findLocked(name);
    if (!up) return BreakerState::Closed;
    if (up->state == BreakerState::Open && Clock::now() >= up->openUntil)
      return BreakerState::HalfOpen;
    return up->state;
  }

  milliseconds unavailableFor(const std::string& name) const {
    std::lock_guard lock(mutex_);
    const Upstream* up = findLocked(name);
    if (!up) return milliseconds(0);
    const auto now = Clock::now();
    auto until = up->pausedUntil;
    if (up->state != BreakerState::Closed) until = std::max(until, up->openUntil);
    return until > now ? std::chrono::ceil<milliseconds>(until - now) : milliseconds(0);
  }

  Fetcher::Stats stats(const std::string& name) const {
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

  std::vector<std::string> upstreamNames() const {
    std::lock_guard lock(mutex_);
    std::vector<std::string> out;
    for (const auto& [name, up] : upstreams_)
      out.push_back(name);
    return out;
  }

  // ---- fetcher thread ---------------------------------------------------------------------------

  static void invoke(Job& job, FetchResult&& result) noexcept {
    if (!job.done) return;
    try {
      job.done(std::move(result));
    } catch (...) {
      // A callback's exception must not cross into the fetcher loop; the fetch is complete.
    }
  }

  void complete(JobPtr job, FetchResult result) {
    const auto now = Clock::now();
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

  void fail(JobPtr job, FetchErrc code, std::string message, int httpStatus = 0) {
    FetchError e{code, std::move(message), httpStatus, job->attempts};
    complete(std::move(job), std::unexpected(std::move(e)));
  }

  void circuitOpen(JobPtr job) {
    std::string msg = "upstream '" + job->request.upstream + "' is unreachable (circuit open)";
    FetchError e{FetchErrc::CircuitOpen, std::move(msg), 0, job->attempts};
    complete(std::move(job), std::unexpected(std::move(e)));
  }

  void run() {
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
        int running = 0;
        curl_multi_perform(multi_, &running);
        drainMessages();
        startTransfers();
      } catch (...) {
        // Only allocation failures can get here; fail what was being admitted and go on.
        for (auto& job : incoming) {
          if (job) fail(std::move(job), FetchErrc::Unknown, "internal error");
        }
      }
      curl_multi_poll(multi_, nullptr, 0, pollTimeoutMs(), nullptr);
    }
    shutdown();
  }

  void admit(JobPtr job) {
    Upstream& up = *job->upstream;
    if (!up.known) {
      up.known = true;
      known_.push_back(&up);
    }
    bool reject = false;
    bool paused = false;
    {
      std::lock_guard lock(mutex_);
      reject = up.state == BreakerState::HalfOpen ||
               (up.state == BreakerState::Open && Clock::now() < up.openUntil);
      paused = Clock::now() < up.pausedUntil;
    }
    if (reject) {
      circuitOpen(std::move(job));
      return;
    }
    if (paused) {
      fail(std::move(job),
           FetchErrc::Throttled,
           "upstream '" + job->request.upstream + "' asked for a pause (Retry-After)");
      return;
    }
    up.queue.push_back(std::move(job));
  }

  int pollTimeoutMs() const {
    if (timers_.empty()) return 1000;
    const auto wait = timers_.begin()->first - Clock::now();
    const auto ms = std::chrono::ceil<milliseconds>(wait).count();
    return static_cast<int>(std::clamp<std::int64_t>(ms, 0, 1000));
  }

  void fireTimers() {
    const auto now = Clock::now();
    while (!timers_.empty() && timers_.begin()->first <= now) {
      JobPtr job = std::move(timers_.begin()->second);
      timers_.erase(timers_.begin());
      bool closed = false;
      {
        std::lock_guard lock(mutex_);
        closed = job->upstream->state == BreakerState::Closed;
      }
      if (closed) {
        job->upstream->queue.push_front(std::move(job)); // it was ahead of everything queued
      } else {
        FetchError e = job->lastError;
        complete(std::move(job), std::unexpected(std::move(e)));
      }
    }
  }

  void startTransfers() {
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
      bool go = true;
      {
        std::lock_guard lock(mutex_);
        if (best->state == BreakerState::Open && Clock::now() >= best->openUntil) {
          best->state = BreakerState::HalfOpen;
          job->probe = true;
        } else if (best->state != BreakerState::Closed) {
          go = false;
        }
      }
      if (!go) {
        circuitOpen(std::move(job));
        continue;
      }
      startAttempt(std::move(job));
    }
  }

  /** Starts a transfer: a new attempt, or (`hop`) the next request of one whose answer was a
   * redirect that is followed. */
  void startAttempt(JobPtr job, bool hop = false) {
    Upstream& up = *job->upstream;
    const UpstreamPolicy& policy = *job->policy;
    CURL* easy = nullptr;
    if (!up.idle.empty()) {
      easy = up.idle.back(); // reset when it came back: connections and caches stay
      up.idle.pop_back();
    } else {
      easy = curl_easy_init();
    }
    if (!easy) {
      fail(std::move(job), FetchErrc::Unknown, "curl_easy_init failed");
      return;
    }
    auto t = std::make_unique<Transfer>();
    t->easy = easy;
    t->maxBody = policy.maxBodyBytes;

    bool headersOk = true;
    auto addHeader = [&](std::string_view name, std::string_view value) {
      if (name.empty() || !validHeaderPart(name) || !validHeaderPart(value) ||
          name.find(':') != std::string_view::npos) {
        headersOk = false;
        return;
      }
      std::string line;
      line.reserve(name.size() + value.size() + 2);
      line.append(name).append(": ").append(value);
      if (curl_slist* next = curl_slist_append(t->headers, line.c_str()))
        t->headers = next;
      else
        headersOk = false;
    };
    // The configured headers (API keys among them) go to the upstream's own origin only.
    if (job->hops == 0 || urlOrigin(job->url) == urlOrigin(job->request.url)) {
      for (const auto& [name, value] : policy.headers)
        addHeader(name, value);
    }
    if (!job->request.ifNoneMatch.empty()) addHeader("If-None-Match", job->request.ifNoneMatch);
    if (!job->request.ifModifiedSince.empty())
      addHeader("If-Modified-Since", job->request.ifModifiedSince);
    if (!headersOk) {
      curl_easy_cleanup(easy);
      fail(std::move(job), FetchErrc::Unknown, "invalid request header");
      return;
    }

    curl_write_callback onBodyFn = &Impl::onBody;
    curl_write_callback onHeaderFn = &Impl::onHeader;
    Transfer* tp = t.get();
    CURLcode rc = CURLE_OK;
    auto set = [&](CURLcode r) {
      if (rc == CURLE_OK) rc = r;
    };
    set(curl_easy_setopt(easy, CURLOPT_URL, job->url.c_str()));
    set(curl_easy_setopt(easy, CURLOPT_PRIVATE, tp));
    set(curl_easy_setopt(easy, CURLOPT_WRITEFUNCTION, onBodyFn));
    set(curl_easy_setopt(easy, CURLOPT_WRITEDATA, tp));
    set(curl_easy_setopt(easy, CURLOPT_HEADERFUNCTION, onHeaderFn));
    set(curl_easy_setopt(easy, CURLOPT_HEADERDATA, tp));
    set(curl_easy_setopt(easy, CURLOPT_ERRORBUFFER, tp->errbuf));
    set(curl_easy_setopt(easy, CURLOPT_NOSIGNAL, 1L));
    set(curl_easy_setopt(easy, CURLOPT_HTTPGET, 1L));
    set(curl_easy_setopt(easy, CURLOPT_CONNECTTIMEOUT_MS, toLongMs(policy.connectTimeout)));
    set(curl_easy_setopt(easy, CURLOPT_TIMEOUT_MS, toLongMs(policy.timeout)));
    // Redirects are followed here, not by libcurl (finish() -> redirect()): libcurl would send
    // the configured headers to whatever host a redirect names.
    set(curl_easy_setopt(easy, CURLOPT_FOLLOWLOCATION, 0L));
    set(curl_easy_setopt(easy, CURLOPT_PROTOCOLS_STR, "http,https"));
    set(curl_easy_setopt(easy, CURLOPT_ACCEPT_ENCODING, ""));
    set(curl_easy_setopt(easy, CURLOPT_USERAGENT, "tellus"));
    set(curl_easy_setopt(easy, CURLOPT_TCP_KEEPALIVE, 1L));
    set(curl_easy_setopt(easy,
                         CURLOPT_MAXFILESIZE_LARGE,
                         static_cast<curl_off_t>(std::min<std::size_t>(
                             policy.maxBodyBytes,
                             static_cast<std::size_t>(std::numeric_limits<curl_off_t>::max())))));
    if (t->headers) set(curl_easy_setopt(easy, CURLOPT_HTTPHEADER, t->headers));
    if (rc != CURLE_OK) {
      curl_easy_cleanup(easy);
      fail(std::move(job),
           FetchErrc::Unknown,
           std::string("bad request: ") + curl_easy_strerror(rc));
      return;
    }

    if (!hop) {
      ++job->attempts;
      if (job->attempts > 1) {
        std::lock_guard lock(mutex_);
        ++up.stats.retries;
      }
    }
    t->job = std::move(job);
    if (curl_multi_add_handle(multi_, easy) != CURLM_OK) {
      JobPtr j = std::move(t->job);
      t.reset();
      curl_easy_cleanup(easy);
      fail(std::move(j), FetchErrc::Unknown, "curl_multi_add_handle failed");
      return;
    }
    ++up.active;
    active_.emplace(easy, std::move(t));
  }

  static std::size_t onBody(char* data, std::size_t size, std::size_t count, void* user) noexcept {
    auto* t = static_cast<Transfer*>(user);
    const std::size_t bytes = size * count;
    if (bytes > t->maxBody - t->body.size()) {
      t->tooLarge = true;
      return 0; // CURLE_WRITE_ERROR
    }
    try {
      const auto* p = reinterpret_cast<const std::byte*>(data);
      t->body.insert(t->body.end(), p, p + bytes);
    } catch (...) {
      t->outOfMemory = true;
      return 0;
    }
    return bytes;
  }

  static std::size_t
  onHeader(char* data, std::size_t size, std::size_t count, void* user) noexcept {
    auto* t = static_cast<Transfer*>(user);
    const std::size_t bytes = size * count;
    try {
      const std::string_view line(data, bytes);
      if (line.starts_with("HTTP/")) { // a new response (after a redirect or 100 Continue)
        t->contentType.clear();
        t->etag.clear();
        t->lastModified.clear();
        t->cacheControl.clear();
        t->expires.clear();
        t->retryAfter.clear();
        return bytes;
      }
      const auto colon = line.find(':');
      if (colon == std::string_view::npos) return bytes;
      const std::string_view name = trim(line.substr(0, colon));
      const std::string_view value = trim(line.substr(colon + 1));
      if (iequals(name, "content-type"))
        t->contentType = value;
      else if (iequals(name, "etag"))
        t->etag = value;
      else if (iequals(name, "last-modified"))
        t->lastModified = value;
      else if (iequals(name, "cache-control"))
        t->cacheControl = value;
      else if (iequals(name, "expires"))
        t->expires = value;
      else if (iequals(name, "retry-after"))
        t->retryAfter = value;
      else if (iequals(name, "content-length")) {
        std::size_t n = 0;
        bool digits = !value.empty() && value.size() < 19;
        for (char c : value) {
          if (c < '0' || c > '9') {
            digits = false;
            break;
          }
          n = n * 10 + static_cast<std::size_t>(c - '0');
        }
        if (digits && n <= t->maxBody) t->body.reserve(n);
      }
    } catch (...) {
      t->outOfMemory = true;
      return 0;
    }
    return bytes;
  }

  void drainMessages() {
    int left = 0;
    while (CURLMsg* msg = curl_multi_info_read(multi_, &left)) {
      if (msg->msg != CURLMSG_DONE) continue;
      CURL* easy = msg->easy_handle;
      const CURLcode rc = msg->data.result; // msg dies with remove_handle
      finish(easy, rc);
    }
  }

  struct Classified {
    std::optional<FetchResponse> response;
    FetchError error;
    bool retryable = false;
    Verdict verdict = Verdict::Neutral;
    std::optional<milliseconds> retryAfter; ///< 429/503 with a valid Retry-After
  };

  static Classified classify(Transfer& t, CURLcode rc, long status) {
    Classified c;
    auto err = [&](FetchErrc code, bool retryable, Verdict v, std::string what) {
      c.error = FetchError{code, std::move(what), static_cast<int>(status), 0};
      c.retryable = retryable;
      c.verdict = v;
    };
    const std::string detail = t.errbuf[0] ? std::string(t.errbuf) : curl_easy_strerror(rc);
    if (rc == CURLE_OK) {
      if (status == 429 || status == 503) {
        // The upstream is alive and asks us to slow down: not a failure for the breaker when it
        // says for how long; a bare 503 still counts as one.
        c.retryAfter = parseRetryAfter(t.retryAfter, std::chrono::system_clock::now());
        err(FetchErrc::HttpError,
            true,
            c.retryAfter || status == 429 ? Verdict::Neutral : Verdict::Failure,
            "HTTP " + std::to_string(status));
        return c;
      }
      if ((status >= 200 && status < 300) || status == 304 || (status >= 400 && status < 500)) {
        FetchResponse r;
        r.status = static_cast<int>(status);
        r.contentType = std::move(t.contentType);
        r.body = std::move(t.body);
        r.etag = std::move(t.etag);
        r.lastModified = std::move(t.lastModified);
        r.cacheControl = std::move(t.cacheControl);
        r.expires = std::move(t.expires);
        c.response = std::move(r);
        c.verdict = Verdict::Success;
      } else if (status >= 500) {
        err(FetchErrc::HttpError, true, Verdict::Failure, "HTTP " + std::to_string(status));
      } else {
        err(FetchErrc::HttpError, false, Verdict::Neutral, "HTTP " + std::to_string(status));
      }
      return c;
    }
    if (t.tooLarge || rc == CURLE_FILESIZE_EXCEEDED) {
      err(FetchErrc::TooLarge,
          false,
          Verdict::Success,
          "body larger than " + std::to_string(t.maxBody) + " bytes");
      return c;
    }
    if (t.outOfMemory) {
      err(FetchErrc::Unknown, false, Verdict::Neutral, "out of memory");
      return c;
    }
    switch (rc) {
    case CURLE_OPERATION_TIMEDOUT:
      err(FetchErrc::Timeout, true, Verdict::Failure, detail);
      break;
    case CURLE_COULDNT_RESOLVE_HOST:
    case CURLE_COULDNT_RESOLVE_PROXY:
    case CURLE_COULDNT_CONNECT:
    case CURLE_GOT_NOTHING:
    case CURLE_SEND_ERROR:
    case CURLE_RECV_ERROR:
    case CURLE_SSL_CONNECT_ERROR:
    case CURLE_HTTP2:
    case CURLE_HTTP2_STREAM:
      err(FetchErrc::Connect, true, Verdict::Failure, detail);
      break;
    case CURLE_PEER_FAILED_VERIFICATION:
    case CURLE_SSL_CERTPROBLEM:
    case CURLE_SSL_CACERT_BADFILE:
      err(FetchErrc::Connect, false, Verdict::Failure, detail);
      break;
    case CURLE_PARTIAL_FILE:
      err(FetchErrc::Truncated, true, Verdict::Failure, detail);
      break;
    case CURLE_TOO_MANY_REDIRECTS:
      err(FetchErrc::HttpError, false, Verdict::Neutral, detail);
      break;
    default:
      err(FetchErrc::Unknown, false, Verdict::Neutral, detail);
      break;
    }
    return c;
  }

  void finish(CURL* easy, CURLcode rc) {
    auto it = active_.find(easy);
    if (it == active_.end()) return;
    std::unique_ptr<Transfer> t = std::move(it->second);
    active_.erase(it);
    curl_multi_remove_handle(multi_, easy);
    long status = 0;
    curl_easy_getinfo(easy, CURLINFO_RESPONSE_CODE, &status);
    JobPtr job = std::move(t->job);
    Upstream& up = *job->upstream;
    --up.active;

    Classified c = classify(*t, rc, status);
    std::string location;
    if (rc == CURLE_OK && isRedirect(status)) {
      char* to = nullptr; // absolute, resolved against this request's URL
      if (curl_easy_getinfo(easy, CURLINFO_REDIRECT_URL, &to) == CURLE_OK && to) location = to;
    }
    curl_easy_reset(easy); // drop pointers into the transfer before it dies
    t.reset();
    int cap = 1;
    bool breakerClosed = false;
    {
      std::lock_guard lock(mutex_);
      cap = up.policy->maxConnections;
      breakerClosed = up.state == BreakerState::Closed;
    }
    if (up.idle.size() < static_cast<std::size_t>(cap))
      up.idle.push_back(easy);
    else
      curl_easy_cleanup(easy);

    if (!location.empty()) return redirect(std::move(job), up, std::move(location), status);

    const UpstreamPolicy& policy = *job->policy;
    bool waitable = true;
    if (c.retryAfter) {
      const auto asked = std::min<milliseconds>(*c.retryAfter, std::chrono::hours(1));
      std::lock_guard lock(mutex_);
      up.pausedUntil = std::max(up.pausedUntil, Clock::now() + asked);
      waitable = asked <= policy.maxRetryAfterWait;
      if (!waitable) {
        c.error.message += " (asked to retry after " +
                           std::to_string(std::chrono::ceil<std::chrono::seconds>(asked).count()) +
                           " s)";
      }
    }
    if (!c.response && c.retryable && waitable && !job->probe && job->attempts <= policy.retries &&
        breakerClosed) {
      c.error.attempts = job->attempts;
      job->lastError = std::move(c.error);
      job->url = job->request.url; // a retry starts from the URL asked, not where it was led
      job->hops = 0;
      auto at = Clock::now() + backoff(policy.retryBackoff, job->attempts - 1);
      {
        std::lock_guard lock(mutex_);
        at = std::max(at, up.pausedUntil); // never earlier than the upstream asked
      }
      timers_.emplace(at, std::move(job));
      return;
    }
    c.error.attempts = job->attempts;

    const bool opened = recordVerdict(up, job->probe, c.verdict);
    if (c.response) {
      c.response->url = job->url;
      c.response->redirects = job->hops;
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
      complete(std::move(job), std::move(*c.response));
    } else
      complete(std::move(job), std::unexpected(std::move(c.error)));
    if (opened) flush(up);
  }

  static bool isRedirect(long status) noexcept {
    return status == 301 || status == 302 || status == 303 || status == 307 || status == 308;
  }

  /** A redirect to `location`: followed at once when the policy allows it (same origin, or any
   * with `Any`; at most maxRedirects), else the fetch fails with FetchErrc::Redirect. The hop
   * is no new attempt: a retry after a failure starts again from the URL asked. */
  void redirect(JobPtr job, Upstream& up, std::string location, long status) {
    const UpstreamPolicy& policy = *job->policy;
    const auto from = urlOrigin(job->request.url);
    const auto to = urlOrigin(location);
    const bool sameOrigin = from && to && *from == *to;
    const bool web = to && (to->starts_with("http://") || to->starts_with("https://"));
    std::string why;
    if (policy.redirects == UpstreamPolicy::Redirects::None) {
      why = "the upstream redirected (HTTP " + std::to_string(status) +
            ") and its redirects are not followed (redirects: none)";
    } else if (!web) {
      why = "the upstream redirected (HTTP " + std::to_string(status) +
            ") to a URL that is not "
            "http(s)";
    } else if (!sameOrigin && policy.redirects == UpstreamPolicy::Redirects::SameOrigin) {
      why = "the upstream redirected (HTTP " + std::to_string(status) + ") to another origin (" +
            *to + ") and redirects: same-origin refuses it";
    } else if (job->hops >= policy.maxRedirects) {
      why = "more than " + std::to_string(policy.maxRedirects) + " redirects";
    }
    if (!why.empty()) {
      logger().log(LogLevel::Warn,
                   "fetcher",
                   "redirect refused",
                   {{"upstream", job->request.upstream},
                    {"url", job->url},
                    {"location", location},
                    {"why", why}});
      const bool opened = recordVerdict(up, job->probe, Verdict::Neutral);
      fail(std::move(job), FetchErrc::Redirect, std::move(why), static_cast<int>(status));
      if (opened) flush(up);
      return;
    }
    if (!sameOrigin && logger().enabled(LogLevel::Debug)) {
      logger().log(
          LogLevel::Debug,
          "fetcher",
          "following a redirect to another origin, without the configured headers",
          {{"upstream", job->request.upstream}, {"url", job->url}, {"location", location}});
    }
    job->url = std::move(location);
    ++job->hops;
    startAttempt(std::move(job), true);
  }

  milliseconds backoff(milliseconds base, int retry) {
    const std::int64_t b = std::max<std::int64_t>(0, base.count());
    const std::int64_t ceiling = std::min<std::int64_t>(b << std::clamp(retry, 0, 16), 600000);
    std::uniform_int_distribution<std::int64_t> dist(0, ceiling);
    return milliseconds(dist(rng_));
  }

  /** Updates the breaker with a finished fetch; true when it has just opened. */
  bool recordVerdict(Upstream& up, bool probe, Verdict v) {
    std::lock_guard lock(mutex_);
    const auto now = Clock::now();
    const UpstreamPolicy& policy = *up.policy;
    if (probe) {
      if (v == Verdict::Success) {
        up.state = BreakerState::Closed;
        up.consecutiveFailures = 0;
      } else {
        up.state = BreakerState::Open;
        // A neutral probe (bad URL, odd status) says nothing: let the next fetch probe again.
        up.openUntil = v == Verdict::Failure ? now + policy.openInterval : now;
      }
      return false; // nothing can be queued or waiting while half open
    }
    if (up.state != BreakerState::Closed) return false; // a straggler from before it opened
    if (v == Verdict::Success) {
      up.consecutiveFailures = 0;
    } else if (v == Verdict::Failure && ++up.consecutiveFailures >= policy.failureThreshold) {
      up.state = BreakerState::Open;
      up.openUntil = now + policy.openInterval;
      return true;
    }
    return false;
  }

  /** The breaker opened: queued fetches fail now, retries waiting for a timer give up now. */
  void flush(Upstream& up) {
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

  void shutdown() {
    std::vector<JobPtr> cancelled;
    for (auto& [easy, t] : active_) {
      curl_multi_remove_handle(multi_, easy);
      curl_easy_cleanup(easy);
      --t->job->upstream->active;
      cancelled.push_back(std::move(t->job));
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
    for (Upstream* up : known_) {
      for (CURL* easy : up->idle)
        curl_easy_cleanup(easy);
      up->idle.clear();
    }
  }

  const std::size_t maxTotal_;
  CURLM* multi_ = nullptr;
  std::thread thread_;

  mutable std::mutex mutex_;
  // Guarded by mutex_.
  std::map<std::string, std::unique_ptr<Upstream>, std::less<>> upstreams_;
  std::vector<JobPtr> incoming_;
  std::uint64_t nextSeq_ = 0;
  bool stopping_ = false;
  bool closed_ = false;

  // Fetcher thread only.
  std::vector<Upstream*> known_;
  std::unordered_map<CURL*, std::unique_ptr<Transfer>> active_;
  std::multimap<Clock::time_point, JobPtr> timers_;
  std::mt19937_64 rng_;
};

Fetcher::Fetcher(std::size_t maxTotalConnections)
    : impl_(std::make_unique<Impl>(maxTotalConnections)) {}

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
