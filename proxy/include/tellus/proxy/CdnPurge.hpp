#pragma once
// Purging a shared HTTP cache by surrogate key (docs/design/cdn.md): `PURGE <endpoint>` with the
// keys in an `xkey-purge` header, as config/examples/varnish.vcl takes it (vmod_xkey's softpurge
// or purge). `tellus cache prune` and `tellus seed --refresh` call it with the keys of what they
// removed or replaced (layerKey, HttpCaching.hpp), for each `server.cdn.purge` endpoint.

#include <chrono>
#include <string>
#include <vector>

namespace tellus {

/** What one endpoint answered: its HTTP status (0: not reached) and, on failure, why (the
 * endpoint's URL is the caller's to show: it may hold credentials). */
struct PurgeOutcome {
  std::string endpoint;
  int status = 0;
  std::string error; ///< "" when the endpoint answered 2xx
  bool ok() const { return error.empty(); }
};

/** PURGE each endpoint once per batch of keys (at most `batch` keys in one header,
 * space-separated); blocking, each request within `timeout`. Keys with blanks or control bytes are
 * refused (error). */
std::vector<PurgeOutcome> purgeKeys(const std::vector<std::string>& endpoints,
                                    const std::vector<std::string>& keys,
                                    std::chrono::milliseconds timeout = std::chrono::seconds(10),
                                    std::size_t batch = 64);

} // namespace tellus
