// The backends the cache contract (TestTileCacheContract.cpp) runs on in tellus_cache_tests: the
// embedded ones. PostgreSQL's run in tellus_cache_pg_tests (tests/cache_pg/).

#include "CacheBackends.hpp"

namespace tellus::test {

std::vector<Backend> contractBackends() {
  return {Backend::SqliteFiles, Backend::Memory};
}

} // namespace tellus::test
