// The tile store as a World Wind file tree under the cache root (TileStore.hpp, openFileTileStore).

#include "FileIo.hpp"

#include <tellus/cache/TilePath.hpp>
#include <tellus/cache/TileStore.hpp>

#include <algorithm>
#include <cerrno>
#include <fcntl.h>
#include <mutex>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <thread>
#include <unistd.h>
#include <unordered_set>

namespace tellus {

namespace fs = std::filesystem;

namespace {

using Result = std::expected<void, CacheError>;

constexpr const char* kDescriptorName = "dataset.txt";
// Each dataset's temp files (tiles being written, tiles being replaced) live in `<dataset>/.tmp`:
// the one folder per dataset that open() looks into for temp files of writers that are gone.
constexpr const char* kTempDirName = ".tmp";

TileVersion versionOf(const struct stat& st) {
  return TileVersion{static_cast<std::uint64_t>(st.st_dev), static_cast<std::uint64_t>(st.st_ino)};
}

/** Opens a file and checks it has `size` bytes. */
std::optional<StoredTile> openFile(const fs::path& path, std::int64_t size) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return std::nullopt;
  struct stat st {};
  if (::fstat(fd, &st) != 0 || st.st_size != size) {
    ::close(fd);
    return std::nullopt;
  }
  return StoredTile{std::make_shared<const TileFile>(fd, size), versionOf(st)};
}

/** A tile's new file going into place (a put): the temp file, and the tile it replaces kept as a
 * hard link in the dataset's `.tmp` until the put's row is committed, so that a commit that fails
 * (a full disk) puts the old tile back instead of losing it. Writer thread, under the files lock.
 */
class TilePlacement final : public StagedTile {
public:
  TilePlacement(fs::path temp, fs::path target, fs::path backup)
      : temp_(std::move(temp)), target_(std::move(target)), backup_(std::move(backup)) {}

  const fs::path& temp() const { return temp_; }
  const fs::path& target() const { return target_; }

  Result install() override {
    if (::link(target_.c_str(), backup_.c_str()) == 0) {
      hasBackup_ = true;
    } else if (fileio::isNoSpace(errno)) {
      // No room to keep the old tile (a link takes an inode on tmpfs): refused, the tile stays.
      return std::unexpected(
          fileio::errnoError(errno, "cannot keep the tile it replaces", target_));
    }
    // ENOENT: a new tile. A file system without hard links: replaced without a way back.
    if (::rename(temp_.c_str(), target_.c_str()) != 0) {
      const int err = errno;
      if (hasBackup_) ::unlink(backup_.c_str());
      hasBackup_ = false;
      return std::unexpected(fileio::errnoError(err, "cannot rename into", target_));
    }
    renamed_ = true;
    return {};
  }

  void finish(bool committed) override {
    if (!renamed_) {
      ::unlink(temp_.c_str());
    } else if (committed) {
      if (hasBackup_) ::unlink(backup_.c_str());
    } else if (hasBackup_) {
      ::rename(backup_.c_str(), target_.c_str()); // the old tile, which its row still describes
    } else {
      ::unlink(target_.c_str()); // a new tile without a row
    }
    renamed_ = hasBackup_ = false;
  }

  /** Written, not yet committed: the bytes are in the temp file, or already in place. */
  std::optional<StoredTile> open(std::int64_t size) const override {
    if (auto t = openFile(temp_, size)) return t;
    return openFile(target_, size);
  }

private:
  fs::path temp_;   // the new bytes, fsynced
  fs::path target_; // where the tile lives
  fs::path backup_; // the old tile while the row is not committed
  bool renamed_ = false;
  bool hasBackup_ = false;
};

/** A tile's file going away with its row (erase, an absent marker): moved aside into the dataset's
 * `.tmp` in the writer's transaction, removed after the commit, put back if the commit fails.
 * Writer thread, under the files lock. */
class TileRemoval final : public StagedRemoval {
public:
  TileRemoval(fs::path target, fs::path aside)
      : target_(std::move(target)), aside_(std::move(aside)) {}

  Result hide() override {
    if (aside_.empty()) return {};
    if (::rename(target_.c_str(), aside_.c_str()) == 0) {
      moved_ = true;
    } else if (errno != ENOENT) {
      return std::unexpected(fileio::errnoError(errno, "cannot remove", target_));
    }
    return {};
  }

  void finish(bool committed) override {
    if (aside_.empty()) {
      if (committed) ::unlink(target_.c_str());
    } else if (moved_) {
      if (committed)
        ::unlink(aside_.c_str());
      else
        ::rename(aside_.c_str(), target_.c_str());
    }
    moved_ = false;
  }

private:
  fs::path target_;
  fs::path aside_; // empty: no `.tmp` could be made (a full disk): unlinked after the commit
  bool moved_ = false;
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

class FileTileStore final : public ITileStore {
public:
  explicit FileTileStore(const FileTileStoreOptions& options) : options_(options) {}
  ~FileTileStore() override {
    if (rootFd_ >= 0) ::close(rootFd_);
  }
  FileTileStore(const FileTileStore&) = delete;
  FileTileStore& operator=(const FileTileStore&) = delete;

  Result open() {
    fileio::ignoreFileSizeSignal();
    if (options_.readOnly) return {};
    std::error_code ec;
    fs::create_directories(options_.root, ec);
    if (ec) {
      return std::unexpected(
          CacheError{CacheErrc::Io,
                     "cannot create cache root " + options_.root.string() + ": " + ec.message()});
    }
    rootFd_ = ::open(options_.root.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (rootFd_ < 0)
      return std::unexpected(fileio::errnoError(errno, "cannot open cache root", options_.root));
    return {};
  }

  // --- datasets --------------------------------------------------------------------------------
  Result prepareDataset(std::string_view folder) override { return ensureDir(dirOf(folder)); }

  std::optional<std::string> readDescriptor(std::string_view folder) override {
    const auto bytes = fileio::readFile(dirOf(folder) / kDescriptorName, std::nullopt);
    if (!bytes) return std::nullopt;
    return std::string(reinterpret_cast<const char*>(bytes->data()), bytes->size());
  }

  Result writeDescriptor(std::string_view folder, std::string_view text) override {
    return fileio::writeFileAtomic(dirOf(folder) / kDescriptorName,
                                   std::as_bytes(std::span(text.data(), text.size())),
                                   options_.fsyncTiles);
  }

  // --- tiles -----------------------------------------------------------------------------------
  std::optional<StoredTile> open(const TileLocation& at, std::int64_t size) override {
    return openFile(pathOf(at), size);
  }

  std::optional<TileStat> stat(const TileLocation& at) override {
    struct stat st {};
    if (::stat(pathOf(at).c_str(), &st) != 0) return std::nullopt;
    return TileStat{st.st_size, versionOf(st)};
  }

  std::expected<std::shared_ptr<StagedTile>, CacheError>
  stage(const TileLocation& at, std::span<const std::byte> bytes) override {
    auto placement = placementFor(at);
    if (!placement) return std::unexpected(placement.error());
    if (auto r = fileio::writeTemp(
            (*placement)->temp(), bytes, options_.fsyncTiles, (*placement)->target(), at.fetchedAt);
        !r)
      return std::unexpected(r.error());
    return *placement;
  }

  std::expected<std::vector<std::shared_ptr<StagedTile>>, CacheError>
  stageMany(std::span<const TileToStage> tiles) override {
    std::vector<std::shared_ptr<TilePlacement>> placements;
    std::vector<fileio::TempWrite> writes;
    placements.reserve(tiles.size());
    writes.reserve(tiles.size());
    for (const TileToStage& t : tiles) {
      auto placement = placementFor(t.at);
      if (!placement) return std::unexpected(placement.error());
      writes.push_back(
          fileio::TempWrite{(*placement)->temp(), t.bytes, (*placement)->target(), t.at.fetchedAt});
      placements.push_back(std::move(*placement));
    }
    if (auto r = fileio::writeTemps(writes, options_.fsyncTiles); !r)
      return std::unexpected(r.error());
    return std::vector<std::shared_ptr<StagedTile>>(placements.begin(), placements.end());
  }

  std::shared_ptr<StagedRemoval> stageRemoval(const TileLocation& at) override {
    fs::path target = pathOf(at);
    const fs::path tempDir = dirOf(at.folder) / kTempDirName;
    fs::path aside;
    if (ensureDir(tempDir)) aside = tempDir / fileio::tempNameFor(target.filename());
    return std::make_shared<TileRemoval>(std::move(target), std::move(aside));
  }

  void remove(const TileLocation& at) override { ::unlink(pathOf(at).c_str()); }

  // --- the files lock, space ---------------------------------------------------------------------
  /** An flock on the root directory. Waits on another process, so real time (SQLite's busy
   * timeout, which it sits beside, is real time too). */
  Result lockChanges(std::chrono::milliseconds timeout) override {
    if (rootFd_ < 0) return {};
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    auto pause = std::chrono::microseconds(200);
    for (;;) {
      if (::flock(rootFd_, LOCK_EX | LOCK_NB) == 0) {
        locked_ = true;
        return {};
      }
      if (errno == EINTR) continue;
      // A file system without flock: work unlocked, as before the lock existed.
      if (errno != EWOULDBLOCK) return {};
      if (std::chrono::steady_clock::now() >= deadline) {
        return std::unexpected(CacheError{CacheErrc::Io,
                                          "another process has held the cache's files lock (" +
                                              options_.root.string() + ") for more than " +
                                              std::to_string(timeout.count()) + " ms"});
      }
      std::this_thread::sleep_for(pause);
      pause = std::min(pause * 2, std::chrono::microseconds(20000));
    }
  }

  void unlockChanges() override {
    if (locked_) ::flock(rootFd_, LOCK_UN);
    locked_ = false;
  }

  std::optional<DiskSpace> freeSpace() const override {
    struct statvfs v {};
    if (::statvfs(options_.root.c_str(), &v) != 0) return std::nullopt;
    return DiskSpace{static_cast<std::uint64_t>(v.f_bavail) * v.f_frsize,
                     static_cast<std::uint64_t>(v.f_favail)};
  }

  // --- maintenance -------------------------------------------------------------------------------
  std::size_t removeDeadTemps(std::string_view folder) override {
    const fs::path dir = dirOf(folder);
    std::size_t removed = removeDeadTempFiles(dir);
    if (!folder.empty()) removed += removeDeadTempFiles(dir / kTempDirName);
    return removed;
  }

  std::vector<std::string> datasetFolders() override {
    {
      // A maintenance scan follows changes made behind the cache: forget the folders it knew.
      std::lock_guard lock(dirsMutex_);
      knownDirs_.clear();
    }
    std::vector<std::string> out;
    std::error_code ec;
    for (const auto& server : fs::directory_iterator(options_.root, ec)) {
      if (!server.is_directory(ec)) continue;
      for (const auto& dsDir : fs::directory_iterator(server.path(), ec)) {
        if (!fs::exists(dsDir.path() / kDescriptorName, ec)) continue;
        out.push_back(fs::relative(dsDir.path(), options_.root, ec).generic_string());
      }
    }
    return out; // in directory order, as rebuilds have always numbered them
  }

  void scan(std::string_view folder, const EntryVisitor& visit) override {
    if (folder.empty()) return scanRoot(visit);
    const fs::path dir = dirOf(folder);
    std::error_code ec;
    for (auto it = fs::recursive_directory_iterator(dir, ec);
         !ec && it != fs::recursive_directory_iterator();
         it.increment(ec)) {
      if (!it->is_regular_file(ec)) continue;
      const std::string name = it->path().filename().string();
      StoreEntry e;
      e.path = fs::relative(it->path(), dir, ec).generic_string();
      if (fileio::isTempName(name)) {
        e.kind = StoreEntry::Kind::Temp;
        e.tempOwnerAlive = fileio::tempOwnerAlive(name);
      } else if (name == kDescriptorName) {
        e.kind = StoreEntry::Kind::Descriptor;
      } else {
        struct stat st {};
        if (::stat(it->path().c_str(), &st) != 0) continue; // gone meanwhile
        e.size = st.st_size;
        e.modified = fileio::modifiedMillis(st);
      }
      visit(e);
    }
  }

  void removeEntry(std::string_view folder, std::string_view path) override {
    std::error_code ec;
    fs::remove(dirOf(folder) / fs::path(path), ec);
  }

private:
  /** Where a new version of `at` is written before install(), its folders made. */
  std::expected<std::shared_ptr<TilePlacement>, CacheError> placementFor(const TileLocation& at) {
    fs::path target = pathOf(at);
    const fs::path tempDir = dirOf(at.folder) / kTempDirName;
    const std::string tileName = target.filename().string();
    auto placement = std::make_shared<TilePlacement>(tempDir / fileio::tempNameFor(tileName),
                                                     std::move(target),
                                                     tempDir / fileio::tempNameFor(tileName));
    if (auto r = ensureDir(placement->target().parent_path()); !r)
      return std::unexpected(r.error());
    if (auto r = ensureDir(tempDir); !r) return std::unexpected(r.error());
    return placement;
  }
  fs::path dirOf(std::string_view folder) const {
    return folder.empty() ? options_.root : options_.root / fs::path(folder);
  }
  fs::path pathOf(const TileLocation& at) const {
    return dirOf(at.folder) / tileRelativePath(at.key, at.extension);
  }

  /** Temp files beside the index (a damage marker being written): the root's own, temps only. */
  void scanRoot(const EntryVisitor& visit) {
    std::error_code ec;
    for (auto it = fs::directory_iterator(options_.root, ec); !ec && it != fs::directory_iterator();
         it.increment(ec)) {
      const std::string name = it->path().filename().string();
      if (!fileio::isTempName(name)) continue;
      StoreEntry e;
      e.kind = StoreEntry::Kind::Temp;
      e.path = name;
      e.tempOwnerAlive = fileio::tempOwnerAlive(name);
      visit(e);
    }
  }

  Result ensureDir(const fs::path& dir) {
    {
      std::lock_guard lock(dirsMutex_);
      if (knownDirs_.contains(dir.native())) return {};
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
    std::lock_guard lock(dirsMutex_);
    knownDirs_.insert(dir.native());
    return {};
  }

  FileTileStoreOptions options_;
  // The files lock: an flock on the root directory, held by the writer while it changes tile files
  // and their rows together. -1 for a read-only store.
  int rootFd_ = -1;
  bool locked_ = false; // writer thread only
  // Directories known to exist (saves a stat per put).
  std::mutex dirsMutex_;
  std::unordered_set<std::string> knownDirs_;
};

} // namespace

std::expected<std::unique_ptr<ITileStore>, CacheError>
openFileTileStore(const FileTileStoreOptions& options) {
  auto store = std::make_unique<FileTileStore>(options);
  if (auto r = store->open(); !r) return std::unexpected(r.error());
  return store;
}

} // namespace tellus
