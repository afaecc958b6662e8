#pragma once
/**
 * @file S3TileStore.hpp
 * @brief Tiles in S3-compatible object storage (issue 27): an ITileStore that several `tellus
 * serve` instances share, each with its own index (docs/design/scale-out-s3.md).
 *
 * Objects, under the store's prefix: `<folder>/<hhhh>/<level>/<row>/<row>_<col>.<ext>` for a tile
 * (hhhh: four hex digits of a hash of folder, level, row and column, so that no key prefix takes
 * all the load) and `<folder>/dataset.txt` for a dataset's descriptor. A tile is written with one
 * PUT `If-None-Match: *` (a 412 means another instance stored it: success when the bytes are the
 * same; a refresh with other bytes replaces it, keeping the old bytes for a rollback); where the
 * server refuses conditional PUTs (Swift's s3api answers 501), a GET first tells whether it is
 * there. A new tile is PUT when it is staged, on the caller's thread (many at once), and deleted
 * again if its index row is not committed; only a refresh that replaces other bytes waits for the
 * index's writer thread (install), which kept every PUT one after another before.
 * A PUT is atomic in S3: a failed or cut upload leaves the old object or none, never part
 * of one, and the payload's SHA-256 (x-amz-content-sha256) makes the server refuse bytes that are
 * not the ones signed. A tile is read with one GET (no HEAD first) into an unlinked file of the
 * local folder (a TileFile is a descriptor, sent with sendfile(2)). The changes lock is nothing:
 * objects are replaced whole.
 *
 * Requests are signed by libcurl (CURLOPT_AWS_SIGV4 "aws:amz:REGION:s3"); keys are
 * percent-encoded here, listing query strings are built sorted. Path-style URLs
 * (`ENDPOINT/BUCKET/KEY`). Credentials never appear in an error message or a log line.
 *
 * Thread safety: as ITileStore (any thread); connections are pooled and reused.
 */

#include <tellus/cache/CacheError.hpp>
#include <tellus/cache/TileStore.hpp>

#include <chrono>
#include <expected>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

namespace tellus {

/** The bucket and key prefix of `s3://BUCKET[/PREFIX]`. */
struct S3Url {
  std::string bucket;
  std::string prefix; ///< without leading or trailing '/'; may be empty
};

/** Parses `s3://bucket/prefix`; InvalidArgument for anything else (the message quotes it). */
std::expected<S3Url, CacheError> parseS3Url(std::string_view url);

struct S3Credentials {
  std::string accessKeyId;
  std::string secretAccessKey;
};

/** AWS_ACCESS_KEY_ID and AWS_SECRET_ACCESS_KEY from the environment, else the `[default]` (or
 * AWS_PROFILE's) section of `file` (AWS_SHARED_CREDENTIALS_FILE, else ~/.aws/credentials when
 * `file` is empty). InvalidArgument naming where it looked (never a key) when there are none. */
std::expected<S3Credentials, CacheError>
s3CredentialsFromEnvironment(const std::filesystem::path& file = {});

struct S3TileStoreOptions {
  std::string endpoint;                     ///< `http://host:port` or `https://...`, no path
  std::string region = "us-east-1";         ///< signs the requests
  S3Url location;                           ///< bucket and prefix
  S3Credentials credentials;                ///< never logged
  std::filesystem::path localFolder;        ///< where read tiles land (unlinked files); created
  std::chrono::milliseconds timeout{10000}; ///< per request
  /** Keys a listing page asks for (ListObjectsV2's max-keys, 1-1000; servers send at most 1,000):
   * the pages of a scan or a folder search are followed by their continuation tokens. */
  int listPageKeys = 1000;
};

/** Opens the store; checks the folder (created if missing) and that the bucket answers (one
 * listing of at most one key): Io naming the endpoint and bucket, and the server's error code,
 * when it does not. */
std::expected<std::unique_ptr<ITileStore>, CacheError>
openS3TileStore(const S3TileStoreOptions& options);

} // namespace tellus
