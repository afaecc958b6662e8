#pragma once
/**
 * @file RowRemoval.hpp
 * @brief Removing many tiles with their rows (prune, LRU eviction), on the writer thread (inside an
 * operation that runs alone, or the writer's own eviction run).
 *
 * Rows go in chunks of at most 1000 per transaction, rows first and then their tiles, each chunk
 * under the store's changes lock (so the tiles removed are the ones the deleted rows named: no put
 * can put a new tile into place between the commit and the removal). When the index is so full
 * that the deletion cannot be committed, the chunk's tiles go first (they free the room) and the
 * rows after.
 */

#include "CacheCore.hpp"

#include <cstdint>
#include <expected>
#include <functional>
#include <optional>

namespace tellus::detail {

/** Which rows to take: calls the visitor with the next candidates (ITileIndex::forEachPrunable or
 * forEachEvictable) until it returns false. */
using RowSelector = std::function<std::expected<void, CacheError>(const ITileIndex::RowVisitor&)>;

/** Removes selected rows and their tiles until `maxRows` rows or `bytesToFree` bytes are gone, or
 * nothing is selected any more; returns how many were removed. */
std::expected<std::int64_t, CacheError> removeSelected(TileCache::Impl& im,
                                                       const RowSelector& select,
                                                       std::int64_t maxRows,
                                                       std::optional<std::int64_t> bytesToFree);

/** LRU eviction of unpinned tiles down to 95% of Options::sizeLimitBytes when the total is over
 * it (pinned data over the limit stays); returns how many were evicted. */
std::expected<std::int64_t, CacheError> evictOverLimit(TileCache::Impl& im);

} // namespace tellus::detail
