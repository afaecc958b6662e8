#include "MemoryTileStore.hpp"

#include <tellus/cache/TilePath.hpp>

#include <cerrno>
#include <sys/mman.h>
#include <unistd.h>

namespace tellus::test {

namespace {

using State = MemoryTileStore::State;
using Version = MemoryTileStore::Version;
using Result = std::expected<void, CacheError>;

constexpr std::uint64_t kInodes = 1u << 30;

std::string pathOf(const TileLocation& at) {
  return std::string(at.folder) + "/" + tileRelativePath(at.key, at.extension);
}

/** The bytes as a TileFile on a memfd (a descriptor like a file's: pread, sendfile). */
std::optional<StoredTile> openVersion(const Version& v, std::int64_t size) {
  if (static_cast<std::int64_t>(v.bytes->size()) != size) return std::nullopt;
  const int fd = ::memfd_create("tellus-tile", MFD_CLOEXEC);
  if (fd < 0) return std::nullopt;
  const auto* p = reinterpret_cast<const char*>(v.bytes->data());
  std::size_t left = v.bytes->size();
  while (left > 0) {
    const ssize_t n = ::write(fd, p, left);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      ::close(fd);
      return std::nullopt;
    }
    p += n;
    left -= static_cast<std::size_t>(n);
  }
  return StoredTile{std::make_shared<const TileFile>(fd, size), v.version};
}

class MemoryStagedTile final : public StagedTile {
public:
  MemoryStagedTile(std::shared_ptr<State> state, std::string path, Version version)
      : state_(std::move(state)), path_(std::move(path)), version_(std::move(version)) {}

  Result install() override {
    previous_ = state_->swap(path_, version_);
    installed_ = true;
    return {};
  }
  void finish(bool committed) override {
    if (installed_ && !committed) state_->swap(path_, previous_); // the old tile, or none
    installed_ = false;
    previous_.reset();
  }
  std::optional<StoredTile> open(std::int64_t size) const override {
    return openVersion(version_, size);
  }

private:
  std::shared_ptr<State> state_;
  std::string path_;
  Version version_;
  std::optional<Version> previous_;
  bool installed_ = false;
};

class MemoryRemoval final : public StagedRemoval {
public:
  MemoryRemoval(std::shared_ptr<State> state, std::string path)
      : state_(std::move(state)), path_(std::move(path)) {}

  Result hide() override {
    aside_ = state_->swap(path_, std::nullopt);
    return {};
  }
  void finish(bool committed) override {
    if (aside_ && !committed) state_->swap(path_, aside_);
    aside_.reset();
  }

private:
  std::shared_ptr<State> state_;
  std::string path_;
  std::optional<Version> aside_;
};

} // namespace

std::optional<Version> State::swap(const std::string& path, std::optional<Version> v) {
  std::lock_guard lock(mutex);
  std::optional<Version> old;
  if (auto it = tiles.find(path); it != tiles.end()) {
    old = std::move(it->second);
    used -= old->bytes->size();
    tiles.erase(it);
  }
  if (v) {
    used += v->bytes->size();
    tiles.emplace(path, std::move(*v));
  }
  return old;
}

MemoryTileStore::MemoryTileStore(std::shared_ptr<const Clock> clock)
    : state_(std::make_shared<State>()) {
  state_->clock = clock ? std::move(clock) : systemClock();
}

void MemoryTileStore::setCapacity(std::optional<std::uint64_t> bytes) {
  std::lock_guard lock(state_->mutex);
  state_->capacity = bytes;
}

std::uint64_t MemoryTileStore::usedBytes() const {
  std::lock_guard lock(state_->mutex);
  return state_->used;
}

// ---------------------------------------------------------------------------------- datasets

MemoryTileStore::Result MemoryTileStore::prepareDataset(std::string_view) {
  return {};
}

std::optional<std::string> MemoryTileStore::readDescriptor(std::string_view folder) {
  std::lock_guard lock(state_->mutex);
  const auto it = state_->descriptors.find(std::string(folder));
  if (it == state_->descriptors.end()) return std::nullopt;
  return it->second;
}

MemoryTileStore::Result MemoryTileStore::writeDescriptor(std::string_view folder,
                                                         std::string_view text) {
  std::lock_guard lock(state_->mutex);
  state_->descriptors[std::string(folder)] = std::string(text);
  return {};
}

// ---------------------------------------------------------------------------------- tiles

std::optional<StoredTile> MemoryTileStore::open(const TileLocation& at, std::int64_t size) {
  Version v;
  {
    std::lock_guard lock(state_->mutex);
    const auto it = state_->tiles.find(pathOf(at));
    if (it == state_->tiles.end()) return std::nullopt;
    v = it->second;
  }
  return openVersion(v, size);
}

std::optional<TileStat> MemoryTileStore::stat(const TileLocation& at) {
  std::lock_guard lock(state_->mutex);
  const auto it = state_->tiles.find(pathOf(at));
  if (it == state_->tiles.end()) return std::nullopt;
  return TileStat{static_cast<std::int64_t>(it->second.bytes->size()), it->second.version};
}

std::expected<std::shared_ptr<StagedTile>, CacheError>
MemoryTileStore::stage(const TileLocation& at, std::span<const std::byte> bytes) {
  std::string path = pathOf(at);
  Version v;
  {
    std::lock_guard lock(state_->mutex);
    if (state_->capacity && state_->used + bytes.size() > *state_->capacity) {
      return std::unexpected(CacheError{
          CacheErrc::DiskFull, "cannot write " + path + ": No space left on device (memory)"});
    }
    v.version = TileVersion{0, ++state_->serial};
  }
  v.bytes = std::make_shared<const std::vector<std::byte>>(bytes.begin(), bytes.end());
  v.modified = state_->clock->now();
  return std::make_shared<MemoryStagedTile>(state_, std::move(path), std::move(v));
}

std::shared_ptr<StagedRemoval> MemoryTileStore::stageRemoval(const TileLocation& at) {
  return std::make_shared<MemoryRemoval>(state_, pathOf(at));
}

void MemoryTileStore::remove(const TileLocation& at) {
  state_->swap(pathOf(at), std::nullopt);
}

// ---------------------------------------------------------------------------------- lock, space

MemoryTileStore::Result MemoryTileStore::lockChanges(std::chrono::milliseconds timeout) {
  std::unique_lock lock(changesMutex_);
  if (changesFree_.wait_for(lock, timeout, [this] { return !changesHeld_; })) {
    changesHeld_ = true;
    return {};
  }
  return std::unexpected(CacheError{CacheErrc::Io, "the memory store's changes lock is held"});
}

void MemoryTileStore::unlockChanges() {
  {
    std::lock_guard lock(changesMutex_);
    changesHeld_ = false;
  }
  changesFree_.notify_one();
}

std::optional<DiskSpace> MemoryTileStore::freeSpace() const {
  std::lock_guard lock(state_->mutex);
  if (!state_->capacity) return DiskSpace{UINT64_MAX / 2, kInodes};
  const std::uint64_t cap = *state_->capacity;
  return DiskSpace{cap > state_->used ? cap - state_->used : 0, kInodes};
}

// ---------------------------------------------------------------------------------- maintenance

std::vector<std::string> MemoryTileStore::datasetFolders() {
  std::lock_guard lock(state_->mutex);
  std::vector<std::string> out;
  for (const auto& [folder, text] : state_->descriptors)
    out.push_back(folder);
  return out;
}

void MemoryTileStore::scan(std::string_view folder, const EntryVisitor& visit) {
  if (folder.empty()) return; // nothing beside the index
  std::vector<StoreEntry> entries;
  {
    std::lock_guard lock(state_->mutex);
    const std::string prefix = std::string(folder) + "/";
    if (state_->descriptors.contains(std::string(folder)))
      entries.push_back(StoreEntry{StoreEntry::Kind::Descriptor, "dataset.txt", 0, 0, false});
    for (auto it = state_->tiles.lower_bound(prefix);
         it != state_->tiles.end() && it->first.starts_with(prefix);
         ++it) {
      entries.push_back(StoreEntry{StoreEntry::Kind::Tile,
                                   it->first.substr(prefix.size()),
                                   static_cast<std::int64_t>(it->second.bytes->size()),
                                   it->second.modified,
                                   false});
    }
  }
  for (const auto& e : entries)
    visit(e);
}

void MemoryTileStore::removeEntry(std::string_view folder, std::string_view path) {
  if (path == "dataset.txt") {
    std::lock_guard lock(state_->mutex);
    state_->descriptors.erase(std::string(folder));
    return;
  }
  state_->swap(std::string(folder) + "/" + std::string(path), std::nullopt);
}

} // namespace tellus::test
