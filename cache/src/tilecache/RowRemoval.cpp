#include "RowRemoval.hpp"

#include <limits>
#include <vector>

namespace tellus::detail {

namespace {

using Result = std::expected<void, CacheError>;

constexpr std::int64_t kChunkRows = 1000;

TileLocation locationOf(const SelectedRow& row) {
  return TileLocation{row.folder, row.extension, row.key};
}

/** Deletes a chunk's rows in one transaction; the row cache forgets them after. */
Result deleteRows(TileCache::Impl& im, const std::vector<SelectedRow>& victims) {
  if (auto b = im.index->begin(); !b) return b;
  for (const auto& v : victims)
    (void)im.deleteRow(v.dataset, v.key);
  auto c = im.index->commit();
  im.writer.publishRowChanges();
  return c;
}

/** Rows, then tiles; on a full index, tiles first. Under the changes lock. */
Result removeChunk(TileCache::Impl& im, const std::vector<SelectedRow>& victims) {
  auto c = deleteRows(im, victims);
  if (!c && c.error().code == CacheErrc::DiskFull) {
    for (const auto& v : victims)
      im.store->remove(locationOf(v));
    c = deleteRows(im, victims);
    if (!c) {
      return std::unexpected(
          CacheError{CacheErrc::DiskFull,
                     c.error().message + ": " + std::to_string(victims.size()) +
                         " tiles were removed but the index is too full to forget them; free some "
                         "space and run `tellus cache rebuild`"});
    }
    return {};
  }
  if (!c) return std::unexpected(c.error());
  for (const auto& v : victims)
    im.store->remove(locationOf(v));
  return {};
}

} // namespace

std::expected<std::int64_t, CacheError> removeSelected(TileCache::Impl& im,
                                                       const RowSelector& select,
                                                       std::int64_t maxRows,
                                                       std::optional<std::int64_t> bytesToFree) {
  std::int64_t removed = 0;
  std::int64_t freed = 0;
  auto done = [&] { return removed >= maxRows || (bytesToFree && freed >= *bytesToFree); };
  while (!done()) {
    auto changesLock = im.writer.lockChanges();
    if (!changesLock) return std::unexpected(changesLock.error());
    std::vector<SelectedRow> victims;
    std::int64_t chunkFreed = 0;
    auto selected = select([&](const SelectedRow& row) {
      victims.push_back(row);
      chunkFreed += row.bytes;
      const auto n = static_cast<std::int64_t>(victims.size());
      return !(n >= kChunkRows || removed + n >= maxRows ||
               (bytesToFree && freed + chunkFreed >= *bytesToFree));
    });
    if (!selected) return std::unexpected(selected.error());
    freed += chunkFreed;
    if (victims.empty()) break;
    if (auto r = removeChunk(im, victims); !r) return std::unexpected(r.error());
    removed += static_cast<std::int64_t>(victims.size());
    im.gate.noteRoom();
  }
  return removed;
}

std::expected<std::int64_t, CacheError> evictOverLimit(TileCache::Impl& im) {
  const auto limit = static_cast<std::int64_t>(im.options.sizeLimitBytes);
  if (limit <= 0) return 0;
  auto total = im.index->totalBytes();
  if (!total) return std::unexpected(total.error());
  if (*total <= limit) return 0;
  const std::int64_t target = limit - limit / 20;
  // Only pinned data left over the limit: nothing is selected and the limit stays exceeded.
  return removeSelected(
      im,
      [&](const ITileIndex::RowVisitor& visit) { return im.index->forEachEvictable(visit); },
      std::numeric_limits<std::int64_t>::max(),
      *total - target);
}

} // namespace tellus::detail
