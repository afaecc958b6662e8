// The cache contract (tests/cache/TestTileCacheContract.cpp) on PostgreSQL + files: each cache
// root of a test is a database of its own on the test server (PgServer.hpp).

#include "../cache/CacheBackends.hpp"
#include "PgServer.hpp"

#include <tellus/cache_pg/PgTileIndex.hpp>

#include <map>
#include <mutex>

namespace tellus::test {

namespace {

std::expected<std::shared_ptr<ITileIndex>, CacheError> openPgAt(const std::filesystem::path& root,
                                                                bool readOnly) {
  static std::mutex mutex;
  static std::map<std::string, std::string> databases; // root -> URI
  std::string uri;
  {
    std::lock_guard lock(mutex);
    auto& u = databases[root.string()];
    if (u.empty()) u = pgCreateDatabase();
    uri = u;
  }
  PgTileIndexOptions o;
  o.connect.conninfo = uri;
  o.readOnly = readOnly;
  auto index = openPgTileIndex(o);
  if (!index) return std::unexpected(index.error());
  return std::shared_ptr<ITileIndex>(std::move(*index));
}

const bool registered = [] {
  sharedIndexOpener() = openPgAt;
  return true;
}();

} // namespace

std::vector<Backend> contractBackends() {
  return {Backend::PostgresFiles};
}

} // namespace tellus::test
