#pragma once
/**
 * @file TileStore.hpp
 * @brief The bytes half of the tile cache: tiles by location (a dataset's folder, the tile's key,
 * its format's extension), written where nobody sees them, put into place atomically, removed,
 * read; the dataset descriptors a rebuild starts from; the lock that keeps a tile and its index
 * row changing together across processes; the room left.
 *
 * Implementations: the World Wind file tree under the cache root (openFileTileStore, the embedded
 * default: `<root>/<folder>/<level>/<row>/<row>_<col>.<ext>`, temp files in `<folder>/.tmp`) and
 * an in-memory one for tests (tests/support/MemoryTileStore.hpp). S3-compatible object storage
 * (cache/s3): stage = a new tile's object written at once with If-None-Match (deleted by
 * finish(false) if its row is not committed), install = only a refresh's replacement, open = one
 * GET into a local tier file (a TileFile is a descriptor), the changes lock = nothing to lock
 * where objects are immutable.
 *
 * Thread safety: every method may be called from any thread at once, except that install() and
 * finish() of staged changes, and lockChanges()/unlockChanges(), come from the cache's writer (one
 * thread at a time, holding the changes lock while it installs).
 */

#include <tellus/cache/CacheError.hpp>
#include <tellus/cache/CacheTypes.hpp>
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
#include <string_view>
#include <vector>

namespace tellus {

/** Where a tile is stored. The views must outlive the call they are passed to. */
struct TileLocation {
  std::string_view folder;    ///< the dataset's folder (DatasetInfo::folder)
  std::string_view extension; ///< the dataset's extension ("jpg")
  TileKey key;
  /** Which version of the tile: its index row's fetched-at, where the caller knows it (0: not
   * known). A writer passes the one it stores (a file store makes it the file's mtime); a reader
   * the row's: a tier's copy of another version (refreshed elsewhere since) is not served. Only
   * equality counts, never order, so that writers' clocks need not agree. */
  UnixMillis fetchedAt = 0;
};

/** Whether a file's mtime (seconds, nanoseconds) names the version `fetchedAt`, as a file store
 * writes it (TileLocation::fetchedAt): the same millisecond; on a file system that keeps whole
 * seconds only (FAT, ext3), the same second. */
constexpr bool
mtimeNamesVersion(std::int64_t sec, std::int64_t nsec, UnixMillis fetchedAt) noexcept {
  const UnixMillis ms = sec * 1000 + nsec / 1000000;
  return ms == fetchedAt || (nsec == 0 && ms == fetchedAt - fetchedAt % 1000);
}

/** One of several tiles staged together (ITileStore::stageMany). */
struct TileToStage {
  TileLocation at;
  std::span<const std::byte> bytes;
};

/** Which version of a tile is stored: changes whenever the tile is replaced (files: device and
 * inode). */
struct TileVersion {
  std::uint64_t volume = 0;
  std::uint64_t serial = 0;
  bool operator==(const TileVersion&) const = default;
};

/** A stored tile held open. */
struct StoredTile {
  std::shared_ptr<const TileFile> file;
  TileVersion version;
};

/** A stored tile's size and version, without opening it. */
struct TileStat {
  std::int64_t size = 0;
  TileVersion version;
};

/** A put's bytes, durable where no reader finds them, until install() puts them into place. */
class StagedTile {
public:
  virtual ~StagedTile() = default;
  /** Puts the bytes into place atomically, keeping the tile they replace until finish(). */
  virtual std::expected<void, CacheError> install() = 0;
  /** After the row's commit (keep the new tile, drop the old) or rollback (put the old one back, or
   * remove a new tile that has no row). Also after a failed install(). */
  virtual void finish(bool committed) = 0;
  /** The staged bytes, before or after install (a write-behind reader); nullopt when they are gone
   * or not `size` bytes long. Any thread. */
  virtual std::optional<StoredTile> open(std::int64_t size) const = 0;
};

/** A tile going away with its row: hidden in the transaction, gone after the commit, back after a
 * rollback. */
class StagedRemoval {
public:
  virtual ~StagedRemoval() = default;
  virtual std::expected<void, CacheError> hide() = 0;
  virtual void finish(bool committed) = 0;
};

/** One thing a maintenance scan of a dataset folder finds. */
struct StoreEntry {
  enum class Kind {
    Tile,       ///< anything that is neither of the others (named like a tile or not)
    Temp,       ///< a writer's temp file
    Descriptor, ///< the dataset's descriptor
  };
  Kind kind = Kind::Tile;
  std::string path;            ///< relative to the folder scanned, '/'-separated
  std::int64_t size = 0;       ///< bytes
  UnixMillis modified = 0;     ///< last written (a rebuilt row's fetched-at)
  bool tempOwnerAlive = false; ///< Temp: its writer may still be writing it
};

class ITileStore {
public:
  using Result = std::expected<void, CacheError>;
  using EntryVisitor = std::function<void(const StoreEntry&)>;

  virtual ~ITileStore() = default;

  // --- datasets --------------------------------------------------------------------------------
  /** Makes room for a dataset's tiles (files: creates its folder). */
  virtual Result prepareDataset(std::string_view folder) = 0;
  /** The descriptor kept with a dataset's tiles (Dataset.hpp); nullopt when there is none. */
  virtual std::optional<std::string> readDescriptor(std::string_view folder) = 0;
  /** Replaces the descriptor atomically. */
  virtual Result writeDescriptor(std::string_view folder, std::string_view text) = 0;

  // --- tiles -----------------------------------------------------------------------------------
  /** Opens a tile; nullopt when there is none or it is not `size` bytes long. */
  virtual std::optional<StoredTile> open(const TileLocation& at, std::int64_t size) = 0;
  /** A tile's size and version; nullopt when there is none. */
  virtual std::optional<TileStat> stat(const TileLocation& at) = 0;
  /** stat() that tells "there is none" (nullopt) from "the store could not be asked" (an error:
   * an object store out of reach). The cache drops a tile's row only on a definite "none", so an
   * outage of a shared store never empties the shared index. A local store always knows. */
  virtual std::expected<std::optional<TileStat>, CacheError> statOrError(const TileLocation& at) {
    return stat(at);
  }
  /** Writes a tile's new bytes durably where no reader sees them. DiskFull when there is no room
   * (nothing is left behind); messages name the tile. */
  virtual std::expected<std::shared_ptr<StagedTile>, CacheError>
  stage(const TileLocation& at, std::span<const std::byte> bytes) = 0;
  /** stage() for several tiles (a metatile's), all or none: on a failure nothing stays staged.
   * Where the store can, their flush is shared (the file store starts every file's write-back
   * before the first fsync, so that one journal commit carries them all, not one each). The
   * default stages them one after another. */
  virtual std::expected<std::vector<std::shared_ptr<StagedTile>>, CacheError>
  stageMany(std::span<const TileToStage> tiles) {
    std::vector<std::shared_ptr<StagedTile>> staged;
    staged.reserve(tiles.size());
    for (const TileToStage& t : tiles) {
      auto one = stage(t.at, t.bytes);
      if (!one) {
        for (const auto& s : staged)
          s->finish(false);
        return std::unexpected(std::move(one.error()));
      }
      staged.push_back(std::move(*one));
    }
    return staged;
  }
  /** Prepares the removal of a tile (there may be none). */
  virtual std::shared_ptr<StagedRemoval> stageRemoval(const TileLocation& at) = 0;
  /** Removes a tile now (prune and eviction after their rows are gone; a tile of a wrong size). */
  virtual void remove(const TileLocation& at) = 0;

  // --- shared with other processes ---------------------------------------------------------------
  /** Takes the lock under which tiles and their rows change together (every process using this
   * store takes the same one), waiting at most `timeout` for another holder. Never taken while the
   * index's write lock is held, so the two cannot deadlock. Where the store cannot lock, this
   * succeeds without a lock. */
  virtual Result lockChanges(std::chrono::milliseconds timeout) = 0;
  virtual void unlockChanges() = 0;
  /** Room left; nullopt when it cannot be known. */
  virtual std::optional<DiskSpace> freeSpace() const = 0;

  // --- maintenance -------------------------------------------------------------------------------
  /** Removes the temp files of writers that are gone from where writers put them for `folder`
   * ("": the root itself), without a scan of the tree; returns how many. */
  virtual std::size_t removeDeadTemps(std::string_view folder) = 0;
  /** Folders that hold a dataset descriptor. */
  virtual std::vector<std::string> datasetFolders() = 0;
  /** Everything stored in `folder`, recursively; "": the root's own entries (temps only: folders
   * below it are datasets). */
  virtual void scan(std::string_view folder, const EntryVisitor& visit) = 0;
  /** Removes one entry that scan() reported. */
  virtual void removeEntry(std::string_view folder, std::string_view path) = 0;
};

/** Where and how the file tree is kept. */
struct FileTileStoreOptions {
  std::filesystem::path root; ///< created if missing (unless readOnly)
  bool readOnly = false;      ///< offline media: nothing is created or locked
  bool fsyncTiles = true;     ///< fsync each tile (and descriptor) before its rename
};

/** Opens the World Wind file tree under `root`. */
std::expected<std::unique_ptr<ITileStore>, CacheError>
openFileTileStore(const FileTileStoreOptions& options);

} // namespace tellus
