#include "S3Client.hpp"

#include <curl/curl.h>

#include <algorithm>
#include <cstring>
#include <openssl/evp.h>

namespace tellus::s3 {

namespace {

struct Transfer {
  const Request* request = nullptr;
  std::size_t sent = 0;
  Response* response = nullptr;
  bool tooLarge = false;
};

std::size_t onBody(char* data, std::size_t size, std::size_t n, void* user) {
  auto* t = static_cast<Transfer*>(user);
  const std::size_t bytes = size * n;
  if (static_cast<long>(t->response->body.size() + bytes) > t->request->maxBodyBytes) {
    t->tooLarge = true;
    return 0;
  }
  t->response->body.append(data, bytes);
  return bytes;
}

std::size_t onUpload(char* buffer, std::size_t size, std::size_t n, void* user) {
  auto* t = static_cast<Transfer*>(user);
  const auto body = t->request->body;
  const std::size_t left = body.size() - t->sent;
  const std::size_t bytes = std::min(left, size * n);
  std::memcpy(buffer, body.data() + t->sent, bytes);
  t->sent += bytes;
  return bytes;
}

bool startsWithNoCase(std::string_view s, std::string_view prefix) {
  if (s.size() < prefix.size()) return false;
  for (std::size_t i = 0; i < prefix.size(); ++i) {
    const auto a = static_cast<unsigned char>(s[i]);
    const auto b = static_cast<unsigned char>(prefix[i]);
    if (std::tolower(a) != std::tolower(b)) return false;
  }
  return true;
}

std::string trimmed(std::string_view s) {
  while (!s.empty() && (s.back() == '\r' || s.back() == '\n' || s.back() == ' '))
    s.remove_suffix(1);
  while (!s.empty() && s.front() == ' ')
    s.remove_prefix(1);
  return std::string(s);
}

std::size_t onHeader(char* data, std::size_t size, std::size_t n, void* user) {
  auto* t = static_cast<Transfer*>(user);
  const std::string_view line(data, size * n);
  if (startsWithNoCase(line, "HTTP/")) { // a new response (after a 100 Continue, a redirect)
    t->response->etag.clear();
    t->response->contentLength = -1;
  } else if (startsWithNoCase(line, "etag:")) {
    t->response->etag = trimmed(line.substr(5));
  } else if (startsWithNoCase(line, "content-length:")) {
    const std::string v = trimmed(line.substr(15));
    t->response->contentLength = std::strtoll(v.c_str(), nullptr, 10);
  }
  return size * n;
}

/** The text of `<tag>...</tag>` in an S3 error body; "" when there is none. */
std::string xmlField(std::string_view body, std::string_view tag) {
  const std::string open = "<" + std::string(tag) + ">";
  const std::string close = "</" + std::string(tag) + ">";
  const auto a = body.find(open);
  if (a == std::string_view::npos) return {};
  const auto b = body.find(close, a);
  if (b == std::string_view::npos) return {};
  return std::string(body.substr(a + open.size(), b - a - open.size()));
}

} // namespace

std::string Response::describe() const {
  if (status == 0) return transport;
  std::string out = "HTTP " + std::to_string(status);
  if (const auto code = xmlField(body, "Code"); !code.empty() && code.size() < 64)
    out += " " + code;
  return out;
}

std::string sha256Hex(std::span<const std::byte> bytes) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int len = 0;
  EVP_Digest(bytes.data(), bytes.size(), digest, &len, EVP_sha256(), nullptr);
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  out.reserve(len * 2);
  for (unsigned int i = 0; i < len; ++i) {
    out += kHex[digest[i] >> 4];
    out += kHex[digest[i] & 15];
  }
  return out;
}

std::string uriEncode(std::string_view s, bool keepSlash) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string out;
  out.reserve(s.size());
  for (const char ch : s) {
    const auto c = static_cast<unsigned char>(ch);
    if (std::isalnum(c) || c == '-' || c == '.' || c == '_' || c == '~' ||
        (keepSlash && c == '/')) {
      out += ch;
    } else {
      out += '%';
      out += kHex[c >> 4];
      out += kHex[c & 15];
    }
  }
  return out;
}

Client::Client(const S3TileStoreOptions& options)
    : base_(options.endpoint + "/" + uriEncode(options.location.bucket, false)),
      sigv4_("aws:amz:" + options.region + ":s3"), accessKey_(options.credentials.accessKeyId),
      secretKey_(options.credentials.secretAccessKey),
      timeoutMs_(static_cast<long>(options.timeout.count())) {
  while (!base_.empty() && base_.back() == '/')
    base_.pop_back();
}

Client::~Client() {
  for (void* h : idle_)
    curl_easy_cleanup(static_cast<CURL*>(h));
}

void* Client::acquire() {
  {
    std::lock_guard lock(mutex_);
    if (!idle_.empty()) {
      void* h = idle_.back();
      idle_.pop_back();
      return h;
    }
  }
  return curl_easy_init();
}

void Client::release(void* handle) {
  std::lock_guard lock(mutex_);
  if (idle_.size() < 64)
    idle_.push_back(handle);
  else
    curl_easy_cleanup(static_cast<CURL*>(handle));
}

Response Client::send(const Request& r) {
  Response out;
  auto* curl = static_cast<CURL*>(acquire());
  if (!curl) {
    out.transport = "cannot create a libcurl handle";
    return out;
  }
  curl_easy_reset(curl);
  std::string url = base_;
  if (!r.key.empty()) url += "/" + std::string(r.key);
  if (!r.query.empty()) url += "?" + std::string(r.query);
  Transfer t{&r, 0, &out, false};
  const std::string method(r.method); // outlives the transfer (CURLOPT_CUSTOMREQUEST)

  curl_slist* headers = nullptr;
  const std::string hash = "x-amz-content-sha256: " +
                           sha256Hex(r.method == "PUT" ? r.body : std::span<const std::byte>{});
  headers = curl_slist_append(headers, hash.c_str());
  for (const auto& h : r.headers)
    headers = curl_slist_append(headers, h.c_str());

  curl_easy_setopt(curl, CURLOPT_URL, url.c_str());
  curl_easy_setopt(curl, CURLOPT_AWS_SIGV4, sigv4_.c_str());
  curl_easy_setopt(curl, CURLOPT_USERNAME, accessKey_.c_str());
  curl_easy_setopt(curl, CURLOPT_PASSWORD, secretKey_.c_str());
  curl_easy_setopt(curl, CURLOPT_HTTPHEADER, headers);
  curl_easy_setopt(curl, CURLOPT_TIMEOUT_MS, timeoutMs_);
  curl_easy_setopt(curl, CURLOPT_CONNECTTIMEOUT_MS, std::min(timeoutMs_, 5000L));
  curl_easy_setopt(curl, CURLOPT_NOSIGNAL, 1L);
  curl_easy_setopt(curl, CURLOPT_WRITEFUNCTION, onBody);
  curl_easy_setopt(curl, CURLOPT_WRITEDATA, &t);
  curl_easy_setopt(curl, CURLOPT_HEADERFUNCTION, onHeader);
  curl_easy_setopt(curl, CURLOPT_HEADERDATA, &t);
  if (r.method == "PUT") {
    curl_easy_setopt(curl, CURLOPT_UPLOAD, 1L);
    curl_easy_setopt(curl, CURLOPT_READFUNCTION, onUpload);
    curl_easy_setopt(curl, CURLOPT_READDATA, &t);
    curl_easy_setopt(curl, CURLOPT_INFILESIZE_LARGE, static_cast<curl_off_t>(r.body.size()));
  } else if (r.method == "HEAD") {
    curl_easy_setopt(curl, CURLOPT_NOBODY, 1L);
  } else if (r.method != "GET") {
    curl_easy_setopt(curl, CURLOPT_CUSTOMREQUEST, method.c_str());
  }
  const CURLcode rc = curl_easy_perform(curl);
  curl_easy_getinfo(curl, CURLINFO_RESPONSE_CODE, &out.status);
  if (rc != CURLE_OK) {
    out.status = 0;
    out.transport = t.tooLarge ? std::string("answer larger than expected")
                               : std::string(curl_easy_strerror(rc));
  }
  curl_slist_free_all(headers);
  release(curl);
  return out;
}

} // namespace tellus::s3
