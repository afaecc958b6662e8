#pragma once
// Purging the shared HTTP caches of `server.cdn.purge` (CdnPurge.hpp) after a command removed or
// replaced tiles: `tellus cache prune` and `tellus seed --refresh`.

#include <tellus/config/Config.hpp>

#include <string>
#include <vector>

namespace tellus::commands {

/** PURGE `keys` at every `server.cdn.purge` endpoint (none: nothing, true). Says on stdout what
 * was purged and on stderr which endpoint failed (by its position and host, never its whole URL,
 * which may hold credentials). False when any endpoint failed. */
bool purgeCdn(const Config& config, const std::vector<std::string>& keys, const char* command);

} // namespace tellus::commands
