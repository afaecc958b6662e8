#pragma once
/**
 * @file TileCache.hpp
 * @brief The tile cache: an index (TileIndex.hpp) and a tile store (TileStore.hpp) kept in step.
 * The embedded default is one SQLite index and a World Wind file tree per cache root.
 *
 * Layout: `<root>/index.sqlite` and
 * `<root>/<server>/<name>-<hash>/<level>/<row>/<row>_<col>.<ext>`, each dataset folder holding a
 * `dataset.txt` descriptor. The index is the source of truth for what is cached; tiles are only
 * read through it.
 *
 * Guarantees (TileCache keeps them whatever the index and store are):
 * - a tile is never visible half written: bytes are staged (a temp file in the dataset's `.tmp`
 *   folder, fsynced) and put into place by the writer together with its index row (one batched
 *   transaction for many writers);
 * - a tile and its row change together: the install and the commit of a put, and the commit and
 *   the removal of a tile (prune, eviction, erase), run under the store's changes lock, shared by
 *   every process on the cache (flock on the root), so a prune racing a put never leaves a row
 *   without its file or a file without its row;
 * - a full disk (ENOSPC, EDQUOT, EFBIG, SQLITE_FULL) is reported as CacheErrc::DiskFull with the
 *   root and its free bytes and inodes; the staged tile is removed, a tile being replaced is kept
 *   (even when the commit fails after the install) and the index is left as it was. After a
 *   refusal the cache refuses puts at once for Options::fullRecheck, then tries again
 *   (storeStatus());
 * - temp files of writers that are gone (their pid and start time are in the name) are removed
 *   at open, from the `.tmp` folders, without a scan of the tree;
 * - many threads may read at once (pooled read connections, WAL); one writer per process batches
 *   writes (WriteQueue); two processes (a server and a seeder) may share one cache without
 *   "database is locked" (WAL, BEGIN IMMEDIATE, a busy timeout);
 * - opening costs the same for an empty cache and for millions of tiles (no scan); a damaged index
 *   is detected at open, moved aside and rebuilt from the store.
 *
 * Time (fetched-at, last access, expiry, the intervals below) is read from Options::clock.
 * Maintenance (stats, verify, rebuild, prune, eviction) is CacheMaintenance; the methods of the
 * same names here are that, kept for callers of the whole cache.
 *
 * Thread safety: every public method may be called from any thread concurrently.
 */

#include <tellus/cache/CacheError.hpp>
#include <tellus/cache/CacheTypes.hpp>
#include <tellus/cache/Clock.hpp>
#include <tellus/cache/Dataset.hpp>
#include <tellus/cache/TileFile.hpp>
#include <tellus/cache/TileKey.hpp>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace tellus {

class ITileIndex;
class ITileStore;
class CacheMaintenance;

class TileCache {
public:
  struct Options {
    std::filesystem::path root;       ///< created if missing (unless readOnly)
    std::uint64_t sizeLimitBytes = 0; ///< 0 = unlimited; LRU beyond it
    bool readOnly = false;            ///< offline media: no writes at all
    bool fsyncTiles = true;           ///< fsync each tile before its rename
    /// Write-behind (for seeding): put() returns once the bytes are in their temp file; the tile
    /// is visible to this process at once and renamed into place and committed by the writer
    /// thread with everything else queued. A crash loses the tiles not yet committed (their temp
    /// files are removed at the next open; seeding resumes from the index), another process sees
    /// the tile a few milliseconds later, and a failure to commit drops the tile and is counted in
    /// storeStatus().dropped, not returned.
    bool indexWriteBehind = false;
    std::chrono::milliseconds busyTimeout{60000}; ///< wait for another process's writer
    std::chrono::milliseconds accessFlushInterval{
        1000};               ///< how often last-access times are written
    int readConnections = 4; ///< pooled read connections
    /// Rows of present tiles remembered in memory (0: every lookup asks SQLite), and how many of
    /// their files are held open for openTile()/get(). Size the open files well below the
    /// process's descriptor limit.
    std::size_t rowCacheEntries = 65536;
    std::size_t openFiles = 256;
    /// How often another process's writes are looked for (PRAGMA data_version): at most this long
    /// after a seeder or `cache prune` in another process commits, this one still answers from
    /// the rows it remembered. This process's own writes are seen at once.
    std::chrono::milliseconds otherWritersCheck{100};
    /// How often a held-open file is checked (stat) against the path it came from, to notice a
    /// file replaced or deleted behind the index.
    std::chrono::milliseconds fileRecheck{1000};
    /// After a put refused for lack of space, further puts are refused at once (nothing is
    /// written) for this long; the first put after it tries the disk again.
    std::chrono::milliseconds fullRecheck{10000};
    /// Wall time (fetched-at, last access, expiry, prune's age) and steady time (the intervals
    /// above); null: the system clock. Tests inject a ManualClock.
    std::shared_ptr<const Clock> clock;
  };

  /** Opens (creating or migrating) the cache: the SQLite index and the file tree at
   * Options::root. A damaged index is moved aside to `index.sqlite.corrupt-<millis>` and rebuilt
   * from the tree. Fails for an unusable root, an index of a newer schema, or an index that cannot
   * be created. */
  static std::expected<std::unique_ptr<TileCache>, CacheError> open(const Options& options);
  /** Opens the cache on a given index and store (Options::root only names it in messages; the
   * index's and the store's own options are theirs). An index damaged at open is rebuilt from the
   * store. The two may be shared with another TileCache opened after this one is closed. */
  static std::expected<std::unique_ptr<TileCache>, CacheError> open(
      const Options& options, std::shared_ptr<ITileIndex> index, std::shared_ptr<ITileStore> store);

  ~TileCache();
  TileCache(const TileCache&) = delete;
  TileCache& operator=(const TileCache&) = delete;

  const std::filesystem::path& root() const noexcept;
  /** True when open() found the index damaged and rebuilt it. */
  bool wasRebuiltAtOpen() const noexcept;

  // --- datasets -------------------------------------------------------------------------------
  /** Registers a dataset (idempotent: the same spec gives the same id; `pinned` is updated). */
  std::expected<DatasetId, CacheError> registerDataset(const DatasetSpec& spec);
  std::optional<DatasetInfo> dataset(DatasetId id) const;
  std::vector<DatasetInfo> datasets() const;
  std::expected<void, CacheError> setPinned(DatasetId id, bool pinned);

  // --- tiles ----------------------------------------------------------------------------------
  /** Looks a tile up. A row whose file vanished or changed size is a Miss (and the row is dropped).
   */
  std::expected<CacheLookup, CacheError> get(DatasetId id, const TileKey& key);
  /** Like get(), but the Hit holds the tile's file open (`file`, no `bytes`): for sendfile and
   * for readers that want the bytes later. Repeated lookups of a tile cost neither SQLite nor
   * open(2): rows and descriptors are remembered (see Options::rowCacheEntries). */
  std::expected<CacheLookup, CacheError> openTile(DatasetId id, const TileKey& key);
  /** openTile() for several tiles of one dataset, in the order of `keys`; those not remembered
   * are looked up in one index round trip (peekMany). */
  std::expected<std::vector<CacheLookup>, CacheError> openTiles(DatasetId id,
                                                                std::span<const TileKey> keys);
  /** Index-only check (no file access): Hit/Absent/Miss kind and staleness, no bytes, no touch. */
  std::expected<CacheLookup, CacheError> peek(DatasetId id, const TileKey& key) const;
  /** peek() for several tiles of one dataset, in the order of `keys`: one index round trip for a
   * metatile's tiles on a networked index (ITileIndex::lookupMany). */
  std::expected<std::vector<CacheLookup>, CacheError> peekMany(DatasetId id,
                                                               std::span<const TileKey> keys) const;
  /** The store alone, for when the index cannot be reached (a shared index's server down, issue
   * 27): the tile file held open as openTile() does, with the dataset's content type and no
   * validators or expiry (never stale); Miss when the store has none. Tiles are written whole
   * (staged, then renamed), so what is found is a complete tile. */
  std::expected<CacheLookup, CacheError> openFromStore(DatasetId id, const TileKey& key);
  /** Stores a tile durably; returns when the index row is committed (write-behind: when the
   * bytes are in a temp file). DiskFull when the disk (bytes, inodes, quota) or the index refuses,
   * or at once while storeStatus().writable is false and Options::fullRecheck has not passed. */
  std::expected<void, CacheError>
  put(DatasetId id, const TileKey& key, std::span<const std::byte> bytes, const TileMeta& meta);
  /** One of the tiles of putMany. */
  struct TileBytes {
    TileKey key;
    std::span<const std::byte> bytes;
  };
  /** put() for several tiles of one dataset (a metatile's), all or none, with one `meta`: their
   * files flushed to disk together and their rows in one transaction, where one put each costs an
   * fsync and a commit each. */
  std::expected<void, CacheError>
  putMany(DatasetId id, std::span<const TileBytes> tiles, const TileMeta& meta);
  /** Records a successful revalidation (HTTP 304): new expiry, ETag, Last-Modified, fetched-at;
   * the bytes stay. A tile that is not present is not an error (nothing to update). */
  std::expected<void, CacheError>
  revalidated(DatasetId id, const TileKey& key, const TileMeta& meta);
  /** Remembers that upstream has no tile here until retryAfter (its file, if any, is removed). */
  std::expected<void, CacheError>
  putAbsent(DatasetId id, const TileKey& key, UnixMillis retryAfter);
  /** Removes a tile (row, then the file, under the files lock). Removing an unknown tile is not an
   * error. */
  std::expected<void, CacheError> erase(DatasetId id, const TileKey& key);

  /** Calls `visit` with every present tile of a dataset in levels [fromLevel, toLevel] (index
   * order: level, row, column) and its byte count; `visit` returns false to stop. */
  std::expected<void, CacheError>
  forEachTile(DatasetId id,
              std::int32_t fromLevel,
              std::int32_t toLevel,
              const std::function<bool(const TileKey&, std::int64_t bytes)>& visit) const;

  // --- maintenance: CacheMaintenance(*this), kept here for callers of the whole cache ----------
  std::expected<std::vector<DatasetStats>, CacheError> stats() const;
  /** What prune(options) would remove now: per dataset with such tiles, their count and bytes
   * (levels left empty). Read-only; `tellus cache prune` says it before it removes anything. */
  std::expected<std::vector<DatasetStats>, CacheError> prunable(const PruneOptions& options) const;
  std::expected<VerifyReport, CacheError> verify() const;
  /** Rebuilds the index from the tree (datasets from their descriptors, tiles from file names);
   * removes the temp files of writers that are gone. Returns the number of tiles indexed. */
  std::expected<std::int64_t, CacheError> rebuild();
  /** Removes tiles as selected; returns how many. On a disk so full that the index cannot record
   * the removal, the files go first (freeing the room) and the rows after. */
  std::expected<std::int64_t, CacheError> prune(const PruneOptions& options);
  /** Evicts least recently used tiles of unpinned datasets until the total is at most the limit.
   * Runs by itself after writes; returns the number evicted. */
  std::expected<std::int64_t, CacheError> evictToLimit();
  /** Total bytes of all cached tiles (from the index's counters, no scan). */
  std::expected<std::int64_t, CacheError> totalBytes() const;
  /** Writes pending last-access times and waits until every queued write is committed. */
  void flush();

  /** Whether the cache stores tiles now, and how many it refused or dropped. Lock-free. */
  StoreStatus storeStatus() const noexcept;
  /** Free bytes and inodes under the root; nullopt when statvfs fails. */
  std::optional<DiskSpace> diskSpace() const;
  /** How many temp files of writers that are gone open() removed. */
  std::size_t tempFilesRemovedAtOpen() const noexcept;

  struct Impl; ///< the composition (cache/src/tilecache/CacheCore.hpp)

private:
  friend class CacheMaintenance;
  explicit TileCache(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/** File extension for a MIME type ("image/jpeg" -> "jpg", "application/bil16" -> "bil"), and back.
 */
std::string extensionForMimeType(std::string_view mimeType);
std::string mimeTypeForExtension(std::string_view extension);

} // namespace tellus
