#pragma once
/**
 * @file CacheTypes.hpp
 * @brief The values the tile cache, its index and its maintenance hand out: a tile's metadata and
 * lookup, a dataset as registered, statistics, what verify finds, what prune selects, whether the
 * cache stores.
 */

#include <tellus/cache/Clock.hpp>
#include <tellus/cache/Dataset.hpp>
#include <tellus/cache/TileFile.hpp>

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace tellus {

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
  std::string folder; ///< relative to the cache root (the tile store's name for the dataset)
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
  std::string integrity;                     ///< "ok" or the index's own check's message
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

/** Free space where the tiles are stored (files: statvfs, as an unprivileged user sees it). */
struct DiskSpace {
  std::uint64_t freeBytes = 0;
  std::uint64_t freeInodes = 0;
};

} // namespace tellus
