#include "../support/FakeUpstream.hpp"

#include <tellus/cache/Clock.hpp>
#include <tellus/proxy/Fetcher.hpp>

#include <gtest/gtest.h>

#include <atomic>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

using namespace tellus;
using namespace std::chrono_literals;
using tellus::test::FakeReply;
using tellus::test::FakeRequest;
using tellus::test::FakeUpstream;

namespace {

using Steady = std::chrono::steady_clock;

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
  FetchResult wait(std::chrono::milliseconds limit = 5000ms) {
    std::unique_lock lock(state_->mutex);
    if (!state_->cv.wait_for(lock, limit, [&] { return state_->result.has_value(); })) {
      ADD_FAILURE() << "fetch did not complete in " << limit.count() << " ms";
      return std::unexpected(FetchError{FetchErrc::Unknown, "test timeout", 0, 0});
    }
    return std::move(*state_->result);
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

FetchResult fetchNow(Fetcher& f, FetchRequest req, std::chrono::milliseconds limit = 5000ms) {
  Pending p;
  f.fetch(std::move(req), p.callback());
  return p.wait(limit);
}

FetchRequest get(const std::string& upstream, const std::string& url) {
  FetchRequest r;
  r.upstream = upstream;
  r.url = url;
  return r;
}

std::string text(const std::vector<std::byte>& body) {
  return std::string(reinterpret_cast<const char*>(body.data()), body.size());
}

/** Short timeouts and backoffs so that fault tests stay fast. */
UpstreamPolicy fastPolicy() {
  UpstreamPolicy p;
  p.connectTimeout = 1000ms;
  p.timeout = 2000ms;
  p.retries = 2;
  p.retryBackoff = 5ms;
  p.openInterval = 300ms;
  return p;
}

} // namespace

// ---- Fetcher: no server needed ----------------------------------------------------------------

TEST(Fetcher, UnknownUpstreamIsClosedAndIdle) {
  Fetcher f;
  EXPECT_EQ(f.breaker("nobody"), BreakerState::Closed);
  EXPECT_TRUE(f.reachable("nobody"));
  const auto s = f.stats("nobody");
  EXPECT_EQ(s.requests, 0u);
  EXPECT_EQ(s.inFlight, 0u);
}

TEST(Fetcher, OnlyHttpAndHttpsAreFetched) {
  Fetcher f;
  f.setPolicy("u", fastPolicy());
  for (const char* url : {"file:///etc/hostname", "ftp://127.0.0.1/x", "gopher://127.0.0.1/"}) {
    auto r = fetchNow(f, get("u", url));
    ASSERT_FALSE(r) << url;
    EXPECT_EQ(r.error().code, FetchErrc::Unknown) << url;
    EXPECT_EQ(r.error().attempts, 1) << url; // not retried
  }
  EXPECT_EQ(f.stats("u").retries, 0u);
  EXPECT_EQ(f.breaker("u"), BreakerState::Closed); // a bad URL says nothing about the upstream
}

TEST(Fetcher, MalformedUrlIsUnknown) {
  Fetcher f;
  auto r = fetchNow(f, get("u", "http://[::1"));
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, FetchErrc::Unknown);
}

TEST(Fetcher, HeaderInjectionIsRefusedBeforeAnyRequest) {
  Fetcher f;
  auto req = get("u", "http://127.0.0.1:9/");
  req.ifNoneMatch = "\"a\"\r\nX-Evil: 1";
  auto r = fetchNow(f, req);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, FetchErrc::Unknown);
  EXPECT_EQ(r.error().attempts, 0);
}

TEST(Fetcher, ErrorCodesHaveNames) {
  EXPECT_STREQ(toString(FetchErrc::Timeout), "timeout");
  EXPECT_STREQ(toString(FetchErrc::CircuitOpen), "circuit-open");
  EXPECT_STREQ(toString(FetchErrc::TooLarge), "too-large");
  EXPECT_STREQ(toString(FetchErrc::Throttled), "throttled");
  EXPECT_STREQ(toString(FetchErrc::Redirect), "redirect");
}

TEST(Fetcher, OriginsAreSchemeHostAndPort) {
  EXPECT_EQ(urlOrigin("http://Example.COM/wms?x=1"), "http://example.com:80");
  EXPECT_EQ(urlOrigin("https://example.com:443/a"), "https://example.com:443");
  EXPECT_EQ(urlOrigin("https://example.com/a"), urlOrigin("https://example.com:443/b"));
  EXPECT_NE(urlOrigin("http://example.com/a"), urlOrigin("https://example.com/a"));
  EXPECT_NE(urlOrigin("http://127.0.0.1:8080/a"), urlOrigin("http://127.0.0.1:8081/a"));
  EXPECT_NE(urlOrigin("http://example.com/a"), urlOrigin("http://example.com.evil.net/a"));
  EXPECT_EQ(urlOrigin("http://user:pw@example.com/a"), "http://example.com:80");
  EXPECT_FALSE(urlOrigin("not a url"));
}

// ---- FetcherIntegration: against FakeUpstream on 127.0.0.1 ------------------------------------

TEST(FetcherIntegration, FetchesATileWithItsCacheHeaders) {
  FakeUpstream server([](const FakeRequest&) {
    auto r = FakeReply::ok("tile-bytes", "image/png");
    r.headers.emplace_back("ETag", "\"v1\"");
    r.headers.emplace_back("Last-Modified", "Wed, 21 Oct 2015 07:28:00 GMT");
    r.headers.emplace_back("Cache-Control", "max-age=3600");
    r.headers.emplace_back("Expires", "Thu, 22 Oct 2015 07:28:00 GMT");
    return r;
  });
  Fetcher f;
  auto policy = fastPolicy();
  policy.headers.emplace_back("X-Tellus-Test", "yes");
  f.setPolicy("wms", policy);
  auto r = fetchNow(f, get("wms", server.url("/wms?REQUEST=GetMap&X=1")));
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(r->contentType, "image/png");
  EXPECT_EQ(text(r->body), "tile-bytes");
  EXPECT_EQ(r->etag, "\"v1\"");
  EXPECT_EQ(r->lastModified, "Wed, 21 Oct 2015 07:28:00 GMT");
  EXPECT_EQ(r->cacheControl, "max-age=3600");
  EXPECT_EQ(r->expires, "Thu, 22 Oct 2015 07:28:00 GMT");
  EXPECT_EQ(r->attempts, 1);
  EXPECT_EQ(server.requests("/wms?REQUEST=GetMap&X=1"), 1u);
  const auto seen = server.received();
  ASSERT_EQ(seen.size(), 1u);
  EXPECT_EQ(seen[0].method, "GET");
  EXPECT_EQ(seen[0].header("x-tellus-test"), "yes");
  const auto s = f.stats("wms");
  EXPECT_EQ(s.requests, 1u);
  EXPECT_EQ(s.failures, 0u);
  EXPECT_EQ(s.inFlight, 0u); // counted out before the callback ran
}

TEST(FetcherIntegration, ReusesTheConnection) {
  FakeUpstream server;
  Fetcher f;
  f.setPolicy("u", fastPolicy());
  for (int i = 0; i < 10; ++i) {
    auto r = fetchNow(f, get("u", server.url("/t" + std::to_string(i))));
    ASSERT_TRUE(r) << r.error().message;
  }
  EXPECT_EQ(server.requests(), 10u);
  EXPECT_EQ(server.accepts(), 1u);
}

TEST(FetcherIntegration, CapsConcurrentTransfersPerUpstream) {
  const auto held = std::make_shared<tellus::test::Gate>(); // the slow upstream's answers
  FakeUpstream slow([held](const FakeRequest&) {
    auto r = FakeReply::ok("x");
    r.holdUntilOpen = held;
    return r;
  });
  FakeUpstream fast;
  Fetcher f;
  auto capped = fastPolicy();
  capped.maxConnections = 2;
  f.setPolicy("slow", capped);
  f.setPolicy("fast", fastPolicy());
  std::vector<Pending> pending(10);
  for (std::size_t i = 0; i < pending.size(); ++i)
    f.fetch(get("slow", slow.url("/t" + std::to_string(i))), pending[i].callback());
  // Another upstream is not held up by the first one's cap.
  auto quick = fetchNow(f, get("fast", fast.url("/quick")));
  ASSERT_TRUE(quick);
  ASSERT_TRUE(slow.waitForRequests(2));
  EXPECT_EQ(slow.requests(), 2u); // the cap: the other eight wait in the fetcher's queue
  held->open();
  for (auto& p : pending)
    ASSERT_TRUE(p.wait());
  EXPECT_EQ(slow.requests(), 10u);
  EXPECT_EQ(slow.maxConcurrent(), 2);
  EXPECT_LE(slow.accepts(), 2u);
  // FIFO: the first two queued went out first.
  const auto seen = slow.received();
  ASSERT_EQ(seen.size(), 10u);
  EXPECT_TRUE((seen[0].target == "/t0" && seen[1].target == "/t1") ||
              (seen[0].target == "/t1" && seen[1].target == "/t0"));
}

TEST(FetcherIntegration, RetriesA5xxThenSucceeds) {
  std::atomic<int> calls{0};
  FakeUpstream server([&](const FakeRequest&) {
    return ++calls == 1 ? FakeReply::withStatus(500, "boom") : FakeReply::ok("fine");
  });
  Fetcher f;
  f.setPolicy("u", fastPolicy());
  auto r = fetchNow(f, get("u", server.url("/t")));
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(text(r->body), "fine");
  EXPECT_EQ(r->attempts, 2);
  EXPECT_EQ(server.requests(), 2u);
  EXPECT_EQ(f.stats("u").retries, 1u);
  EXPECT_EQ(f.stats("u").failures, 0u);
}

TEST(FetcherIntegration, Persistent5xxIsAnHttpErrorAfterRetries) {
  FakeUpstream server([](const FakeRequest&) { return FakeReply::withStatus(503, "busy"); });
  Fetcher f;
  f.setPolicy("u", fastPolicy()); // 2 retries
  auto r = fetchNow(f, get("u", server.url("/t")));
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, FetchErrc::HttpError);
  EXPECT_EQ(r.error().httpStatus, 503);
  EXPECT_EQ(r.error().attempts, 3);
  EXPECT_EQ(server.requests(), 3u);
  EXPECT_EQ(f.stats("u").failures, 1u);
}

TEST(FetcherIntegration, HangingUpstreamTimesOutWithinTheTimeout) {
  FakeUpstream server([](const FakeRequest&) {
    FakeReply r;
    r.hangForever = true;
    return r;
  });
  Fetcher f;
  auto policy = fastPolicy();
  policy.timeout = 300ms;
  policy.retries = 0;
  f.setPolicy("once", policy);
  policy.timeout = 150ms;
  policy.retries = 1;
  f.setPolicy("twice", policy);

  const auto t0 = Steady::now();
  auto r = fetchNow(f, get("once", server.url("/a")));
  const auto took = Steady::now() - t0;
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, FetchErrc::Timeout);
  EXPECT_EQ(r.error().attempts, 1);
  EXPECT_GE(took, 290ms);
  EXPECT_LT(took, 800ms);

  auto r2 = fetchNow(f, get("twice", server.url("/b")));
  ASSERT_FALSE(r2);
  EXPECT_EQ(r2.error().code, FetchErrc::Timeout);
  EXPECT_EQ(r2.error().attempts, 2); // timeouts are retried
  EXPECT_EQ(server.requests("/b"), 2u);
}

TEST(FetcherIntegration, TruncatedBodyIsRetriedThenTruncated) {
  std::atomic<int> n{0};
  FakeUpstream server([&](const FakeRequest& req) {
    auto r = FakeReply::ok(std::string(1000, 'z'));
    r.truncate = req.target == "/always" || ++n == 1;
    return r;
  });
  Fetcher f;
  f.setPolicy("u", fastPolicy());
  auto r = fetchNow(f, get("u", server.url("/always")));
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, FetchErrc::Truncated);
  EXPECT_EQ(r.error().attempts, 3);
  EXPECT_EQ(server.requests("/always"), 3u);

  auto ok = fetchNow(f, get("u", server.url("/once")));
  ASSERT_TRUE(ok) << ok.error().message;
  EXPECT_EQ(ok->body.size(), 1000u);
  EXPECT_EQ(ok->attempts, 2);
}

TEST(FetcherIntegration, DripFedBodyHitsTheTotalTimeout) {
  FakeUpstream server([](const FakeRequest&) {
    auto r = FakeReply::ok(std::string(100, 'd'));
    r.dripBytesPerSecond = 1;
    return r;
  });
  Fetcher f;
  auto policy = fastPolicy();
  policy.timeout = 500ms;
  policy.retries = 0;
  f.setPolicy("u", policy);
  const auto t0 = Steady::now();
  auto r = fetchNow(f, get("u", server.url("/drip")));
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, FetchErrc::Timeout);
  EXPECT_LT(Steady::now() - t0, 1500ms);
}

TEST(FetcherIntegration, OversizedBodyIsTooLargeAndNotRetried) {
  FakeUpstream server([](const FakeRequest& req) {
    auto r = FakeReply::ok(std::string(5000, 'b'));
    r.chunked = req.target == "/chunked"; // no Content-Length: caught while receiving
    return r;
  });
  Fetcher f;
  auto policy = fastPolicy();
  policy.maxBodyBytes = 1000;
  f.setPolicy("u", policy);
  for (const std::string target : {"/length", "/chunked"}) {
    auto r = fetchNow(f, get("u", server.url(target)));
    ASSERT_FALSE(r) << target;
    EXPECT_EQ(r.error().code, FetchErrc::TooLarge) << target;
    EXPECT_EQ(server.requests(target), 1u) << target;
  }
  EXPECT_EQ(f.breaker("u"), BreakerState::Closed);
  policy.maxBodyBytes = 5000; // exactly at the limit is fine
  f.setPolicy("u", policy);
  auto r = fetchNow(f, get("u", server.url("/chunked")));
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(r->body.size(), 5000u);
}

TEST(FetcherIntegration, ClientErrorsAreAnswersNotRetried) {
  FakeUpstream server([](const FakeRequest& req) {
    return FakeReply::withStatus(req.target == "/missing" ? 404 : 403, "no");
  });
  Fetcher f;
  f.setPolicy("u", fastPolicy());
  auto r = fetchNow(f, get("u", server.url("/missing")));
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 404);
  EXPECT_EQ(r->attempts, 1);
  EXPECT_EQ(server.requests("/missing"), 1u);
  auto forbidden = fetchNow(f, get("u", server.url("/forbidden")));
  ASSERT_TRUE(forbidden);
  EXPECT_EQ(forbidden->status, 403);
  EXPECT_EQ(server.requests(), 2u);
  EXPECT_EQ(f.stats("u").retries, 0u);
}

TEST(FetcherIntegration, RevalidationSendsConditionalHeadersAndGets304) {
  FakeUpstream server([](const FakeRequest& req) {
    if (req.header("if-none-match") == "\"v7\"") {
      FakeReply r = FakeReply::withStatus(304);
      r.headers.emplace_back("ETag", "\"v7\"");
      return r;
    }
    return FakeReply::ok("fresh", "image/jpeg");
  });
  Fetcher f;
  f.setPolicy("u", fastPolicy());
  auto req = get("u", server.url("/t"));
  req.ifNoneMatch = "\"v7\"";
  req.ifModifiedSince = "Wed, 21 Oct 2015 07:28:00 GMT";
  auto r = fetchNow(f, req);
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(r->status, 304);
  EXPECT_TRUE(r->body.empty());
  EXPECT_EQ(r->etag, "\"v7\"");
  EXPECT_EQ(server.requests(), 1u);
  const auto seen = server.received();
  ASSERT_EQ(seen.size(), 1u);
  EXPECT_EQ(seen[0].header("if-none-match"), "\"v7\"");
  EXPECT_EQ(seen[0].header("if-modified-since"), "Wed, 21 Oct 2015 07:28:00 GMT");
}

TEST(FetcherIntegration, FollowsAFewRedirectsButNotLoops) {
  FakeUpstream server([](const FakeRequest& req) {
    FakeReply r = FakeReply::withStatus(302);
    if (req.target == "/final") return FakeReply::ok("here");
    r.headers.emplace_back("Location", req.target == "/hop" ? "/final" : "/loop");
    return r;
  });
  Fetcher f;
  f.setPolicy("u", fastPolicy());
  auto r = fetchNow(f, get("u", server.url("/hop")));
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(text(r->body), "here");
  EXPECT_EQ(r->url, server.url("/final")); // the final URL is recorded
  EXPECT_EQ(r->redirects, 1);
  EXPECT_EQ(r->attempts, 1); // a hop is not a retry
  auto loop = fetchNow(f, get("u", server.url("/loop")));
  ASSERT_FALSE(loop);
  EXPECT_EQ(loop.error().code, FetchErrc::Redirect);
  EXPECT_EQ(loop.error().attempts, 1);
  EXPECT_EQ(server.requests("/loop"), 1u + 5u); // the first request and at most 5 redirects
}

// Two fake upstreams on two ports of 127.0.0.1 are two origins. The first redirects; the
// configured header (an API key) must reach the first only, whatever the policy.
TEST(FetcherIntegration, RedirectsStayInTheUpstreamsOriginAndHeadersNeverLeaveIt) {
  FakeUpstream other([](const FakeRequest&) { return FakeReply::ok("from the other origin"); });
  FakeUpstream server([&](const FakeRequest& req) {
    if (req.target == "/tile") return FakeReply::ok("from the upstream");
    FakeReply r = FakeReply::withStatus(req.target == "/same" ? 301 : 307);
    r.headers.emplace_back("Location", req.target == "/same" ? "/tile" : other.url("/elsewhere"));
    return r;
  });
  const auto policyWith = [](UpstreamPolicy::Redirects redirects) {
    UpstreamPolicy p = fastPolicy();
    p.headers = {{"X-Api-Key", "SECRET-KEY"}, {"Authorization", "Bearer SECRET-TOKEN"}};
    p.redirects = redirects;
    return p;
  };
  Fetcher f;
  // The default: within the upstream's origin, with its headers on every hop.
  f.setPolicy("same-origin", policyWith(UpstreamPolicy::Redirects::SameOrigin));
  auto same = fetchNow(f, get("same-origin", server.url("/same")));
  ASSERT_TRUE(same) << same.error().message;
  EXPECT_EQ(text(same->body), "from the upstream");
  EXPECT_EQ(same->url, server.url("/tile"));
  for (const auto& req : server.received())
    EXPECT_EQ(req.header("x-api-key"), "SECRET-KEY") << req.target;
  // To another origin: refused, an upstream failure, and the other origin sees nothing.
  auto cross = fetchNow(f, get("same-origin", server.url("/cross")));
  ASSERT_FALSE(cross);
  EXPECT_EQ(cross.error().code, FetchErrc::Redirect);
  EXPECT_EQ(cross.error().httpStatus, 307);
  EXPECT_EQ(cross.error().attempts, 1); // not retried
  EXPECT_NE(cross.error().message.find("another origin"), std::string::npos)
      << cross.error().message;
  EXPECT_EQ(other.requests(), 0u);
  // `any`: followed, but without the configured headers.
  f.setPolicy("any", policyWith(UpstreamPolicy::Redirects::Any));
  auto any = fetchNow(f, get("any", server.url("/cross")));
  ASSERT_TRUE(any) << any.error().message;
  EXPECT_EQ(text(any->body), "from the other origin");
  EXPECT_EQ(any->url, other.url("/elsewhere"));
  ASSERT_EQ(other.requests(), 1u);
  const FakeRequest there = other.received().at(0);
  EXPECT_EQ(there.header("x-api-key"), "");
  EXPECT_EQ(there.header("authorization"), "");
  EXPECT_EQ(server.received().back().header("x-api-key"), "SECRET-KEY");
  // `none`: not even within the origin.
  f.setPolicy("none", policyWith(UpstreamPolicy::Redirects::None));
  const auto before = server.requests();
  auto none = fetchNow(f, get("none", server.url("/same")));
  ASSERT_FALSE(none);
  EXPECT_EQ(none.error().code, FetchErrc::Redirect);
  EXPECT_EQ(server.requests(), before + 1);
}

TEST(FetcherIntegration, DroppedConnectionIsAConnectFailureAndRetried) {
  std::atomic<int> n{0};
  FakeUpstream server([&](const FakeRequest&) {
    FakeReply r = FakeReply::ok("after");
    r.closeWithoutResponse = ++n == 1;
    return r;
  });
  Fetcher f;
  auto policy = fastPolicy();
  policy.retries = 0; // curl itself resends once on a dead reused connection, not on a fresh one
  f.setPolicy("once", policy);
  auto r = fetchNow(f, get("once", server.url("/t")));
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, FetchErrc::Connect);
  n = 0;
  f.setPolicy("retrying", fastPolicy());
  auto ok = fetchNow(f, get("retrying", server.url("/t")));
  ASSERT_TRUE(ok) << ok.error().message;
  EXPECT_EQ(ok->attempts, 2);
}

// libcurl against a real socket, time on a manual clock: the breaker's interval passes when the
// test says (FetcherPolicy tests the same policies on a fake transport).
TEST(FetcherIntegration, RefusedConnectionsOpenTheBreakerAndAProbeRetriesLater) {
  const std::uint16_t port = FakeUpstream::closedPort();
  const std::string url = "http://127.0.0.1:" + std::to_string(port) + "/t";
  ManualClock clock;
  Fetcher f(makeCurlTransport(64), clock);
  auto policy = fastPolicy();
  policy.retries = 1;
  policy.retryBackoff = 0ms; // the retry is due at once: the clock does not move by itself
  policy.failureThreshold = 3;
  policy.openInterval = 300ms;
  f.setPolicy("offline", policy);
  for (int i = 0; i < 3; ++i) {
    EXPECT_TRUE(f.reachable("offline"));
    auto r = fetchNow(f, get("offline", url));
    ASSERT_FALSE(r);
    EXPECT_EQ(r.error().code, FetchErrc::Connect);
    EXPECT_EQ(r.error().attempts, 2);
  }
  EXPECT_EQ(f.breaker("offline"), BreakerState::Open);
  EXPECT_FALSE(f.reachable("offline"));
  const auto retriesBefore = f.stats("offline").retries;

  // Open: no network at all, and immediate.
  const auto t0 = Steady::now();
  for (int i = 0; i < 20; ++i) {
    auto r = fetchNow(f, get("offline", url));
    ASSERT_FALSE(r);
    EXPECT_EQ(r.error().code, FetchErrc::CircuitOpen);
    EXPECT_EQ(r.error().attempts, 0);
  }
  EXPECT_LT(Steady::now() - t0, 250ms);
  EXPECT_EQ(f.stats("offline").retries, retriesBefore);
  EXPECT_EQ(f.stats("offline").failures, 23u);

  // After the interval one probe goes out (a single attempt); its failure re-opens the breaker.
  clock.advance(299ms);
  EXPECT_EQ(f.breaker("offline"), BreakerState::Open);
  clock.advance(1ms);
  EXPECT_EQ(f.breaker("offline"), BreakerState::HalfOpen);
  EXPECT_TRUE(f.reachable("offline"));
  auto probe = fetchNow(f, get("offline", url));
  ASSERT_FALSE(probe);
  EXPECT_EQ(probe.error().code, FetchErrc::Connect);
  EXPECT_EQ(probe.error().attempts, 1);
  EXPECT_EQ(f.breaker("offline"), BreakerState::Open);
  auto after = fetchNow(f, get("offline", url));
  ASSERT_FALSE(after);
  EXPECT_EQ(after.error().code, FetchErrc::CircuitOpen);
}

TEST(FetcherIntegration, HalfOpenProbeClosesTheBreakerAndOthersWaitForIt) {
  std::atomic<bool> healthy{false};
  auto probeHeld = std::make_shared<tellus::test::Gate>();
  FakeUpstream server([&](const FakeRequest&) {
    if (!healthy) return FakeReply::withStatus(500, "down");
    auto r = FakeReply::ok("up");
    r.holdUntilOpen = probeHeld; // until the other fetch has been refused
    return r;
  });
  ManualClock clock;
  Fetcher f(makeCurlTransport(64), clock);
  auto policy = fastPolicy();
  policy.retries = 0;
  policy.failureThreshold = 2;
  policy.openInterval = 250ms;
  f.setPolicy("u", policy);
  for (int i = 0; i < 2; ++i) {
    auto r = fetchNow(f, get("u", server.url("/t")));
    ASSERT_FALSE(r);
    EXPECT_EQ(r.error().code, FetchErrc::HttpError);
  }
  EXPECT_EQ(f.breaker("u"), BreakerState::Open);
  auto blocked = fetchNow(f, get("u", server.url("/t")));
  ASSERT_FALSE(blocked);
  EXPECT_EQ(blocked.error().code, FetchErrc::CircuitOpen);
  EXPECT_EQ(server.requests(), 2u); // the open breaker sent nothing

  healthy = true;
  clock.advance(250ms);
  Pending probe;
  Pending other;
  f.fetch(get("u", server.url("/probe")), probe.callback());
  f.fetch(get("u", server.url("/other")), other.callback());
  auto o = other.wait();
  ASSERT_FALSE(o); // the probe is still out: everyone else still fails fast
  EXPECT_EQ(o.error().code, FetchErrc::CircuitOpen);
  probeHeld->open();
  auto p = probe.wait();
  ASSERT_TRUE(p) << p.error().message;
  EXPECT_EQ(f.breaker("u"), BreakerState::Closed);
  EXPECT_EQ(server.requests(), 3u);
  EXPECT_EQ(server.requests("/other"), 0u);
  auto again = fetchNow(f, get("u", server.url("/t")));
  EXPECT_TRUE(again);
}

TEST(FetcherIntegration, DestructorCancelsEverythingInFlightExactlyOnce) {
  FakeUpstream hanging([](const FakeRequest&) {
    FakeReply r;
    r.hangForever = true;
    return r;
  });
  FakeUpstream failing([](const FakeRequest&) { return FakeReply::withStatus(500); });
  std::vector<Pending> pending(6);
  {
    auto fetcher = std::make_unique<Fetcher>();
    Fetcher& f = *fetcher;
    auto policy = fastPolicy();
    policy.maxConnections = 2;
    policy.timeout = 10s;
    f.setPolicy("hang", policy);
    policy.retryBackoff = 10s; // the retry waits on a timer
    f.setPolicy("retry", policy);
    for (std::size_t i = 0; i < 5; ++i) // two running, three queued
      f.fetch(get("hang", hanging.url("/h" + std::to_string(i))), pending[i].callback());
    f.fetch(get("retry", failing.url("/r")), pending[5].callback());
    ASSERT_TRUE(hanging.waitForRequests(2));
    ASSERT_TRUE(failing.waitForRequests(1));
    EXPECT_EQ(f.stats("hang").inFlight, 5u);
    const auto t0 = Steady::now();
    fetcher.reset();
    EXPECT_LT(Steady::now() - t0, 1s);
  }
  for (auto& p : pending) {
    auto r = p.wait(100ms);
    ASSERT_FALSE(r);
    EXPECT_EQ(r.error().code, FetchErrc::Cancelled);
    EXPECT_EQ(p.calls(), 1);
  }
  EXPECT_EQ(hanging.requests(), 2u);
}

TEST(FetcherIntegration, ManyConcurrentFetchesCompleteExactlyOnce) {
  constexpr int kUpstreams = 4;
  constexpr int kFetches = 200;
  std::vector<std::unique_ptr<FakeUpstream>> servers;
  for (int i = 0; i < kUpstreams; ++i) {
    servers.push_back(std::make_unique<FakeUpstream>([](const FakeRequest& req) {
      auto r = FakeReply::ok(req.target);
      if (req.target.back() == '3') r.delayBeforeHeaders = 5ms;
      return r;
    }));
  }
  std::vector<std::atomic<int>> calls(kFetches);
  std::vector<std::atomic<bool>> right(kFetches);
  std::atomic<int> done{0};
  std::mutex m;
  std::condition_variable cv;
  {
    Fetcher f(8);
    for (int u = 0; u < kUpstreams; ++u)
      f.setPolicy("up" + std::to_string(u), fastPolicy());
    // Submitted from several threads at once.
    std::vector<std::thread> submitters;
    for (int t = 0; t < 4; ++t) {
      submitters.emplace_back([&, t] {
        for (int i = t; i < kFetches; i += 4) {
          const int u = i % kUpstreams;
          const std::string target = "/tile/" + std::to_string(i);
          f.fetch(get("up" + std::to_string(u), servers[static_cast<std::size_t>(u)]->url(target)),
                  [&, i, target](FetchResult&& r) {
                    const auto k = static_cast<std::size_t>(i);
                    right[k] = r && r->status == 200 && text(r->body) == target;
                    ++calls[k];
                    std::lock_guard lock(m);
                    ++done;
                    cv.notify_all();
                  });
        }
      });
    }
    for (auto& t : submitters)
      t.join();
    std::unique_lock lock(m);
    ASSERT_TRUE(cv.wait_for(lock, 8s, [&] { return done == kFetches; }));
    lock.unlock();
    for (int u = 0; u < kUpstreams; ++u) {
      const auto s = f.stats("up" + std::to_string(u));
      EXPECT_EQ(s.requests, 50u);
      EXPECT_EQ(s.failures, 0u);
    }
  }
  for (int i = 0; i < kFetches; ++i) {
    EXPECT_EQ(calls[static_cast<std::size_t>(i)], 1) << i;
    EXPECT_TRUE(right[static_cast<std::size_t>(i)]) << i;
  }
  std::size_t total = 0;
  for (const auto& s : servers) {
    total += s->requests();
    EXPECT_LE(s->maxConcurrent(), 4); // the default cap
  }
  EXPECT_EQ(total, static_cast<std::size_t>(kFetches));
}

TEST(FetcherIntegration, CallbacksMayFetchAgainAndMayThrow) {
  FakeUpstream server;
  Fetcher f;
  f.setPolicy("u", fastPolicy());
  Pending second;
  auto secondCb = second.callback();
  f.fetch(get("u", server.url("/first")), [&](FetchResult&& r) {
    EXPECT_TRUE(r);
    f.fetch(get("u", server.url("/second")), secondCb); // from the fetcher thread itself
    throw std::runtime_error("a careless callback");
  });
  auto r = second.wait();
  ASSERT_TRUE(r) << r.error().message;
  auto third = fetchNow(f, get("u", server.url("/third"))); // the fetcher thread survived
  EXPECT_TRUE(third);
  EXPECT_EQ(server.requests(), 3u);
}

// ---- Retry-After (429 / 503) ------------------------------------------------------------------

TEST(Fetcher, RetryAfterIsSecondsOrAnHttpDate) {
  using std::chrono::seconds;
  const auto now = std::chrono::system_clock::time_point(seconds(1'700'000'000));
  EXPECT_EQ(parseRetryAfter("120", now), std::chrono::milliseconds(120000));
  EXPECT_EQ(parseRetryAfter("0", now), std::chrono::milliseconds(0));
  // 1700000000 is Tue, 14 Nov 2023 22:13:20 GMT.
  EXPECT_EQ(parseRetryAfter("Tue, 14 Nov 2023 22:14:00 GMT", now),
            std::chrono::milliseconds(40000));
  EXPECT_EQ(parseRetryAfter("Tue, 14 Nov 2023 22:00:00 GMT", now), std::chrono::milliseconds(0));
  EXPECT_GE(*parseRetryAfter("99999999999999999999", now), std::chrono::hours(24));
  for (const char* bad : {"", "soon", "-5", "1.5", " 12", "12 "})
    EXPECT_FALSE(parseRetryAfter(bad, now)) << "'" << bad << "'";
}

TEST(FetcherIntegration, A503WithAShortRetryAfterIsRetriedNoEarlierThanAsked) {
  std::atomic<int> calls{0};
  FakeUpstream server([&](const FakeRequest&) {
    if (++calls > 1) return FakeReply::ok("fine");
    auto r = FakeReply::withStatus(503, "busy");
    r.headers.emplace_back("Retry-After", "1");
    return r;
  });
  Fetcher f;
  f.setPolicy("u", fastPolicy()); // 5 ms backoff: without Retry-After it would retry at once
  const auto started = Steady::now();
  auto r = fetchNow(f, get("u", server.url("/t")));
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(text(r->body), "fine");
  EXPECT_EQ(r->attempts, 2);
  EXPECT_GE(Steady::now() - started, 950ms);
  EXPECT_EQ(f.stats("u").failures, 0u);
  EXPECT_EQ(f.breaker("u"), BreakerState::Closed);
}

TEST(FetcherIntegration, A429WithALongRetryAfterPausesTheUpstream) {
  FakeUpstream server([](const FakeRequest&) {
    auto r = FakeReply::withStatus(429, "slow down");
    r.headers.emplace_back("Retry-After", "3600");
    return r;
  });
  Fetcher f;
  f.setPolicy("u", fastPolicy());
  auto r = fetchNow(f, get("u", server.url("/a")));
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, FetchErrc::HttpError);
  EXPECT_EQ(r.error().httpStatus, 429);
  EXPECT_NE(r.error().message.find("3600 s"), std::string::npos) << r.error().message;
  EXPECT_EQ(server.requests(), 1u); // not retried: the wait is longer than maxRetryAfterWait
  for (int i = 0; i < 5; ++i) {
    auto again = fetchNow(f, get("u", server.url("/b")));
    ASSERT_FALSE(again);
    EXPECT_EQ(again.error().code, FetchErrc::Throttled);
    EXPECT_EQ(again.error().attempts, 0);
  }
  EXPECT_EQ(server.requests(), 1u);                // the paused upstream saw nothing more
  EXPECT_EQ(f.breaker("u"), BreakerState::Closed); // throttling is not a failure
}

TEST(FetcherIntegration, A429WithoutRetryAfterIsRetriedWithBackoff) {
  std::atomic<int> calls{0};
  FakeUpstream server([&](const FakeRequest&) {
    return ++calls == 1 ? FakeReply::withStatus(429, "slow down") : FakeReply::ok("fine");
  });
  Fetcher f;
  f.setPolicy("u", fastPolicy());
  auto r = fetchNow(f, get("u", server.url("/t")));
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(r->attempts, 2);
}
