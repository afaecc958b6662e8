// The Fetcher's policies (retries and backoff, Retry-After, the circuit breaker, per-upstream caps,
// redirects, cancellation) against a fake transport and a manual clock: no socket, no sleep. Time
// moves only by ManualClock::advance(); FakeTransport::waitIdle() says when the fetcher thread has
// done all it can. The same behaviours against libcurl and a real server: TestFetcher.cpp.
#include "../support/FakeTransport.hpp"

#include <tellus/cache/Clock.hpp>
#include <tellus/proxy/Fetcher.hpp>

#include <gtest/gtest.h>

#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>

using namespace tellus;
using namespace std::chrono_literals;
using tellus::test::FakeTransport;

namespace {

/** One fetch's result, handed from the fetcher thread to the test thread. */
class Pending {
public:
  std::function<void(FetchResult&&)> callback() {
    return [state = state_](FetchResult&& r) {
      std::lock_guard lock(state->mutex);
      ++state->calls;
      state->result = std::move(r);
      state->cv.notify_all();
    };
  }
  /** The result (`limit` only guards against a hang). */
  FetchResult wait(std::chrono::milliseconds limit = 5000ms) {
    std::unique_lock lock(state_->mutex);
    if (!state_->cv.wait_for(lock, limit, [&] { return state_->result.has_value(); })) {
      ADD_FAILURE() << "fetch did not complete";
      return std::unexpected(FetchError{FetchErrc::Unknown, "test timeout", 0, 0});
    }
    return std::move(*state_->result);
  }
  bool done() const {
    std::lock_guard lock(state_->mutex);
    return state_->result.has_value();
  }
  int calls() const {
    std::lock_guard lock(state_->mutex);
    return state_->calls;
  }

private:
  struct State {
    std::mutex mutex;
    std::condition_variable cv;
    std::optional<FetchResult> result;
    int calls = 0;
  };
  std::shared_ptr<State> state_ = std::make_shared<State>();
};

FetchRequest get(const std::string& upstream, const std::string& url) {
  FetchRequest r;
  r.upstream = upstream;
  r.url = url;
  return r;
}

/** A Fetcher on a FakeTransport and a ManualClock. */
struct Rig {
  ManualClock clock;
  FakeTransport* transport = nullptr; // owned by the fetcher
  std::unique_ptr<Fetcher> fetcher;

  explicit Rig(FakeTransport::Handler handler = {}, std::size_t maxTotal = 64) {
    auto t = std::make_unique<FakeTransport>(std::move(handler));
    transport = t.get();
    fetcher = std::make_unique<Fetcher>(std::move(t), clock, maxTotal);
  }
  Fetcher& f() { return *fetcher; }
  FetchResult fetchNow(const std::string& upstream, const std::string& url = "http://up/t") {
    Pending p;
    fetcher->fetch(get(upstream, url), p.callback());
    return p.wait();
  }
  /** Moves time on and lets the fetcher act on it (its due timers fire). */
  void advance(std::chrono::milliseconds d) {
    clock.advance(d);
    transport->poke();
    EXPECT_TRUE(transport->waitIdle());
  }
};

UpstreamPolicy policy(int retries = 0, std::chrono::milliseconds backoff = 0ms) {
  UpstreamPolicy p;
  p.retries = retries;
  p.retryBackoff = backoff;
  return p;
}

std::string text(const std::vector<std::byte>& body) {
  return std::string(reinterpret_cast<const char*>(body.data()), body.size());
}

} // namespace

// ---- retries ------------------------------------------------------------------------------------

TEST(FetcherPolicy, RetriesWaitForTheirBackoffOnTheClock) {
  Rig rig; // every transfer held: the test answers
  rig.f().setPolicy("u", policy(2, 1000ms));
  Pending p;
  rig.f().fetch(get("u", "http://up/t"), p.callback());
  ASSERT_TRUE(rig.transport->waitForStarted(1));
  rig.transport->answer(0, FakeTransport::status(500));
  ASSERT_TRUE(rig.transport->waitIdle());
  // The first retry waits random(0, 1 s), the second random(0, 2 s): due at the latest then.
  rig.advance(1000ms);
  ASSERT_EQ(rig.transport->startedCount(), 2u);
  rig.transport->answer(1, FakeTransport::status(502));
  ASSERT_TRUE(rig.transport->waitIdle());
  rig.advance(2000ms);
  ASSERT_EQ(rig.transport->startedCount(), 3u);
  rig.transport->answer(2, FakeTransport::ok("fine"));
  auto r = p.wait();
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(text(r->body), "fine");
  EXPECT_EQ(r->attempts, 3);
  EXPECT_EQ(rig.f().stats("u").retries, 2u);
  EXPECT_EQ(rig.f().stats("u").failures, 0u);
}

TEST(FetcherPolicy, RetriesEndWithTheLastErrorAfterRetriesAttempts) {
  Rig rig([](const TransferRequest&) { return FakeTransport::status(503); });
  rig.f().setPolicy("u", policy(2));
  auto r = rig.fetchNow("u");
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, FetchErrc::HttpError);
  EXPECT_EQ(r.error().httpStatus, 503);
  EXPECT_EQ(r.error().attempts, 3);
  EXPECT_EQ(rig.transport->startedCount(), 3u);
}

TEST(FetcherPolicy, TransportFailuresAreRetriedOrNotByKind) {
  struct Case {
    TransferFailure failure;
    FetchErrc code;
    int attempts; // with one retry allowed
  };
  for (const Case c : {Case{TransferFailure::Timeout, FetchErrc::Timeout, 2},
                       Case{TransferFailure::Connect, FetchErrc::Connect, 2},
                       Case{TransferFailure::Truncated, FetchErrc::Truncated, 2},
                       Case{TransferFailure::Tls, FetchErrc::Connect, 1},
                       Case{TransferFailure::TooLarge, FetchErrc::TooLarge, 1},
                       Case{TransferFailure::OutOfMemory, FetchErrc::Unknown, 1},
                       Case{TransferFailure::TooManyRedirects, FetchErrc::HttpError, 1},
                       Case{TransferFailure::Other, FetchErrc::Unknown, 1}}) {
    Rig rig([&](const TransferRequest&) { return FakeTransport::failure(c.failure); });
    rig.f().setPolicy("u", policy(1));
    auto r = rig.fetchNow("u");
    ASSERT_FALSE(r);
    EXPECT_EQ(r.error().code, c.code) << toString(c.code);
    EXPECT_EQ(r.error().attempts, c.attempts) << toString(c.code);
  }
}

TEST(FetcherPolicy, AnswersAreNotRetried) {
  for (const int status : {200, 204, 304, 400, 403, 404, 410}) {
    Rig rig([&](const TransferRequest&) { return FakeTransport::status(status); });
    rig.f().setPolicy("u", policy(3));
    auto r = rig.fetchNow("u");
    ASSERT_TRUE(r) << status;
    EXPECT_EQ(r->status, status);
    EXPECT_EQ(r->attempts, 1);
  }
  // A status that is neither an answer nor a server error: an error, not retried.
  Rig odd([](const TransferRequest&) { return FakeTransport::status(399); });
  odd.f().setPolicy("u", policy(3));
  auto r = odd.fetchNow("u");
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, FetchErrc::HttpError);
  EXPECT_EQ(r.error().attempts, 1);
}

TEST(FetcherPolicy, ElapsedTimeAndLatencyAreTheClocks) {
  Rig rig;
  rig.f().setPolicy("u", policy());
  Pending p;
  rig.f().fetch(get("u", "http://up/t"), p.callback());
  ASSERT_TRUE(rig.transport->waitForStarted(1));
  rig.clock.advance(300ms);
  rig.transport->answer(0, FakeTransport::ok());
  auto r = p.wait();
  ASSERT_TRUE(r);
  EXPECT_EQ(r->elapsed, 300ms);
  const auto s = rig.f().stats("u");
  EXPECT_EQ(s.latencyCount, 1u);
  EXPECT_DOUBLE_EQ(s.latencySumSeconds, 0.3);
  EXPECT_EQ(s.latencyBuckets[4], 0u); // <= 0.1 s
  EXPECT_EQ(s.latencyBuckets[5], 0u); // <= 0.25 s
  EXPECT_EQ(s.latencyBuckets[6], 1u); // <= 0.5 s
}

// ---- Retry-After --------------------------------------------------------------------------------

TEST(FetcherPolicy, AShortRetryAfterIsWaitedOutToTheMillisecond) {
  Rig rig([](const TransferRequest&) -> std::optional<TransferResult> { return std::nullopt; });
  rig.f().setPolicy("u", policy(3)); // no backoff of its own: the retry goes when asked
  Pending p;
  rig.f().fetch(get("u", "http://up/t"), p.callback());
  ASSERT_TRUE(rig.transport->waitForStarted(1));
  rig.transport->answer(0, FakeTransport::status(503, "5"));
  ASSERT_TRUE(rig.transport->waitIdle());
  EXPECT_EQ(rig.f().unavailableFor("u"), 5000ms);
  rig.advance(4999ms);
  EXPECT_EQ(rig.transport->startedCount(), 1u) << "no retry before the upstream asked";
  rig.advance(1ms);
  ASSERT_EQ(rig.transport->startedCount(), 2u);
  rig.transport->answer(1, FakeTransport::ok());
  auto r = p.wait();
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(r->attempts, 2);
  EXPECT_EQ(rig.f().breaker("u"), BreakerState::Closed); // asked to wait: not a failure
}

TEST(FetcherPolicy, ALongRetryAfterPausesTheUpstreamUntilItEnds) {
  Rig rig([](const TransferRequest&) { return FakeTransport::status(429, "120"); });
  rig.f().setPolicy("u", policy(3));
  auto r = rig.fetchNow("u");
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().httpStatus, 429);
  EXPECT_NE(r.error().message.find("120 s"), std::string::npos) << r.error().message;
  EXPECT_EQ(r.error().attempts, 1); // longer than maxRetryAfterWait (10 s): not waited out
  EXPECT_EQ(rig.f().unavailableFor("u"), 120000ms);
  rig.advance(119999ms);
  auto paused = rig.fetchNow("u");
  ASSERT_FALSE(paused);
  EXPECT_EQ(paused.error().code, FetchErrc::Throttled);
  EXPECT_EQ(paused.error().attempts, 0);
  EXPECT_EQ(rig.transport->startedCount(), 1u);
  rig.advance(1ms);
  EXPECT_EQ(rig.f().unavailableFor("u"), 0ms);
  rig.transport->setHandler([](const TransferRequest&) { return FakeTransport::ok(); });
  EXPECT_TRUE(rig.fetchNow("u"));
  EXPECT_EQ(rig.transport->startedCount(), 2u);
}

TEST(FetcherPolicy, ARetryAfterDateIsReadAgainstTheWallClock) {
  // 1700000000 s is Tue, 14 Nov 2023 22:13:20 GMT.
  ManualClock clock(std::chrono::steady_clock::time_point{},
                    std::chrono::system_clock::time_point(std::chrono::seconds(1'700'000'000)));
  auto t = std::make_unique<FakeTransport>([](const TransferRequest&) {
    return FakeTransport::status(503, "Tue, 14 Nov 2023 22:13:50 GMT");
  });
  Fetcher f(std::move(t), clock);
  f.setPolicy("u", policy(0));
  Pending p;
  f.fetch(get("u", "http://up/t"), p.callback());
  ASSERT_FALSE(p.wait());
  EXPECT_EQ(f.unavailableFor("u"), 30000ms);
}

// ---- the circuit breaker ------------------------------------------------------------------------

TEST(FetcherPolicy, TheBreakerOpensAfterTheThresholdAndProbesAfterItsInterval) {
  Rig rig([](const TransferRequest&) { return FakeTransport::failure(TransferFailure::Connect); });
  auto p = policy(0);
  p.failureThreshold = 3;
  p.openInterval = 30s;
  rig.f().setPolicy("u", p);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(rig.f().breaker("u"), BreakerState::Closed);
    EXPECT_EQ(rig.fetchNow("u").error().code, FetchErrc::Connect);
  }
  EXPECT_EQ(rig.f().breaker("u"), BreakerState::Open);
  EXPECT_FALSE(rig.f().reachable("u"));
  EXPECT_EQ(rig.f().unavailableFor("u"), 30000ms);
  auto open = rig.fetchNow("u");
  EXPECT_EQ(open.error().code, FetchErrc::CircuitOpen);
  EXPECT_EQ(open.error().attempts, 0);
  rig.advance(29999ms);
  EXPECT_EQ(rig.fetchNow("u").error().code, FetchErrc::CircuitOpen);
  EXPECT_EQ(rig.transport->startedCount(), 3u);
  rig.advance(1ms);
  EXPECT_EQ(rig.f().breaker("u"), BreakerState::HalfOpen);
  EXPECT_TRUE(rig.f().reachable("u"));
  // The probe, held; meanwhile everyone else fails fast.
  rig.transport->setHandler({});
  Pending probe;
  rig.f().fetch(get("u", "http://up/probe"), probe.callback());
  ASSERT_TRUE(rig.transport->waitForStarted(4));
  EXPECT_EQ(rig.fetchNow("u").error().code, FetchErrc::CircuitOpen);
  EXPECT_EQ(rig.transport->startedCount(), 4u);
  rig.transport->answer(3, FakeTransport::ok());
  ASSERT_TRUE(probe.wait());
  EXPECT_EQ(rig.f().breaker("u"), BreakerState::Closed);
  EXPECT_EQ(rig.f().stats("u").failures, 6u); // three failures, three refusals
}

TEST(FetcherPolicy, AFailedProbeReopensTheBreakerForAnotherInterval) {
  Rig rig([](const TransferRequest&) { return FakeTransport::status(500); });
  auto p = policy(2);
  p.failureThreshold = 1;
  p.openInterval = 10s;
  rig.f().setPolicy("u", p);
  EXPECT_EQ(rig.fetchNow("u").error().attempts, 3);
  EXPECT_EQ(rig.f().breaker("u"), BreakerState::Open);
  rig.advance(10s);
  auto probe = rig.fetchNow("u");
  EXPECT_EQ(probe.error().code, FetchErrc::HttpError);
  EXPECT_EQ(probe.error().attempts, 1); // a probe is one attempt
  EXPECT_EQ(rig.f().breaker("u"), BreakerState::Open);
  EXPECT_EQ(rig.f().unavailableFor("u"), 10000ms);
}

TEST(FetcherPolicy, ANeutralProbeLetsTheNextFetchProbeAgain) {
  Rig rig([](const TransferRequest&) { return FakeTransport::status(500); });
  auto p = policy(0);
  p.failureThreshold = 1;
  p.openInterval = 10s;
  rig.f().setPolicy("u", p);
  EXPECT_FALSE(rig.fetchNow("u"));
  rig.advance(10s);
  rig.transport->setHandler(
      [](const TransferRequest&) { return FakeTransport::failure(TransferFailure::Other); });
  EXPECT_EQ(rig.fetchNow("u").error().code, FetchErrc::Unknown); // says nothing of the upstream
  EXPECT_EQ(rig.f().breaker("u"), BreakerState::HalfOpen);
  rig.transport->setHandler([](const TransferRequest&) { return FakeTransport::ok(); });
  EXPECT_TRUE(rig.fetchNow("u"));
  EXPECT_EQ(rig.f().breaker("u"), BreakerState::Closed);
}

TEST(FetcherPolicy, OpeningFailsTheQueuedFetchesAtOnce) {
  Rig rig;
  auto p = policy(3);
  p.maxConnections = 1;
  p.failureThreshold = 1;
  rig.f().setPolicy("u", p);
  Pending running, queued;
  rig.f().fetch(get("u", "http://up/1"), running.callback());
  rig.f().fetch(get("u", "http://up/2"), queued.callback()); // behind the cap of one
  ASSERT_TRUE(rig.transport->waitIdle());
  ASSERT_EQ(rig.transport->startedCount(), 1u);
  // A TLS failure is not retried: it opens the breaker.
  rig.transport->answer(0, FakeTransport::failure(TransferFailure::Tls));
  EXPECT_EQ(running.wait().error().code, FetchErrc::Connect);
  EXPECT_EQ(queued.wait().error().code, FetchErrc::CircuitOpen);
  EXPECT_EQ(rig.transport->startedCount(), 1u);
}

TEST(FetcherPolicy, OpeningEndsTheRetriesWaitingForTheirTimer) {
  Rig rig;
  auto p = policy(3);
  p.failureThreshold = 1;
  rig.f().setPolicy("u", p);
  Pending waiting, failing;
  rig.f().fetch(get("u", "http://up/1"), waiting.callback());
  rig.f().fetch(get("u", "http://up/2"), failing.callback());
  ASSERT_TRUE(rig.transport->waitForStarted(2));
  rig.transport->answer(0, FakeTransport::status(503, "5")); // its retry waits 5 s
  ASSERT_TRUE(rig.transport->waitIdle());
  EXPECT_FALSE(waiting.done());
  rig.transport->answer(1, FakeTransport::failure(TransferFailure::Tls)); // not retried
  EXPECT_EQ(failing.wait().error().code, FetchErrc::Connect);
  auto r = waiting.wait(); // at once, with its own last error: no clock moved
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, FetchErrc::HttpError);
  EXPECT_EQ(r.error().httpStatus, 503);
  EXPECT_EQ(r.error().attempts, 1);
  EXPECT_EQ(rig.transport->startedCount(), 2u);
}

// ---- per-upstream caps --------------------------------------------------------------------------

TEST(FetcherPolicy, EachUpstreamHasItsCapAndWaitersGoFirstInFirstOut) {
  Rig rig;
  auto capped = policy();
  capped.maxConnections = 2;
  rig.f().setPolicy("slow", capped);
  std::vector<Pending> pending(5);
  for (std::size_t i = 0; i < pending.size(); ++i)
    rig.f().fetch(get("slow", "http://slow/" + std::to_string(i)), pending[i].callback());
  ASSERT_TRUE(rig.transport->waitIdle());
  ASSERT_EQ(rig.transport->startedCount(), 2u);
  // Another upstream is not held up by the first one's cap.
  Pending other;
  rig.f().fetch(get("fast", "http://fast/"), other.callback());
  ASSERT_TRUE(rig.transport->waitForStarted(3));
  EXPECT_EQ(rig.transport->started()[2].url, "http://fast/");
  rig.transport->answer(1, FakeTransport::ok());
  ASSERT_TRUE(pending[1].wait());
  ASSERT_TRUE(rig.transport->waitForStarted(4));
  EXPECT_EQ(rig.transport->started()[3].url, "http://slow/2");
  for (std::size_t i : {0u, 2u, 3u})
    rig.transport->answer(i, FakeTransport::ok());
  ASSERT_TRUE(rig.transport->waitForStarted(6));
  EXPECT_EQ(rig.transport->started()[4].url, "http://slow/3");
  EXPECT_EQ(rig.transport->started()[5].url, "http://slow/4");
  EXPECT_EQ(rig.transport->held(), 2u);
  EXPECT_EQ(rig.f().stats("slow").inFlight, 2u);
}

TEST(FetcherPolicy, TheTotalCapHoldsAcrossUpstreams) {
  Rig rig({}, 3);
  for (int u = 0; u < 3; ++u)
    rig.f().setPolicy("u" + std::to_string(u), policy());
  std::vector<Pending> pending(6);
  for (std::size_t i = 0; i < pending.size(); ++i)
    rig.f().fetch(get("u" + std::to_string(i % 3), "http://up/" + std::to_string(i)),
                  pending[i].callback());
  ASSERT_TRUE(rig.transport->waitIdle());
  EXPECT_EQ(rig.transport->startedCount(), 3u);
  rig.transport->answer(0, FakeTransport::ok());
  ASSERT_TRUE(rig.transport->waitForStarted(4));
  EXPECT_EQ(rig.transport->started()[3].url, "http://up/3"); // the oldest waiting
}

TEST(FetcherPolicy, TheRequestCarriesThePolicysTimeoutsLimitAndHeaders) {
  Rig rig([](const TransferRequest&) { return FakeTransport::ok(); });
  auto p = policy();
  p.connectTimeout = 1234ms;
  p.timeout = 5678ms;
  p.maxBodyBytes = 999;
  p.headers = {{"X-Api-Key", "k"}};
  rig.f().setPolicy("u", p);
  auto req = get("u", "http://up/t");
  req.ifNoneMatch = "\"e\"";
  req.ifModifiedSince = "Wed, 21 Oct 2015 07:28:00 GMT";
  Pending done;
  rig.f().fetch(req, done.callback());
  ASSERT_TRUE(done.wait());
  const TransferRequest t = rig.transport->started().at(0);
  EXPECT_EQ(t.url, "http://up/t");
  EXPECT_EQ(t.connectTimeout, 1234ms);
  EXPECT_EQ(t.timeout, 5678ms);
  EXPECT_EQ(t.maxBodyBytes, 999u);
  EXPECT_EQ(t.headerLines,
            (std::vector<std::string>{"X-Api-Key: k",
                                      "If-None-Match: \"e\"",
                                      "If-Modified-Since: Wed, 21 Oct 2015 07:28:00 GMT"}));
}

// ---- redirects ----------------------------------------------------------------------------------

TEST(FetcherPolicy, RedirectsFollowThePolicyAndHeadersStayInTheOrigin) {
  Rig rig([](const TransferRequest& t) {
    if (t.url == "http://up/a") return FakeTransport::redirect(302, "http://up/b");
    if (t.url == "http://up/cross") return FakeTransport::redirect(307, "http://other/x");
    if (t.url == "http://up/ftp") return FakeTransport::redirect(301, "ftp://up/x");
    if (t.url == "http://up/loop") return FakeTransport::redirect(302, "http://up/loop");
    return FakeTransport::ok(t.url);
  });
  auto p = policy(2);
  p.headers = {{"X-Api-Key", "secret"}};
  rig.f().setPolicy("same", p);
  auto a = rig.fetchNow("same", "http://up/a");
  ASSERT_TRUE(a) << a.error().message;
  EXPECT_EQ(text(a->body), "http://up/b");
  EXPECT_EQ(a->url, "http://up/b");
  EXPECT_EQ(a->redirects, 1);
  EXPECT_EQ(a->attempts, 1);
  auto cross = rig.fetchNow("same", "http://up/cross");
  ASSERT_FALSE(cross);
  EXPECT_EQ(cross.error().code, FetchErrc::Redirect);
  EXPECT_EQ(cross.error().httpStatus, 307);
  EXPECT_EQ(cross.error().attempts, 1); // not retried
  EXPECT_EQ(rig.fetchNow("same", "http://up/ftp").error().code, FetchErrc::Redirect);
  auto loop = rig.fetchNow("same", "http://up/loop");
  EXPECT_EQ(loop.error().code, FetchErrc::Redirect);
  EXPECT_EQ(loop.error().message, "more than 5 redirects");
  p.redirects = UpstreamPolicy::Redirects::Any;
  rig.f().setPolicy("any", p);
  auto any = rig.fetchNow("any", "http://up/cross");
  ASSERT_TRUE(any) << any.error().message;
  EXPECT_EQ(any->url, "http://other/x");
  p.redirects = UpstreamPolicy::Redirects::None;
  rig.f().setPolicy("none", p);
  EXPECT_EQ(rig.fetchNow("none", "http://up/a").error().code, FetchErrc::Redirect);
  // The configured header went to the upstream's origin only.
  for (const TransferRequest& t : rig.transport->started()) {
    const bool own = t.url.starts_with("http://up/");
    EXPECT_EQ(!t.headerLines.empty(), own) << t.url;
  }
  EXPECT_EQ(rig.f().breaker("same"), BreakerState::Closed); // refused redirects are neutral
}

// ---- the transport refusing, and stopping ------------------------------------------------------

TEST(FetcherPolicy, ATransferThatCannotStartFailsAtOnceWithoutAnAttempt) {
  Rig rig;
  rig.transport->refuseStarts("bad request: no such option");
  auto r = rig.fetchNow("u");
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, FetchErrc::Unknown);
  EXPECT_EQ(r.error().message, "bad request: no such option");
  EXPECT_EQ(r.error().attempts, 0);
  auto header = get("u", "http://up/t");
  header.ifNoneMatch = "\"a\"\r\nX-Evil: 1";
  Pending p;
  rig.f().fetch(header, p.callback());
  EXPECT_EQ(p.wait().error().message, "invalid request header");
}

TEST(FetcherPolicy, StoppingCancelsRunningQueuedAndWaitingFetchesExactlyOnce) {
  std::vector<Pending> pending(4);
  {
    Rig rig;
    auto p = policy(3, 60000ms);
    p.maxConnections = 1;
    rig.f().setPolicy("u", p);
    rig.f().fetch(get("u", "http://up/0"), pending[0].callback());
    ASSERT_TRUE(rig.transport->waitForStarted(1));
    rig.transport->answer(0, FakeTransport::status(500)); // waits for its retry's timer
    ASSERT_TRUE(rig.transport->waitIdle());
    rig.f().fetch(get("u", "http://up/1"), pending[1].callback()); // running
    rig.f().fetch(get("u", "http://up/2"), pending[2].callback()); // queued
    ASSERT_TRUE(rig.transport->waitIdle());
    EXPECT_EQ(rig.transport->held(), 1u);
    rig.f().fetch(get("u", "http://up/3"), pending[3].callback()); // perhaps not even admitted
  }
  for (auto& p : pending) {
    auto r = p.wait(100ms);
    ASSERT_FALSE(r);
    EXPECT_EQ(r.error().code, FetchErrc::Cancelled);
    EXPECT_EQ(p.calls(), 1);
  }
}
