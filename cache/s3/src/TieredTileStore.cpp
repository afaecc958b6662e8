// The local tier in front of the shared store (TieredTileStore.hpp).

#include <tellus/cache/TileFile.hpp>
#include <tellus/cache_s3/TieredTileStore.hpp>

#include <sys/stat.h>

namespace tellus {

namespace {

using Result = ITileStore::Result;

class TieredStagedTile final : public StagedTile {
public:
  TieredStagedTile(std::shared_ptr<StagedTile> local, std::shared_ptr<StagedTile> shared)
      : local_(std::move(local)), shared_(std::move(shared)) {}

  Result install() override {
    if (auto r = shared_->install(); !r) return r; // what the other instances see comes first
    return local_->install();
  }
  void finish(bool committed) override {
    local_->finish(committed);
    shared_->finish(committed);
  }
  std::optional<StoredTile> open(std::int64_t size) const override { return local_->open(size); }

private:
  std::shared_ptr<StagedTile> local_;
  std::shared_ptr<StagedTile> shared_;
};

class TieredRemoval final : public StagedRemoval {
public:
  TieredRemoval(std::shared_ptr<StagedRemoval> local, std::shared_ptr<StagedRemoval> shared)
      : local_(std::move(local)), shared_(std::move(shared)) {}

  Result hide() override {
    if (auto r = shared_->hide(); !r) return r;
    return local_->hide();
  }
  void finish(bool committed) override {
    local_->finish(committed);
    shared_->finish(committed);
  }

private:
  std::shared_ptr<StagedRemoval> local_;
  std::shared_ptr<StagedRemoval> shared_;
};

/** Whether the local copy was written before its index row (whose fetched-at the reader passes):
 * the tile was refreshed by another instance since, through the shared store; the local copy is
 * replaced from there. Costs one fstat on the slow path only (rows a reader remembers skip it). */
bool olderThanRow(const StoredTile& t, const TileLocation& at) {
  if (at.notBefore <= 0) return false;
  struct stat st {};
  if (::fstat(t.file->fd(), &st) != 0) return true;
  const auto ms =
      static_cast<std::int64_t>(st.st_mtim.tv_sec) * 1000 + st.st_mtim.tv_nsec / 1000000;
  return ms < at.notBefore;
}

class TieredTileStore final : public ITileStore {
public:
  TieredTileStore(std::shared_ptr<ITileStore> local, std::shared_ptr<ITileStore> shared)
      : local_(std::move(local)), shared_(std::move(shared)) {}

  Result prepareDataset(std::string_view folder) override {
    if (auto r = shared_->prepareDataset(folder); !r) return r;
    return local_->prepareDataset(folder);
  }
  std::optional<std::string> readDescriptor(std::string_view folder) override {
    return shared_->readDescriptor(folder);
  }
  Result writeDescriptor(std::string_view folder, std::string_view text) override {
    if (auto r = shared_->writeDescriptor(folder, text); !r) return r;
    return local_->writeDescriptor(folder, text);
  }

  std::optional<StoredTile> open(const TileLocation& at, std::int64_t size) override {
    if (auto t = local_->open(at, size); t && !olderThanRow(*t, at)) return t;
    auto remote = shared_->open(at, size);
    if (!remote) return std::nullopt;
    // Copied into the local tier as it is read; a tier that cannot take it (full) is skipped.
    if (const auto bytes = remote->file->readAll()) {
      if (auto staged = local_->stage(at, *bytes)) {
        const bool ok = (*staged)->install().has_value();
        (*staged)->finish(ok);
        if (ok) {
          if (auto t = local_->open(at, size)) return t;
        }
      }
    }
    return remote;
  }
  std::optional<TileStat> stat(const TileLocation& at) override {
    if (auto s = local_->stat(at)) return s;
    return shared_->stat(at);
  }
  std::expected<std::optional<TileStat>, CacheError> statOrError(const TileLocation& at) override {
    if (auto s = local_->stat(at)) return s;
    return shared_->statOrError(at);
  }
  std::expected<std::shared_ptr<StagedTile>, CacheError>
  stage(const TileLocation& at, std::span<const std::byte> bytes) override {
    auto local = local_->stage(at, bytes);
    if (!local) return std::unexpected(local.error());
    auto shared = shared_->stage(at, bytes);
    if (!shared) return std::unexpected(shared.error());
    return std::make_shared<TieredStagedTile>(std::move(*local), std::move(*shared));
  }
  std::shared_ptr<StagedRemoval> stageRemoval(const TileLocation& at) override {
    return std::make_shared<TieredRemoval>(local_->stageRemoval(at), shared_->stageRemoval(at));
  }
  void remove(const TileLocation& at) override {
    shared_->remove(at);
    local_->remove(at);
  }

  Result lockChanges(std::chrono::milliseconds timeout) override {
    return local_->lockChanges(timeout);
  }
  void unlockChanges() override { local_->unlockChanges(); }
  std::optional<DiskSpace> freeSpace() const override { return local_->freeSpace(); }

  std::size_t removeDeadTemps(std::string_view folder) override {
    return local_->removeDeadTemps(folder);
  }
  std::vector<std::string> datasetFolders() override { return shared_->datasetFolders(); }
  void scan(std::string_view folder, const EntryVisitor& visit) override {
    shared_->scan(folder, visit);
  }
  void removeEntry(std::string_view folder, std::string_view path) override {
    shared_->removeEntry(folder, path);
    local_->removeEntry(folder, path);
  }

private:
  std::shared_ptr<ITileStore> local_;
  std::shared_ptr<ITileStore> shared_;
};

} // namespace

std::unique_ptr<ITileStore> makeTieredTileStore(std::shared_ptr<ITileStore> local,
                                                std::shared_ptr<ITileStore> shared) {
  return std::make_unique<TieredTileStore>(std::move(local), std::move(shared));
}

} // namespace tellus
