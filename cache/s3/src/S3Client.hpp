#pragma once
// S3 requests through libcurl's own SigV4 signing (CURLOPT_AWS_SIGV4): path-style URLs, keys
// percent-encoded by the caller, the payload's SHA-256 supplied as x-amz-content-sha256 (libcurl
// 7.88 then signs that header instead of hashing a body it does not see). Easy handles are pooled
// so that connections are reused across requests and threads.

#include <tellus/cache_s3/S3TileStore.hpp>

#include <chrono>
#include <cstddef>
#include <mutex>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace tellus::s3 {

struct Response {
  long status = 0;       ///< HTTP status; 0 when no answer came (transport)
  std::string transport; ///< libcurl's error when status is 0
  std::string etag;      ///< the ETag header, quotes kept
  std::int64_t contentLength = -1;
  std::string body;

  bool ok() const { return status >= 200 && status < 300; }
  /** "HTTP 403 AccessDenied" / "connection refused ..." for messages (no credentials). */
  std::string describe() const;
};

struct Request {
  std::string_view method;               ///< GET, PUT, HEAD, DELETE
  std::string_view key;                  ///< percent-encoded, no leading '/' ("" = bucket)
  std::string_view query;                ///< sorted and encoded, no '?'
  std::span<const std::byte> body;       ///< PUT only
  std::vector<std::string> headers;      ///< "Name: value"
  long maxBodyBytes = 64L * 1024 * 1024; ///< larger answers fail
};

class Client {
public:
  explicit Client(const S3TileStoreOptions& options);
  ~Client();
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  Response send(const Request& request);

private:
  void* acquire();
  void release(void* handle);

  std::string base_; ///< endpoint + "/" + bucket
  std::string sigv4_;
  std::string accessKey_;
  std::string secretKey_;
  long timeoutMs_;
  std::mutex mutex_;
  std::vector<void*> idle_;
};

/** Lower-case hex SHA-256 of the bytes. */
std::string sha256Hex(std::span<const std::byte> bytes);
/** Percent-encodes everything but A-Za-z0-9-._~ (and '/' when keepSlash). */
std::string uriEncode(std::string_view s, bool keepSlash);

} // namespace tellus::s3
