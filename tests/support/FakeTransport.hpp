#pragma once
// A transport for the Fetcher's tests (tellus/proxy/Transport.hpp): no network, every transfer
// answered by the test, at once (a handler) or later (held, then answer()). With a ManualClock the
// Fetcher's policies (retries, backoff, Retry-After, the breaker, caps, redirects) run without a
// socket and without sleeping: time moves when the test says, and waitIdle() says when the
// fetcher thread has done everything it can.
//
// poll() ignores its timeout (except 0: something is due now), since time is the test's: after
// ManualClock::advance(), poke() the fetcher so that it looks at its timers.

#include <tellus/proxy/Transport.hpp>

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace tellus::test {

class FakeTransport final : public ITransport {
public:
  /// A started transfer's answer: a result at once, or nullopt to hold it until answer().
  using Handler = std::function<std::optional<TransferResult>(const TransferRequest&)>;

  /** Without a handler every transfer is held. */
  explicit FakeTransport(Handler handler = {}) : handler_(std::move(handler)) {}

  static TransferResult ok(std::string body = "ok", std::string contentType = "image/png") {
    TransferResult r;
    r.status = 200;
    r.contentType = std::move(contentType);
    r.body.resize(body.size());
    for (std::size_t i = 0; i < body.size(); ++i)
      r.body[i] = static_cast<std::byte>(body[i]);
    return r;
  }
  static TransferResult status(int code, std::string retryAfter = {}) {
    TransferResult r;
    r.status = code;
    r.retryAfter = std::move(retryAfter);
    return r;
  }
  static TransferResult redirect(int code, std::string location) {
    TransferResult r;
    r.status = code;
    r.location = std::move(location);
    return r;
  }
  static TransferResult failure(TransferFailure f, std::string detail = "fake failure") {
    TransferResult r;
    r.failure = f;
    r.detail = std::move(detail);
    return r;
  }

  void setHandler(Handler handler) {
    std::lock_guard lock(mutex_);
    handler_ = std::move(handler);
  }
  /** start() fails with this message from now on ("" : it starts transfers again). */
  void refuseStarts(std::string why) {
    std::lock_guard lock(mutex_);
    refuse_ = std::move(why);
  }

  /** Every transfer started so far, in order. */
  std::vector<TransferRequest> started() const {
    std::lock_guard lock(mutex_);
    return started_;
  }
  std::size_t startedCount() const {
    std::lock_guard lock(mutex_);
    return started_.size();
  }
  /** Transfers started and not answered yet. */
  std::size_t held() const {
    std::lock_guard lock(mutex_);
    return held_.size();
  }
  /** Answers the held transfer that was started `index`-th (0 = the first ever). */
  bool answer(std::size_t index, TransferResult result) {
    std::lock_guard lock(mutex_);
    const auto it = held_.find(index);
    if (it == held_.end()) return false;
    ready_.emplace_back(it->second, std::move(result));
    held_.erase(it);
    cv_.notify_all();
    return true;
  }
  /** Waits until `n` transfers have started (`limit` only guards against a hang). */
  bool waitForStarted(std::size_t n, std::chrono::milliseconds limit = std::chrono::seconds(5)) {
    std::unique_lock lock(mutex_);
    return cv_.wait_for(lock, limit, [&] { return started_.size() >= n; });
  }
  /** Waits until the fetcher waits in poll() with nothing to do: every fetch(), answer() and
   * poke() before this call has been taken in and every callback that could run has run. */
  bool waitIdle(std::chrono::milliseconds limit = std::chrono::seconds(5)) {
    std::unique_lock lock(mutex_);
    return cv_.wait_for(lock, limit, [&] { return polling_ && !woken_ && ready_.empty(); });
  }
  /** Wakes the fetcher, e.g. after the test moved its clock on. */
  void poke() { wake(); }

  // ---- ITransport (the fetcher thread) ----

  std::expected<void, std::string> start(Id id, const TransferRequest& request) override {
    Handler handler;
    {
      std::lock_guard lock(mutex_);
      if (!refuse_.empty()) return std::unexpected(refuse_);
      handler = handler_;
    }
    std::optional<TransferResult> now = handler ? handler(request) : std::nullopt;
    std::lock_guard lock(mutex_);
    const std::size_t index = started_.size();
    started_.push_back(request);
    if (now)
      ready_.emplace_back(id, std::move(*now));
    else
      held_.emplace(index, id);
    cv_.notify_all();
    return {};
  }

  std::vector<std::pair<Id, TransferResult>> perform() override {
    std::lock_guard lock(mutex_);
    std::vector<std::pair<Id, TransferResult>> done;
    done.swap(ready_);
    return done;
  }

  void poll(std::chrono::milliseconds timeout) override {
    std::unique_lock lock(mutex_);
    if (timeout.count() > 0 && !woken_ && ready_.empty()) {
      polling_ = true;
      cv_.notify_all();
      cv_.wait(lock, [&] { return woken_ || !ready_.empty(); });
      polling_ = false;
    }
    woken_ = false;
  }

  void wake() override {
    std::lock_guard lock(mutex_);
    woken_ = true;
    cv_.notify_all();
  }

  void abandonAll() override {
    std::lock_guard lock(mutex_);
    held_.clear();
    ready_.clear();
  }

private:
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  Handler handler_;
  std::string refuse_;
  std::vector<TransferRequest> started_;
  std::map<std::size_t, Id> held_; ///< by start index
  std::vector<std::pair<Id, TransferResult>> ready_;
  bool woken_ = false;
  bool polling_ = false;
};

} // namespace tellus::test
