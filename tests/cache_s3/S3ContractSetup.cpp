// Runs the cache's contract (tests/cache/TestTileCacheContract.cpp, compiled here with
// TELLUS_CONTRACT_S3) on the S3 store: each cache root gets its own key prefix in the bucket of
// the one server this executable shares, and its local folder under the root; S3Tiered puts the
// file tree under the root in front of it. The index is SQLite (each instance's own, issue 27).

#include "../cache/CacheBackends.hpp"
#include "S3Server.hpp"

#include <tellus/cache_s3/TieredTileStore.hpp>

namespace {

const bool registered = [] {
  tellus::test::s3StoreFactory() = [](const std::filesystem::path& root, bool tiered) {
    auto& server = tellus::test::S3Server::get();
    EXPECT_TRUE(server.ok()) << server.error();
    auto store = tellus::openS3TileStore(
        server.options(tellus::test::uniquePrefix(root.filename().string()), root / ".s3local"));
    EXPECT_TRUE(store) << (store ? "" : store.error().message);
    if (!store) return std::shared_ptr<tellus::ITileStore>();
    std::shared_ptr<tellus::ITileStore> shared = std::move(*store);
    if (!tiered) return shared;
    auto local = tellus::openFileTileStore(tellus::FileTileStoreOptions{root, false, false});
    EXPECT_TRUE(local) << (local ? "" : local.error().message);
    return std::shared_ptr<tellus::ITileStore>(
        tellus::makeTieredTileStore(std::move(*local), std::move(shared)));
  };
  return true;
}();

} // namespace
