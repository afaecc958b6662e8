#pragma once
/**
 * @file TieredTileStore.hpp
 * @brief An instance's own disk in front of a shared store (issue 27, "tiers"): the file tree
 * under the cache root holds copies of the tiles this instance served or stored, the shared store
 * (S3) all of them.
 *
 * Reads try the local tier first; a tile only the shared store has is copied into the local tier
 * as it is read (the next read is a local hit, sent with sendfile(2) from the local file). Writes
 * and removals go to both, the shared store first (what the other instances see), the local tier
 * second; a rollback undoes both. Descriptors are written to both and read from the shared store;
 * maintenance (datasets, scans) lists the shared store, whose tiles the index describes. The
 * changes lock, the free space and the temp files are the local tier's.
 */

#include <tellus/cache/TileStore.hpp>

#include <memory>

namespace tellus {

/** `local` (the file tree) in front of `shared` (the S3 store). */
std::unique_ptr<ITileStore> makeTieredTileStore(std::shared_ptr<ITileStore> local,
                                                std::shared_ptr<ITileStore> shared);

} // namespace tellus
