#pragma once
/**
 * @file MemoryTileStore.hpp
 * @brief An ITileStore in memory, for tests (with MemoryTileIndex: the cache with no file and no
 * database). Built on the public interface alone.
 *
 * Tiles are immutable byte vectors by path (`<folder>/<level>/<row>/<row>_<col>.<ext>`, as the
 * file tree names them); each installed version gets a new TileVersion. open() hands out a
 * TileFile on a memfd holding the bytes, so a held tile keeps its bytes when it is replaced, and
 * sendfile(2) works as with a file. Staged tiles and removals keep what they replace until
 * finish(), exactly as the file store does, so rollbacks behave the same. A capacity makes it
 * "full": a stage() that would pass it is refused with DiskFull, as ENOSPC would be. The changes
 * lock is a mutex (one process). Writers leave no temp files.
 */

#include <tellus/cache/Clock.hpp>
#include <tellus/cache/TileStore.hpp>

#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

namespace tellus::test {

class MemoryTileStore final : public ITileStore {
public:
  /** `clock` dates what is installed (a rebuilt row's fetched-at); null: the system clock. */
  explicit MemoryTileStore(std::shared_ptr<const Clock> clock = nullptr);

  /** Room for this many bytes of tiles at most (nullopt: unlimited). */
  void setCapacity(std::optional<std::uint64_t> bytes);
  /** Bytes of the tiles in place. */
  std::uint64_t usedBytes() const;

  Result prepareDataset(std::string_view folder) override;
  std::optional<std::string> readDescriptor(std::string_view folder) override;
  Result writeDescriptor(std::string_view folder, std::string_view text) override;

  std::optional<StoredTile> open(const TileLocation& at, std::int64_t size) override;
  std::optional<TileStat> stat(const TileLocation& at) override;
  std::expected<std::shared_ptr<StagedTile>, CacheError>
  stage(const TileLocation& at, std::span<const std::byte> bytes) override;
  std::shared_ptr<StagedRemoval> stageRemoval(const TileLocation& at) override;
  void remove(const TileLocation& at) override;

  Result lockChanges(std::chrono::milliseconds timeout) override;
  void unlockChanges() override;
  std::optional<DiskSpace> freeSpace() const override;

  std::size_t removeDeadTemps(std::string_view) override { return 0; }
  std::vector<std::string> datasetFolders() override;
  void scan(std::string_view folder, const EntryVisitor& visit) override;
  void removeEntry(std::string_view folder, std::string_view path) override;

  /** Shared with staged tiles and removals, which may outlive a call. */
  struct Version {
    std::shared_ptr<const std::vector<std::byte>> bytes;
    TileVersion version;
    UnixMillis modified = 0;
  };
  struct State {
    mutable std::mutex mutex;
    std::map<std::string, Version> tiles; // by path
    std::map<std::string, std::string> descriptors;
    std::uint64_t used = 0;
    std::optional<std::uint64_t> capacity;
    std::uint64_t serial = 0;
    std::shared_ptr<const Clock> clock;

    /** Puts a version in place (or takes it out: nullopt) and returns what was there. */
    std::optional<Version> swap(const std::string& path, std::optional<Version> v);
  };

private:
  std::shared_ptr<State> state_;
  // The changes lock as a flag under a mutex, not a std::timed_mutex: GCC 12's TSan does not see
  // try_lock_for (pthread_mutex_clocklock) and reports the unlock as of an unlocked mutex.
  std::mutex changesMutex_;
  std::condition_variable changesFree_;
  bool changesHeld_ = false;
};

} // namespace tellus::test
