#include <tellus/proxy/HttpServer.hpp>

#include <algorithm>
#include <atomic>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <cctype>
#include <cerrno>
#include <csignal>
#include <mutex>
#include <optional>
#include <sys/sendfile.h>
#include <sys/socket.h>
#include <thread>
#include <unordered_map>
#include <unordered_set>

namespace tellus {

namespace beast = boost::beast;
namespace http = boost::beast::http;
namespace net = boost::asio;
using tcp = boost::asio::ip::tcp;

std::string_view HttpRequest::header(std::string_view lowerName) const noexcept {
  for (const auto& [k, v] : headers) {
    if (k == lowerName) return v;
  }
  return {};
}

void HttpResponse::setHeader(std::string name, std::string value) {
  for (auto& [k, v] : headers) {
    if (std::equal(k.begin(), k.end(), name.begin(), name.end(), [](char a, char b) {
          return std::tolower(static_cast<unsigned char>(a)) ==
                 std::tolower(static_cast<unsigned char>(b));
        })) {
      v = std::move(value);
      return;
    }
  }
  headers.emplace_back(std::move(name), std::move(value));
}

HttpResponse HttpResponse::text(int status, std::string_view contentType, std::string_view body) {
  HttpResponse r;
  r.status = status;
  r.headers.emplace_back("Content-Type", std::string(contentType));
  r.body.resize(body.size());
  std::transform(
      body.begin(), body.end(), r.body.begin(), [](char c) { return static_cast<std::byte>(c); });
  return r;
}

const char* toString(HttpRefusal refusal) noexcept {
  switch (refusal) {
  case HttpRefusal::None:
    return "none";
  case HttpRefusal::BadRequest:
    return "bad-request";
  case HttpRefusal::MethodNotAllowed:
    return "method-not-allowed";
  case HttpRefusal::BodyTooLarge:
    return "body-too-large";
  case HttpRefusal::TooManyRequests:
    return "too-many-requests";
  case HttpRefusal::HeaderTooLarge:
    return "header-too-large";
  }
  return "none";
}

namespace {
class Session;
}

struct HttpServer::Impl : std::enable_shared_from_this<Impl> {
  HttpServerOptions options;
  HttpHandler handler;
  // One event loop per thread, as nginx has one per worker: a connection lives on one loop for its
  // whole life, so its handlers need no strand, and a loop never wakes another to run them (one
  // shared io_context with N threads cost a futex wake-up per request). The acceptor is on loop 0
  // and hands new connections out round-robin.
  std::vector<std::unique_ptr<net::io_context>> loops;
  std::vector<net::executor_work_guard<net::io_context::executor_type>> keepRunning;
  std::size_t nextLoop = 0; // acceptor's handler only
  std::optional<tcp::acceptor> acceptor;
  std::vector<std::thread> threads;
  std::atomic<std::size_t> connections{0};
  std::uint16_t boundPort = 0;

  // Responders post back into the loop only while it runs (see stop()).
  std::mutex postMutex;
  bool stopped = false;

  std::mutex sessionsMutex;
  std::unordered_set<Session*> sessions;

  // Token buckets per client address (requestsPerSecond > 0).
  struct Bucket {
    double tokens;
    std::chrono::steady_clock::time_point last;
  };
  std::mutex bucketsMutex;
  std::unordered_map<std::string, Bucket> buckets;

  /** Takes a token for this address; false when its bucket is empty. */
  bool admit(const std::string& address) {
    const double rate = options.requestsPerSecond;
    if (rate <= 0) return true;
    const double burst = std::max(1.0, 2 * rate);
    const auto now = (options.clock ? *options.clock : Clock::system()).steady();
    std::lock_guard lock(bucketsMutex);
    if (buckets.size() > 100000) { // forget addresses whose buckets are full again
      std::erase_if(buckets, [&](const auto& kv) {
        return std::chrono::duration<double>(now - kv.second.last).count() * rate >= burst;
      });
    }
    auto [it, fresh] = buckets.try_emplace(address, Bucket{burst, now});
    Bucket& b = it->second;
    if (!fresh) {
      b.tokens =
          std::min(burst, b.tokens + std::chrono::duration<double>(now - b.last).count() * rate);
      b.last = now;
    }
    if (b.tokens < 1.0) return false;
    b.tokens -= 1.0;
    return true;
  }

  Impl(HttpServerOptions o, HttpHandler h) : options(std::move(o)), handler(std::move(h)) {}

  void doAccept();
};

namespace {

using LoopExecutor = net::io_context::executor_type;

class Session : public std::enable_shared_from_this<Session> {
public:
  Session(tcp::socket&& socket, std::shared_ptr<HttpServer::Impl> server)
      : server_(std::move(server)), stream_(std::move(socket)),
        writeTimer_(stream_.get_executor()) {
    server_->connections.fetch_add(1);
    // Once per connection, not per request.
    beast::error_code ec;
    const auto ep = stream_.socket().remote_endpoint(ec);
    if (!ec) remoteAddress_ = ep.address().to_string();
  }
  ~Session() {
    server_->connections.fetch_sub(1);
    std::lock_guard lock(server_->sessionsMutex);
    server_->sessions.erase(this);
  }

  void start() {
    {
      // Registered only now: make_shared has set up weak_from_this(), which stop() reads.
      std::lock_guard lock(server_->sessionsMutex);
      server_->sessions.insert(this);
    }
    net::dispatch(stream_.get_executor(), [self = shared_from_this()] { self->doRead(true); });
  }

  /** Closes the socket from the session's own strand (used by stop()). */
  void close() {
    net::post(stream_.get_executor(), [self = shared_from_this()] {
      beast::error_code ec;
      self->stream_.socket().shutdown(tcp::socket::shutdown_both, ec);
      self->stream_.close();
    });
  }

private:
  void doRead(bool first) {
    parser_.emplace();
    parser_->header_limit(static_cast<std::uint32_t>(server_->options.maxHeaderBytes));
    // tellus serves GET, HEAD and OPTIONS (and POST where acceptPost); a small body is read (to
    // refuse its request, or for POST).
    parser_->body_limit(8192);
    // The first request must arrive within the request timeout; later ones within keep-alive.
    stream_.expires_after(first ? server_->options.requestTimeout
                                : server_->options.keepAliveTimeout);
    http::async_read(
        stream_, buffer_, *parser_, [self = shared_from_this()](beast::error_code ec, std::size_t) {
          self->onRead(ec);
        });
  }

  /** Whether a read error means the request was malformed (answered 400), as opposed to the
   * connection ending or timing out (closed without an answer). */
  static bool malformed(const beast::error_code& ec) {
    if (ec.category() != http::make_error_code(http::error::bad_target).category()) return false;
    return ec != http::error::end_of_stream && ec != http::error::partial_message &&
           ec != http::error::need_more && ec != http::error::need_buffer;
  }

  /** Method and target of what could be read of the request line (a request the parser refused:
   * its bytes are still in the buffer), for the handler and the access log. */
  void requestLineFromBuffer(HttpRequest& req) const {
    const auto data = buffer_.data();
    std::string_view raw(static_cast<const char*>(data.data()),
                         std::min<std::size_t>(data.size(), server_->options.maxHeaderBytes));
    if (const auto eol = raw.find_first_of("\r\n"); eol != std::string_view::npos)
      raw = raw.substr(0, eol);
    const auto sp = raw.find(' ');
    if (sp == std::string_view::npos) {
      req.method = std::string(raw.substr(0, 32));
      return;
    }
    req.method = std::string(raw.substr(0, std::min<std::size_t>(sp, 32)));
    std::string_view target = raw.substr(sp + 1);
    // The version is the last word when it looks like one: a raw space stays in the target.
    if (const auto v = target.rfind(" HTTP/"); v != std::string_view::npos)
      target = target.substr(0, v);
    req.target = std::string(target.substr(0, kMaxRefusedTarget));
  }

  static constexpr std::size_t kMaxRefusedTarget = 2048;

  void onRead(beast::error_code ec) {
    HttpRequest req;
    req.remoteAddress = remoteAddress_;
    if (ec == http::error::header_limit || ec == http::error::body_limit || malformed(ec)) {
      // Refused before it could be served; the handler answers (and logs) it, then the connection
      // closes: what follows on it cannot be told apart from the refused request.
      req.refusal = ec == http::error::header_limit ? HttpRefusal::HeaderTooLarge
                    : ec == http::error::body_limit ? HttpRefusal::BodyTooLarge
                                                    : HttpRefusal::BadRequest;
      // The parser consumes the request line (and each header line) as it reads them: what it
      // has read is in its message, what it refused is still in the buffer.
      if (parser_ && !parser_->get().target().empty()) {
        copyRequest(parser_->get(), req);
      } else {
        requestLineFromBuffer(req);
      }
      keepAlive_ = false;
      head_ = false;
      stream_.expires_never();
      return dispatch(std::move(req));
    }
    if (ec) return shutdownSend(); // timeout, end of stream, a reset
    auto& msg = parser_->get();
    copyRequest(msg, req);
    keepAlive_ = msg.keep_alive();
    head_ = msg.method() == http::verb::head;
    version_ = msg.version();
    stream_.expires_never(); // the handler's own timeouts bound the wait for the answer
    const bool post = msg.method() == http::verb::post && server_->options.acceptPost;
    if (post) req.body = msg.body();
    if (msg.method() != http::verb::get && msg.method() != http::verb::head &&
        msg.method() != http::verb::options && !post) {
      req.refusal = HttpRefusal::MethodNotAllowed;
    } else if (!server_->admit(req.remoteAddress)) {
      req.refusal = HttpRefusal::TooManyRequests;
    }
    dispatch(std::move(req));
  }

  template <class Message> static void copyRequest(const Message& msg, HttpRequest& req) {
    req.method = std::string(msg.method_string());
    req.target = std::string(msg.target());
    const auto q = req.target.find('?');
    req.path = req.target.substr(0, q);
    if (q != std::string::npos) req.query = req.target.substr(q + 1);
    for (const auto& field : msg) {
      std::string name(field.name_string());
      std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) {
        return static_cast<char>(std::tolower(c));
      });
      req.headers.emplace_back(std::move(name), std::string(field.value()));
    }
  }

  void dispatch(HttpRequest&& req) {
    if (req.refusal != HttpRefusal::None && req.path.empty()) {
      const auto q = req.target.find('?');
      req.path = req.target.substr(0, q);
      if (q != std::string::npos) req.query = req.target.substr(q + 1);
    }
    auto server = server_;
    const bool refused = req.refusal != HttpRefusal::None;
    Responder respond = [self = shared_from_this(), server, refused](HttpResponse&& r) {
      // A refused request is never served, whatever the handler does with it.
      if (refused && r.status < 400)
        r = HttpResponse::text(500, "text/plain", "internal error: a refused request was served\n");
      // Answered on the connection's own strand (a cache hit, an error): write at once. Posting
      // would hand the connection to whichever loop thread is free, a thread hop per request.
      if (self->onOwnStrand()) return self->write(std::move(r));
      std::lock_guard lock(server->postMutex);
      if (server->stopped) return;
      net::post(self->stream_.get_executor(),
                [self, r = std::move(r)]() mutable { self->write(std::move(r)); });
    };
    server_->handler(std::move(req), std::move(respond));
  }

  bool onOwnStrand() {
    const auto executor = stream_.get_executor();
    const auto* loop = executor.target<LoopExecutor>();
    return loop && loop->running_in_this_thread();
  }

  void write(HttpResponse&& r) {
    if (r.file) return writeFile(std::move(r));
    out_ = std::move(r);
    res_.emplace();
    res_->version(version_);
    res_->result(static_cast<unsigned>(out_.status));
    res_->set(http::field::server, server_->options.serverName);
    for (const auto& [k, v] : out_.headers)
      res_->set(k, v);
    res_->keep_alive(keepAlive_);
    const std::size_t n = out_.body.size();
    if (head_) {
      res_->body() = http::span_body<const char>::value_type();
      res_->set(http::field::content_length, std::to_string(n));
    } else {
      res_->body() = http::span_body<const char>::value_type(
          reinterpret_cast<const char*>(out_.body.data()), n);
      res_->prepare_payload();
    }
    stream_.expires_after(
        server_->options.requestTimeout); // a client that does not read is cut off
    http::async_write(
        stream_, *res_, [self = shared_from_this()](beast::error_code ec, std::size_t) {
          // An idle keep-alive connection holds no response.
          self->res_.reset();
          self->out_ = HttpResponse{};
          if (ec || !self->keepAlive_) return self->shutdownSend();
          self->doRead(false);
        });
  }

  // ------------------------------------------------------------------------ file bodies
  // The header goes out with MSG_MORE and the body with sendfile(2) from the tile's descriptor,
  // as nginx does: no read into a buffer and no copy from user space into the socket.

  static bool headerValueOk(std::string_view v) {
    return v.find_first_of("\r\n") == std::string_view::npos;
  }

  void writeFile(HttpResponse&& r) {
    file_ = std::move(*r.file);
    fileOffset_ = 0;
    fileEnd_ = head_ ? 0 : file_.size;
    headSent_ = 0;
    std::string& h = headText_;
    h.clear();
    h += version_ == 10 ? "HTTP/1.0 " : "HTTP/1.1 ";
    h += std::to_string(r.status);
    h += ' ';
    const auto reason = http::obsolete_reason(static_cast<http::status>(r.status));
    h.append(reason.data(), reason.size());
    h += "\r\nServer: ";
    h += server_->options.serverName;
    h += "\r\n";
    for (const auto& [k, v] : r.headers) {
      if (!headerValueOk(k) || !headerValueOk(v)) continue;
      h += k;
      h += ": ";
      h += v;
      h += "\r\n";
    }
    h += "Content-Length: ";
    h += std::to_string(file_.size);
    h += "\r\n";
    if (version_ == 10 && keepAlive_) h += "Connection: keep-alive\r\n";
    if (version_ != 10 && !keepAlive_) h += "Connection: close\r\n";
    h += "\r\n";
    if (!nonBlocking_) { // one ioctl per connection, not per response
      beast::error_code ec;
      stream_.socket().native_non_blocking(true, ec);
      if (ec) return fileDone(false);
      nonBlocking_ = true;
    }
    lastProgress_ = std::chrono::steady_clock::now();
    continueFile();
  }

  /** A client that reads nothing for requestTimeout is cut off (as nginx's send_timeout: the time
   * between two successful writes, not for the whole body). */
  void armWriteTimer(std::chrono::steady_clock::duration after) {
    writeTimer_.expires_after(after);
    writeTimer_.async_wait(
        [self = shared_from_this(), gen = writeGeneration_](beast::error_code e) {
          // Cancelled, or it expired just as that write finished (cancel cannot recall a handler
          // already queued): it must not touch a later request.
          if (e || !self->writeTimerArmed_ || gen != self->writeGeneration_) return;
          const auto idle = std::chrono::steady_clock::now() - self->lastProgress_;
          const auto limit = self->server_->options.requestTimeout;
          if (idle < limit) return self->armWriteTimer(limit - idle);
          beast::error_code ignored;
          self->stream_.socket().cancel(ignored); // fails the pending wait, which closes
        });
  }

  void continueFile() {
    const int sock = stream_.socket().native_handle();
    while (headSent_ < headText_.size()) {
      const bool more = fileOffset_ < fileEnd_;
      const ssize_t n = ::send(sock,
                               headText_.data() + headSent_,
                               headText_.size() - headSent_,
                               MSG_NOSIGNAL | (more ? MSG_MORE : 0));
      if (n < 0 && errno == EINTR) continue;
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return waitWritable();
      if (n <= 0) return fileDone(false);
      headSent_ += static_cast<std::size_t>(n);
      lastProgress_ = std::chrono::steady_clock::now();
    }
    while (fileOffset_ < fileEnd_) {
      off_t off = static_cast<off_t>(fileOffset_);
      const ssize_t n =
          ::sendfile(sock, file_.fd, &off, static_cast<std::size_t>(fileEnd_ - fileOffset_));
      if (n < 0 && errno == EINTR) continue;
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return waitWritable();
      // 0: the file is shorter than promised; the Content-Length cannot be kept, so close.
      if (n <= 0) return fileDone(false);
      fileOffset_ += n;
      lastProgress_ = std::chrono::steady_clock::now();
    }
    fileDone(true);
  }

  void waitWritable() {
    // Armed only when the socket is full: most tiles go out at once, and arming a timer costs a
    // timerfd_settime(2) per response.
    if (!writeTimerArmed_) {
      writeTimerArmed_ = true;
      armWriteTimer(server_->options.requestTimeout);
    }
    stream_.socket().async_wait(tcp::socket::wait_write,
                                [self = shared_from_this()](beast::error_code ec) {
                                  if (ec) return self->fileDone(false);
                                  self->continueFile();
                                });
  }

  void fileDone(bool ok) {
    if (writeTimerArmed_) {
      writeTimerArmed_ = false;
      ++writeGeneration_;
      writeTimer_.cancel();
    }
    file_ = HttpFileBody{}; // an idle keep-alive connection holds no descriptor
    headText_.clear();      // its capacity (a few hundred bytes) is kept for the next response
    if (!ok || !keepAlive_) return shutdownSend();
    doRead(false);
  }

  void shutdownSend() {
    beast::error_code ec;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ec);
  }

  // First, so destroyed last: a session can outlive the HttpServer object (a composed map's worker
  // or a fetch callback may hold the responder when the server is destroyed), and the server's
  // Impl owns the event loops that the socket and the timer below belong to. Released before
  // them, the last reference would destroy the loops first (ASan: heap-use-after-free in
  // ~io_object_impl).
  std::shared_ptr<HttpServer::Impl> server_;
  beast::tcp_stream stream_;
  net::steady_timer writeTimer_; // bounds a file body's write
  std::string remoteAddress_;
  HttpFileBody file_;
  std::string headText_;
  std::size_t headSent_ = 0;
  std::int64_t fileOffset_ = 0;
  std::int64_t fileEnd_ = 0;
  std::chrono::steady_clock::time_point lastProgress_{};
  bool writeTimerArmed_ = false;
  std::uint64_t writeGeneration_ = 0;
  bool nonBlocking_ = false;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
  std::optional<http::response<http::span_body<const char>>> res_;
  HttpResponse out_;
  bool keepAlive_ = true;
  bool head_ = false;
  unsigned version_ = 11;
};

} // namespace

void HttpServer::Impl::doAccept() {
  acceptor->async_accept(
      *loops[nextLoop], [self = shared_from_this()](beast::error_code ec, tcp::socket socket) {
        self->nextLoop = (self->nextLoop + 1) % self->loops.size();
        if (ec) {
          if (ec == net::error::operation_aborted) return; // stopping
        } else if (self->connections.load() >= self->options.maxConnections) {
          beast::error_code ignored;
          socket.close(ignored); // over the limit: refuse rather than stall everyone
        } else {
          std::make_shared<Session>(std::move(socket), self)->start();
        }
        self->doAccept();
      });
}

HttpServer::HttpServer(HttpServerOptions options, HttpHandler handler)
    : impl_(std::make_shared<Impl>(std::move(options), std::move(handler))) {}

HttpServer::~HttpServer() {
  stop();
}

std::expected<void, std::string> HttpServer::start() {
  auto& im = *impl_;
  // sendfile(2) has no MSG_NOSIGNAL: a client that resets its connection while a file body is
  // being sent would raise SIGPIPE and end the whole process (seen under wrk with 1,000
  // connections). Like nginx, a server ignores SIGPIPE; the write then fails with EPIPE and only
  // that connection closes.
  std::signal(SIGPIPE, SIG_IGN);
  beast::error_code ec;
  const auto address = net::ip::make_address(im.options.host, ec);
  if (ec) return std::unexpected("bad listen address '" + im.options.host + "': " + ec.message());
  const tcp::endpoint endpoint(address, im.options.port);
  // Default: a loop per core but one. Hits are answered on the loop itself; misses go to the tile
  // service's workers, the cache's writer and the fetcher, which need a core that the loops do not
  // keep busy (measured on 2 cores: 1 loop gave a p99 of 3.9-4.2 ms where 2 gave 5.3-6.7 ms at the
  // same throughput; bench/RESULTS.md).
  int n = im.options.threads > 0 ? im.options.threads
                                 : static_cast<int>(std::thread::hardware_concurrency()) - 1;
  n = std::max(n, 1);
  for (int i = 0; i < n; ++i) {
    im.loops.push_back(std::make_unique<net::io_context>(1)); // one thread: no scheduler locking
    im.keepRunning.push_back(net::make_work_guard(*im.loops.back()));
  }
  im.acceptor.emplace(*im.loops.front());
  const std::string where = im.options.host + ":" + std::to_string(im.options.port);
  im.acceptor->open(endpoint.protocol(), ec);
  if (!ec) im.acceptor->set_option(net::socket_base::reuse_address(true), ec);
  if (!ec) im.acceptor->bind(endpoint, ec);
  if (!ec) im.acceptor->listen(net::socket_base::max_listen_connections, ec);
  if (ec) return std::unexpected("cannot listen on " + where + ": " + ec.message());
  im.boundPort = im.acceptor->local_endpoint().port();
  im.doAccept();
  for (auto& loop : im.loops)
    im.threads.emplace_back([io = loop.get()] { io->run(); });
  return {};
}

std::uint16_t HttpServer::port() const noexcept {
  return impl_->boundPort;
}

std::size_t HttpServer::connections() const noexcept {
  return impl_->connections.load();
}

void HttpServer::stop() {
  auto& im = *impl_;
  if (im.threads.empty()) return;
  {
    std::lock_guard lock(im.postMutex);
    im.stopped = true; // answers that arrive from now on are dropped
  }
  // Sessions first: the pending accept keeps the loop running until their closes have run.
  std::vector<std::shared_ptr<Session>> open;
  {
    std::lock_guard lock(im.sessionsMutex);
    for (Session* s : im.sessions) {
      if (auto sp = s->weak_from_this().lock()) open.push_back(std::move(sp));
    }
  }
  // Outside the lock: dropping the last reference runs ~Session, which takes it too.
  for (auto& sp : open)
    sp->close();
  open.clear();
  net::post(*im.loops.front(), [&im] {
    beast::error_code ec;
    if (im.acceptor) im.acceptor->close(ec);
  });
  im.keepRunning.clear(); // loops with nothing left to do may return now
  // With the acceptor and every socket closed, the loop runs out of work and the threads return.
  for (auto& t : im.threads)
    t.join();
  // Anything posted after the last thread left (it would hold a session, which holds this
  // object: a cycle) runs here, on the caller's thread.
  for (auto& loop : im.loops) {
    loop->restart();
    loop->poll();
  }
  im.threads.clear();
}

} // namespace tellus
