// The libcurl transport (Transport.hpp): one multi handle driven by the Fetcher's thread
// (curl_multi_perform, curl_multi_poll, curl_multi_wakeup from any thread), easy handles kept per
// pool for reuse, bodies and the headers the Fetcher reads collected per transfer. The only code
// in tellus that uses libcurl's multi API (CdnPurge.cpp sends PURGE with the easy API);
// urlOrigin() is here too (libcurl's URL parser).
// It reports what happened and decides nothing: retries, the breaker, redirects are the Fetcher's.
#include <tellus/proxy/Fetcher.hpp>
#include <tellus/proxy/Transport.hpp>

#include <curl/curl.h>

#include <algorithm>
#include <limits>
#include <map>
#include <stdexcept>
#include <string_view>
#include <unordered_map>

namespace tellus {

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

long toLongMs(std::chrono::milliseconds ms) noexcept {
  return static_cast<long>(
      std::clamp<std::int64_t>(ms.count(), 1, std::numeric_limits<int>::max()));
}

void globalInit() {
  // Once per process, before any easy or multi handle exists.
  static const CURLcode rc = curl_global_init(CURL_GLOBAL_DEFAULT);
  if (rc != CURLE_OK) throw std::runtime_error("curl_global_init failed");
}

/** What one running transfer collects (CURLOPT_PRIVATE, the callbacks' user data). */
struct Transfer {
  ITransport::Id id = 0;
  CURL* easy = nullptr;
  curl_slist* headers = nullptr;
  std::string pool;
  std::size_t keepIdle = 0;
  std::size_t maxBody = 0;
  bool tooLarge = false;
  bool outOfMemory = false;
  TransferResult result;
  char errbuf[CURL_ERROR_SIZE] = {};
  Transfer() = default;
  Transfer(const Transfer&) = delete;
  Transfer& operator=(const Transfer&) = delete;
  ~Transfer() { curl_slist_free_all(headers); }
};

std::size_t onBody(char* data, std::size_t size, std::size_t count, void* user) noexcept {
  auto* t = static_cast<Transfer*>(user);
  const std::size_t bytes = size * count;
  std::vector<std::byte>& body = t->result.body;
  if (bytes > t->maxBody - body.size()) {
    t->tooLarge = true;
    return 0; // CURLE_WRITE_ERROR
  }
  try {
    const auto* p = reinterpret_cast<const std::byte*>(data);
    body.insert(body.end(), p, p + bytes);
  } catch (...) {
    t->outOfMemory = true;
    return 0;
  }
  return bytes;
}

/** A Content-Length within the limit reserves the body's storage at once. */
void reserveFor(Transfer& t, std::string_view value) {
  std::size_t n = 0;
  bool digits = !value.empty() && value.size() < 19;
  for (char c : value) {
    if (c < '0' || c > '9') {
      digits = false;
      break;
    }
    n = n * 10 + static_cast<std::size_t>(c - '0');
  }
  if (digits && n <= t.maxBody) t.result.body.reserve(n);
}

std::size_t onHeader(char* data, std::size_t size, std::size_t count, void* user) noexcept {
  auto* t = static_cast<Transfer*>(user);
  TransferResult& r = t->result;
  const std::size_t bytes = size * count;
  try {
    const std::string_view line(data, bytes);
    if (line.starts_with("HTTP/")) { // a new response (after a redirect or 100 Continue)
      r.contentType.clear();
      r.etag.clear();
      r.lastModified.clear();
      r.cacheControl.clear();
      r.expires.clear();
      r.retryAfter.clear();
      return bytes;
    }
    const auto colon = line.find(':');
    if (colon == std::string_view::npos) return bytes;
    const std::string_view name = trim(line.substr(0, colon));
    const std::string_view value = trim(line.substr(colon + 1));
    if (iequals(name, "content-type"))
      r.contentType = value;
    else if (iequals(name, "etag"))
      r.etag = value;
    else if (iequals(name, "last-modified"))
      r.lastModified = value;
    else if (iequals(name, "cache-control"))
      r.cacheControl = value;
    else if (iequals(name, "expires"))
      r.expires = value;
    else if (iequals(name, "retry-after"))
      r.retryAfter = value;
    else if (iequals(name, "content-length"))
      reserveFor(*t, value);
  } catch (...) {
    t->outOfMemory = true;
    return 0;
  }
  return bytes;
}

/** A finished transfer's libcurl code as a TransferFailure. */
TransferFailure failureOf(const Transfer& t, CURLcode rc) noexcept {
  if (rc == CURLE_OK) return TransferFailure::None;
  if (t.tooLarge || rc == CURLE_FILESIZE_EXCEEDED) return TransferFailure::TooLarge;
  if (t.outOfMemory) return TransferFailure::OutOfMemory;
  switch (rc) {
  case CURLE_OPERATION_TIMEDOUT:
    return TransferFailure::Timeout;
  case CURLE_COULDNT_RESOLVE_HOST:
  case CURLE_COULDNT_RESOLVE_PROXY:
  case CURLE_COULDNT_CONNECT:
  case CURLE_GOT_NOTHING:
  case CURLE_SEND_ERROR:
  case CURLE_RECV_ERROR:
  case CURLE_SSL_CONNECT_ERROR:
  case CURLE_HTTP2:
  case CURLE_HTTP2_STREAM:
    return TransferFailure::Connect;
  case CURLE_PEER_FAILED_VERIFICATION:
  case CURLE_SSL_CERTPROBLEM:
  case CURLE_SSL_CACERT_BADFILE:
    return TransferFailure::Tls;
  case CURLE_PARTIAL_FILE:
    return TransferFailure::Truncated;
  case CURLE_TOO_MANY_REDIRECTS:
    return TransferFailure::TooManyRedirects;
  default:
    return TransferFailure::Other;
  }
}

class CurlTransport final : public ITransport {
public:
  explicit CurlTransport(std::size_t maxConnections) {
    globalInit();
    multi_ = curl_multi_init();
    if (!multi_) throw std::runtime_error("curl_multi_init failed");
    curl_multi_setopt(
        multi_,
        CURLMOPT_MAXCONNECTS,
        static_cast<long>(std::min<std::size_t>(std::max<std::size_t>(1, maxConnections),
                                                std::numeric_limits<int>::max())));
  }

  ~CurlTransport() override {
    abandonAll();
    for (auto& [pool, easies] : idle_) {
      for (CURL* easy : easies)
        curl_easy_cleanup(easy);
    }
    curl_multi_cleanup(multi_);
  }

  CurlTransport(const CurlTransport&) = delete;
  CurlTransport& operator=(const CurlTransport&) = delete;

  std::expected<void, std::string> start(Id id, const TransferRequest& request) override {
    CURL* easy = takeIdle(request.pool);
    if (!easy) return std::unexpected("curl_easy_init failed");
    auto t = std::make_unique<Transfer>();
    t->id = id;
    t->easy = easy;
    t->pool = request.pool;
    t->keepIdle = request.keepIdle;
    t->maxBody = request.maxBodyBytes;
    for (const std::string& line : request.headerLines) {
      curl_slist* next = curl_slist_append(t->headers, line.c_str());
      if (!next) {
        curl_easy_cleanup(easy);
        return std::unexpected("invalid request header");
      }
      t->headers = next;
    }
    if (const CURLcode rc = configure(*t, request); rc != CURLE_OK) {
      curl_easy_cleanup(easy);
      return std::unexpected(std::string("bad request: ") + curl_easy_strerror(rc));
    }
    if (curl_multi_add_handle(multi_, easy) != CURLM_OK) {
      curl_easy_cleanup(easy);
      return std::unexpected("curl_multi_add_handle failed");
    }
    active_.emplace(easy, std::move(t));
    return {};
  }

  std::vector<std::pair<Id, TransferResult>> perform() override {
    int running = 0;
    curl_multi_perform(multi_, &running);
    std::vector<std::pair<Id, TransferResult>> done;
    int left = 0;
    while (CURLMsg* msg = curl_multi_info_read(multi_, &left)) {
      if (msg->msg != CURLMSG_DONE) continue;
      CURL* easy = msg->easy_handle;
      const CURLcode rc = msg->data.result; // msg dies with remove_handle
      if (auto r = finish(easy, rc)) done.push_back(std::move(*r));
    }
    return done;
  }

  void poll(std::chrono::milliseconds timeout) override {
    curl_multi_poll(multi_,
                    nullptr,
                    0,
                    static_cast<int>(std::clamp<std::int64_t>(timeout.count(), 0, 1000)),
                    nullptr);
  }

  void wake() override { curl_multi_wakeup(multi_); }

  void abandonAll() override {
    for (auto& [easy, t] : active_) {
      curl_multi_remove_handle(multi_, easy);
      curl_easy_cleanup(easy);
    }
    active_.clear();
  }

private:
  CURL* takeIdle(const std::string& pool) {
    auto it = idle_.find(pool);
    if (it == idle_.end() || it->second.empty()) return curl_easy_init();
    CURL* easy = it->second.back(); // reset when it came back: connections and caches stay
    it->second.pop_back();
    return easy;
  }

  static CURLcode configure(Transfer& t, const TransferRequest& request) {
    CURL* easy = t.easy;
    curl_write_callback onBodyFn = &onBody;
    curl_write_callback onHeaderFn = &onHeader;
    Transfer* tp = &t;
    CURLcode rc = CURLE_OK;
    auto set = [&](CURLcode r) {
      if (rc == CURLE_OK) rc = r;
    };
    set(curl_easy_setopt(easy, CURLOPT_URL, request.url.c_str()));
    set(curl_easy_setopt(easy, CURLOPT_PRIVATE, tp));
    set(curl_easy_setopt(easy, CURLOPT_WRITEFUNCTION, onBodyFn));
    set(curl_easy_setopt(easy, CURLOPT_WRITEDATA, tp));
    set(curl_easy_setopt(easy, CURLOPT_HEADERFUNCTION, onHeaderFn));
    set(curl_easy_setopt(easy, CURLOPT_HEADERDATA, tp));
    set(curl_easy_setopt(easy, CURLOPT_ERRORBUFFER, tp->errbuf));
    set(curl_easy_setopt(easy, CURLOPT_NOSIGNAL, 1L));
    set(curl_easy_setopt(easy, CURLOPT_HTTPGET, 1L));
    set(curl_easy_setopt(easy, CURLOPT_CONNECTTIMEOUT_MS, toLongMs(request.connectTimeout)));
    set(curl_easy_setopt(easy, CURLOPT_TIMEOUT_MS, toLongMs(request.timeout)));
    // Redirects are the Fetcher's to follow or refuse, not libcurl's: libcurl would send the
    // configured headers to whatever host a redirect names.
    set(curl_easy_setopt(easy, CURLOPT_FOLLOWLOCATION, 0L));
    set(curl_easy_setopt(easy, CURLOPT_PROTOCOLS_STR, "http,https"));
    set(curl_easy_setopt(easy, CURLOPT_ACCEPT_ENCODING, ""));
    set(curl_easy_setopt(easy, CURLOPT_USERAGENT, "tellus"));
    set(curl_easy_setopt(easy, CURLOPT_TCP_KEEPALIVE, 1L));
    set(curl_easy_setopt(easy,
                         CURLOPT_MAXFILESIZE_LARGE,
                         static_cast<curl_off_t>(std::min<std::size_t>(
                             request.maxBodyBytes,
                             static_cast<std::size_t>(std::numeric_limits<curl_off_t>::max())))));
    if (t.headers) set(curl_easy_setopt(easy, CURLOPT_HTTPHEADER, t.headers));
    return rc;
  }

  std::optional<std::pair<Id, TransferResult>> finish(CURL* easy, CURLcode rc) {
    auto it = active_.find(easy);
    if (it == active_.end()) return std::nullopt;
    std::unique_ptr<Transfer> t = std::move(it->second);
    active_.erase(it);
    curl_multi_remove_handle(multi_, easy);
    long status = 0;
    curl_easy_getinfo(easy, CURLINFO_RESPONSE_CODE, &status);
    TransferResult r = std::move(t->result);
    r.status = static_cast<int>(status);
    r.failure = failureOf(*t, rc);
    if (r.failure != TransferFailure::None)
      r.detail = t->errbuf[0] ? std::string(t->errbuf) : curl_easy_strerror(rc);
    if (rc == CURLE_OK && status >= 300 && status < 400) {
      char* to = nullptr; // absolute, resolved against this request's URL
      if (curl_easy_getinfo(easy, CURLINFO_REDIRECT_URL, &to) == CURLE_OK && to) r.location = to;
    }
    curl_easy_reset(easy); // drop pointers into the transfer before it dies
    std::vector<CURL*>& idle = idle_[t->pool];
    if (idle.size() < t->keepIdle)
      idle.push_back(easy);
    else
      curl_easy_cleanup(easy);
    return std::pair<Id, TransferResult>{t->id, std::move(r)};
  }

  CURLM* multi_ = nullptr;
  std::unordered_map<CURL*, std::unique_ptr<Transfer>> active_;
  std::map<std::string, std::vector<CURL*>, std::less<>> idle_; ///< per pool
};

} // namespace

std::unique_ptr<ITransport> makeCurlTransport(std::size_t maxConnections) {
  return std::make_unique<CurlTransport>(maxConnections);
}

} // namespace tellus
