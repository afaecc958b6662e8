// PURGE by surrogate key after a command changed the cache (Purge.hpp).
#include "Purge.hpp"

#include <tellus/proxy/CdnPurge.hpp>
#include <tellus/proxy/Fetcher.hpp>

#include <cstdio>

namespace tellus::commands {

bool purgeCdn(const Config& config, const std::vector<std::string>& keys, const char* command) {
  const auto& endpoints = config.server.cdn.purge;
  if (endpoints.empty() || keys.empty()) return true;
  const auto outcomes = purgeKeys(endpoints, keys);
  bool ok = true;
  for (std::size_t i = 0; i < outcomes.size(); ++i) {
    const auto origin = urlOrigin(outcomes[i].endpoint);
    const std::string where = origin ? *origin : std::string("?");
    if (outcomes[i].ok()) {
      std::printf("purged %zu keys at server.cdn.purge[%zu] (%s)\n", keys.size(), i, where.c_str());
    } else {
      ok = false;
      std::fprintf(stderr,
                   "tellus %s: purging server.cdn.purge[%zu] (%s) failed: %s\n",
                   command,
                   i,
                   where.c_str(),
                   outcomes[i].error.c_str());
    }
  }
  return ok;
}

} // namespace tellus::commands
