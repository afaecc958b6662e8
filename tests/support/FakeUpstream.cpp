#include "FakeUpstream.hpp"

#include <algorithm>
#include <arpa/inet.h>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <stdexcept>
#include <sys/socket.h>
#include <unistd.h>

namespace tellus::test {

namespace {

char lower(char c) {
  return (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t'))
    s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t'))
    s.remove_suffix(1);
  return s;
}

const char* reason(int status) {
  switch (status) {
  case 200:
    return "OK";
  case 204:
    return "No Content";
  case 301:
    return "Moved Permanently";
  case 302:
    return "Found";
  case 304:
    return "Not Modified";
  case 400:
    return "Bad Request";
  case 403:
    return "Forbidden";
  case 404:
    return "Not Found";
  case 500:
    return "Internal Server Error";
  case 502:
    return "Bad Gateway";
  case 503:
    return "Service Unavailable";
  default:
    return "Status";
  }
}

bool parseHead(std::string_view head, FakeRequest& out) {
  auto eol = head.find("\r\n");
  const std::string_view line = head.substr(0, eol);
  const auto sp1 = line.find(' ');
  const auto sp2 = line.rfind(' ');
  if (sp1 == std::string_view::npos || sp2 == sp1) return false;
  out.method = std::string(line.substr(0, sp1));
  out.target = std::string(line.substr(sp1 + 1, sp2 - sp1 - 1));
  while (eol != std::string_view::npos) {
    const auto start = eol + 2;
    eol = head.find("\r\n", start);
    const std::string_view h =
        head.substr(start, eol == std::string_view::npos ? eol : eol - start);
    const auto colon = h.find(':');
    if (colon == std::string_view::npos) continue;
    std::string name(trim(h.substr(0, colon)));
    for (char& c : name)
      c = lower(c);
    out.headers[name] = std::string(trim(h.substr(colon + 1)));
  }
  return true;
}

} // namespace

FakeUpstream::FakeUpstream(FakeHandler handler) : handler_(std::move(handler)) {
  if (::pipe2(stopPipe_, O_CLOEXEC) != 0) throw std::runtime_error("pipe2 failed");
  listenFd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (listenFd_ < 0) throw std::runtime_error("socket failed");
  int one = 1;
  ::setsockopt(listenFd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  if (::bind(listenFd_, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0 ||
      ::listen(listenFd_, 128) != 0)
    throw std::runtime_error("bind/listen on 127.0.0.1:0 failed");
  socklen_t len = sizeof addr;
  ::getsockname(listenFd_, reinterpret_cast<sockaddr*>(&addr), &len);
  port_ = ntohs(addr.sin_port);
  acceptor_ = std::thread([this] { acceptLoop(); });
}

FakeUpstream::~FakeUpstream() {
  stop();
}

void FakeUpstream::setHandler(FakeHandler handler) {
  std::lock_guard lock(mutex_);
  handler_ = std::move(handler);
}

std::string FakeUpstream::url(std::string_view target) const {
  return "http://127.0.0.1:" + std::to_string(port_) + std::string(target);
}

std::size_t FakeUpstream::requests() const {
  std::lock_guard lock(mutex_);
  return requests_;
}

std::size_t FakeUpstream::requests(const std::string& target) const {
  std::lock_guard lock(mutex_);
  auto it = perTarget_.find(target);
  return it == perTarget_.end() ? 0 : it->second;
}

std::size_t FakeUpstream::accepts() const {
  std::lock_guard lock(mutex_);
  return accepts_;
}

int FakeUpstream::concurrent() const {
  std::lock_guard lock(mutex_);
  return concurrent_;
}

int FakeUpstream::maxConcurrent() const {
  std::lock_guard lock(mutex_);
  return maxConcurrent_;
}

std::vector<FakeRequest> FakeUpstream::received() const {
  std::lock_guard lock(mutex_);
  return received_;
}

bool FakeUpstream::waitForRequests(std::size_t n, std::chrono::milliseconds limit) const {
  std::unique_lock lock(mutex_);
  return requestArrived_.wait_for(lock, limit, [&] { return requests_ >= n; });
}

void FakeUpstream::stop() {
  {
    std::lock_guard lock(mutex_);
    if (stopped_) return;
    stopped_ = true;
    for (const auto& gate : gates_)
      gate->open();
  }
  const char byte = 'x';
  // The pipe is never read: once written, every poll on it reports readable.
  while (::write(stopPipe_[1], &byte, 1) < 0 && errno == EINTR) {
  }
  if (acceptor_.joinable()) acceptor_.join();
  std::vector<std::thread> connections;
  {
    std::lock_guard lock(mutex_);
    connections.swap(connections_);
  }
  for (auto& t : connections)
    t.join();
  ::close(listenFd_);
  ::close(stopPipe_[0]);
  ::close(stopPipe_[1]);
}

std::uint16_t FakeUpstream::closedPort() {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  socklen_t len = sizeof addr;
  ::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr);
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  ::close(fd);
  return ntohs(addr.sin_port);
}

int FakeUpstream::waitFor(int fd, short events, int timeoutMs) const {
  for (;;) {
    pollfd fds[2] = {{stopPipe_[0], POLLIN, 0}, {fd, events, 0}};
    const int n = ::poll(fds, fd >= 0 ? 2 : 1, timeoutMs);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return -1;
    if (n == 0) return 0;
    if (fds[0].revents != 0) return -1;
    return 1;
  }
}

bool FakeUpstream::pause(std::chrono::milliseconds d) const {
  const auto until = std::chrono::steady_clock::now() + d;
  for (;;) {
    const auto left =
        std::chrono::ceil<std::chrono::milliseconds>(until - std::chrono::steady_clock::now());
    if (left.count() <= 0) return true;
    pollfd fds[1] = {{stopPipe_[0], POLLIN, 0}};
    const int n = ::poll(fds, 1, static_cast<int>(left.count()));
    if (n > 0) return false;
  }
}

bool FakeUpstream::sendAll(int fd, std::string_view data) const {
  while (!data.empty()) {
    const ssize_t n = ::send(fd, data.data(), data.size(), MSG_NOSIGNAL);
    if (n > 0) {
      data.remove_prefix(static_cast<std::size_t>(n));
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
      if (waitFor(fd, POLLOUT, -1) != 1) return false;
      continue;
    }
    return false;
  }
  return true;
}

void FakeUpstream::acceptLoop() {
  for (;;) {
    if (waitFor(listenFd_, POLLIN, -1) != 1) return;
    const int fd = ::accept4(listenFd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) continue;
    int one = 1;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    std::lock_guard lock(mutex_);
    ++accepts_;
    connections_.emplace_back([this, fd] { serve(fd); });
  }
}

void FakeUpstream::serve(int fd) {
  std::string buffer;
  for (;;) {
    std::size_t end = 0;
    bool open = true;
    while ((end = buffer.find("\r\n\r\n")) == std::string::npos) {
      char chunk[4096];
      const ssize_t n = ::recv(fd, chunk, sizeof chunk, 0);
      if (n > 0) {
        buffer.append(chunk, static_cast<std::size_t>(n));
        if (buffer.size() > 64 * 1024) open = false;
      } else if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) {
        if (waitFor(fd, POLLIN, -1) != 1) open = false;
      } else {
        open = false; // peer closed or error
      }
      if (!open) break;
    }
    if (!open) break;
    FakeRequest request;
    const bool parsed = parseHead(std::string_view(buffer).substr(0, end), request);
    buffer.erase(0, end + 4);
    if (!parsed) break;
    // Request bodies are read and dropped (the fetcher only sends GETs).
    std::size_t bodyLeft = 0;
    if (auto cl = request.headers.find("content-length"); cl != request.headers.end())
      bodyLeft = static_cast<std::size_t>(std::strtoull(cl->second.c_str(), nullptr, 10));
    while (bodyLeft > 0) {
      const std::size_t take = std::min(bodyLeft, buffer.size());
      buffer.erase(0, take);
      bodyLeft -= take;
      if (bodyLeft == 0) break;
      char chunk[4096];
      const ssize_t n = ::recv(fd, chunk, sizeof chunk, 0);
      if (n > 0)
        buffer.append(chunk, static_cast<std::size_t>(n));
      else if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) {
        if (waitFor(fd, POLLIN, -1) != 1) break;
      } else {
        break;
      }
    }

    FakeHandler handler;
    {
      std::lock_guard lock(mutex_);
      ++requests_;
      ++perTarget_[request.target];
      received_.push_back(request);
      requestArrived_.notify_all();
      ++concurrent_;
      maxConcurrent_ = std::max(maxConcurrent_, concurrent_);
      handler = handler_;
    }
    FakeReply reply;
    try {
      reply = handler ? handler(request) : FakeReply::ok("ok", "text/plain");
    } catch (...) {
      reply = FakeReply::withStatus(500, "handler threw");
    }
    // The request stops being answered just before its last byte goes out: once the client has
    // that byte it may send its next request (on this connection or another), which must not be
    // counted while this one still is.
    bool released = false;
    auto release = [&] {
      if (released) return;
      released = true;
      std::lock_guard lock(mutex_);
      --concurrent_;
    };
    bool keep = answer(fd, request, reply, release);
    release();
    if (request.header("connection") == "close") keep = false;
    if (!keep) break;
  }
  ::close(fd);
}

bool FakeUpstream::answer(int fd,
                          const FakeRequest& request,
                          const FakeReply& reply,
                          const std::function<void()>& beforeLastByte) {
  if (reply.closeWithoutResponse) return false;
  if (reply.resetWithoutResponse) {
    // Linger on with a zero timeout: close() sends RST instead of FIN.
    const linger hard{1, 0};
    ::setsockopt(fd, SOL_SOCKET, SO_LINGER, &hard, sizeof hard);
    return false;
  }
  if (reply.holdUntilOpen) {
    {
      std::lock_guard lock(mutex_);
      gates_.push_back(reply.holdUntilOpen);
      if (stopped_) reply.holdUntilOpen->open();
    }
    reply.holdUntilOpen->wait();
    std::lock_guard lock(mutex_);
    if (stopped_) return false;
  }
  if (reply.delayBeforeHeaders.count() > 0 && !pause(reply.delayBeforeHeaders)) return false;
  if (reply.hangForever) {
    waitFor(-1, 0, -1); // until stop()
    return false;
  }
  const bool bodyAllowed = !(reply.status == 204 || reply.status == 304 || reply.status < 200) &&
                           request.method != "HEAD";
  bool hasLength = false;
  std::string head =
      "HTTP/1.1 " + std::to_string(reply.status) + " " + reason(reply.status) + "\r\n";
  for (const auto& [name, value] : reply.headers) {
    std::string n = name;
    for (char& c : n)
      c = lower(c);
    if (n == "content-length") hasLength = true;
    head += name + ": " + value + "\r\n";
  }
  std::string payload;
  if (bodyAllowed && reply.chunked) {
    head += "Transfer-Encoding: chunked\r\n";
    if (!reply.body.empty()) {
      char size[32];
      std::snprintf(size, sizeof size, "%zx\r\n", reply.body.size());
      payload = size + reply.body + "\r\n";
    }
    payload += "0\r\n\r\n";
  } else if (bodyAllowed) {
    if (!hasLength) head += "Content-Length: " + std::to_string(reply.body.size()) + "\r\n";
    payload = reply.truncate ? reply.body.substr(0, reply.body.size() / 2) : reply.body;
  } else if (!hasLength && reply.status != 304 && reply.status != 204) {
    head += "Content-Length: 0\r\n";
  }
  if (reply.closeAfter) head += "Connection: close\r\n";
  head += "\r\n";
  // The whole reply but its last byte, then beforeLastByte(), then the last byte.
  const std::string_view all = payload.empty() ? std::string_view(head) : std::string_view(payload);
  if (!payload.empty() && !sendAll(fd, head)) return false;
  if (reply.dripBytesPerSecond > 0 && !payload.empty()) {
    const auto gap = std::chrono::milliseconds(1000 / reply.dripBytesPerSecond);
    for (std::size_t i = 0; i + 1 < all.size(); ++i)
      if (!sendAll(fd, all.substr(i, 1)) || !pause(gap)) return false;
  } else if (!sendAll(fd, all.substr(0, all.size() - 1))) {
    return false;
  }
  beforeLastByte();
  if (!sendAll(fd, all.substr(all.size() - 1))) return false;
  return !reply.truncate && !reply.closeAfter;
}

} // namespace tellus::test
