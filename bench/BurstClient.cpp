// N concurrent GETs spread round-robin over several loopback servers, all let go at once: the
// burst of bench/peers/burst.sh (issue 27), as tests/cli/burst.py makes it, without its client's
// own queue. burst.py's 300 Python threads take turns on one interpreter lock to parse and hash
// the answers that all arrive together, which adds tens of milliseconds to the last answers of
// every server alike; here each client is a thread of its own that reads and hashes its answer
// without waiting for another, so the tail measured is the servers'.
//
// Usage: tellus_bench_burst N TARGET PORT [PORT...]   (TARGET: a path and query, or @FILE, one per
// line, client i asking for the (i mod count)-th). Prints one JSON line, as burst.py: the statuses,
// how many distinct bodies came back, and latency p50/p99/max in milliseconds, each measured from
// just before the client sends its request to the last byte of its answer. Exits 1 unless every
// answer is a 200 with an image/* Content-Type and every target's answers have one body.
#include <algorithm>
#include <arpa/inet.h>
#include <barrier>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <set>
#include <string>
#include <sys/socket.h>
#include <sys/time.h>
#include <thread>
#include <unistd.h>
#include <vector>

namespace {

struct Result {
  std::string status; // "200", "404 not an image", or what went wrong
  std::uint64_t bodyHash = 0;
  double ms = 0;
};

std::uint64_t fnv1a(const std::string& s) {
  std::uint64_t h = 1469598103934665603ULL;
  for (const char c : s)
    h = (h ^ static_cast<unsigned char>(c)) * 1099511628211ULL;
  return h;
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](char c) {
    return static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  });
  return s;
}

int connectTo(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return -1;
  timeval tv{120, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  ::setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
  const int one = 1;
  ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

// Reads more of the answer into `buf`; false at the end of the stream or on an error.
bool readMore(int fd, std::string& buf) {
  char chunk[65536];
  const ssize_t n = ::recv(fd, chunk, sizeof chunk, 0);
  if (n <= 0) return false;
  buf.append(chunk, static_cast<std::size_t>(n));
  return true;
}

// One HTTP/1.1 answer: a Content-Length body, a chunked one, or one delimited by the close.
Result exchange(int fd, const std::string& request) {
  Result r;
  if (::send(fd, request.data(), request.size(), MSG_NOSIGNAL) !=
      static_cast<ssize_t>(request.size())) {
    r.status = "send failed";
    return r;
  }
  std::string buf;
  std::size_t headEnd = std::string::npos;
  while ((headEnd = buf.find("\r\n\r\n")) == std::string::npos)
    if (!readMore(fd, buf)) {
      r.status = "no answer";
      return r;
    }
  const std::string head = lower(buf.substr(0, headEnd));
  std::string body = buf.substr(headEnd + 4);
  const auto sp = head.find(' ');
  const std::string code = sp == std::string::npos ? "?" : head.substr(sp + 1, 3);
  auto header = [&head](const std::string& name) -> std::string {
    const auto at = head.find("\r\n" + name + ":");
    if (at == std::string::npos) return {};
    auto v = head.substr(at + name.size() + 3, head.find("\r\n", at + 2) - at - name.size() - 3);
    v.erase(0, v.find_first_not_of(' '));
    return v;
  };
  if (const std::string cl = header("content-length"); !cl.empty()) {
    const std::size_t want = std::strtoull(cl.c_str(), nullptr, 10);
    while (body.size() < want)
      if (!readMore(fd, body)) break;
    if (body.size() != want) {
      r.status = "short body";
      return r;
    }
  } else if (header("transfer-encoding").find("chunked") != std::string::npos) {
    std::string raw = std::move(body), out;
    std::size_t at = 0;
    for (;;) {
      std::size_t eol;
      while ((eol = raw.find("\r\n", at)) == std::string::npos)
        if (!readMore(fd, raw)) {
          r.status = "short chunk";
          return r;
        }
      const std::size_t n = std::strtoull(raw.c_str() + at, nullptr, 16);
      at = eol + 2;
      if (n == 0) break;
      while (raw.size() < at + n + 2)
        if (!readMore(fd, raw)) {
          r.status = "short chunk";
          return r;
        }
      out.append(raw, at, n);
      at += n + 2;
    }
    body = std::move(out);
  } else {
    while (readMore(fd, body)) {
    }
  }
  r.status = header("content-type").starts_with("image/") ? code : code + " not an image";
  r.bodyHash = fnv1a(body);
  return r;
}

} // namespace

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: %s N TARGET PORT [PORT...]\n", argv[0]);
    return 2;
  }
  const int n = std::atoi(argv[1]);
  std::vector<std::string> targets;
  if (const std::string t = argv[2]; t.starts_with("@")) {
    std::ifstream in(t.substr(1));
    for (std::string line; std::getline(in, line);)
      if (!line.empty()) targets.push_back(line);
  } else {
    targets.push_back(t);
  }
  std::vector<int> ports;
  for (int i = 3; i < argc; ++i)
    ports.push_back(std::atoi(argv[i]));
  if (n <= 0 || targets.empty() || std::find(ports.begin(), ports.end(), 0) != ports.end()) {
    std::fprintf(stderr, "burst: N, the targets and the ports must be given\n");
    return 2;
  }

  std::vector<Result> results(static_cast<std::size_t>(n));
  std::barrier gate(n);
  std::vector<std::thread> clients;
  clients.reserve(results.size());
  for (int i = 0; i < n; ++i) {
    clients.emplace_back([&, i] {
      const int port = ports[static_cast<std::size_t>(i) % ports.size()];
      const std::string request = "GET " + targets[static_cast<std::size_t>(i) % targets.size()] +
                                  " HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(port) +
                                  "\r\nAccept-Encoding: identity\r\n\r\n";
      const int fd = connectTo(port); // connected before the barrier, as burst.py
      gate.arrive_and_wait();
      const auto start = std::chrono::steady_clock::now();
      Result r = fd < 0 ? Result{"connect failed", 0, 0} : exchange(fd, request);
      r.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
                 .count();
      if (fd >= 0) ::close(fd);
      results[static_cast<std::size_t>(i)] = std::move(r);
    });
  }
  for (auto& t : clients)
    t.join();

  std::vector<double> ms;
  std::map<std::string, int> statuses;
  std::map<std::size_t, std::set<std::uint64_t>> perTarget;
  std::set<std::uint64_t> bodies;
  for (std::size_t i = 0; i < results.size(); ++i) {
    ms.push_back(results[i].ms);
    ++statuses[results[i].status];
    perTarget[i % targets.size()].insert(results[i].bodyHash);
    bodies.insert(results[i].bodyHash);
  }
  std::sort(ms.begin(), ms.end());
  const auto at = [&ms](std::size_t k) {
    return std::round(ms[std::min(k, ms.size() - 1)] * 10) / 10;
  };
  std::printf("{\"statuses\": {");
  bool first = true;
  for (const auto& [s, c] : statuses) {
    std::printf("%s\"%s\": %d", first ? "" : ", ", s.c_str(), c);
    first = false;
  }
  std::printf("}, \"bodies\": %zu, \"p50_ms\": %.1f, \"p99_ms\": %.1f, \"max_ms\": %.1f}\n",
              bodies.size(),
              at(ms.size() / 2),
              at(static_cast<std::size_t>(static_cast<double>(ms.size()) * 0.99)),
              at(ms.size() - 1));
  const bool oneBodyEach = std::all_of(
      perTarget.begin(), perTarget.end(), [](const auto& p) { return p.second.size() == 1; });
  return statuses.size() == 1 && statuses.begin()->first == "200" && oneBodyEach ? 0 : 1;
}
