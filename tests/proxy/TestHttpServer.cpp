#include "../support/TempDir.hpp"

#include <tellus/proxy/HttpServer.hpp>

#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <csignal>
#include <cstring>
#include <fcntl.h>
#include <fstream>
#include <future>
#include <mutex>
#include <netinet/in.h>
#include <poll.h>
#include <string>
#include <sys/resource.h>
#include <sys/socket.h>
#include <thread>
#include <unistd.h>
#include <vector>

using namespace tellus;
using namespace std::chrono_literals;

namespace {

/** A raw loopback client: exactly the bytes we send, exactly the bytes we get. */
class RawClient {
public:
  explicit RawClient(std::uint16_t port) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    connected_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  }
  ~RawClient() {
    if (fd_ >= 0) ::close(fd_);
  }
  RawClient(const RawClient&) = delete;
  RawClient& operator=(const RawClient&) = delete;
  bool connected() const { return connected_; }
  void send(std::string_view s) { (void)::send(fd_, s.data(), s.size(), MSG_NOSIGNAL); }
  /** Reads until `marker` has arrived (and, with a Content-Length, the body), EOF or timeout. */
  std::string readResponse(std::chrono::milliseconds timeout = 3000ms) {
    std::string got;
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      if (complete(got)) break;
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 20) <= 0) continue;
      char buf[65536];
      const auto n = ::recv(fd_, buf, sizeof buf, 0);
      if (n <= 0) {
        closedByPeer_ = true;
        break;
      }
      got.append(buf, static_cast<std::size_t>(n));
    }
    return got;
  }
  /** True when a response has started to arrive within the timeout (nothing is read). */
  bool answerStarted(std::chrono::milliseconds timeout) {
    pollfd p{fd_, POLLIN, 0};
    return ::poll(&p, 1, static_cast<int>(timeout.count())) > 0;
  }
  /** True when the server closed the connection within the timeout. */
  bool closedWithin(std::chrono::milliseconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 20) <= 0) continue;
      char buf[4096];
      if (::recv(fd_, buf, sizeof buf, 0) <= 0) return true;
    }
    return false;
  }

private:
  static bool complete(const std::string& s) {
    const auto end = s.find("\r\n\r\n");
    if (end == std::string::npos) return false;
    const auto cl = s.find("Content-Length: ");
    if (cl == std::string::npos || cl > end) return true;
    const auto len = std::stoul(s.substr(cl + 16, 20));
    return s.size() >= end + 4 + len;
  }
  int fd_ = -1;
  bool connected_ = false;
  bool closedByPeer_ = false;
};

HttpServerOptions quickOptions() {
  HttpServerOptions o;
  o.threads = 2;
  o.requestTimeout = 300ms;
  o.keepAliveTimeout = 2000ms;
  return o;
}

/** The statuses the front end gives refusals (ProxyFrontEnd makes them; here a stand-in). */
int refusalStatus(HttpRefusal r) {
  switch (r) {
  case HttpRefusal::BadRequest:
    return 400;
  case HttpRefusal::MethodNotAllowed:
    return 405;
  case HttpRefusal::BodyTooLarge:
    return 413;
  case HttpRefusal::TooManyRequests:
    return 429;
  case HttpRefusal::HeaderTooLarge:
    return 431;
  case HttpRefusal::None:
    break;
  }
  return 500;
}

/** Echoes the path and query. A refused request is answered with its status and
 * "<refusal> <method> <target>". */
HttpHandler echoHandler(std::atomic<int>* calls = nullptr, std::atomic<int>* refused = nullptr) {
  return [calls, refused](HttpRequest&& req, Responder respond) {
    if (calls) ++*calls;
    if (req.refusal != HttpRefusal::None) {
      if (refused) ++*refused;
      return respond(HttpResponse::text(refusalStatus(req.refusal),
                                        "text/plain",
                                        std::string(toString(req.refusal)) + " " + req.method +
                                            " " + req.target));
    }
    std::string body = req.method + " " + req.path + " ?" + req.query +
                       " ua=" + std::string(req.header("user-agent"));
    auto r = HttpResponse::text(req.path == "/missing" ? 404 : 200, "text/plain", body);
    r.setHeader("X-Test", "1");
    respond(std::move(r));
  };
}

} // namespace

TEST(HttpServer, AnswersGetAndHeadOnAnAnyPort) {
  HttpServer server(quickOptions(), echoHandler());
  ASSERT_TRUE(server.start());
  ASSERT_NE(server.port(), 0);
  RawClient c(server.port());
  ASSERT_TRUE(c.connected());
  c.send("GET /wms?SERVICE=WMS&x=%20 HTTP/1.1\r\nHost: a\r\nUser-Agent: t\r\n\r\n");
  const std::string r = c.readResponse();
  EXPECT_TRUE(r.starts_with("HTTP/1.1 200 OK\r\n")) << r;
  EXPECT_NE(r.find("X-Test: 1"), std::string::npos);
  EXPECT_NE(r.find("Server: tellus"), std::string::npos);
  EXPECT_TRUE(r.ends_with("GET /wms ?SERVICE=WMS&x=%20 ua=t")) << r;
  c.send("HEAD /x HTTP/1.1\r\nHost: a\r\n\r\n");
  const std::string h = c.readResponse(500ms);
  EXPECT_TRUE(h.starts_with("HTTP/1.1 200 OK\r\n")) << h;
  EXPECT_NE(h.find("Content-Length: 13"), std::string::npos) << h; // "HEAD /x ? ua="
  EXPECT_TRUE(h.ends_with("\r\n\r\n")) << "HEAD must carry no body: " << h;
}

TEST(HttpServer, KeepAliveServesManyRequestsOnOneConnection) {
  std::atomic<int> calls{0};
  HttpServer server(quickOptions(), echoHandler(&calls));
  ASSERT_TRUE(server.start());
  RawClient c(server.port());
  for (int i = 0; i < 20; ++i) {
    c.send("GET /n" + std::to_string(i) + " HTTP/1.1\r\nHost: a\r\n\r\n");
    const std::string r = c.readResponse();
    ASSERT_NE(r.find("GET /n" + std::to_string(i) + " "), std::string::npos) << r;
  }
  EXPECT_EQ(calls.load(), 20);
  EXPECT_EQ(server.connections(), 1u);
}

TEST(HttpServer, AnswersLaterFromAnotherThread) {
  // The slow answer is held until the fast one has arrived: one pending answer never blocks others.
  std::promise<void> release;
  std::shared_future<void> released = release.get_future().share();
  HttpServer server(quickOptions(), [released](HttpRequest&& req, Responder respond) {
    if (req.path == "/slow") {
      std::thread([respond = std::move(respond), released] {
        released.wait();
        respond(HttpResponse::text(200, "text/plain", "slow"));
      }).detach();
      return;
    }
    respond(HttpResponse::text(200, "text/plain", "fast"));
  });
  ASSERT_TRUE(server.start());
  RawClient slow(server.port());
  RawClient fast(server.port());
  slow.send("GET /slow HTTP/1.1\r\nHost: a\r\n\r\n");
  fast.send("GET /fast HTTP/1.1\r\nHost: a\r\n\r\n");
  EXPECT_TRUE(fast.readResponse().ends_with("fast"));
  release.set_value();
  EXPECT_TRUE(slow.readResponse().ends_with("slow"));
}

TEST(HttpServer, RefusedRequestsReachTheHandlerFlagged) {
  HttpServerOptions o = quickOptions();
  o.maxHeaderBytes = 1024;
  std::atomic<int> calls{0};
  std::atomic<int> refused{0};
  HttpServer server(o, echoHandler(&calls, &refused));
  ASSERT_TRUE(server.start());
  {
    // Another method: refused, and the connection stays usable.
    RawClient c(server.port());
    c.send("POST /x?a=1 HTTP/1.1\r\nHost: a\r\nContent-Length: 3\r\n\r\nabc");
    const std::string r = c.readResponse();
    EXPECT_TRUE(r.starts_with("HTTP/1.1 405")) << r;
    EXPECT_TRUE(r.ends_with("method-not-allowed POST /x?a=1")) << r;
    c.send("GET /after HTTP/1.1\r\nHost: a\r\n\r\n");
    EXPECT_TRUE(c.readResponse().starts_with("HTTP/1.1 200")) << "kept alive after a 405";
  }
  {
    RawClient c(server.port());
    c.send("GET /big HTTP/1.1\r\nHost: a\r\nX-Big: " + std::string(4000, 'a') + "\r\n\r\n");
    const std::string r = c.readResponse();
    EXPECT_TRUE(r.starts_with("HTTP/1.1 431")) << r;
    EXPECT_TRUE(r.ends_with("header-too-large GET /big")) << r;
    EXPECT_TRUE(c.closedWithin(1000ms));
  }
  {
    RawClient c(server.port());
    c.send("GET /body HTTP/1.1\r\nHost: a\r\nContent-Length: 100000\r\n\r\n");
    const std::string r = c.readResponse();
    EXPECT_TRUE(r.starts_with("HTTP/1.1 413")) << r;
    EXPECT_TRUE(r.ends_with("body-too-large GET /body")) << r;
    EXPECT_TRUE(c.closedWithin(1000ms));
  }
  {
    RawClient c(server.port());
    c.send("NONSENSE\r\n\r\n");
    const std::string r = c.readResponse();
    EXPECT_TRUE(r.starts_with("HTTP/1.1 400")) << r;
    EXPECT_TRUE(r.ends_with("bad-request NONSENSE ")) << r;
    EXPECT_TRUE(c.closedWithin(1000ms));
  }
  EXPECT_EQ(refused.load(), 4);
  EXPECT_EQ(calls.load(), 5);
}

// A raw space or a control byte in the request target is a malformed request line: 400 (the
// handler sees what could be read of it, for the access log), then the connection closes.
// acceptPost (tellus cluster's control API): POST reaches the handler with its body; a body over
// 8 KiB is still refused.
TEST(HttpServer, AcceptPostHandsTheBodyOver) {
  HttpServerOptions o = quickOptions();
  o.acceptPost = true;
  HttpServer server(o, [](HttpRequest&& req, Responder respond) {
    if (req.refusal != HttpRefusal::None)
      return respond(HttpResponse::text(refusalStatus(req.refusal), "text/plain", "refused"));
    respond(HttpResponse::text(200, "text/plain", req.method + " " + req.path + " " + req.body));
  });
  ASSERT_TRUE(server.start());
  RawClient c(server.port());
  c.send("POST /camera HTTP/1.1\r\nHost: a\r\nContent-Length: 11\r\n\r\n{\"lat\": 10}");
  const std::string r = c.readResponse();
  EXPECT_TRUE(r.starts_with("HTTP/1.1 200")) << r;
  EXPECT_TRUE(r.ends_with("POST /camera {\"lat\": 10}")) << r;
  RawClient big(server.port());
  big.send("POST /x HTTP/1.1\r\nHost: a\r\nContent-Length: 9000\r\n\r\n" + std::string(9000, 'a'));
  EXPECT_TRUE(big.readResponse().starts_with("HTTP/1.1 413"));
}

TEST(HttpServer, ARawSpaceOrControlByteInTheTargetIs400) {
  std::mutex m;
  std::vector<std::string> targets;
  HttpServer server(quickOptions(), [&](HttpRequest&& req, Responder respond) {
    {
      std::lock_guard lock(m);
      targets.push_back(req.target);
    }
    respond(HttpResponse::text(
        req.refusal == HttpRefusal::BadRequest ? 400 : 200, "text/plain", toString(req.refusal)));
  });
  ASSERT_TRUE(server.start());
  const std::vector<std::string> bad{std::string("/wms?a=b c"),
                                     std::string("/tiles/x\x01y"),
                                     std::string("/a\x7f"),
                                     std::string("/a\tb"),
                                     std::string("/nul\0x", 6)};
  for (const std::string& target : bad) {
    RawClient c(server.port());
    c.send("GET " + target + " HTTP/1.1\r\nHost: a\r\n\r\n");
    const std::string r = c.readResponse();
    EXPECT_TRUE(r.starts_with("HTTP/1.1 400"))
        << "target " << testing::PrintToString(target) << " got " << testing::PrintToString(r);
    EXPECT_NE(r.find("Connection: close"), std::string::npos) << r;
    EXPECT_TRUE(c.closedWithin(1000ms));
  }
  std::lock_guard lock(m);
  ASSERT_EQ(targets.size(), bad.size());
  EXPECT_EQ(targets[0], "/wms?a=b c");
  EXPECT_EQ(targets[1], "/tiles/x\x01y");
}

TEST(HttpServer, OptionsIsServedAndARefusedRequestIsNeverServed) {
  HttpServer server(quickOptions(), [](HttpRequest&& req, Responder respond) {
    // Wrong on purpose: it serves whatever comes, refused or not.
    respond(HttpResponse::text(200, "text/plain", req.method + " " + toString(req.refusal)));
  });
  ASSERT_TRUE(server.start());
  RawClient c(server.port());
  c.send("OPTIONS /wms HTTP/1.1\r\nHost: a\r\nOrigin: http://b\r\n"
         "Access-Control-Request-Method: GET\r\n\r\n");
  const std::string o = c.readResponse();
  EXPECT_TRUE(o.starts_with("HTTP/1.1 200")) << o;
  EXPECT_TRUE(o.ends_with("OPTIONS none")) << o;
  c.send("DELETE /wms HTTP/1.1\r\nHost: a\r\n\r\n");
  const std::string d = c.readResponse();
  EXPECT_TRUE(d.starts_with("HTTP/1.1 500")) << d;
}

TEST(HttpServerIntegration, SlowClientsAreCutOff) {
  HttpServer server(quickOptions(), echoHandler());
  ASSERT_TRUE(server.start());
  RawClient c(server.port());
  c.send("GET /x HTTP/1.1\r\nHo"); // never finishes its request
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_TRUE(c.closedWithin(5000ms));
  EXPECT_GE(std::chrono::steady_clock::now() - t0, 250ms); // not before its time (300 ms)
}

TEST(HttpServerIntegration, AThousandIdleConnectionsDoNotStallIt) {
  rlimit lim{};
  ::getrlimit(RLIMIT_NOFILE, &lim);
  if (lim.rlim_cur < 2200 && lim.rlim_max >= 2200) {
    lim.rlim_cur = 2200;
    ::setrlimit(RLIMIT_NOFILE, &lim);
  }
  ASSERT_GE(lim.rlim_cur, 2200u) << "needs 2 x 1000 descriptors (client and server side)";
  HttpServerOptions o = quickOptions();
  o.keepAliveTimeout = 10s;
  o.requestTimeout = 10s;
  HttpServer server(o, echoHandler());
  ASSERT_TRUE(server.start());
  std::vector<std::unique_ptr<RawClient>> idle;
  for (int i = 0; i < 1000; ++i) {
    idle.push_back(std::make_unique<RawClient>(server.port()));
    ASSERT_TRUE(idle.back()->connected());
  }
  // Half of them have made a request and keep the connection open.
  for (int i = 0; i < 1000; i += 2)
    idle[static_cast<std::size_t>(i)]->send("GET /k HTTP/1.1\r\nHost: a\r\n\r\n");
  for (int i = 0; i < 1000; i += 2)
    ASSERT_NE(idle[static_cast<std::size_t>(i)]->readResponse().find("/k"), std::string::npos);
  RawClient c(server.port());
  c.send("GET /fresh HTTP/1.1\r\nHost: a\r\n\r\n");
  EXPECT_NE(c.readResponse().find("/fresh"), std::string::npos);
  EXPECT_GE(server.connections(), 1001u);
}

TEST(HttpServerIntegration, ConnectionLimitRefusesTheRest) {
  HttpServerOptions o = quickOptions();
  o.maxConnections = 3;
  o.keepAliveTimeout = 5s;
  o.requestTimeout = 5s;
  HttpServer server(o, echoHandler());
  ASSERT_TRUE(server.start());
  std::vector<std::unique_ptr<RawClient>> held;
  for (int i = 0; i < 3; ++i) {
    held.push_back(std::make_unique<RawClient>(server.port()));
    held.back()->send("GET /a HTTP/1.1\r\nHost: a\r\n\r\n");
    ASSERT_NE(held.back()->readResponse().find("/a"), std::string::npos);
  }
  RawClient extra(server.port());
  EXPECT_TRUE(extra.closedWithin(1000ms));
}

TEST(HttpServer, StopsWithAnAnswerStillPending) {
  Responder kept;
  std::mutex m;
  std::condition_variable handled;
  HttpServer server(quickOptions(), [&](HttpRequest&&, Responder respond) {
    std::lock_guard lock(m);
    kept = std::move(respond); // never answered before stop()
    handled.notify_all();
  });
  ASSERT_TRUE(server.start());
  RawClient c(server.port());
  c.send("GET /hang HTTP/1.1\r\nHost: a\r\n\r\n");
  {
    std::unique_lock lock(m);
    handled.wait_for(lock, 2s, [&] { return static_cast<bool>(kept); });
  }
  server.stop();
  std::lock_guard lock(m);
  ASSERT_TRUE(kept);
  kept(HttpResponse::text(200, "text/plain", "late")); // after stop: dropped, not a crash
  kept = nullptr;
}

TEST(HttpServer, RateLimitPerClientAnswers429) {
  HttpServerOptions o = quickOptions();
  o.requestsPerSecond = 5; // burst of 10
  std::atomic<int> calls{0};
  std::atomic<int> refused{0};
  HttpServer server(o, echoHandler(&calls, &refused));
  ASSERT_TRUE(server.start());
  RawClient c(server.port());
  int ok = 0;
  int limited = 0;
  for (int i = 0; i < 30; ++i) {
    c.send("GET /r HTTP/1.1\r\nHost: a\r\n\r\n");
    const std::string r = c.readResponse();
    if (r.starts_with("HTTP/1.1 200")) ++ok;
    if (r.starts_with("HTTP/1.1 429")) {
      ++limited;
      EXPECT_TRUE(r.ends_with("too-many-requests GET /r")) << r;
    }
  }
  EXPECT_GE(ok, 10);     // the burst
  EXPECT_GE(limited, 5); // the loop is far faster than 5 a second, even on a loaded machine
  EXPECT_EQ(ok + limited, 30);
  // Every request reaches the handler, the refused ones flagged (to be answered and counted).
  EXPECT_EQ(calls.load(), 30);
  EXPECT_EQ(refused.load(), limited);
}

// ------------------------------------------------------------------------ file bodies (sendfile)

namespace {

/** A file of `n` bytes with a position-dependent pattern, opened read-only. */
struct PatternFile {
  test::TempDir dir{"http-file"};
  std::string bytes;
  std::shared_ptr<int> fd;
  explicit PatternFile(std::size_t n) {
    bytes.resize(n);
    for (std::size_t i = 0; i < n; ++i)
      bytes[i] = static_cast<char>((i * 131 + i / 251) & 0xFF);
    const auto path = dir.path() / "tile.bin";
    std::ofstream(path, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(n));
    fd = std::shared_ptr<int>(new int(::open(path.c_str(), O_RDONLY | O_CLOEXEC)), [](int* p) {
      ::close(*p);
      delete p;
    });
  }
  HttpResponse response(std::int64_t promised = -1) const {
    HttpResponse r;
    r.setHeader("Content-Type", "image/jpeg");
    r.setHeader("ETag", "\"e1\"");
    r.file =
        HttpFileBody{*fd, promised < 0 ? static_cast<std::int64_t>(bytes.size()) : promised, fd};
    return r;
  }
};

HttpHandler fileHandler(const PatternFile& f) {
  return [&f](HttpRequest&& req, Responder respond) {
    if (req.path == "/short")
      return respond(f.response(static_cast<std::int64_t>(f.bytes.size()) + 100));
    if (req.path == "/later") {
      std::thread([&f, respond = std::move(respond)] { respond(f.response()); }).detach();
      return;
    }
    respond(f.response());
  };
}

/** Waits until the server has at most `n` connections open. A poll of the server's count: it
 * drops a connection on its own (Asio's send timeout on a real socket, or a write into a reset
 * one), and nothing the client can observe without reading tells when (reading would unstick a
 * stuck client). */
bool connectionsDropTo(const HttpServer& server, std::size_t n, std::chrono::milliseconds limit) {
  const auto deadline = std::chrono::steady_clock::now() + limit;
  while (server.connections() > n) {
    if (std::chrono::steady_clock::now() >= deadline) return false;
    std::this_thread::sleep_for(5ms);
  }
  return true;
}

std::string bodyOf(const std::string& r) {
  const auto end = r.find("\r\n\r\n");
  return end == std::string::npos ? std::string() : r.substr(end + 4);
}

} // namespace

TEST(HttpServer, FileBodiesAreSentWholeOnAKeptAliveConnection) {
  const PatternFile f(3 * 1024 * 1024 + 17); // larger than the socket buffers: partial sends
  HttpServer server(quickOptions(), fileHandler(f));
  ASSERT_TRUE(server.start());
  RawClient c(server.port());
  for (const char* path : {"/now", "/later", "/now"}) {
    c.send(std::string("GET ") + path + " HTTP/1.1\r\nHost: a\r\n\r\n");
    const std::string r = c.readResponse(5000ms);
    ASSERT_TRUE(r.starts_with("HTTP/1.1 200 OK\r\n")) << r.substr(0, 200);
    EXPECT_NE(r.find("Content-Length: " + std::to_string(f.bytes.size()) + "\r\n"),
              std::string::npos);
    EXPECT_NE(r.find("Content-Type: image/jpeg\r\n"), std::string::npos);
    EXPECT_NE(r.find("Server: tellus\r\n"), std::string::npos);
    EXPECT_EQ(r.find("Connection: close"), std::string::npos);
    EXPECT_TRUE(bodyOf(r) == f.bytes) << path << ": body differs";
  }
  c.send("HEAD /now HTTP/1.1\r\nHost: a\r\n\r\n");
  const std::string h = c.readResponse(500ms);
  EXPECT_NE(h.find("Content-Length: " + std::to_string(f.bytes.size())), std::string::npos) << h;
  EXPECT_TRUE(h.ends_with("\r\n\r\n")) << "HEAD must carry no body";
}

TEST(HttpServer, FileBodiesHonourHttp10AndConnectionClose) {
  const PatternFile f(5000);
  HttpServer server(quickOptions(), fileHandler(f));
  ASSERT_TRUE(server.start());
  {
    RawClient c(server.port());
    c.send("GET /now HTTP/1.0\r\nConnection: keep-alive\r\n\r\n");
    const std::string r = c.readResponse();
    EXPECT_TRUE(r.starts_with("HTTP/1.0 200 OK\r\n")) << r.substr(0, 100);
    EXPECT_NE(r.find("Connection: keep-alive\r\n"), std::string::npos);
    EXPECT_TRUE(bodyOf(r) == f.bytes);
    c.send("GET /now HTTP/1.0\r\n\r\n"); // no keep-alive: closed after the answer
    EXPECT_TRUE(bodyOf(c.readResponse()) == f.bytes);
    EXPECT_TRUE(c.closedWithin(1000ms));
  }
  RawClient c(server.port());
  c.send("GET /now HTTP/1.1\r\nHost: a\r\nConnection: close\r\n\r\n");
  const std::string r = c.readResponse();
  EXPECT_NE(r.find("Connection: close\r\n"), std::string::npos);
  EXPECT_TRUE(c.closedWithin(1000ms));
}

TEST(HttpServer, AFileShorterThanPromisedClosesTheConnection) {
  const PatternFile f(1000);
  HttpServer server(quickOptions(), fileHandler(f));
  ASSERT_TRUE(server.start());
  RawClient c(server.port());
  c.send("GET /short HTTP/1.1\r\nHost: a\r\n\r\n");
  (void)c.readResponse(300ms);
  EXPECT_TRUE(c.closedWithin(1000ms)); // never a hang, never the next response mid-body
}

TEST(HttpServer, AClientThatDoesNotReadAFileBodyIsCutOff) {
  const PatternFile f(16 * 1024 * 1024);
  HttpServer server(quickOptions(), fileHandler(f)); // request timeout 300 ms
  ASSERT_TRUE(server.start());
  {
    RawClient stuck(server.port());
    stuck.send("GET /now HTTP/1.1\r\nHost: a\r\n\r\n");
    ASSERT_TRUE(stuck.answerStarted(2000ms)); // the server is sending it the file, which it leaves
    // Meanwhile others are served.
    RawClient other(server.port());
    other.send("GET /now HTTP/1.1\r\nHost: a\r\n\r\n");
    EXPECT_TRUE(bodyOf(other.readResponse(5000ms)) == f.bytes);
    EXPECT_TRUE(connectionsDropTo(server, 1, 3s)) << "the stuck connection is still open";
  }
}

// A client that resets its connection in the middle of a file body: sendfile(2) gets EPIPE, which
// must close that connection only. (Before, SIGPIPE ended the process: tellus serve died under
// wrk -c1000 in the peer benchmark.) The test runs with SIGPIPE at its default, as a fresh process
// has it.
TEST(HttpServer, AClientResettingMidBodyDoesNotKillTheServer) {
  std::signal(SIGPIPE, SIG_DFL);
  const PatternFile f(16 * 1024 * 1024); // far more than the socket buffers hold
  HttpServer server(quickOptions(), fileHandler(f));
  ASSERT_TRUE(server.start());
  for (int i = 0; i < 5; ++i) {
    const int s = ::socket(AF_INET, SOCK_STREAM, 0);
    ASSERT_GE(s, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(server.port());
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(::connect(s, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
    const std::string req = "GET /now HTTP/1.1\r\nHost: a\r\n\r\n";
    ASSERT_EQ(::send(s, req.data(), req.size(), MSG_NOSIGNAL), static_cast<ssize_t>(req.size()));
    char buf[4096];
    ASSERT_GT(::recv(s, buf, sizeof buf, 0), 0); // the body has started
    const linger reset{1, 0};                    // close with RST, not FIN
    ::setsockopt(s, SOL_SOCKET, SO_LINGER, &reset, sizeof reset);
    ::close(s);
    // The server has written into the reset connection (EPIPE) and dropped it.
    ASSERT_TRUE(connectionsDropTo(server, 0, 3s)) << i;
  }
  RawClient c(server.port());
  c.send("GET /now HTTP/1.1\r\nHost: a\r\n\r\n");
  EXPECT_TRUE(bodyOf(c.readResponse(5000ms)) == f.bytes) << "the server still answers";
}
