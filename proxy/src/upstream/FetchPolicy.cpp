#include "upstream/FetchPolicy.hpp"

#include <tellus/proxy/HttpDates.hpp>

#include <algorithm>

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

} // namespace tellus

namespace tellus::fetch {

// ---- the circuit breaker ----------------------------------------------------------------------

BreakerState Breaker::observed(SteadyTime now) const noexcept {
  if (state == BreakerState::Open && now >= openUntil) return BreakerState::HalfOpen;
  return state;
}

bool Breaker::refuses(SteadyTime now) const noexcept {
  return state == BreakerState::HalfOpen || (state == BreakerState::Open && now < openUntil);
}

Breaker::Gate Breaker::gate(SteadyTime now) noexcept {
  if (state == BreakerState::Open && now >= openUntil) {
    state = BreakerState::HalfOpen;
    return Gate::Probe;
  }
  return state == BreakerState::Closed ? Gate::Go : Gate::Refuse;
}

bool Breaker::record(bool probe, Verdict v, SteadyTime now, const UpstreamPolicy& policy) noexcept {
  if (probe) {
    if (v == Verdict::Success) {
      state = BreakerState::Closed;
      consecutiveFailures = 0;
    } else {
      state = BreakerState::Open;
      openUntil = v == Verdict::Failure ? now + policy.openInterval : now;
    }
    return false; // nothing can be queued or waiting while half open
  }
  if (state != BreakerState::Closed) return false; // a straggler from before it opened
  if (v == Verdict::Success) {
    consecutiveFailures = 0;
  } else if (v == Verdict::Failure && ++consecutiveFailures >= policy.failureThreshold) {
    state = BreakerState::Open;
    openUntil = now + policy.openInterval;
    return true;
  }
  return false;
}

// ---- what an answer means ---------------------------------------------------------------------

namespace {

/** An HTTP answer (failure None): a response, or an error for 429, 5xx and the odd statuses. */
Classified classifyAnswer(TransferResult&& t, std::chrono::system_clock::time_point wallNow) {
  Classified c;
  const int status = t.status;
  auto err = [&](bool retryable, Verdict v) {
    c.error = FetchError{FetchErrc::HttpError, "HTTP " + std::to_string(status), status, 0};
    c.retryable = retryable;
    c.verdict = v;
  };
  if (status == 429 || status == 503) {
    // The upstream is alive and asks us to slow down: not a failure for the breaker when it says
    // for how long; a bare 503 still counts as one.
    c.retryAfter = parseRetryAfter(t.retryAfter, wallNow);
    err(true, c.retryAfter || status == 429 ? Verdict::Neutral : Verdict::Failure);
    return c;
  }
  if ((status >= 200 && status < 300) || status == 304 || (status >= 400 && status < 500)) {
    FetchResponse r;
    r.status = status;
    r.contentType = std::move(t.contentType);
    r.body = std::move(t.body);
    r.etag = std::move(t.etag);
    r.lastModified = std::move(t.lastModified);
    r.cacheControl = std::move(t.cacheControl);
    r.expires = std::move(t.expires);
    c.response = std::move(r);
    c.verdict = Verdict::Success;
  } else if (status >= 500) {
    err(true, Verdict::Failure);
  } else {
    err(false, Verdict::Neutral);
  }
  return c;
}

} // namespace

Classified classify(TransferResult&& t,
                    std::size_t maxBodyBytes,
                    std::chrono::system_clock::time_point wallNow) {
  if (t.failure == TransferFailure::None) return classifyAnswer(std::move(t), wallNow);
  Classified c;
  auto err = [&](FetchErrc code, bool retryable, Verdict v, std::string what) {
    c.error = FetchError{code, std::move(what), t.status, 0};
    c.retryable = retryable;
    c.verdict = v;
  };
  switch (t.failure) {
  case TransferFailure::TooLarge:
    err(FetchErrc::TooLarge,
        false,
        Verdict::Success,
        "body larger than " + std::to_string(maxBodyBytes) + " bytes");
    break;
  case TransferFailure::OutOfMemory:
    err(FetchErrc::Unknown, false, Verdict::Neutral, "out of memory");
    break;
  case TransferFailure::Timeout:
    err(FetchErrc::Timeout, true, Verdict::Failure, std::move(t.detail));
    break;
  case TransferFailure::Connect:
    err(FetchErrc::Connect, true, Verdict::Failure, std::move(t.detail));
    break;
  case TransferFailure::Tls:
    err(FetchErrc::Connect, false, Verdict::Failure, std::move(t.detail));
    break;
  case TransferFailure::Truncated:
    err(FetchErrc::Truncated, true, Verdict::Failure, std::move(t.detail));
    break;
  case TransferFailure::TooManyRedirects:
    err(FetchErrc::HttpError, false, Verdict::Neutral, std::move(t.detail));
    break;
  case TransferFailure::None:
  case TransferFailure::Other:
    err(FetchErrc::Unknown, false, Verdict::Neutral, std::move(t.detail));
    break;
  }
  return c;
}

bool isRedirect(int status) noexcept {
  return status == 301 || status == 302 || status == 303 || status == 307 || status == 308;
}

milliseconds backoffCeiling(milliseconds base, int retry) noexcept {
  const std::int64_t b = std::max<std::int64_t>(0, base.count());
  return milliseconds(std::min<std::int64_t>(b << std::clamp(retry, 0, 16), 600000));
}

// ---- redirects and headers --------------------------------------------------------------------

std::string redirectRefusal(const UpstreamPolicy& policy,
                            const std::string& askedUrl,
                            const std::string& location,
                            int hops,
                            int status) {
  const auto from = urlOrigin(askedUrl);
  const auto to = urlOrigin(location);
  const bool sameOrigin = from && to && *from == *to;
  const bool web = to && (to->starts_with("http://") || to->starts_with("https://"));
  const std::string http = "the upstream redirected (HTTP " + std::to_string(status) + ")";
  if (policy.redirects == UpstreamPolicy::Redirects::None)
    return http + " and its redirects are not followed (redirects: none)";
  if (!web) return http + " to a URL that is not http(s)";
  if (!sameOrigin && policy.redirects == UpstreamPolicy::Redirects::SameOrigin)
    return http + " to another origin (" + *to + ") and redirects: same-origin refuses it";
  if (hops >= policy.maxRedirects)
    return "more than " + std::to_string(policy.maxRedirects) + " redirects";
  return {};
}

namespace {

bool validHeaderPart(std::string_view s) noexcept {
  return s.find_first_of("\r\n") == std::string_view::npos;
}

} // namespace

std::optional<std::vector<std::string>> requestHeaderLines(const UpstreamPolicy& policy,
                                                           const FetchRequest& request,
                                                           const std::string& url,
                                                           int hops) {
  std::vector<std::string> lines;
  bool ok = true;
  auto add = [&](std::string_view name, std::string_view value) {
    if (name.empty() || !validHeaderPart(name) || !validHeaderPart(value) ||
        name.find(':') != std::string_view::npos) {
      ok = false;
      return;
    }
    std::string line;
    line.reserve(name.size() + value.size() + 2);
    line.append(name).append(": ").append(value);
    lines.push_back(std::move(line));
  };
  // The configured headers (API keys among them) go to the upstream's own origin only.
  if (hops == 0 || urlOrigin(url) == urlOrigin(request.url)) {
    for (const auto& [name, value] : policy.headers)
      add(name, value);
  }
  if (!request.ifNoneMatch.empty()) add("If-None-Match", request.ifNoneMatch);
  if (!request.ifModifiedSince.empty()) add("If-Modified-Since", request.ifModifiedSince);
  if (!ok) return std::nullopt;
  return lines;
}

} // namespace tellus::fetch
