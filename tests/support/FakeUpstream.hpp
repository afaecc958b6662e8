#pragma once
// A scriptable HTTP/1.1 server on 127.0.0.1 for fetcher tests: keep-alive, request counting, and
// faults on demand (delays, drip-fed bodies, truncation, dropped and reset connections, hangs), and
// replies held until the test opens a Gate, so that a test waits for events, not for intervals.

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>
#include <utility>
#include <vector>

namespace tellus::test {

struct FakeRequest {
  std::string method;
  std::string target;                         ///< path and query, as sent
  std::map<std::string, std::string> headers; ///< names in lower case
  /** A header's value, or "" (name in lower case). */
  std::string header(const std::string& name) const {
    auto it = headers.find(name);
    return it == headers.end() ? std::string() : it->second;
  }
};

/** Holds the replies that carry it until the test opens it (or the server stops). */
class Gate {
public:
  void open() {
    std::lock_guard lock(mutex_);
    open_ = true;
    cv_.notify_all();
  }
  void wait() {
    std::unique_lock lock(mutex_);
    cv_.wait(lock, [&] { return open_; });
  }

private:
  std::mutex mutex_;
  std::condition_variable cv_;
  bool open_ = false;
};

struct FakeReply {
  int status = 200;
  std::vector<std::pair<std::string, std::string>> headers;
  std::string body;
  std::chrono::milliseconds delayBeforeHeaders{0};
  int dripBytesPerSecond = 0;          ///< > 0: the body goes out one byte at a time at this rate
  bool truncate = false;               ///< announce Content-Length body.size(), send half, close
  bool chunked = false;                ///< Transfer-Encoding: chunked instead of Content-Length
  bool closeAfter = false;             ///< "Connection: close" and close after the reply
  bool closeWithoutResponse = false;   ///< read the request, then close
  bool resetWithoutResponse = false;   ///< read the request, then reset the connection (RST)
  bool hangForever = false;            ///< read the request, then wait until the server stops
  std::shared_ptr<Gate> holdUntilOpen; ///< set: nothing is sent before the gate opens

  static FakeReply ok(std::string body, std::string contentType = "application/octet-stream") {
    FakeReply r;
    r.body = std::move(body);
    r.headers.emplace_back("Content-Type", std::move(contentType));
    return r;
  }
  static FakeReply withStatus(int status, std::string body = {}) {
    FakeReply r;
    r.status = status;
    r.body = std::move(body);
    return r;
  }
};

using FakeHandler = std::function<FakeReply(const FakeRequest&)>;

class FakeUpstream {
public:
  /** Listens on 127.0.0.1 with an ephemeral port. Without a handler every request gets 200 "ok". */
  explicit FakeUpstream(FakeHandler handler = {});
  /** stop(). */
  ~FakeUpstream();
  FakeUpstream(const FakeUpstream&) = delete;
  FakeUpstream& operator=(const FakeUpstream&) = delete;

  void setHandler(FakeHandler handler);

  std::uint16_t port() const { return port_; }
  /** "http://127.0.0.1:<port>" + target. */
  std::string url(std::string_view target = "/") const;

  std::size_t requests() const;
  std::size_t requests(const std::string& target) const;
  std::size_t accepts() const; ///< TCP connections accepted
  int concurrent() const;      ///< requests being answered now
  int maxConcurrent() const;   ///< the most requests answered at once so far
  std::vector<FakeRequest> received() const;
  /** Waits until `n` requests have arrived (`limit` only guards against a hang). */
  bool waitForRequests(std::size_t n,
                       std::chrono::milliseconds limit = std::chrono::seconds(5)) const;

  /** Closes the listener, wakes every connection (hanging ones included) and joins all threads.
   * Idempotent. */
  void stop();

  /** A loopback port that nothing listens on (bound, read back and closed). */
  static std::uint16_t closedPort();

private:
  void acceptLoop();
  void serve(int fd);
  /** Answers one request; false when the connection must close. */
  bool answer(int fd,
              const FakeRequest& request,
              const FakeReply& reply,
              const std::function<void()>& beforeLastByte);
  /** Waits until fd has `events` or the server stops: 1 ready, 0 timeout, -1 stopped or error. */
  int waitFor(int fd, short events, int timeoutMs) const;
  /** Sleeps unless the server stops first; false when it stopped. */
  bool pause(std::chrono::milliseconds d) const;
  bool sendAll(int fd, std::string_view data) const;

  int listenFd_ = -1;
  int stopPipe_[2] = {-1, -1};
  std::uint16_t port_ = 0;
  std::thread acceptor_;

  mutable std::mutex mutex_;
  mutable std::condition_variable requestArrived_;
  FakeHandler handler_;
  std::vector<std::shared_ptr<Gate>> gates_; ///< of replies held: opened by stop()
  std::vector<std::thread> connections_;
  std::map<std::string, std::size_t> perTarget_;
  std::vector<FakeRequest> received_;
  std::size_t requests_ = 0;
  std::size_t accepts_ = 0;
  int concurrent_ = 0;
  int maxConcurrent_ = 0;
  bool stopped_ = false;
};

} // namespace tellus::test
