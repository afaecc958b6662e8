#pragma once
/**
 * @file TileIndex.hpp
 * @brief The index half of the tile cache: the datasets, one row per tile (present, with its size
 * and HTTP validators, or absent upstream), last-access times for LRU, and the selections that
 * eviction and prune remove. The index is the source of truth for what is cached; the tile store
 * (TileStore.hpp) holds bytes only, and TileCache keeps the two in step.
 *
 * Implementations: SQLite in the cache root (openSqliteTileIndex, the embedded default) and an
 * in-memory one for tests (tests/support/MemoryTileIndex.hpp). A database shared by several
 * machines (PostgreSQL, issue 27) is the next one; its single-flight leases belong beside the rows
 * (a lease per metatile taken on a miss), as a separate interface the proxy asks, not in this one.
 *
 * An index is used the way a database is:
 * - reads (the "reads" section) may come from any thread at once and see committed state only;
 * - writes (the "writes" section) come from one thread at a time (the cache's writer serialises
 *   them) and, except where said, inside a transaction begun with begin(). A savepoint per
 *   operation lets one failed operation of a batch roll back alone; commit() makes the whole
 *   transaction visible at once, and rolls it back when it fails. Writers of several processes on
 *   one index are serialised by the index (SQLite: BEGIN IMMEDIATE and a busy timeout).
 *
 * Errors: CacheErrc::DiskFull when the index has no room to commit, Corrupt when it is damaged,
 * Io for the rest (the message says which operation).
 */

#include <tellus/cache/CacheError.hpp>
#include <tellus/cache/CacheTypes.hpp>
#include <tellus/cache/Clock.hpp>
#include <tellus/cache/Dataset.hpp>
#include <tellus/cache/TileKey.hpp>

#include <chrono>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace tellus {

/** A tile's row. A present row says the store holds `bytes` bytes for the tile; an absent one that
 * upstream has no tile there (0 bytes, nothing in the store). */
struct TileRow {
  bool present = true;
  std::int64_t bytes = 0;
  TileMeta meta;                        ///< present: what the lookup gives back
  std::optional<UnixMillis> retryAfter; ///< absent: when to ask upstream again
};

/** Which rows prune takes (and prunable counts): fetched before a time, of the datasets of one
 * name, pinned datasets only when asked. Absent markers are rows like the others. */
struct PruneSelection {
  UnixMillis fetchedBefore = std::numeric_limits<UnixMillis>::max();
  std::optional<std::string> datasetName;
  bool includePinned = false;
};

/** A row chosen for removal, with where its tile is stored. */
struct SelectedRow {
  DatasetId dataset = 0;
  TileKey key;
  std::string folder;    ///< the dataset's folder (DatasetInfo::folder)
  std::string extension; ///< the dataset's extension
  std::int64_t bytes = 0;
};

/** Tiles and bytes of one dataset at one level, as the index counts them. */
struct IndexLevelCount {
  DatasetId dataset = 0;
  LevelStats level;
};

/** Rows of one dataset that a selection takes. */
struct IndexSelectionCount {
  DatasetId dataset = 0;
  std::int64_t tiles = 0;
  std::int64_t bytes = 0;
};

class ITileIndex {
public:
  using Result = std::expected<void, CacheError>;
  using TileVisitor = std::function<bool(const TileKey&, std::int64_t bytes)>;
  using RowVisitor = std::function<bool(const SelectedRow&)>;

  virtual ~ITileIndex() = default;

  /** True when the index was found damaged at open and started empty: the cache rebuilds it from
   * the tile store before it is used. */
  virtual bool damagedAtOpen() const noexcept = 0;

  // --- reads (any thread; committed state) -----------------------------------------------------
  /** The row of a tile; nullopt when the index knows nothing of it. */
  virtual std::expected<std::optional<TileRow>, CacheError> lookup(DatasetId id,
                                                                   const TileKey& key) = 0;
  /** The rows of several tiles of one dataset, in the order of `keys` (nullopt: unknown). One
   * lookup() each here; a networked index answers a metatile's tiles in one round trip. */
  virtual std::expected<std::vector<std::optional<TileRow>>, CacheError>
  lookupMany(DatasetId id, std::span<const TileKey> keys) {
    std::vector<std::optional<TileRow>> rows;
    rows.reserve(keys.size());
    for (const TileKey& k : keys) {
      auto r = lookup(id, k);
      if (!r) return std::unexpected(r.error());
      rows.push_back(std::move(*r));
    }
    return rows;
  }
  /** Every dataset, by id. */
  virtual std::expected<std::vector<DatasetInfo>, CacheError> datasets() = 0;
  /** The dataset stored in `folder`, if any. */
  virtual std::expected<std::optional<DatasetInfo>, CacheError>
  datasetInFolder(std::string_view folder) = 0;
  /** Calls `visit` with every present tile of a dataset in levels [fromLevel, toLevel], in index
   * order (level, row, column), until it returns false. */
  virtual Result forEachTile(DatasetId id,
                             std::int32_t fromLevel,
                             std::int32_t toLevel,
                             const TileVisitor& visit) = 0;
  /** Bytes of all present tiles (kept as counters: no scan). */
  virtual std::expected<std::int64_t, CacheError> totalBytes() = 0;
  /** Tiles, absent markers and bytes per dataset and level, ordered by dataset and level. */
  virtual std::expected<std::vector<IndexLevelCount>, CacheError> levelCounts() = 0;
  /** What forEachPrunable would select now, per dataset, ordered by dataset. */
  virtual std::expected<std::vector<IndexSelectionCount>, CacheError>
  countPrunable(const PruneSelection& selection) = 0;
  /** "ok", or what the index's own consistency check found. */
  virtual std::string integrity() = 0;

  // --- writes (one thread at a time) ----------------------------------------------------------
  /** Starts a transaction; every write below runs inside one unless it says otherwise. */
  virtual Result begin() = 0;
  /** Commits; when that fails the transaction is rolled back and the error returned. */
  virtual Result commit() = 0;
  virtual void rollback() = 0;
  /** One level of savepoint inside a transaction: marked, released, or rolled back to. */
  virtual void savepoint() = 0;
  virtual void releaseSavepoint() = 0;
  virtual void rollbackToSavepoint() = 0;

  /** Inserts or replaces a row; its last access becomes row.meta.fetchedAt. */
  virtual Result putRow(DatasetId id, const TileKey& key, const TileRow& row) = 0;
  /** putRow() for several tiles of one dataset (distinct keys): one putRow each here; a networked
   * index writes a metatile's rows in one statement. */
  virtual Result putRows(DatasetId id, std::span<const std::pair<TileKey, TileRow>> rows) {
    for (const auto& [key, row] : rows)
      if (auto r = putRow(id, key, row); !r) return r;
    return {};
  }
  /** Removes a row (none is not an error). */
  virtual Result deleteRow(DatasetId id, const TileKey& key) = 0;
  /** A present row's new expiry, validators and fetched-at (none, or absent: nothing happens). */
  virtual Result revalidate(DatasetId id, const TileKey& key, const TileMeta& meta) = 0;
  /** Moves a row's last access forward to `when` (never back). Advisory: failures are dropped. */
  virtual void touch(DatasetId id, const TileKey& key, UnixMillis when) = 0;
  /** The byte count of a present row as this transaction sees it; nullopt: absent or none. */
  virtual std::expected<std::optional<std::int64_t>, CacheError>
  presentBytes(DatasetId id, const TileKey& key) = 0;
  /** Registers a dataset in `folder`, or updates the one there (its `pinned` only); returns it
   * with its id and creation time (`createdAt` for a new one). */
  virtual std::expected<DatasetInfo, CacheError>
  upsertDataset(const DatasetSpec& spec, std::string_view folder, UnixMillis createdAt) = 0;
  virtual Result setPinned(DatasetId id, bool pinned) = 0;
  /** Forgets every dataset and row (a rebuild refills it). */
  virtual Result clear() = 0;

  /** Outside a transaction: calls `visit` with the rows prune takes, until it returns false. The
   * writer deletes them in chunks, each chunk in a transaction of its own, so `visit` is called
   * anew for each chunk and sees what is still there. */
  virtual Result forEachPrunable(const PruneSelection& selection, const RowVisitor& visit) = 0;
  /** Outside a transaction: present tiles of unpinned datasets, least recently used first. */
  virtual Result forEachEvictable(const RowVisitor& visit) = 0;

  /** Outside a transaction: whether another process (another connection) has committed since
   * the last call. Errors count as a change. */
  virtual bool changedByOthers() = 0;
};

/** Where and how the SQLite index opens (`<root>/index.sqlite`, schema version 2). */
struct SqliteTileIndexOptions {
  std::filesystem::path root;
  bool readOnly = false; ///< no writes; the index must exist
  std::chrono::milliseconds busyTimeout{60000};
  int readConnections = 4;            ///< pooled read connections kept
  std::shared_ptr<const Clock> clock; ///< names a damaged index moved aside; null: the system's
};

/** Opens (creating or migrating) the SQLite index. A damaged one (or one a reader marked damaged)
 * is moved aside to `index.sqlite.corrupt-<millis>` and started empty (damagedAtOpen()). Fails for
 * a missing index when read-only, a newer schema, or an index that cannot be created. */
std::expected<std::unique_ptr<ITileIndex>, CacheError>
openSqliteTileIndex(const SqliteTileIndexOptions& options);

} // namespace tellus
