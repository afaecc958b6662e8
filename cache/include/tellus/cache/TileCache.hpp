#pragma once
/**
 * @file TileCache.hpp
 * @brief The tile cache: files in a World Wind tree plus one SQLite index per cache root.
 *
 * Layout: `<root>/index.sqlite` and
 * `<root>/<server>/<name>-<hash>/<level>/<row>/<row>_<col>.<ext>`, each dataset folder holding a
 * `dataset.txt` descriptor. The index is the source of truth for what is cached; files are only
 * read through it.
 *
 * Guarantees:
 * - a tile is never visible half written: bytes go to a temp file in the dataset's `.tmp` folder,
 *   are fsynced, and are renamed into place by the writer together with its index row (one
 *   batched transaction for many writers);
 * - a tile file and its row change together: the rename and the commit of a put, and the commit and
 *   the unlink of a removal (prune, eviction, erase), run under one lock shared by every process
 *   on the cache (flock on the root), so a prune racing a put never leaves a row without its file
 *   or a file without its row;
 * - a full disk (ENOSPC, EDQUOT, EFBIG, SQLITE_FULL) is reported as CacheErrc::DiskFull with the
 *   root and its free bytes and inodes; the temp file is removed, a tile being replaced is kept
 *   (even when the commit fails after the rename) and the index is left as it was. After a refusal
 *   the cache refuses puts at once for Options::fullRecheck, then tries again (storeStatus());
 * - temp files of writers that are gone (their pid and start time are in the name) are removed
 *   at open, from the `.tmp` folders, without a scan of the tree;
 * - many threads may read at once (pooled read connections, WAL); one writer thread per process
 *   batches writes; two processes (a server and a seeder) may share one cache without
 *   "database is locked" (WAL, BEGIN IMMEDIATE, a busy timeout);
 * - opening costs the same for an empty cache and for millions of tiles (no scan); a damaged index
 *   is detected at open, moved aside and rebuilt from the tree.
 *
 * Thread safety: every public method may be called from any thread concurrently.
 */

#include <tellus/cache/CacheError.hpp>
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

/** Milliseconds since the Unix epoch (the cache's clock unit). */
using UnixMillis = std::int64_t;

/** HTTP-ish metadata kept with a tile. */
struct TileMeta {
  std::string contentType;             ///< e.g. "image/jpeg"
  std::string etag;                    ///< upstream ETag, "" if none
  std::string lastModified;            ///< upstream Last-Modified, "" if none
  std::optional<UnixMillis> expiresAt; ///< after this the tile is stale; nullopt = never
  UnixMillis fetchedAt = 0;            ///< when it was fetched (0 = now, filled in by put)
};

/** Result of a lookup. */
struct CacheLookup {
  enum class Kind {
    Miss,   ///< nothing known: fetch it
    Absent, ///< upstream said "no tile here"; ask again after retryAfter
    Hit,    ///< bytes are there
  };
  Kind kind = Kind::Miss;
  std::vector<std::byte> bytes;         ///< Hit from get() only
  std::shared_ptr<const TileFile> file; ///< Hit from openTile() only
  TileMeta meta;                        ///< Hit only
  bool stale = false;                   ///< Hit: expiresAt has passed (serve, but refresh)
  std::int64_t size = 0;                ///< Hit: byte count recorded in the index
  UnixMillis retryAfter = 0;            ///< Absent only
};

/** A registered dataset with its id. */
struct DatasetInfo {
  DatasetId id = 0;
  DatasetSpec spec;
  std::string folder; ///< relative to the cache root
  /// When this dataset was first registered (its definition has not changed since: another
  /// definition is another dataset). WMS capabilities give it as a layer's LastUpdate.
  std::int64_t createdAt = 0;
};

/** Tiles and bytes of one dataset at one level (absent markers count as tiles of 0 bytes). */
struct LevelStats {
  std::int32_t level = 0;
  std::int64_t tiles = 0;
  std::int64_t absent = 0;
  std::int64_t bytes = 0;
};
struct DatasetStats {
  DatasetInfo dataset;
  std::int64_t tiles = 0;
  std::int64_t bytes = 0;
  std::vector<LevelStats> levels;
};

/** What `verify` found. Paths are relative to the cache root. */
struct VerifyReport {
  std::vector<std::string> filesWithoutRows; ///< tile files the index does not know
  std::vector<std::string> rowsWithoutFiles; ///< index rows whose file is missing
  std::vector<std::string> sizeMismatches;   ///< index bytes != file size
  std::vector<std::string> strayTempFiles;   ///< temp files of writers that are gone
  std::int64_t tempFilesInUse = 0;           ///< temp files of running writers (not a problem)
  std::string integrity;                     ///< "ok" or SQLite's quick_check message
  bool ok() const {
    return filesWithoutRows.empty() && rowsWithoutFiles.empty() && sizeMismatches.empty() &&
           strayTempFiles.empty() && integrity == "ok";
  }
};

/** Which tiles `prune` removes. */
struct PruneOptions {
  std::optional<std::chrono::milliseconds> olderThan; ///< fetched longer ago than this
  std::optional<std::string> datasetName;             ///< only datasets with this name
  bool includePinned = false;                         ///< pinned datasets are kept unless set
};

/** Whether the cache stores what it is given (see TileCache::storeStatus). */
struct StoreStatus {
  /// False from a put refused for lack of space until a put succeeds or tiles are removed.
  bool writable = true;
  std::uint64_t refused = 0; ///< puts refused for lack of space (counting write-behind drops)
  std::uint64_t dropped = 0; ///< write-behind puts whose row could not be committed, any cause
};

/** Free space of the file system under the cache root (statvfs, as an unprivileged user sees it).
 */
struct DiskSpace {
  std::uint64_t freeBytes = 0;
  std::uint64_t freeInodes = 0;
};

class TileCache {
public:
  using Clock = std::chrono::steady_clock;

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
    /// The clock of fullRecheck (tests inject one); empty: the steady clock.
    std::function<Clock::time_point()> clock;
  };

  /** Opens (creating or migrating) the cache. A damaged index is moved aside to
   * `index.sqlite.corrupt-<millis>` and rebuilt from the tree. Fails for an unusable root, an index
   * of a newer schema, or an index that cannot be created. */
  static std::expected<std::unique_ptr<TileCache>, CacheError> open(const Options& options);

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
  /** Index-only check (no file access): Hit/Absent/Miss kind and staleness, no bytes, no touch. */
  std::expected<CacheLookup, CacheError> peek(DatasetId id, const TileKey& key) const;
  /** Stores a tile durably; returns when the index row is committed (write-behind: when the
   * bytes are in a temp file). DiskFull when the disk (bytes, inodes, quota) or the index refuses,
   * or at once while storeStatus().writable is false and Options::fullRecheck has not passed. */
  std::expected<void, CacheError>
  put(DatasetId id, const TileKey& key, std::span<const std::byte> bytes, const TileMeta& meta);
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

  // --- maintenance ----------------------------------------------------------------------------
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

private:
  struct Impl;
  explicit TileCache(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/** Milliseconds since the Unix epoch, now. */
UnixMillis unixMillisNow() noexcept;

/** File extension for a MIME type ("image/jpeg" -> "jpg", "application/bil16" -> "bil"), and back.
 */
std::string extensionForMimeType(std::string_view mimeType);
std::string mimeTypeForExtension(std::string_view extension);

} // namespace tellus
