#pragma once
/**
 * @file DatasetRegistry.hpp
 * @brief The datasets as the cache uses them: loaded from the index at open, reloaded when an id is
 * unknown (another process may have registered it), shared and immutable so that the hit path
 * takes a reference count, not a copy of the grid.
 */

#include <tellus/cache/CacheTypes.hpp>
#include <tellus/cache/TileGrid.hpp>
#include <tellus/cache/TileIndex.hpp>
#include <tellus/cache/TileStore.hpp>

#include <expected>
#include <map>
#include <memory>
#include <mutex>
#include <shared_mutex>
#include <vector>

namespace tellus::detail {

struct DatasetEntry {
  DatasetInfo info;
  TileGrid grid;

  /** Where a tile of this dataset is stored (views into this entry). */
  TileLocation at(const TileKey& key) const {
    return TileLocation{info.folder, info.spec.extension, key};
  }
};

class DatasetRegistry {
public:
  using Result = std::expected<void, CacheError>;

  explicit DatasetRegistry(ITileIndex& index) : index_(index) {}

  /** Replaces what is known with the index's datasets (rows whose grid this build cannot use are
   * left out). */
  Result load();
  /** A dataset by id; an unknown id reloads from the index first. */
  std::shared_ptr<const DatasetEntry> find(DatasetId id);
  /** find(), and the key checked against the dataset's grid (InvalidArgument otherwise). */
  std::expected<std::shared_ptr<const DatasetEntry>, CacheError> checked(DatasetId id,
                                                                         const TileKey& key);
  /** Every dataset, reloaded from the index first (on failure: what is known). */
  std::vector<DatasetInfo> all();
  /** Every dataset as last loaded, without asking the index. */
  std::vector<DatasetInfo> known() const;
  /** Remembers a dataset as registered; returns its id. */
  DatasetId remember(DatasetInfo info, const TileGrid& grid);
  void setPinned(DatasetId id, bool pinned);

private:
  ITileIndex& index_;
  mutable std::shared_mutex mutex_;
  std::map<DatasetId, std::shared_ptr<const DatasetEntry>> byId_;
};

} // namespace tellus::detail
