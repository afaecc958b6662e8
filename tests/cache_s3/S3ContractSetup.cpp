// Runs the cache's contract (tests/cache/TestTileCacheContract.cpp, compiled here with
// TELLUS_CONTRACT_S3) on the S3 store: each cache root gets its own key prefix in the bucket of
// the one server this executable shares, and its local folder under the root. The index is
// SQLite (the local index of each instance, issue 27).

#include "../cache/CacheBackends.hpp"
#include "S3Server.hpp"

namespace {

const bool registered = [] {
  tellus::test::s3StoreFactory() = [](const std::filesystem::path& root) {
    auto& server = tellus::test::S3Server::get();
    EXPECT_TRUE(server.ok()) << server.error();
    auto store = tellus::openS3TileStore(
        server.options(tellus::test::uniquePrefix(root.filename().string()), root / ".s3local"));
    EXPECT_TRUE(store) << (store ? "" : store.error().message);
    return store ? std::shared_ptr<tellus::ITileStore>(std::move(*store)) : nullptr;
  };
  return true;
}();

} // namespace
