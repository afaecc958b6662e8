#include "../files/FileIo.hpp"
#include "../sqlite/Schema.hpp"
#include "../sqlite/Sqlite.hpp"
#include "RowCache.hpp"

#include <tellus/cache/TileCache.hpp>
#include <tellus/cache/TilePath.hpp>

#include <algorithm>
#include <cassert>
#include <cerrno>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <fcntl.h>
#include <functional>
#include <future>
#include <limits>
#include <map>
#include <mutex>
#include <set>
#include <shared_mutex>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <thread>
#include <unistd.h>
#include <unordered_map>
#include <unordered_set>
#include <utility>

namespace tellus {

namespace fs = std::filesystem;

UnixMillis unixMillisNow() noexcept {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::string extensionForMimeType(std::string_view m) {
  if (m == "image/jpeg" || m == "image/jpg") return "jpg";
  if (m == "image/png" || m.starts_with("image/png;")) return "png";
  if (m == "image/tiff" || m == "image/geotiff") return "tif";
  if (m == "application/bil16" || m == "application/bil" || m == "image/bil") return "bil";
  if (m == "image/webp") return "webp";
  if (m == "image/gif") return "gif";
  if (m == "image/dds") return "dds";
  return "bin";
}

std::string mimeTypeForExtension(std::string_view e) {
  if (e == "jpg" || e == "jpeg") return "image/jpeg";
  if (e == "png") return "image/png";
  if (e == "tif" || e == "tiff") return "image/tiff";
  if (e == "bil") return "application/bil16";
  if (e == "webp") return "image/webp";
  if (e == "gif") return "image/gif";
  if (e == "dds") return "image/dds";
  return "application/octet-stream";
}

namespace {

constexpr const char* kIndexName = "index.sqlite";
constexpr const char* kCorruptMarker = "index.corrupt";
constexpr const char* kDescriptorName = "dataset.txt";
// Each dataset's temp files (tiles being written, tiles being replaced) live in `<dataset>/.tmp`:
// the one folder per dataset that open() looks into for temp files of writers that are gone.
constexpr const char* kTempDirName = ".tmp";
constexpr int kStatePresent = 1;
constexpr int kStateAbsent = 2;
constexpr std::size_t kMaxBatch = 1024;
constexpr std::int64_t kTouchResolutionMs = 60000; // last-access times of remembered rows

using Result = std::expected<void, CacheError>;

CacheError invalid(std::string msg) {
  return CacheError{CacheErrc::InvalidArgument, std::move(msg)};
}

std::string keyText(const TileKey& k) {
  return "L" + std::to_string(k.level) + " R" + std::to_string(k.row) + " C" +
         std::to_string(k.col);
}

/** Binds ?1..?4 = dataset, level, row, col: the tiles table's primary key. */
void bindKey(sql::Stmt::Use& u, DatasetId id, const TileKey& k) {
  u.bind(1, id).bind(2, std::int64_t{k.level}).bind(3, k.row).bind(4, k.col);
}

using TouchKey = detail::RowKey;
using TouchKeyHash = detail::RowKeyHash;

std::int64_t steadyNanos() noexcept {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

/** One read connection with its prepared statements. */
struct ReadConn {
  sql::DbPtr db;
  sql::Stmt lookup;
};

/** A dataset as the cache uses it. */
struct DatasetEntry {
  DatasetInfo info;
  TileGrid grid;
  fs::path dir; // absolute
};

sql::DbPtr openDb(const fs::path& path, bool readOnly, bool create, int busyMs, int* rcOut) {
  sqlite3* raw = nullptr;
  int flags = SQLITE_OPEN_NOMUTEX;
  flags |=
      readOnly ? SQLITE_OPEN_READONLY : (SQLITE_OPEN_READWRITE | (create ? SQLITE_OPEN_CREATE : 0));
  const int rc = sqlite3_open_v2(path.c_str(), &raw, flags, nullptr);
  sql::DbPtr db(raw);
  *rcOut = rc;
  if (rc != SQLITE_OK) return nullptr;
  sqlite3_busy_timeout(db.get(), busyMs);
  sqlite3_extended_result_codes(db.get(), 1);
  // The WAL and its shared-memory index stay when the last connection closes: a cache whose disk
  // filled up can still be opened and read (creating them needs room), and commits that fit in
  // the kept WAL still succeed on a full disk.
  int persist = 1;
  (void)sqlite3_file_control(db.get(), "main", SQLITE_FCNTL_PERSIST_WAL, &persist);
  return db;
}

/** A tile's new file going into place (a put): the temp file, and the tile it replaces kept as a
 * hard link in the dataset's `.tmp` until the put's row is committed, so that a commit that fails
 * (a full disk) puts the old tile back instead of losing it. Writer thread, under the files lock.
 */
struct TilePlacement {
  fs::path temp;   // the new bytes, fsynced
  fs::path target; // where the tile lives
  fs::path backup; // the old tile while the row is not committed
  bool renamed = false;
  bool hasBackup = false;

  std::expected<void, CacheError> install() {
    if (::link(target.c_str(), backup.c_str()) == 0) {
      hasBackup = true;
    } else if (fileio::isNoSpace(errno)) {
      // No room to keep the old tile (a link takes an inode on tmpfs): refused, the tile stays.
      return std::unexpected(fileio::errnoError(errno, "cannot keep the tile it replaces", target));
    }
    // ENOENT: a new tile. A file system without hard links: replaced without a way back.
    if (::rename(temp.c_str(), target.c_str()) != 0) {
      const int err = errno;
      if (hasBackup) ::unlink(backup.c_str());
      hasBackup = false;
      return std::unexpected(fileio::errnoError(err, "cannot rename into", target));
    }
    renamed = true;
    return {};
  }

  /** After the commit (or the rollback) of the put's row. */
  void finish(bool committed) {
    if (!renamed) {
      ::unlink(temp.c_str());
    } else if (committed) {
      if (hasBackup) ::unlink(backup.c_str());
    } else if (hasBackup) {
      ::rename(backup.c_str(), target.c_str()); // the old tile, which its row still describes
    } else {
      ::unlink(target.c_str()); // a new tile without a row
    }
    renamed = hasBackup = false;
  }
};

/** A tile's file going away with its row (erase, an absent marker): moved aside into the dataset's
 * `.tmp` in the writer's transaction, removed after the commit, put back if the commit fails.
 * Writer thread, under the files lock. */
struct TileRemoval {
  fs::path target;
  fs::path aside; // empty: no `.tmp` could be made (a full disk): unlinked after the commit
  bool moved = false;

  std::expected<void, CacheError> hide() {
    if (aside.empty()) return {};
    if (::rename(target.c_str(), aside.c_str()) == 0) {
      moved = true;
    } else if (errno != ENOENT) {
      return std::unexpected(fileio::errnoError(errno, "cannot remove", target));
    }
    return {};
  }
  void finish(bool committed) {
    if (aside.empty()) {
      if (committed) ::unlink(target.c_str());
    } else if (moved) {
      if (committed)
        ::unlink(aside.c_str());
      else
        ::rename(aside.c_str(), target.c_str());
    }
    moved = false;
  }
};

/** Removes the temp files of writers that are gone from one folder (not recursive). */
std::size_t removeDeadTempFiles(const fs::path& dir) {
  std::size_t removed = 0;
  std::error_code ec;
  for (auto it = fs::directory_iterator(dir, ec); !ec && it != fs::directory_iterator();
       it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (!fileio::isTempName(name) || fileio::tempOwnerAlive(name)) continue;
    if (!it->is_regular_file(ec)) continue;
    if (::unlink(it->path().c_str()) == 0) ++removed;
  }
  return removed;
}

} // namespace

// ------------------------------------------------------------------------------------------------

struct TileCache::Impl {
  Options options;
  fs::path indexPath;
  bool rebuiltAtOpen = false;
  std::size_t tempFilesRemoved = 0;

  // The files lock: an flock on the root directory, held by the writer while it changes tile files
  // and their rows together (a put's rename and commit, a removal's commit and unlink), so that
  // those pairs never interleave between processes. -1 for a read-only cache.
  int rootFd = -1;

  // Whether puts are stored (StoreStatus), and until when a full disk is believed.
  std::atomic<bool> full{false};
  std::atomic<std::int64_t> fullUntilNs{0};
  std::atomic<std::uint64_t> refusedPuts{0};
  std::atomic<std::uint64_t> droppedPuts{0};

  // Datasets, loaded at open, refreshed on an unknown id (another process may register some).
  mutable std::shared_mutex datasetsMutex;
  // Shared and immutable: the hit path takes a reference count, not a copy of the grid.
  mutable std::map<DatasetId, std::shared_ptr<const DatasetEntry>> datasetsById;

  // Directories known to exist (saves a stat per put).
  std::mutex dirsMutex;
  std::unordered_set<std::string> knownDirs;

  // Read connections.
  mutable std::mutex readMutex;
  mutable std::vector<std::unique_ptr<ReadConn>> idleReaders;

  // One writer per process: operations are queued and committed in batches (group commit) by
  // whoever holds writeMutex: the caller of submit() itself when the connection is free (no thread
  // hand-off on the common, uncontended path), else the writer thread, which also writes access
  // times and runs eviction.
  using After = std::function<void(const Result& outcome)>;
  struct WriteOp {
    std::function<Result(Impl&)> apply; // inside the transaction
    After after; // after commit/rollback (file clean-up), with the operation's outcome
    bool ownTransactions = false; // runs alone and manages its transactions
    std::promise<Result> done;
  };
  sql::DbPtr writeDb;
  std::mutex queueMutex;
  std::condition_variable queueCv;
  std::condition_variable idleCv;
  std::deque<std::unique_ptr<WriteOp>> queue;
  int busy = 0; // batches being run (guarded by queueMutex)
  bool stopping = false;
  bool evictDue = false; // guarded by queueMutex
  std::mutex writeMutex; // owns writeDb and the writer statements below

  // Write-behind puts whose rows are queued but not committed yet (Options::indexWriteBehind).
  struct PendingRow {
    std::int64_t size;
    TileMeta meta;
    std::uint64_t generation;
    fs::path temp; // the bytes until the writer renames them into place
  };
  std::mutex pendingMutex;
  std::unordered_map<TouchKey, PendingRow, TouchKeyHash> pendingRows;
  std::uint64_t pendingGeneration = 0;

  void dropPending(DatasetId id, const TileKey& key) {
    std::lock_guard lock(pendingMutex);
    pendingRows.erase(TouchKey{id, key});
  }
  std::unordered_map<TouchKey, UnixMillis, TouchKeyHash> touches; // guarded by queueMutex
  std::thread writer;

  // Rows and open files of present tiles, for openTile()/get() (RowCache.hpp).
  detail::RowCache rows;
  // Rows the writer changed since its last commit (under writeMutex): invalidated right after the
  // commit, before the writer reports success, so this process reads its own writes.
  std::vector<TouchKey> changedRows;
  bool allRowsChanged = false;
  // Other processes' commits move writeDb's PRAGMA data_version (its own commits do not).
  std::atomic<std::int64_t> nextVersionCheckNs{0};
  sql::Stmt dataVersionStmt;         // on writeDb, under writeMutex
  std::int64_t lastDataVersion = -1; // under writeMutex

  void rowChanged(DatasetId id, const TileKey& key) {
    if (changedRows.size() < 4096)
      changedRows.push_back(TouchKey{id, key});
    else
      allRowsChanged = true;
  }

  /** After a commit (or rollback) of the writer: forget what changed. Under writeMutex. */
  void publishRowChanges() {
    if (allRowsChanged) {
      rows.clear();
    } else {
      for (const auto& k : changedRows)
        rows.invalidate(k);
    }
    changedRows.clear();
    allRowsChanged = false;
  }

  /** Drops every remembered row when another process has committed since the last look; runs at
   * most every otherWritersCheck, on whichever reader comes first, and never waits for the
   * writer. */
  void noticeOtherWriters() {
    const auto interval = options.otherWritersCheck.count();
    if (interval <= 0) {
      rows.clear(); // every lookup goes to SQLite
      return;
    }
    const std::int64_t now = steadyNanos();
    if (now < nextVersionCheckNs.load(std::memory_order_relaxed)) return;
    std::unique_lock w(writeMutex, std::try_to_lock);
    if (!w) return; // the writer is busy; the next reader looks
    nextVersionCheckNs.store(now + interval * 1000000, std::memory_order_relaxed);
    if (!dataVersionStmt.ok()) {
      rows.clear();
      return;
    }
    sql::Stmt::Use u(dataVersionStmt);
    if (u.step() != SQLITE_ROW) {
      rows.clear();
      return;
    }
    const std::int64_t v = u.i64(0);
    if (v != lastDataVersion) {
      lastDataVersion = v;
      rows.clear();
    }
  }

  // Writer-side prepared statements (used under writeMutex only).
  sql::Stmt upsertTile, deleteTile, touchTile, totalStmt, rowBytesStmt;
  sql::Stmt beginStmt, commitStmt, rollbackStmt, savepointStmt, releaseStmt, rollbackToStmt;

  ~Impl() {
    stopWriter();
    if (rootFd >= 0) ::close(rootFd);
    // Readers close first: the write connection, last, checkpoints and empties the (kept) WAL, so
    // the next open reads the database file itself.
    std::lock_guard lock(readMutex);
    idleReaders.clear();
  }

  // ---------------------------------------------------------------------------- full disk
  std::int64_t nowNs() const {
    const auto t = options.clock ? options.clock() : Clock::now();
    return std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch()).count();
  }

  std::optional<DiskSpace> diskSpace() const {
    struct statvfs v {};
    if (::statvfs(options.root.c_str(), &v) != 0) return std::nullopt;
    return DiskSpace{static_cast<std::uint64_t>(v.f_bavail) * v.f_frsize,
                     static_cast<std::uint64_t>(v.f_favail)};
  }

  /** A DiskFull error that names the root and what is left on its file system. */
  CacheError fullError(const std::string& detail) const {
    std::string msg = "the cache at " + options.root.string() + " is full";
    if (const auto space = diskSpace()) {
      msg += " (" + std::to_string(space->freeBytes) + " bytes and " +
             std::to_string(space->freeInodes) + " inodes free)";
    }
    msg += ": " + detail;
    return CacheError{CacheErrc::DiskFull, std::move(msg)};
  }

  /** A write refused for lack of space: refuse puts at once until fullRecheck has passed. */
  void noteFull() {
    fullUntilNs.store(nowNs() + std::chrono::nanoseconds(options.fullRecheck).count(),
                      std::memory_order_relaxed);
    full.store(true, std::memory_order_release);
  }
  /** A tile stored or removed: the disk has room (again). */
  void noteRoom() { full.store(false, std::memory_order_release); }

  /** Whether a refusal for lack of space is recent (fullRecheck has not passed). */
  bool refusingNow() const {
    return full.load(std::memory_order_acquire) &&
           nowNs() < fullUntilNs.load(std::memory_order_relaxed);
  }

  /** DiskFull at once while a refusal is recent (nothing touches the disk). */
  Result refuseWhileFull() {
    if (!refusingNow()) return {};
    refusedPuts.fetch_add(1, std::memory_order_relaxed);
    return std::unexpected(fullError("a write was refused for lack of space less than " +
                                     std::to_string(options.fullRecheck.count()) +
                                     " ms ago; nothing was written"));
  }

  /** The outcome of a put as the caller sees it: a refusal for lack of space is counted, remembered
   * and worded with the root and its free space. */
  Result putOutcome(Result r) {
    if (r) {
      noteRoom();
      return r;
    }
    if (r.error().code != CacheErrc::DiskFull) return r;
    noteFull();
    refusedPuts.fetch_add(1, std::memory_order_relaxed);
    return std::unexpected(fullError(r.error().message));
  }

  // ---------------------------------------------------------------------------- files lock
  struct FilesLock {
    int fd = -1;
    FilesLock() = default;
    explicit FilesLock(int f) : fd(f) {}
    FilesLock(FilesLock&& o) noexcept : fd(std::exchange(o.fd, -1)) {}
    FilesLock& operator=(FilesLock&&) = delete;
    ~FilesLock() {
      if (fd >= 0) ::flock(fd, LOCK_UN);
    }
  };

  /** Takes the files lock, waiting at most busyTimeout for another process to let go of it.
   * Writer thread (under writeMutex: one holder per process). Never taken while this connection
   * holds SQLite's write lock, so the two locks cannot deadlock. */
  std::expected<FilesLock, CacheError> lockFiles() const {
    if (rootFd < 0) return FilesLock{};
    const auto deadline = Clock::now() + options.busyTimeout;
    auto pause = std::chrono::microseconds(200);
    for (;;) {
      if (::flock(rootFd, LOCK_EX | LOCK_NB) == 0) return FilesLock{rootFd};
      if (errno == EINTR) continue;
      // A file system without flock: work unlocked, as before the lock existed.
      if (errno != EWOULDBLOCK) return FilesLock{};
      if (Clock::now() >= deadline) {
        return std::unexpected(CacheError{CacheErrc::Io,
                                          "another process has held the cache's files lock (" +
                                              options.root.string() + ") for more than " +
                                              std::to_string(options.busyTimeout.count()) + " ms"});
      }
      std::this_thread::sleep_for(pause);
      pause = std::min(pause * 2, std::chrono::microseconds(20000));
    }
  }

  // ---------------------------------------------------------------------------- connections
  std::expected<std::unique_ptr<ReadConn>, CacheError> makeReader() const {
    int rc = 0;
    auto db = openDb(indexPath, true, false, static_cast<int>(options.busyTimeout.count()), &rc);
    if (!db) return std::unexpected(sql::errorFrom(nullptr, rc, "opening index for reading"));
    auto c = std::make_unique<ReadConn>();
    c->lookup = sql::Stmt(db.get(),
                          "SELECT state, bytes, content_type, etag, last_modified, expires, "
                          "fetched_at, retry_after FROM tiles "
                          "WHERE dataset = ?1 AND level = ?2 AND row = ?3 AND col = ?4");
    // Memory-mapped reads: lookups skip a copy through SQLite's page cache (about 25% at p99).
    (void)sql::exec(db.get(), "PRAGMA mmap_size = 268435456");
    if (!c->lookup.ok()) {
      return std::unexpected(sql::errorFrom(db.get(), c->lookup.prepareRc(), "preparing lookup"));
    }
    c->db = std::move(db);
    return c;
  }

  struct ReaderLease {
    const Impl* impl;
    std::unique_ptr<ReadConn> conn;
    ReaderLease(const Impl* i, std::unique_ptr<ReadConn> c) : impl(i), conn(std::move(c)) {}
    ReaderLease(ReaderLease&&) noexcept = default;
    ReaderLease& operator=(ReaderLease&&) = delete;
    ~ReaderLease() {
      if (!conn) return;
      std::lock_guard lock(impl->readMutex);
      if (impl->idleReaders.size() <
          static_cast<std::size_t>(std::max(1, impl->options.readConnections))) {
        impl->idleReaders.push_back(std::move(conn));
      }
    }
  };

  std::expected<ReaderLease, CacheError> acquireReader() const {
    {
      std::lock_guard lock(readMutex);
      if (!idleReaders.empty()) {
        auto c = std::move(idleReaders.back());
        idleReaders.pop_back();
        return ReaderLease{this, std::move(c)};
      }
    }
    auto c = makeReader();
    if (!c) return std::unexpected(c.error());
    return ReaderLease{this, std::move(*c)};
  }

  // ---------------------------------------------------------------------------- datasets
  static DatasetSpec specFromRow(const sql::Stmt::Use& u) {
    DatasetSpec s;
    s.server = u.text(1);
    s.name = u.text(2);
    s.grid.sector = Sector{u.f64(4), u.f64(5), u.f64(6), u.f64(7)};
    s.grid.levelZeroDeltaDeg = u.f64(8);
    s.grid.tileWidth = static_cast<std::int32_t>(u.i64(9));
    s.grid.tileHeight = static_cast<std::int32_t>(u.i64(10));
    s.grid.numLevels = static_cast<std::int32_t>(u.i64(11));
    s.mimeType = u.text(12);
    s.extension = u.text(13);
    s.style = u.text(14);
    s.time = u.text(15);
    s.pinned = u.i64(16) != 0;
    return s;
  }

  /** Reloads the dataset table into memory (any connection). */
  Result loadDatasets(sqlite3* db) const {
    sql::Stmt s(db,
                "SELECT id, server, name, folder, west, south, east, north, level_zero_delta, "
                "tile_width, tile_height, num_levels, mime_type, extension, style, time, pinned, "
                "created_at FROM datasets ORDER BY id");
    if (!s.ok()) return std::unexpected(sql::errorFrom(db, s.prepareRc(), "reading datasets"));
    std::map<DatasetId, std::shared_ptr<const DatasetEntry>> loaded;
    sql::Stmt::Use u(s);
    int rc = 0;
    while ((rc = u.step()) == SQLITE_ROW) {
      DatasetSpec spec = specFromRow(u);
      auto grid = TileGrid::create(spec.grid);
      if (!grid) continue; // a row this build cannot use; `verify` will not touch it either
      const DatasetId id = u.i64(0);
      std::string folder = u.text(3);
      fs::path dir = options.root / folder;
      const std::int64_t createdAt = u.i64(17);
      loaded.emplace(id,
                     std::make_shared<const DatasetEntry>(DatasetEntry{
                         DatasetInfo{id, std::move(spec), std::move(folder), createdAt},
                         std::move(*grid),
                         std::move(dir)}));
    }
    if (rc != SQLITE_DONE) return std::unexpected(sql::errorFrom(db, rc, "reading datasets"));
    std::unique_lock lock(datasetsMutex);
    datasetsById = std::move(loaded);
    return {};
  }

  std::shared_ptr<const DatasetEntry> findDataset(DatasetId id) const {
    {
      std::shared_lock lock(datasetsMutex);
      if (auto it = datasetsById.find(id); it != datasetsById.end()) return it->second;
    }
    auto r = acquireReader();
    if (!r) return nullptr;
    if (!loadDatasets(r->conn->db.get())) return nullptr;
    std::shared_lock lock(datasetsMutex);
    if (auto it = datasetsById.find(id); it != datasetsById.end()) return it->second;
    return nullptr;
  }

  std::expected<std::shared_ptr<const DatasetEntry>, CacheError>
  checkedDataset(DatasetId id, const TileKey& key) const {
    auto d = findDataset(id);
    if (!d) return std::unexpected(invalid("unknown dataset id " + std::to_string(id)));
    if (key.level < 0 || key.level >= d->grid.numLevels() || !d->grid.isValid(key)) {
      return std::unexpected(invalid("tile " + keyText(key) + " is outside the grid of dataset '" +
                                     d->info.spec.name + "'"));
    }
    return d;
  }

  fs::path tilePath(const DatasetEntry& d, const TileKey& key) const {
    return d.dir / tileRelativePath(key, d.info.spec.extension);
  }

  /** How a tile's file goes away with its row (see TileRemoval). */
  std::shared_ptr<TileRemoval> removalOf(const DatasetEntry& d, const TileKey& key) {
    auto r = std::make_shared<TileRemoval>();
    r->target = tilePath(d, key);
    const fs::path tempDir = d.dir / kTempDirName;
    if (ensureDir(tempDir)) r->aside = tempDir / fileio::tempNameFor(r->target.filename());
    return r;
  }

  Result ensureDir(const fs::path& dir) {
    {
      std::lock_guard lock(dirsMutex);
      if (knownDirs.contains(dir.native())) return {};
    }
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) {
      const bool noRoom =
          (ec.category() == std::generic_category() || ec.category() == std::system_category()) &&
          fileio::isNoSpace(ec.value());
      return std::unexpected(CacheError{noRoom ? CacheErrc::DiskFull : CacheErrc::Io,
                                        "cannot create " + dir.string() + ": " + ec.message()});
    }
    std::lock_guard lock(dirsMutex);
    knownDirs.insert(dir.native());
    return {};
  }

  // ---------------------------------------------------------------------------- writer
  Result prepareWriter() {
    sqlite3* db = writeDb.get();
    upsertTile =
        sql::Stmt(db,
                  "INSERT INTO tiles(dataset, level, row, col, state, bytes, content_type, "
                  "etag, last_modified, expires, fetched_at, last_access, retry_after) "
                  "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?11, ?12) "
                  "ON CONFLICT(dataset, level, row, col) DO UPDATE SET "
                  "state = excluded.state, bytes = excluded.bytes, "
                  "content_type = excluded.content_type, etag = excluded.etag, "
                  "last_modified = excluded.last_modified, expires = excluded.expires, "
                  "fetched_at = excluded.fetched_at, last_access = excluded.last_access, "
                  "retry_after = excluded.retry_after");
    deleteTile = sql::Stmt(db,
                           "DELETE FROM tiles WHERE dataset = ?1 AND level = ?2 AND row = ?3 "
                           "AND col = ?4");
    touchTile = sql::Stmt(db,
                          "UPDATE tiles SET last_access = max(last_access, ?5) WHERE "
                          "dataset = ?1 AND level = ?2 AND row = ?3 AND col = ?4");
    totalStmt = sql::Stmt(db, "SELECT coalesce(sum(bytes), 0) FROM usage");
    rowBytesStmt = sql::Stmt(db,
                             "SELECT state, bytes FROM tiles WHERE dataset = ?1 AND level = ?2 "
                             "AND row = ?3 AND col = ?4");
    beginStmt = sql::Stmt(db, "BEGIN IMMEDIATE");
    commitStmt = sql::Stmt(db, "COMMIT");
    rollbackStmt = sql::Stmt(db, "ROLLBACK");
    savepointStmt = sql::Stmt(db, "SAVEPOINT op");
    releaseStmt = sql::Stmt(db, "RELEASE op");
    rollbackToStmt = sql::Stmt(db, "ROLLBACK TO op");
    for (const sql::Stmt* s : {&upsertTile,
                               &deleteTile,
                               &touchTile,
                               &totalStmt,
                               &rowBytesStmt,
                               &beginStmt,
                               &commitStmt,
                               &rollbackStmt,
                               &savepointStmt,
                               &releaseStmt,
                               &rollbackToStmt}) {
      if (!s->ok()) return std::unexpected(sql::errorFrom(db, s->prepareRc(), "preparing writer"));
    }
    return {};
  }

  void startWriter() {
    writer = std::thread([this] { writerLoop(); });
  }

  void stopWriter() {
    if (!writer.joinable()) return;
    {
      std::lock_guard lock(queueMutex);
      stopping = true;
    }
    queueCv.notify_all();
    writer.join();
  }

  /** Queues an operation for the writer thread and waits for its commit. `after` runs in every
   * case, with the outcome. */
  Result
  submit(std::function<Result(Impl&)> apply, After after = {}, bool ownTransactions = false) {
    auto refuse = [&](CacheError e) -> Result {
      Result r = std::unexpected(std::move(e));
      if (after) after(r);
      return r;
    };
    if (options.readOnly) return refuse(CacheError{CacheErrc::ReadOnly, "the cache is read-only"});
    auto op = std::make_unique<WriteOp>();
    op->apply = std::move(apply);
    op->after = std::move(after);
    op->ownTransactions = ownTransactions;
    auto fut = op->done.get_future();
    {
      std::lock_guard lock(queueMutex);
      if (stopping) {
        after = std::move(op->after);
        return refuse(CacheError{CacheErrc::Io, "the cache is closing"});
      }
      queue.push_back(std::move(op));
    }
    if (writeMutex.try_lock()) {
      // The connection is free: commit the queue (ours included) on this thread.
      drainLocked();
      writeMutex.unlock();
    } else {
      queueCv.notify_one(); // whoever holds it, or the writer thread after it, takes ours too
    }
    return fut.get();
  }

  /** Queues without waiting (self-healing clean-ups from readers, write-behind puts). `after`
   * runs in every case, with the outcome. */
  void submitDetached(std::function<Result(Impl&)> apply, After after = {}) {
    auto op = std::make_unique<WriteOp>();
    op->apply = std::move(apply);
    op->after = std::move(after);
    {
      std::lock_guard lock(queueMutex);
      if (!stopping && !options.readOnly) {
        queue.push_back(std::move(op));
        op = nullptr;
      }
    }
    if (op) {
      if (op->after) op->after(std::unexpected(CacheError{CacheErrc::Io, "the cache is closing"}));
      return;
    }
    queueCv.notify_one();
  }

  static bool isSqlFailure(const CacheError& e) { return e.code != CacheErrc::InvalidArgument; }

  static int run(const sql::Stmt& s) {
    sql::Stmt::Use u(s);
    return u.step();
  }
  Result begin() {
    const int rc = run(beginStmt);
    if (rc != SQLITE_DONE)
      return std::unexpected(sql::errorFrom(writeDb.get(), rc, "starting a write"));
    return {};
  }
  Result commit() {
    const int rc = run(commitStmt);
    if (rc != SQLITE_DONE) {
      run(rollbackStmt);
      return std::unexpected(sql::errorFrom(writeDb.get(), rc, "committing"));
    }
    return {};
  }

  void flushTouches(std::unordered_map<TouchKey, UnixMillis, TouchKeyHash>& batch) {
    if (batch.empty()) return;
    if (!begin()) return; // last-access times are advisory: a failure only delays them
    for (const auto& [tk, when] : batch) {
      sql::Stmt::Use u(touchTile);
      bindKey(u, tk.dataset, tk.key);
      u.bind(5, when);
      u.step();
    }
    (void)commit();
    batch.clear();
  }

  /** One transaction for a batch of operations, under the files lock. Operations change tile
   * files in their `apply`, in order (a put renames its file into place, a removal moves the file
   * aside), and their `after` keeps or undoes that: an operation that fails is undone at once,
   * before the next one runs; when the commit fails, every one is undone, the last first. */
  void runBatch(std::vector<std::unique_ptr<WriteOp>>& ops) {
    std::vector<Result> results(ops.size());
    std::vector<bool> finished(ops.size(), false);
    auto finish = [&](std::size_t i, const Result& outcome) {
      if (ops[i]->after) ops[i]->after(outcome);
      finished[i] = true;
    };
    auto failAll = [&](const CacheError& e) {
      const Result r = std::unexpected(e);
      for (std::size_t i = ops.size(); i-- > 0;)
        finish(i, r);
      for (auto& op : ops)
        op->done.set_value(r);
    };
    auto filesLock = lockFiles();
    if (!filesLock) return failAll(filesLock.error());
    auto started = begin();
    if (!started) return failAll(started.error());
    if (ops.size() == 1) {
      // Alone in its transaction: a failure rolls the whole (one-operation) batch back.
      results[0] = ops[0]->apply(*this);
      if (!results[0]) {
        run(rollbackStmt);
        publishRowChanges();
        finish(0, results[0]);
        ops[0]->done.set_value(std::move(results[0]));
        return;
      }
    } else {
      // A savepoint per operation: one failure does not sink the batch.
      for (std::size_t i = 0; i < ops.size(); ++i) {
        run(savepointStmt);
        results[i] = ops[i]->apply(*this);
        if (!results[i]) {
          run(rollbackToStmt);
          finish(i, results[i]);
        }
        run(releaseStmt);
      }
    }
    const auto committed = commit();
    publishRowChanges(); // before anyone is told: a put is visible to the next get
    for (std::size_t i = ops.size(); i-- > 0;) {
      if (finished[i]) continue;
      finish(i, committed ? results[i] : Result(std::unexpected(committed.error())));
    }
    for (std::size_t i = 0; i < ops.size(); ++i)
      ops[i]->done.set_value(!committed && results[i] ? Result(std::unexpected(committed.error()))
                                                      : results[i]);
  }

  /** Runs queued operations until the queue is empty. Requires writeMutex. */
  void drainLocked() {
    for (;;) {
      std::vector<std::unique_ptr<WriteOp>> ops;
      {
        std::lock_guard lock(queueMutex);
        while (!queue.empty() && ops.size() < kMaxBatch) {
          ops.push_back(std::move(queue.front()));
          queue.pop_front();
        }
        if (ops.empty()) return;
        ++busy;
      }
      std::vector<std::unique_ptr<WriteOp>> group;
      for (auto& op : ops) {
        if (!op->ownTransactions) {
          group.push_back(std::move(op));
          continue;
        }
        if (!group.empty()) runBatch(group);
        group.clear();
        auto r = op->apply(*this);
        publishRowChanges();
        if (op->after) op->after(r);
        op->done.set_value(std::move(r));
      }
      if (!group.empty()) runBatch(group);
      {
        std::lock_guard lock(queueMutex);
        --busy;
        evictDue = evictDue || options.sizeLimitBytes > 0;
      }
      idleCv.notify_all();
      if (options.sizeLimitBytes > 0) queueCv.notify_one(); // eviction runs on the writer thread
    }
  }

  void writerLoop() {
    auto lastTouchFlush = std::chrono::steady_clock::now();
    for (;;) {
      std::unordered_map<TouchKey, UnixMillis, TouchKeyHash> touchBatch;
      bool stop = false;
      bool evict = false;
      {
        std::unique_lock lock(queueMutex);
        queueCv.wait_for(lock, options.accessFlushInterval, [this] {
          return stopping || !queue.empty() || evictDue;
        });
        const auto now = std::chrono::steady_clock::now();
        if (stopping || now - lastTouchFlush >= options.accessFlushInterval ||
            touches.size() > 65536) {
          touchBatch.swap(touches);
          lastTouchFlush = now;
        }
        stop = stopping;
        evict = std::exchange(evictDue, false);
        ++busy;
      }
      {
        std::lock_guard w(writeMutex);
        flushTouches(touchBatch);
        drainLocked();
        if (evict) (void)evictLocked();
      }
      {
        std::lock_guard lock(queueMutex);
        --busy;
        if (stop && queue.empty()) {
          idleCv.notify_all();
          return;
        }
      }
      idleCv.notify_all();
    }
  }

  std::expected<std::int64_t, CacheError> totalLocked() {
    sql::Stmt::Use u(totalStmt);
    const int rc = u.step();
    if (rc != SQLITE_ROW)
      return std::unexpected(sql::errorFrom(writeDb.get(), rc, "reading totals"));
    return u.i64(0);
  }

  /** Deletes rows chosen by a query (dataset, level, row, col, folder, extension, bytes), in chunks
   * of at most 1000 rows per transaction, rows first and then their files, each chunk under the
   * files lock (so the files unlinked are the ones the deleted rows named: no put can rename a new
   * tile into place between the commit and the unlink). When the disk is so full that the deletion
   * cannot be committed, the chunk's files go first (they free the room) and the rows after. Stops
   * after `maxRows` rows or once `bytesToFree` bytes are gone. Writer thread only. Returns the
   * number removed. */
  std::expected<std::int64_t, CacheError>
  deleteSelected(const char* selectSql,
                 const std::function<void(sql::Stmt::Use&)>& bind,
                 std::int64_t maxRows,
                 std::optional<std::int64_t> bytesToFree = std::nullopt) {
    std::int64_t removed = 0;
    std::int64_t freed = 0;
    auto done = [&] { return removed >= maxRows || (bytesToFree && freed >= *bytesToFree); };
    while (!done()) {
      auto filesLock = lockFiles();
      if (!filesLock) return std::unexpected(filesLock.error());
      std::vector<std::pair<TouchKey, fs::path>> victims;
      {
        sql::Stmt sel(writeDb.get(), selectSql);
        if (!sel.ok())
          return std::unexpected(sql::errorFrom(writeDb.get(), sel.prepareRc(), "selecting tiles"));
        sql::Stmt::Use u(sel);
        bind(u);
        int rc = 0;
        std::int64_t chunkFreed = 0;
        while ((rc = u.step()) == SQLITE_ROW) {
          const TileKey k{static_cast<std::int32_t>(u.i64(1)), u.i64(2), u.i64(3)};
          victims.push_back(
              {TouchKey{u.i64(0), k}, options.root / u.text(4) / tileRelativePath(k, u.text(5))});
          chunkFreed += u.i64(6);
          const auto n = static_cast<std::int64_t>(victims.size());
          if (n >= 1000 || removed + n >= maxRows ||
              (bytesToFree && freed + chunkFreed >= *bytesToFree))
            break;
        }
        if (rc != SQLITE_ROW && rc != SQLITE_DONE) {
          return std::unexpected(sql::errorFrom(writeDb.get(), rc, "selecting tiles"));
        }
        freed += chunkFreed;
      }
      if (victims.empty()) break;
      auto deleteRows = [&]() -> Result {
        if (auto b = begin(); !b) return b;
        for (const auto& [tk, path] : victims) {
          sql::Stmt::Use d(deleteTile);
          bindKey(d, tk.dataset, tk.key);
          d.step();
          rowChanged(tk.dataset, tk.key);
        }
        auto c = commit();
        publishRowChanges();
        return c;
      };
      auto c = deleteRows();
      if (!c && c.error().code == CacheErrc::DiskFull) {
        for (const auto& [tk, path] : victims)
          ::unlink(path.c_str());
        c = deleteRows();
        if (!c) {
          return std::unexpected(CacheError{
              CacheErrc::DiskFull,
              c.error().message + ": " + std::to_string(victims.size()) +
                  " tiles were removed but the index is too full to forget them; free some "
                  "space and run `tellus cache rebuild`"});
        }
      } else if (!c) {
        return std::unexpected(c.error());
      } else {
        for (const auto& [tk, path] : victims)
          ::unlink(path.c_str());
      }
      removed += static_cast<std::int64_t>(victims.size());
      noteRoom();
    }
    return removed;
  }

  /** LRU eviction of unpinned tiles down to 95% of the limit. Writer thread only. */
  std::expected<std::int64_t, CacheError> evictLocked() {
    const auto limit = static_cast<std::int64_t>(options.sizeLimitBytes);
    if (limit <= 0) return 0;
    auto total = totalLocked();
    if (!total) return std::unexpected(total.error());
    if (*total <= limit) return 0;
    const std::int64_t target = limit - limit / 20;
    // Only pinned data left over the limit: nothing is selected and the limit stays exceeded.
    return deleteSelected(
        "SELECT t.dataset, t.level, t.row, t.col, d.folder, d.extension, t.bytes FROM tiles t "
        "JOIN datasets d ON d.id = t.dataset WHERE d.pinned = 0 AND t.state = 1 "
        "ORDER BY t.last_access",
        [](sql::Stmt::Use&) {},
        std::numeric_limits<std::int64_t>::max(),
        *total - target);
  }

  void waitIdle() {
    std::unique_lock lock(queueMutex);
    idleCv.wait(lock, [this] { return queue.empty() && busy == 0 && !evictDue; });
  }

  // ---------------------------------------------------------------------------- tiles
  Result writeRow(const DatasetEntry& d,
                  const TileKey& key,
                  int state,
                  std::int64_t bytes,
                  const TileMeta& meta,
                  std::optional<UnixMillis> retryAfter) {
    sql::Stmt::Use u(upsertTile);
    bindKey(u, d.info.id, key);
    u.bind(5, std::int64_t{state}).bind(6, bytes);
    u.bind(7, std::string_view(meta.contentType)).bind(8, std::string_view(meta.etag));
    u.bind(9, std::string_view(meta.lastModified)).bind(10, meta.expiresAt);
    u.bind(11, meta.fetchedAt ? meta.fetchedAt : unixMillisNow()).bind(12, retryAfter);
    rowChanged(d.info.id, key);
    const int rc = u.step();
    if (rc != SQLITE_DONE)
      return std::unexpected(sql::errorFrom(writeDb.get(), rc, "indexing tile"));
    return {};
  }

  Result deleteRow(DatasetId id, const TileKey& key) {
    rowChanged(id, key);
    sql::Stmt::Use u(deleteTile);
    bindKey(u, id, key);
    const int rc = u.step();
    if (rc != SQLITE_DONE)
      return std::unexpected(sql::errorFrom(writeDb.get(), rc, "removing tile"));
    return {};
  }

  /** A reader found a present row whose file is missing or of another size: drops the row if that
   * is still so now, under the files lock (where a row and its file agree unless something outside
   * the cache changed them), not if a put or a prune came between and made them agree again. */
  Result healRow(DatasetId id, const TileKey& key) {
    const auto d = findDataset(id);
    if (!d) return {};
    std::optional<std::int64_t> bytes;
    {
      sql::Stmt::Use u(rowBytesStmt);
      bindKey(u, id, key);
      const int rc = u.step();
      if (rc == SQLITE_ROW && u.i64(0) == kStatePresent) {
        bytes = u.i64(1);
      } else if (rc != SQLITE_ROW && rc != SQLITE_DONE) {
        return std::unexpected(sql::errorFrom(writeDb.get(), rc, "checking a tile"));
      }
    }
    if (!bytes) return {};
    const fs::path path = tilePath(*d, key);
    struct stat st {};
    const bool exists = ::stat(path.c_str(), &st) == 0;
    if (exists && st.st_size == *bytes) return {};
    // A file of another size than its row says is not that tile: both go (it is fetched again).
    if (exists) ::unlink(path.c_str());
    return deleteRow(id, key);
  }
};

// ------------------------------------------------------------------------------------------------

namespace {

/** Inserts a dataset row (the usage row follows by trigger); returns its id. */
std::expected<DatasetId, CacheError> insertDataset(sqlite3* db,
                                                   const DatasetSpec& spec,
                                                   const std::string& folder,
                                                   UnixMillis createdAt = unixMillisNow()) {
  sql::Stmt ins(db,
                "INSERT INTO datasets(server, name, folder, west, south, east, north, "
                "level_zero_delta, tile_width, tile_height, num_levels, mime_type, extension, "
                "style, time, pinned, created_at) VALUES "
                "(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16, ?17)");
  if (!ins.ok()) return std::unexpected(sql::errorFrom(db, ins.prepareRc(), "registering dataset"));
  sql::Stmt::Use u(ins);
  const GridSpec& g = spec.grid;
  u.bind(1, std::string_view(spec.server))
      .bind(2, std::string_view(spec.name))
      .bind(3, std::string_view(folder));
  u.bind(4, g.sector.west).bind(5, g.sector.south).bind(6, g.sector.east).bind(7, g.sector.north);
  u.bind(8, g.levelZeroDeltaDeg)
      .bind(9, std::int64_t{g.tileWidth})
      .bind(10, std::int64_t{g.tileHeight});
  u.bind(11, std::int64_t{g.numLevels}).bind(12, std::string_view(spec.mimeType));
  u.bind(13, std::string_view(spec.extension)).bind(14, std::string_view(spec.style));
  u.bind(15, std::string_view(spec.time)).bind(16, std::int64_t{spec.pinned ? 1 : 0});
  u.bind(17, createdAt);
  const int rc = u.step();
  if (rc != SQLITE_DONE) return std::unexpected(sql::errorFrom(db, rc, "registering dataset"));
  return sqlite3_last_insert_rowid(db);
}

/** Runs statements that return at most rows nobody reads; the first failure is the result. */
Result runAll(sqlite3* db, std::initializer_list<const char*> statements, const char* what) {
  for (const char* q : statements) {
    sql::Stmt s(db, q);
    if (!s.ok()) return std::unexpected(sql::errorFrom(db, s.prepareRc(), what));
    sql::Stmt::Use u(s);
    const int rc = u.step();
    if (rc != SQLITE_ROW && rc != SQLITE_DONE) return std::unexpected(sql::errorFrom(db, rc, what));
  }
  return {};
}

/** Cheap damage checks at open: header, schema, both edges of the tiles b-tree. No scan. */
Result probe(sqlite3* db) {
  return runAll(db,
                {"SELECT count(*) FROM datasets",
                 "SELECT dataset FROM tiles ORDER BY dataset, level, row, col LIMIT 1",
                 "SELECT dataset FROM tiles ORDER BY dataset DESC, level DESC, row DESC, "
                 "col DESC LIMIT 1",
                 "SELECT last_access FROM tiles ORDER BY last_access DESC LIMIT 1",
                 "SELECT count(*) FROM usage"},
                "checking index");
}

Result configure(sqlite3* db, bool readOnly) {
  if (readOnly) return {};
  // The WAL persists (openDb); it is cut back to 64 MiB when it is reset, so one huge transaction
  // (a rebuild) does not keep its size forever.
  return runAll(db,
                {"PRAGMA journal_mode = WAL",
                 "PRAGMA synchronous = NORMAL",
                 "PRAGMA journal_size_limit = 67108864"},
                "configuring index");
}

void moveAside(const fs::path& indexPath) {
  const std::string suffix = ".corrupt-" + std::to_string(unixMillisNow());
  std::error_code ec;
  for (const char* extra : {"", "-wal", "-shm"}) {
    const fs::path p = indexPath.string() + extra;
    if (fs::exists(p, ec)) fs::rename(p, indexPath.string() + suffix + extra, ec);
  }
}

} // namespace

std::expected<std::unique_ptr<TileCache>, CacheError> TileCache::open(const Options& options) {
  fileio::ignoreFileSizeSignal();
  auto impl = std::make_unique<Impl>();
  impl->options = options;
  impl->indexPath = options.root / kIndexName;
  std::error_code ec;
  if (!options.readOnly) {
    fs::create_directories(options.root, ec);
    if (ec)
      return std::unexpected(
          CacheError{CacheErrc::Io,
                     "cannot create cache root " + options.root.string() + ": " + ec.message()});
  } else if (!fs::exists(impl->indexPath, ec)) {
    return std::unexpected(
        CacheError{CacheErrc::Io, "no cache index at " + impl->indexPath.string()});
  }
  const int busyMs = static_cast<int>(options.busyTimeout.count());

  bool damaged = !options.readOnly && fs::exists(options.root / kCorruptMarker, ec);
  for (int attempt = 0; attempt < 2; ++attempt) {
    if (damaged) {
      moveAside(impl->indexPath);
      fs::remove(options.root / kCorruptMarker, ec);
      impl->rebuiltAtOpen = true;
    }
    int rc = 0;
    impl->writeDb = openDb(impl->indexPath, options.readOnly, true, busyMs, &rc);
    if (!impl->writeDb)
      return std::unexpected(sql::errorFrom(nullptr, rc, "opening " + impl->indexPath.string()));
    Result r = configure(impl->writeDb.get(), options.readOnly);
    if (r && !options.readOnly) r = schema::ensure(impl->writeDb.get());
    if (r) r = probe(impl->writeDb.get());
    if (r) break;
    if (r.error().code != CacheErrc::Corrupt || options.readOnly || attempt == 1)
      return std::unexpected(r.error());
    impl->writeDb.reset();
    damaged = true;
  }
  if (!options.readOnly) {
    if (auto r = impl->prepareWriter(); !r) return std::unexpected(r.error());
    impl->rootFd = ::open(options.root.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (impl->rootFd < 0)
      return std::unexpected(fileio::errnoError(errno, "cannot open cache root", options.root));
  }
  if (auto r = impl->loadDatasets(impl->writeDb.get()); !r) return std::unexpected(r.error());
  if (!options.readOnly) {
    // Temp files of writers that are gone (killed mid-write): only where writers put them, no scan.
    impl->tempFilesRemoved = removeDeadTempFiles(options.root);
    std::shared_lock lock(impl->datasetsMutex);
    for (const auto& [id, d] : impl->datasetsById) {
      impl->tempFilesRemoved += removeDeadTempFiles(d->dir);
      impl->tempFilesRemoved += removeDeadTempFiles(d->dir / kTempDirName);
    }
  }
  impl->rows.configure(options.rowCacheEntries, options.openFiles);
  impl->dataVersionStmt = sql::Stmt(impl->writeDb.get(), "PRAGMA data_version");
  std::unique_ptr<TileCache> cache(new TileCache(std::move(impl)));
  if (!options.readOnly) cache->impl_->startWriter();
  if (cache->impl_->rebuiltAtOpen) {
    if (auto n = cache->rebuild(); !n) return std::unexpected(n.error());
  }
  return cache;
}

TileCache::TileCache(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

TileCache::~TileCache() {
  if (impl_) impl_->stopWriter();
}

const fs::path& TileCache::root() const noexcept {
  return impl_->options.root;
}
bool TileCache::wasRebuiltAtOpen() const noexcept {
  return impl_->rebuiltAtOpen;
}

// ---------------------------------------------------------------------------------- datasets

std::expected<DatasetId, CacheError> TileCache::registerDataset(const DatasetSpec& spec) {
  auto grid = TileGrid::create(spec.grid);
  if (!grid) return std::unexpected(invalid("dataset '" + spec.name + "': " + grid.error()));
  if (spec.extension.empty() || spec.extension.size() > 8 ||
      !std::all_of(spec.extension.begin(), spec.extension.end(), [](char c) {
        return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9');
      })) {
    return std::unexpected(
        invalid("dataset '" + spec.name + "': extension must be 1-8 of [a-z0-9]"));
  }
  const std::string folder = datasetFolder(spec);
  const fs::path dir = impl_->options.root / folder;
  const std::string descriptor = serializeDatasetSpec(spec);
  const fs::path descriptorPath = dir / kDescriptorName;
  // Registered already as it is now defined? Then nothing is written: a restart on a full disk
  // finds every dataset it had and starts.
  struct Known {
    DatasetId id;
    UnixMillis createdAt;
    bool pinned;
  };
  std::optional<Known> known;
  if (auto lease = impl_->acquireReader()) {
    sql::Stmt find(lease->conn->db.get(),
                   "SELECT id, created_at, pinned FROM datasets WHERE folder = ?1");
    if (find.ok()) {
      sql::Stmt::Use u(find);
      u.bind(1, std::string_view(folder));
      if (u.step() == SQLITE_ROW) known = Known{u.i64(0), u.i64(1), u.i64(2) != 0};
    }
  }
  auto remember = [&](DatasetId id, UnixMillis createdAt, bool pinned) {
    std::unique_lock lock(impl_->datasetsMutex);
    DatasetSpec stored = spec;
    stored.pinned = pinned;
    impl_->datasetsById.insert_or_assign(
        id,
        std::make_shared<const DatasetEntry>(
            DatasetEntry{DatasetInfo{id, std::move(stored), folder, createdAt}, *grid, dir}));
    return id;
  };
  const auto onDisk = fileio::readFile(descriptorPath, std::nullopt);
  const bool descriptorCurrent =
      onDisk &&
      std::string_view(reinterpret_cast<const char*>(onDisk->data()), onDisk->size()) == descriptor;
  if (known && known->pinned == spec.pinned && descriptorCurrent)
    return remember(known->id, known->createdAt, known->pinned);
  if (!known && impl_->refusingNow()) {
    return std::unexpected(
        impl_->fullError("dataset '" + spec.name + "' is not registered while the disk is full"));
  }
  if (auto r = impl_->ensureDir(dir); !r) {
    if (!known) {
      if (r.error().code != CacheErrc::DiskFull) return std::unexpected(r.error());
      impl_->noteFull();
      return std::unexpected(impl_->fullError(r.error().message));
    }
  } else if (!descriptorCurrent) {
    // The descriptor goes first: a rebuild from the tree needs it, and it is harmless without a
    // row. A known dataset keeps working without it (its old descriptor stays).
    if (auto w =
            fileio::writeFileAtomic(descriptorPath,
                                    std::as_bytes(std::span(descriptor.data(), descriptor.size())),
                                    impl_->options.fsyncTiles);
        !w && !known) {
      if (w.error().code != CacheErrc::DiskFull) return std::unexpected(w.error());
      impl_->noteFull();
      return std::unexpected(impl_->fullError(w.error().message));
    }
  }
  if (known && known->pinned == spec.pinned)
    return remember(known->id, known->createdAt, known->pinned);
  DatasetId id = 0;
  UnixMillis createdAt = unixMillisNow();
  auto r = impl_->submit([&](Impl& im) -> Result {
    sqlite3* db = im.writeDb.get();
    sql::Stmt find(db, "SELECT id, created_at FROM datasets WHERE folder = ?1");
    {
      sql::Stmt::Use u(find);
      u.bind(1, std::string_view(folder));
      const int rc = u.step();
      if (rc == SQLITE_ROW) {
        id = u.i64(0);
        createdAt = u.i64(1);
      } else if (rc != SQLITE_DONE) {
        return std::unexpected(sql::errorFrom(db, rc, "finding dataset"));
      }
    }
    if (id != 0) {
      sql::Stmt upd(db, "UPDATE datasets SET pinned = ?2 WHERE id = ?1");
      sql::Stmt::Use u(upd);
      u.bind(1, id).bind(2, std::int64_t{spec.pinned ? 1 : 0});
      const int rc = u.step();
      if (rc != SQLITE_DONE) return std::unexpected(sql::errorFrom(db, rc, "updating dataset"));
      return {};
    }
    auto inserted = insertDataset(db, spec, folder, createdAt);
    if (!inserted) return std::unexpected(inserted.error());
    id = *inserted;
    return {};
  });
  if (!r && known) {
    // Only `pinned` could not be recorded (a full index): the dataset is there and works.
    return remember(known->id, known->createdAt, known->pinned);
  }
  if (!r) {
    if (r.error().code != CacheErrc::DiskFull) return std::unexpected(r.error());
    impl_->noteFull();
    return std::unexpected(impl_->fullError(r.error().message));
  }
  return remember(id, createdAt, spec.pinned);
}

std::optional<DatasetInfo> TileCache::dataset(DatasetId id) const {
  auto d = impl_->findDataset(id);
  if (!d) return std::nullopt;
  return d->info;
}

std::vector<DatasetInfo> TileCache::datasets() const {
  if (auto r = impl_->acquireReader()) (void)impl_->loadDatasets(r->conn->db.get());
  std::shared_lock lock(impl_->datasetsMutex);
  std::vector<DatasetInfo> out;
  for (const auto& [id, d] : impl_->datasetsById)
    out.push_back(d->info);
  return out;
}

std::expected<void, CacheError> TileCache::setPinned(DatasetId id, bool pinned) {
  auto d = impl_->findDataset(id);
  if (!d) return std::unexpected(invalid("unknown dataset id " + std::to_string(id)));
  auto r = impl_->submit([&](Impl& im) -> Result {
    sql::Stmt upd(im.writeDb.get(), "UPDATE datasets SET pinned = ?2 WHERE id = ?1");
    sql::Stmt::Use u(upd);
    u.bind(1, id).bind(2, std::int64_t{pinned ? 1 : 0});
    const int rc = u.step();
    if (rc != SQLITE_DONE) return std::unexpected(sql::errorFrom(im.writeDb.get(), rc, "pinning"));
    return {};
  });
  if (!r) return r;
  std::unique_lock lock(impl_->datasetsMutex);
  if (auto it = impl_->datasetsById.find(id); it != impl_->datasetsById.end()) {
    auto updated = std::make_shared<DatasetEntry>(*it->second);
    updated->info.spec.pinned = pinned;
    it->second = std::move(updated);
  }
  return {};
}

// ---------------------------------------------------------------------------------- tiles

std::expected<CacheLookup, CacheError> TileCache::peek(DatasetId id, const TileKey& key) const {
  auto d = impl_->checkedDataset(id, key);
  if (!d) return std::unexpected(d.error());
  if (impl_->options.indexWriteBehind) {
    std::lock_guard lock(impl_->pendingMutex);
    if (const auto it = impl_->pendingRows.find(TouchKey{id, key});
        it != impl_->pendingRows.end()) {
      CacheLookup out;
      out.kind = CacheLookup::Kind::Hit;
      out.meta = it->second.meta;
      out.size = it->second.size;
      out.stale = out.meta.expiresAt && *out.meta.expiresAt <= unixMillisNow();
      return out;
    }
  }
  auto lease = impl_->acquireReader();
  if (!lease) return std::unexpected(lease.error());
  sql::Stmt::Use u(lease->conn->lookup);
  bindKey(u, id, key);
  const int rc = u.step();
  CacheLookup out;
  if (rc == SQLITE_DONE) return out;
  if (rc != SQLITE_ROW) {
    auto err = sql::errorFrom(lease->conn->db.get(), rc, "looking up tile");
    if (err.code == CacheErrc::Corrupt) {
      // Remember the damage: the next open moves the index aside and rebuilds it.
      const std::string note = err.message;
      (void)fileio::writeFileAtomic(impl_->options.root / kCorruptMarker,
                                    std::as_bytes(std::span(note.data(), note.size())),
                                    false);
    }
    return std::unexpected(std::move(err));
  }
  const UnixMillis now = unixMillisNow();
  if (u.i64(0) == kStateAbsent) {
    out.kind = CacheLookup::Kind::Absent;
    out.retryAfter = u.isNull(7) ? 0 : u.i64(7);
    return out;
  }
  out.kind = CacheLookup::Kind::Hit;
  out.meta.contentType = u.text(2);
  out.meta.etag = u.text(3);
  out.meta.lastModified = u.text(4);
  if (!u.isNull(5)) out.meta.expiresAt = u.i64(5);
  out.meta.fetchedAt = u.i64(6);
  out.stale = out.meta.expiresAt && *out.meta.expiresAt <= now;
  out.size = u.i64(1);
  return out;
}

namespace {

/** Opens a tile file and checks it has the size the index recorded. */
std::shared_ptr<detail::CachedRow> openRowFile(const fs::path& path, const CacheLookup& row) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return nullptr;
  struct stat st {};
  if (::fstat(fd, &st) != 0 || st.st_size != row.size) {
    ::close(fd);
    return nullptr;
  }
  auto r = std::make_shared<detail::CachedRow>();
  r->meta = row.meta;
  r->size = row.size;
  r->file = std::make_shared<const TileFile>(fd, row.size);
  r->dev = st.st_dev;
  r->ino = st.st_ino;
  r->checkedAtNs.store(steadyNanos(), std::memory_order_relaxed);
  return r;
}

} // namespace

std::expected<CacheLookup, CacheError> TileCache::openTile(DatasetId id, const TileKey& key) {
  Impl& im = *impl_;
  auto d = im.checkedDataset(id, key);
  if (!d) return std::unexpected(d.error());
  const TouchKey tk{id, key};
  auto hit = [&](const detail::CachedRow& r) {
    CacheLookup out;
    out.kind = CacheLookup::Kind::Hit;
    out.meta = r.meta;
    out.size = r.size;
    out.file = r.file;
    const UnixMillis now = unixMillisNow();
    out.stale = out.meta.expiresAt && *out.meta.expiresAt <= now;
    // Last access only steers LRU eviction: a minute's resolution is plenty, and a hot tile then
    // costs the writer one update a minute instead of one a second (its bursts hurt tail latency).
    if (now - r.touchedAtMs.load(std::memory_order_relaxed) < kTouchResolutionMs) return out;
    r.touchedAtMs.store(now, std::memory_order_relaxed);
    std::lock_guard lock(im.queueMutex);
    im.touches[tk] = now;
    return out;
  };
  im.noticeOtherWriters();
  const auto pendingRow = [&]() -> std::optional<Impl::PendingRow> {
    if (!im.options.indexWriteBehind) return std::nullopt;
    std::lock_guard lock(im.pendingMutex);
    const auto it = im.pendingRows.find(tk);
    if (it == im.pendingRows.end()) return std::nullopt;
    return it->second;
  }();
  if (pendingRow) {
    // Written, not yet committed: the bytes are in the temp file, or already in place.
    CacheLookup row;
    row.meta = pendingRow->meta;
    row.size = pendingRow->size;
    for (const fs::path& path : {pendingRow->temp, im.tilePath(**d, key)}) {
      if (auto r = openRowFile(path, row)) return hit(*r);
    }
    // Neither: committed (or dropped) meanwhile; the index says which.
  }
  const bool pending = pendingRow.has_value();
  if (!pending) {
    if (auto r = im.rows.find(tk)) {
      const auto recheck = im.options.fileRecheck.count() * 1000000;
      const std::int64_t now = steadyNanos();
      if (now - r->checkedAtNs.load(std::memory_order_relaxed) < recheck) return hit(*r);
      // Still the file the index names? (replaced or deleted behind the cache's back otherwise)
      struct stat st {};
      const fs::path path = im.tilePath(**d, key);
      if (::stat(path.c_str(), &st) == 0 && st.st_dev == r->dev && st.st_ino == r->ino) {
        r->checkedAtNs.store(now, std::memory_order_relaxed);
        return hit(*r);
      }
      im.rows.invalidate(tk);
    }
  }
  const std::uint64_t generation = im.rows.generation();
  auto found = peek(id, key);
  if (!found || found->kind != CacheLookup::Kind::Hit) return found;
  auto row = openRowFile(im.tilePath(**d, key), *found);
  if (!row) {
    // The file vanished or changed under us: report a miss, and let the writer drop the row if
    // it still names no such file (self-healing).
    im.submitDetached([id, key](Impl& w) { return w.healRow(id, key); });
    return CacheLookup{};
  }
  if (!pending) im.rows.insert(tk, row, generation);
  return hit(*row);
}

std::expected<CacheLookup, CacheError> TileCache::get(DatasetId id, const TileKey& key) {
  auto found = openTile(id, key);
  if (!found || found->kind != CacheLookup::Kind::Hit) return found;
  auto bytes = found->file->readAll();
  if (!bytes) {
    impl_->rows.invalidate(TouchKey{id, key});
    impl_->submitDetached([id, key](Impl& w) { return w.healRow(id, key); });
    return CacheLookup{};
  }
  found->bytes = std::move(*bytes);
  found->file.reset();
  return found;
}

std::expected<void, CacheError> TileCache::put(DatasetId id,
                                               const TileKey& key,
                                               std::span<const std::byte> bytes,
                                               const TileMeta& meta) {
  Impl& im = *impl_;
  if (im.options.readOnly)
    return std::unexpected(CacheError{CacheErrc::ReadOnly, "the cache is read-only"});
  auto d = im.checkedDataset(id, key);
  if (!d) return std::unexpected(d.error());
  if (auto refused = im.refuseWhileFull(); !refused) return refused;
  auto placement = std::make_shared<TilePlacement>();
  placement->target = im.tilePath(**d, key);
  const fs::path tempDir = (*d)->dir / kTempDirName;
  const std::string tileName = placement->target.filename().string();
  placement->temp = tempDir / fileio::tempNameFor(tileName);
  placement->backup = tempDir / fileio::tempNameFor(tileName);
  if (auto r = im.ensureDir(placement->target.parent_path()); !r) return im.putOutcome(r);
  if (auto r = im.ensureDir(tempDir); !r) return im.putOutcome(r);
  if (auto r = fileio::writeTemp(placement->temp, bytes, im.options.fsyncTiles, placement->target);
      !r)
    return im.putOutcome(r);
  TileMeta m = meta;
  if (m.contentType.empty()) m.contentType = (*d)->info.spec.mimeType;
  if (m.fetchedAt == 0) m.fetchedAt = unixMillisNow();
  const auto n = static_cast<std::int64_t>(bytes.size());
  // In the writer's transaction, under the files lock: the file goes into place and its row is
  // written; after the commit (or the rollback) the placement keeps or undoes what it did.
  auto apply = [entry = *d, key, n, m, placement](Impl& w) -> Result {
    if (auto r = placement->install(); !r) return r;
    return w.writeRow(*entry, key, kStatePresent, n, m, std::nullopt);
  };
  if (!im.options.indexWriteBehind) {
    return im.putOutcome(im.submit(
        std::move(apply), [placement](const Result& r) { placement->finish(r.has_value()); }));
  }
  // Write-behind: visible to this process at once through the pending overlay (from the temp file
  // until it is in place), renamed and committed by the writer with whatever else is queued.
  const TouchKey tk{id, key};
  std::uint64_t generation = 0;
  {
    std::lock_guard lock(im.pendingMutex);
    generation = ++im.pendingGeneration;
    im.pendingRows.insert_or_assign(tk, Impl::PendingRow{n, m, generation, placement->temp});
  }
  im.submitDetached(std::move(apply),
                    [w = impl_.get(), tk, generation, placement](const Result& r) {
                      placement->finish(r.has_value());
                      {
                        std::lock_guard lock(w->pendingMutex);
                        const auto it = w->pendingRows.find(tk);
                        if (it != w->pendingRows.end() && it->second.generation == generation)
                          w->pendingRows.erase(it);
                      }
                      if (r) {
                        w->noteRoom();
                        return;
                      }
                      // Counted, not printed: the seeder reports how many were dropped
                      // (storeStatus).
                      w->droppedPuts.fetch_add(1, std::memory_order_relaxed);
                      if (r.error().code == CacheErrc::DiskFull) {
                        w->noteFull();
                        w->refusedPuts.fetch_add(1, std::memory_order_relaxed);
                      }
                    });
  return {};
}

std::expected<void, CacheError>
TileCache::revalidated(DatasetId id, const TileKey& key, const TileMeta& meta) {
  auto d = impl_->checkedDataset(id, key);
  if (!d) return std::unexpected(d.error());
  return impl_->submit([id, key, meta](Impl& im) -> Result {
    sql::Stmt upd(im.writeDb.get(),
                  "UPDATE tiles SET expires = ?5, etag = ?6, last_modified = ?7, fetched_at = ?8 "
                  "WHERE dataset = ?1 AND level = ?2 AND row = ?3 AND col = ?4 AND state = 1");
    sql::Stmt::Use u(upd);
    bindKey(u, id, key);
    u.bind(5, meta.expiresAt)
        .bind(6, std::string_view(meta.etag))
        .bind(7, std::string_view(meta.lastModified))
        .bind(8, meta.fetchedAt ? meta.fetchedAt : unixMillisNow());
    im.rowChanged(id, key);
    const int rc = u.step();
    if (rc != SQLITE_DONE)
      return std::unexpected(sql::errorFrom(im.writeDb.get(), rc, "revalidating"));
    return {};
  });
}

std::expected<void, CacheError>
TileCache::putAbsent(DatasetId id, const TileKey& key, UnixMillis retryAfter) {
  auto d = impl_->checkedDataset(id, key);
  if (!d) return std::unexpected(d.error());
  impl_->dropPending(id, key);
  auto removal = impl_->removalOf(**d, key);
  return impl_->submit(
      [entry = *d, key, retryAfter, removal](Impl& im) -> Result {
        if (auto r = removal->hide(); !r) return r;
        TileMeta m;
        m.fetchedAt = unixMillisNow();
        return im.writeRow(*entry, key, kStateAbsent, 0, m, retryAfter);
      },
      [removal](const Result& r) { removal->finish(r.has_value()); });
}

std::expected<void, CacheError> TileCache::erase(DatasetId id, const TileKey& key) {
  auto d = impl_->checkedDataset(id, key);
  if (!d) return std::unexpected(d.error());
  impl_->dropPending(id, key);
  auto removal = impl_->removalOf(**d, key);
  return impl_->submit(
      [id, key, removal](Impl& im) -> Result {
        if (auto r = removal->hide(); !r) return r;
        return im.deleteRow(id, key);
      },
      [removal](const Result& r) { removal->finish(r.has_value()); });
}

std::expected<void, CacheError>
TileCache::forEachTile(DatasetId id,
                       std::int32_t fromLevel,
                       std::int32_t toLevel,
                       const std::function<bool(const TileKey&, std::int64_t)>& visit) const {
  auto lease = impl_->acquireReader();
  if (!lease) return std::unexpected(lease.error());
  sqlite3* db = lease->conn->db.get();
  sql::Stmt s(db,
              "SELECT level, row, col, bytes FROM tiles WHERE dataset = ?1 AND state = 1 "
              "AND level BETWEEN ?2 AND ?3 ORDER BY level, row, col");
  if (!s.ok()) return std::unexpected(sql::errorFrom(db, s.prepareRc(), "listing tiles"));
  sql::Stmt::Use u(s);
  u.bind(1, id).bind(2, std::int64_t{fromLevel}).bind(3, std::int64_t{toLevel});
  int rc = 0;
  while ((rc = u.step()) == SQLITE_ROW) {
    const TileKey k{static_cast<std::int32_t>(u.i64(0)), u.i64(1), u.i64(2)};
    if (!visit(k, u.i64(3))) return {};
  }
  if (rc != SQLITE_DONE) return std::unexpected(sql::errorFrom(db, rc, "listing tiles"));
  return {};
}

// ---------------------------------------------------------------------------------- maintenance

std::expected<std::int64_t, CacheError> TileCache::totalBytes() const {
  auto lease = impl_->acquireReader();
  if (!lease) return std::unexpected(lease.error());
  sql::Stmt s(lease->conn->db.get(), "SELECT coalesce(sum(bytes), 0) FROM usage");
  sql::Stmt::Use u(s);
  const int rc = u.step();
  if (rc != SQLITE_ROW)
    return std::unexpected(sql::errorFrom(lease->conn->db.get(), rc, "reading totals"));
  return u.i64(0);
}

std::expected<std::vector<DatasetStats>, CacheError> TileCache::stats() const {
  const auto infos = datasets();
  auto lease = impl_->acquireReader();
  if (!lease) return std::unexpected(lease.error());
  sqlite3* db = lease->conn->db.get();
  std::map<DatasetId, DatasetStats> byId;
  for (const auto& info : infos)
    byId[info.id].dataset = info;
  sql::Stmt s(db,
              "SELECT dataset, level, count(*), sum(state = 2), sum(bytes) FROM tiles "
              "GROUP BY dataset, level ORDER BY dataset, level");
  if (!s.ok()) return std::unexpected(sql::errorFrom(db, s.prepareRc(), "reading stats"));
  sql::Stmt::Use u(s);
  int rc = 0;
  while ((rc = u.step()) == SQLITE_ROW) {
    auto it = byId.find(u.i64(0));
    if (it == byId.end()) continue;
    LevelStats l{static_cast<std::int32_t>(u.i64(1)), u.i64(2), u.i64(3), u.i64(4)};
    it->second.tiles += l.tiles;
    it->second.bytes += l.bytes;
    it->second.levels.push_back(l);
  }
  if (rc != SQLITE_DONE) return std::unexpected(sql::errorFrom(db, rc, "reading stats"));
  std::vector<DatasetStats> out;
  for (auto& [id, st] : byId)
    out.push_back(std::move(st));
  return out;
}

std::expected<std::vector<DatasetStats>, CacheError>
TileCache::prunable(const PruneOptions& options) const {
  const UnixMillis cutoff = options.olderThan ? unixMillisNow() - options.olderThan->count()
                                              : std::numeric_limits<UnixMillis>::max();
  const auto infos = datasets();
  auto lease = impl_->acquireReader();
  if (!lease) return std::unexpected(lease.error());
  sqlite3* db = lease->conn->db.get();
  // The same selection as prune's.
  sql::Stmt s(db,
              "SELECT t.dataset, count(*), sum(t.bytes) FROM tiles t "
              "JOIN datasets d ON d.id = t.dataset WHERE t.fetched_at < ?1 "
              "AND (?2 IS NULL OR d.name = ?2) AND (?3 = 1 OR d.pinned = 0) "
              "GROUP BY t.dataset ORDER BY t.dataset");
  if (!s.ok()) return std::unexpected(sql::errorFrom(db, s.prepareRc(), "reading the index"));
  sql::Stmt::Use u(s);
  u.bind(1, cutoff);
  if (options.datasetName)
    u.bind(2, std::string_view(*options.datasetName));
  else
    u.bindNull(2);
  u.bind(3, std::int64_t{options.includePinned ? 1 : 0});
  std::vector<DatasetStats> out;
  int rc = 0;
  while ((rc = u.step()) == SQLITE_ROW) {
    const auto info = std::find_if(
        infos.begin(), infos.end(), [&](const DatasetInfo& d) { return d.id == u.i64(0); });
    if (info == infos.end()) continue;
    out.push_back(DatasetStats{*info, u.i64(1), u.i64(2), {}});
  }
  if (rc != SQLITE_DONE) return std::unexpected(sql::errorFrom(db, rc, "reading the index"));
  return out;
}

std::expected<VerifyReport, CacheError> TileCache::verify() const {
  VerifyReport report;
  const auto infos = datasets();
  auto lease = impl_->acquireReader();
  if (!lease) return std::unexpected(lease.error());
  sqlite3* db = lease->conn->db.get();
  {
    sql::Stmt q(db, "PRAGMA quick_check");
    sql::Stmt::Use u(q);
    const int rc = u.step();
    report.integrity = rc == SQLITE_ROW ? u.text(0) : std::string(sqlite3_errmsg(db));
  }
  // Rows -> files.
  sql::Stmt rows(db, "SELECT level, row, col, bytes FROM tiles WHERE dataset = ?1 AND state = 1");
  for (const auto& info : infos) {
    sql::Stmt::Use u(rows);
    u.bind(1, info.id);
    int rc = 0;
    while ((rc = u.step()) == SQLITE_ROW) {
      const TileKey k{static_cast<std::int32_t>(u.i64(0)), u.i64(1), u.i64(2)};
      const std::string rel = info.folder + "/" + tileRelativePath(k, info.spec.extension);
      std::error_code ec;
      const auto size = fs::file_size(impl_->options.root / rel, ec);
      if (ec)
        report.rowsWithoutFiles.push_back(rel);
      else if (static_cast<std::int64_t>(size) != u.i64(3))
        report.sizeMismatches.push_back(rel);
    }
    if (rc != SQLITE_DONE) return std::unexpected(sql::errorFrom(db, rc, "verifying"));
  }
  // Temp files beside the index (a damage marker being written).
  {
    std::error_code ec;
    for (auto it = fs::directory_iterator(impl_->options.root, ec);
         !ec && it != fs::directory_iterator();
         it.increment(ec)) {
      const std::string name = it->path().filename().string();
      if (!fileio::isTempName(name)) continue;
      if (fileio::tempOwnerAlive(name))
        ++report.tempFilesInUse;
      else
        report.strayTempFiles.push_back(name);
    }
  }
  // Files -> rows.
  for (const auto& info : infos) {
    const fs::path dir = impl_->options.root / info.folder;
    std::error_code ec;
    for (auto it = fs::recursive_directory_iterator(dir, ec);
         !ec && it != fs::recursive_directory_iterator();
         it.increment(ec)) {
      if (!it->is_regular_file(ec)) continue;
      const std::string name = it->path().filename().string();
      const std::string rel = fs::relative(it->path(), dir, ec).generic_string();
      if (fileio::isTempName(name)) {
        // A running writer's (a tile on its way, a replaced tile kept until its commit) is fine.
        if (fileio::tempOwnerAlive(name))
          ++report.tempFilesInUse;
        else
          report.strayTempFiles.push_back(info.folder + "/" + rel);
        continue;
      }
      if (name == kDescriptorName) continue;
      std::string ext;
      const auto key = parseTileRelativePath(rel, &ext);
      if (!key || ext != info.spec.extension) {
        report.filesWithoutRows.push_back(info.folder + "/" + rel);
        continue;
      }
      sql::Stmt::Use u(lease->conn->lookup);
      bindKey(u, info.id, *key);
      if (u.step() != SQLITE_ROW || u.i64(0) != kStatePresent)
        report.filesWithoutRows.push_back(info.folder + "/" + rel);
    }
  }
  return report;
}

std::expected<std::int64_t, CacheError> TileCache::rebuild() {
  if (impl_->options.readOnly)
    return std::unexpected(CacheError{CacheErrc::ReadOnly, "the cache is read-only"});
  std::int64_t indexed = 0;
  auto r = impl_->submit([&](Impl& im) -> Result {
    sqlite3* db = im.writeDb.get();
    im.allRowsChanged = true;
    if (sql::exec(db, "DELETE FROM tiles; DELETE FROM datasets; DELETE FROM usage;") != SQLITE_OK) {
      return std::unexpected(sql::errorFrom(db, sqlite3_errcode(db), "clearing index"));
    }
    const fs::path& root = im.options.root;
    removeDeadTempFiles(root);
    std::error_code ec;
    for (const auto& server : fs::directory_iterator(root, ec)) {
      if (!server.is_directory(ec)) continue;
      for (const auto& dsDir : fs::directory_iterator(server.path(), ec)) {
        const fs::path descPath = dsDir.path() / kDescriptorName;
        const auto text = fileio::readFile(descPath, std::nullopt);
        if (!text) continue;
        const auto spec = parseDatasetSpec(
            std::string_view(reinterpret_cast<const char*>(text->data()), text->size()));
        if (!spec) continue;
        auto grid = TileGrid::create(spec->grid);
        if (!grid) continue;
        const std::string folder = fs::relative(dsDir.path(), root, ec).generic_string();
        auto inserted = insertDataset(db, *spec, folder);
        if (!inserted) return std::unexpected(inserted.error());
        const DatasetId id = *inserted;
        const DatasetEntry entry{DatasetInfo{id, *spec, folder}, *grid, dsDir.path()};
        for (auto it = fs::recursive_directory_iterator(dsDir.path(), ec);
             !ec && it != fs::recursive_directory_iterator();
             it.increment(ec)) {
          if (!it->is_regular_file(ec)) continue;
          const std::string name = it->path().filename().string();
          if (fileio::isTempName(name)) {
            // An interrupted write is never a valid tile; a running writer's is left to it.
            if (!fileio::tempOwnerAlive(name)) fs::remove(it->path(), ec);
            ec.clear();
            continue;
          }
          std::string ext;
          const auto key = parseTileRelativePath(
              fs::relative(it->path(), dsDir.path(), ec).generic_string(), &ext);
          if (!key || ext != spec->extension || !grid->isValid(*key)) continue;
          const auto size = it->file_size(ec);
          if (ec) continue;
          const auto mtime = fs::last_write_time(it->path(), ec);
          TileMeta m;
          m.contentType = spec->mimeType;
          m.fetchedAt = std::chrono::duration_cast<std::chrono::milliseconds>(
                            std::chrono::file_clock::to_sys(mtime).time_since_epoch())
                            .count();
          if (auto w = im.writeRow(
                  entry, *key, kStatePresent, static_cast<std::int64_t>(size), m, std::nullopt);
              !w) {
            return w;
          }
          ++indexed;
        }
        ec.clear();
      }
    }
    return im.loadDatasets(db); // inside the writer thread, which owns this connection
  });
  {
    std::lock_guard lock(impl_->dirsMutex);
    impl_->knownDirs.clear();
  }
  if (!r) {
    if (auto lease = impl_->acquireReader()) (void)impl_->loadDatasets(lease->conn->db.get());
    return std::unexpected(r.error());
  }
  return indexed;
}

std::expected<std::int64_t, CacheError> TileCache::prune(const PruneOptions& options) {
  const UnixMillis cutoff = options.olderThan ? unixMillisNow() - options.olderThan->count()
                                              : std::numeric_limits<UnixMillis>::max();
  std::expected<std::int64_t, CacheError> removed = 0;
  auto r = impl_->submit(
      [&](Impl& im) -> Result {
        removed = im.deleteSelected(
            "SELECT t.dataset, t.level, t.row, t.col, d.folder, d.extension, t.bytes FROM tiles t "
            "JOIN datasets d ON d.id = t.dataset WHERE t.fetched_at < ?1 "
            "AND (?2 IS NULL OR d.name = ?2) AND (?3 = 1 OR d.pinned = 0)",
            [&](sql::Stmt::Use& u) {
              u.bind(1, cutoff);
              if (options.datasetName)
                u.bind(2, std::string_view(*options.datasetName));
              else
                u.bindNull(2);
              u.bind(3, std::int64_t{options.includePinned ? 1 : 0});
            },
            std::numeric_limits<std::int64_t>::max());
        return {};
      },
      {},
      true);
  if (!r) return std::unexpected(r.error());
  return removed;
}

std::expected<std::int64_t, CacheError> TileCache::evictToLimit() {
  std::expected<std::int64_t, CacheError> evicted = 0;
  auto r = impl_->submit(
      [&](Impl& im) -> Result {
        evicted = im.evictLocked();
        return {};
      },
      {},
      true);
  if (!r) return std::unexpected(r.error());
  return evicted;
}

StoreStatus TileCache::storeStatus() const noexcept {
  StoreStatus s;
  s.writable = !impl_->full.load(std::memory_order_acquire);
  s.refused = impl_->refusedPuts.load(std::memory_order_relaxed);
  s.dropped = impl_->droppedPuts.load(std::memory_order_relaxed);
  return s;
}

std::optional<DiskSpace> TileCache::diskSpace() const {
  return impl_->diskSpace();
}

std::size_t TileCache::tempFilesRemovedAtOpen() const noexcept {
  return impl_->tempFilesRemoved;
}

void TileCache::flush() {
  if (impl_->options.readOnly) return;
  // An operation that writes the pending last-access times, then wait for the queue to drain.
  (void)impl_->submit([](Impl& im) -> Result {
    std::unordered_map<TouchKey, UnixMillis, TouchKeyHash> batch;
    {
      std::lock_guard lock(im.queueMutex);
      batch.swap(im.touches);
    }
    for (const auto& [tk, when] : batch) {
      sql::Stmt::Use u(im.touchTile);
      bindKey(u, tk.dataset, tk.key);
      u.bind(5, when);
      u.step();
    }
    return {};
  });
  impl_->waitIdle();
}

} // namespace tellus
