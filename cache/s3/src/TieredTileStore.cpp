// The local tier in front of the shared store (TieredTileStore.hpp).

#include <tellus/cache/TileFile.hpp>
#include <tellus/cache/TilePath.hpp>
#include <tellus/cache_s3/TieredTileStore.hpp>

#include <algorithm>
#include <condition_variable>
#include <fstream>
#include <functional>
#include <list>
#include <mutex>
#include <stop_token>
#include <string>
#include <sys/stat.h>
#include <thread>
#include <unistd.h>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace tellus {

namespace {

using Result = ITileStore::Result;

/** A tile of the local tier in the record: its dataset folder and extension (interned), its key. */
struct TierId {
  std::uint32_t folder = 0;
  std::uint32_t extension = 0;
  TileKey key;
  bool operator==(const TierId&) const = default;
};

/** splitmix64's finalizer over each field in turn: neighbouring tiles (rows, columns counted up)
 * spread over the buckets (a boost-style combine of TileKeyHash left chains of 30 and more). */
struct TierIdHash {
  static std::uint64_t mix(std::uint64_t x) noexcept {
    x ^= x >> 30;
    x *= 0xBF58476D1CE4E5B9ULL;
    x ^= x >> 27;
    x *= 0x94D049BB133111EBULL;
    return x ^ (x >> 31);
  }
  std::size_t operator()(const TierId& id) const noexcept {
    std::uint64_t h = mix((static_cast<std::uint64_t>(id.folder) << 32) ^
                          (static_cast<std::uint64_t>(id.extension) << 8) ^
                          static_cast<std::uint64_t>(static_cast<std::uint32_t>(id.key.level)));
    h = mix(h ^ static_cast<std::uint64_t>(id.key.row));
    return static_cast<std::size_t>(mix(h ^ static_cast<std::uint64_t>(id.key.col)));
  }
};

struct NameHash {
  using is_transparent = void;
  std::size_t operator()(std::string_view s) const noexcept {
    return std::hash<std::string_view>{}(s);
  }
};

/** The bound of the local tier (TieredTileStore.hpp): the record of its tile files in order of last
 * use (front: the most recent), and the thread that scans the tree at start and evicts. */
class LocalTier {
public:
  LocalTier(std::shared_ptr<ITileStore> local, const LocalTierOptions& o)
      : local_(std::move(local)), root_(o.root), limit_(o.limitBytes),
        lowWater_(static_cast<std::uint64_t>(static_cast<double>(o.limitBytes) *
                                             std::clamp(o.lowWater, 0.0, 1.0))),
        beforeScan_(o.beforeScan), thread_([this](std::stop_token stop) { run(stop); }) {}
  LocalTier(const LocalTier&) = delete;
  LocalTier& operator=(const LocalTier&) = delete;
  ~LocalTier() {
    thread_.request_stop();
    thread_.join();
    saveOrder();
  }

  /** `at` was used (a hit, a copy, a write) and is `bytes` long. */
  void use(const TileLocation& at, std::int64_t bytes) {
    const auto size = static_cast<std::uint64_t>(std::max<std::int64_t>(bytes, 0));
    bool over = false;
    {
      std::lock_guard lock(mutex_);
      const TierId id = idOf(at);
      touch(id);
      if (auto it = where_.find(id); it != where_.end()) {
        lru_.splice(lru_.begin(), lru_, it->second);
        bytes_ = bytes_ - it->second->bytes + size;
        it->second->bytes = size;
      } else {
        lru_.push_front(Entry{id, size});
        where_.emplace(id, lru_.begin());
        bytes_ += size;
      }
      over = bytes_ > limit_;
    }
    if (over) wake_.notify_one();
  }

  /** `at`'s local file is gone. */
  void forget(const TileLocation& at) {
    std::lock_guard lock(mutex_);
    const TierId id = idOf(at);
    touch(id);
    if (auto it = where_.find(id); it != where_.end()) {
      bytes_ -= it->second->bytes;
      lru_.erase(it->second);
      where_.erase(it);
    }
  }

  /** `at`'s local file is about to change (a write, a copy, a removal; refresh or forget follow).
   * While the start's scan runs, what it finds of that file is left to them. */
  void writing(const TileLocation& at) {
    std::lock_guard lock(mutex_);
    touch(idOf(at));
  }

  /** After a change of `at`'s local file that may or may not have happened (a write or a removal
   * finished, committed or rolled back): recorded as the file is now. */
  void refresh(const TileLocation& at) {
    if (const auto s = local_->stat(at))
      use(at, s->size);
    else
      forget(at);
  }

  LocalTierStats stats() const {
    std::lock_guard lock(mutex_);
    return LocalTierStats{bytes_, lru_.size(), evictions_, evictedBytes_, scanned_};
  }

  void settle() {
    std::unique_lock lock(mutex_);
    idle_.wait(lock, [&] { return scanned_ && !evicting_ && bytes_ <= limit_; });
  }

private:
  struct Entry {
    TierId id;
    std::uint64_t bytes = 0;
  };
  /** A tile file the start's scan found. */
  struct Found {
    TierId id;
    std::uint64_t bytes = 0;
    std::int64_t modifiedNs = 0;
  };
  using Names = std::unordered_map<std::string, std::uint32_t, NameHash, std::equal_to<>>;

  static std::uint32_t intern(Names& ids, std::vector<std::string>& names, std::string_view name) {
    if (auto it = ids.find(name); it != ids.end()) return it->second;
    const auto id = static_cast<std::uint32_t>(names.size());
    names.emplace_back(name);
    ids.emplace(std::string(name), id);
    return id;
  }
  /** Under the lock. Before the start's scan is recorded, `id` is one whose file this process
   * uses or changes: the scan's record of that file (maybe taken before the change, or of a file
   * installed whose use is not recorded yet) would count it twice or at the back of the order. */
  void touch(const TierId& id) {
    if (!scanned_) touched_.insert(id);
  }
  /** Under the lock. */
  TierId idOf(const TileLocation& at) {
    return TierId{intern(folderIds_, folders_, at.folder),
                  intern(extensionIds_, extensions_, at.extension),
                  at.key};
  }

  /** Where a clean stop writes the record's order (a name starting with '.': never a tile). */
  static constexpr std::string_view kOrderFile = ".local-tier-order";
  static constexpr std::string_view kOrderHeader = "tellus local tier order 1";

  /** At a clean stop, after a whole scan: the record's tiles, most recently used first, one
   * `<server>/<dataset>\t<level>/<row>/<row>_<col>.<ext>` a line, written to a temp file and
   * renamed (a crash leaves none or the whole). Best effort: a failure writes nothing. */
  void saveOrder() noexcept {
    if (root_.empty() || !scanComplete_) return;
    namespace fs = std::filesystem;
    std::error_code ec;
    const fs::path file = root_ / kOrderFile;
    const fs::path temp = root_ / (std::string(kOrderFile) + ".tmp-" + std::to_string(::getpid()));
    try {
      std::ofstream out(temp, std::ios::binary | std::ios::trunc);
      out << kOrderHeader << '\n';
      for (const Entry& e : lru_)
        out << folders_[e.id.folder] << '\t'
            << tileRelativePath(e.id.key, extensions_[e.id.extension]) << '\n';
      out.close();
      if (!out) throw std::ios_base::failure("write");
      fs::rename(temp, file, ec);
    } catch (...) {
      ec = std::make_error_code(std::errc::io_error);
    }
    if (ec) fs::remove(temp, ec);
  }

  /** The order a clean stop saved (saveOrder), by tile: 0 the most recently used. The file is
   * removed once read, so that a later crash does not bring back an old order; a file that is
   * not one gives nothing. */
  std::unordered_map<TierId, std::size_t, TierIdHash> readOrder() {
    std::unordered_map<TierId, std::size_t, TierIdHash> rank;
    const std::filesystem::path file = root_ / kOrderFile;
    std::ifstream in(file, std::ios::binary);
    if (!in) return rank;
    std::string line, extension;
    const bool ours = std::getline(in, line) && line == kOrderHeader;
    while (ours && std::getline(in, line)) {
      const auto tab = line.find('\t');
      if (tab == std::string::npos) continue;
      const auto key = parseTileRelativePath(std::string_view(line).substr(tab + 1), &extension);
      if (!key) continue;
      std::lock_guard lock(mutex_);
      const TierId id{intern(folderIds_, folders_, std::string_view(line).substr(0, tab)),
                      intern(extensionIds_, extensions_, extension),
                      *key};
      rank.try_emplace(id, rank.size());
    }
    in.close();
    std::error_code ec;
    std::filesystem::remove(file, ec);
    return rank;
  }

  void run(std::stop_token stop) {
    if (beforeScan_) beforeScan_();
    if (!root_.empty()) scanComplete_ = scan(stop);
    {
      std::lock_guard lock(mutex_);
      scanned_ = true;
      touched_ = {};
    }
    idle_.notify_all();
    std::unique_lock lock(mutex_);
    while (wake_.wait(lock, stop, [&] { return bytes_ > limit_; })) {
      evicting_ = true;
      // One victim at a time, its file unlinked outside the lock: reads and writes go on.
      while (bytes_ > lowWater_ && !lru_.empty() && !stop.stop_requested()) {
        const Entry victim = lru_.back();
        where_.erase(victim.id);
        lru_.pop_back();
        bytes_ -= victim.bytes;
        ++evictions_;
        evictedBytes_ += victim.bytes;
        const std::string folder = folders_[victim.id.folder];
        const std::string extension = extensions_[victim.id.extension];
        lock.unlock();
        local_->remove(TileLocation{folder, extension, victim.id.key});
        lock.lock();
      }
      evicting_ = false;
      idle_.notify_all();
    }
  }

  /** The tiles already in the tree: every `<root>/<server>/<dataset>/<level>/<row>/<row>_<col>.ext`
   * (names starting with '.', the temp files and folders, skipped), behind whatever was used since
   * the start: in the order the last clean stop saved (readOrder), then the others oldest
   * modified last. False when stopped before the end. */
  bool scan(const std::stop_token& stop) {
    namespace fs = std::filesystem;
    std::vector<Found> found;
    std::error_code ec;
    auto hidden = [](const fs::path& p) { return p.filename().native().starts_with('.'); };
    for (auto server = fs::directory_iterator(root_, ec); !ec && server != fs::directory_iterator();
         server.increment(ec)) {
      std::error_code e1;
      if (hidden(server->path()) || !server->is_directory(e1)) continue;
      for (auto ds = fs::directory_iterator(server->path(), e1);
           !e1 && ds != fs::directory_iterator();
           ds.increment(e1)) {
        std::error_code e2;
        if (hidden(ds->path()) || !ds->is_directory(e2)) continue;
        scanDataset(ds->path(),
                    server->path().filename().native() + "/" + ds->path().filename().native(),
                    stop,
                    found);
        if (stop.stop_requested()) return false;
      }
    }
    const auto rank = readOrder();
    const auto rankOf = [&](const Found& f) {
      const auto it = rank.find(f.id);
      return it == rank.end() ? rank.size() : it->second;
    };
    std::sort(found.begin(), found.end(), [&](const Found& a, const Found& b) {
      const std::size_t ra = rankOf(a), rb = rankOf(b);
      return ra != rb ? ra < rb : a.modifiedNs > b.modifiedNs;
    });
    constexpr std::size_t kBatch = 4096; // entries recorded per hold of the lock
    for (std::size_t i = 0; i < found.size() && !stop.stop_requested(); i += kBatch) {
      std::lock_guard lock(mutex_);
      for (std::size_t j = i; j < std::min(found.size(), i + kBatch); ++j) {
        // Used or changed since the start: what that recorded (or will) counts.
        if (where_.contains(found[j].id) || touched_.contains(found[j].id)) continue;
        lru_.push_back(Entry{found[j].id, found[j].bytes});
        where_.emplace(found[j].id, std::prev(lru_.end()));
        bytes_ += found[j].bytes;
      }
    }
    return !stop.stop_requested();
  }

  void scanDataset(const std::filesystem::path& dir,
                   const std::string& folder,
                   const std::stop_token& stop,
                   std::vector<Found>& found) {
    namespace fs = std::filesystem;
    std::uint32_t folderId = 0;
    {
      std::lock_guard lock(mutex_);
      folderId = intern(folderIds_, folders_, folder);
    }
    std::string lastExtension;
    std::uint32_t lastExtensionId = 0;
    std::string extension;
    const std::size_t prefix = dir.native().size() + 1;
    std::error_code ec;
    for (auto it = fs::recursive_directory_iterator(dir, ec);
         !ec && it != fs::recursive_directory_iterator();
         it.increment(ec)) {
      if (stop.stop_requested()) return;
      const std::string& path = it->path().native();
      if (it->path().filename().native().starts_with('.')) { // temps, `.tmp`
        it.disable_recursion_pending();
        continue;
      }
      std::error_code e;
      if (!it->is_regular_file(e) || path.size() <= prefix) continue;
      const auto key = parseTileRelativePath(std::string_view(path).substr(prefix), &extension);
      if (!key) continue;
      struct stat st {};
      if (::stat(path.c_str(), &st) != 0) continue; // gone meanwhile
      if (extension != lastExtension || found.empty()) {
        std::lock_guard lock(mutex_);
        lastExtensionId = intern(extensionIds_, extensions_, extension);
        lastExtension = extension;
      }
      found.push_back(
          Found{TierId{folderId, lastExtensionId, *key},
                static_cast<std::uint64_t>(st.st_size),
                static_cast<std::int64_t>(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec});
    }
  }

  const std::shared_ptr<ITileStore> local_;
  const std::filesystem::path root_;
  const std::uint64_t limit_;
  const std::uint64_t lowWater_;

  mutable std::mutex mutex_;
  std::condition_variable_any wake_; // the thread: over the limit, or stop
  std::condition_variable idle_;     // settle(): scanned, not evicting
  std::list<Entry> lru_;             // front: the most recently used
  std::unordered_map<TierId, std::list<Entry>::iterator, TierIdHash> where_;
  std::unordered_set<TierId, TierIdHash> touched_; // touch(): until the scan is recorded
  Names folderIds_;
  Names extensionIds_;
  std::vector<std::string> folders_;
  std::vector<std::string> extensions_;
  std::uint64_t bytes_ = 0;
  std::uint64_t evictions_ = 0;
  std::uint64_t evictedBytes_ = 0;
  bool scanned_ = false;
  bool evicting_ = false;
  bool scanComplete_ = false; // the thread's, read after it is joined

  const std::function<void()> beforeScan_;
  std::jthread thread_; // last: started once everything above is there
};

/** A location that outlives the call it came with (staged changes finish later). */
struct OwnedLocation {
  explicit OwnedLocation(const TileLocation& at)
      : folder(at.folder), extension(at.extension), key(at.key) {}
  std::string folder;
  std::string extension;
  TileKey key;
  TileLocation view() const { return TileLocation{folder, extension, key}; }
};

class TieredStagedTile final : public StagedTile {
public:
  TieredStagedTile(std::shared_ptr<StagedTile> local,
                   std::shared_ptr<StagedTile> shared,
                   std::shared_ptr<LocalTier> tier,
                   const TileLocation& at)
      : local_(std::move(local)), shared_(std::move(shared)), tier_(std::move(tier)), at_(at) {}

  Result install() override {
    if (auto r = shared_->install(); !r) return r; // what the other instances see comes first
    return local_->install();
  }
  void finish(bool committed) override {
    local_->finish(committed);
    shared_->finish(committed);
    if (tier_) tier_->refresh(at_.view());
  }
  std::optional<StoredTile> open(std::int64_t size) const override {
    if (auto t = local_->open(size)) return t;
    return shared_->open(size); // the local copy evicted meanwhile
  }

private:
  std::shared_ptr<StagedTile> local_;
  std::shared_ptr<StagedTile> shared_;
  std::shared_ptr<LocalTier> tier_;
  OwnedLocation at_;
};

class TieredRemoval final : public StagedRemoval {
public:
  TieredRemoval(std::shared_ptr<StagedRemoval> local,
                std::shared_ptr<StagedRemoval> shared,
                std::shared_ptr<LocalTier> tier,
                const TileLocation& at)
      : local_(std::move(local)), shared_(std::move(shared)), tier_(std::move(tier)), at_(at) {}

  Result hide() override {
    if (auto r = shared_->hide(); !r) return r;
    return local_->hide();
  }
  void finish(bool committed) override {
    local_->finish(committed);
    shared_->finish(committed);
    if (tier_) tier_->refresh(at_.view());
  }

private:
  std::shared_ptr<StagedRemoval> local_;
  std::shared_ptr<StagedRemoval> shared_;
  std::shared_ptr<LocalTier> tier_;
  OwnedLocation at_;
};

/** Whether the local copy is of another version of the tile than the index row the reader found
 * (whose fetched-at it passes): the tile was refreshed by another instance since, through the
 * shared store, and the copy is replaced from there. A copy's mtime is its version's fetched-at
 * (set when it is written, TileLocation::fetchedAt), so only equality counts: the writers' clocks
 * need not agree (mtimeNamesVersion). Costs one fstat on the slow path only (rows a reader
 * remembers skip it). */
bool otherVersion(const StoredTile& t, const TileLocation& at) {
  if (at.fetchedAt <= 0) return false;
  struct stat st {};
  if (::fstat(t.file->fd(), &st) != 0) return true;
  return !mtimeNamesVersion(st.st_mtim.tv_sec, st.st_mtim.tv_nsec, at.fetchedAt);
}

class TieredStore final : public TieredTileStore {
public:
  TieredStore(std::shared_ptr<ITileStore> local,
              std::shared_ptr<ITileStore> shared,
              const LocalTierOptions& tier)
      : local_(std::move(local)), shared_(std::move(shared)),
        tier_(tier.limitBytes > 0 ? std::make_shared<LocalTier>(local_, tier) : nullptr) {}

  LocalTierStats localTier() const override {
    return tier_ ? tier_->stats() : LocalTierStats{0, 0, 0, 0, true};
  }
  void settle() override {
    if (tier_) tier_->settle();
  }

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
    if (auto t = local_->open(at, size); t && !otherVersion(*t, at)) {
      if (tier_) tier_->use(at, size);
      return t;
    }
    // Not an old copy under the row's headers (its ETag): the shared store's or none.
    auto remote = shared_->open(at, size);
    if (!remote) return std::nullopt;
    // Copied into the local tier as it is read; a tier that cannot take it (full) is skipped.
    if (const auto bytes = remote->file->readAll()) {
      if (tier_) tier_->writing(at);
      if (auto staged = local_->stage(at, *bytes)) {
        const bool ok = (*staged)->install().has_value();
        (*staged)->finish(ok);
        if (ok) {
          if (tier_) tier_->use(at, static_cast<std::int64_t>(bytes->size()));
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
    if (tier_) tier_->writing(at);
    auto local = local_->stage(at, bytes);
    if (!local) return std::unexpected(local.error());
    auto shared = shared_->stage(at, bytes);
    if (!shared) {
      (*local)->finish(false); // its temp file goes
      return std::unexpected(shared.error());
    }
    return std::make_shared<TieredStagedTile>(std::move(*local), std::move(*shared), tier_, at);
  }
  std::expected<std::vector<std::shared_ptr<StagedTile>>, CacheError>
  stageMany(std::span<const TileToStage> tiles) override {
    if (tier_) {
      for (const TileToStage& t : tiles)
        tier_->writing(t.at);
    }
    auto local = local_->stageMany(tiles);
    if (!local) return std::unexpected(local.error());
    auto shared = shared_->stageMany(tiles);
    if (!shared) {
      for (const auto& t : *local)
        t->finish(false);
      return std::unexpected(shared.error());
    }
    std::vector<std::shared_ptr<StagedTile>> both;
    both.reserve(tiles.size());
    for (std::size_t i = 0; i < tiles.size(); ++i)
      both.push_back(std::make_shared<TieredStagedTile>(
          std::move((*local)[i]), std::move((*shared)[i]), tier_, tiles[i].at));
    return both;
  }
  std::shared_ptr<StagedRemoval> stageRemoval(const TileLocation& at) override {
    if (tier_) tier_->writing(at);
    return std::make_shared<TieredRemoval>(
        local_->stageRemoval(at), shared_->stageRemoval(at), tier_, at);
  }
  void remove(const TileLocation& at) override {
    if (tier_) tier_->writing(at);
    shared_->remove(at);
    local_->remove(at);
    if (tier_) tier_->forget(at);
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
    std::string extension;
    if (tier_) {
      if (const auto key = parseTileRelativePath(path, &extension))
        tier_->forget(TileLocation{folder, extension, *key});
    }
  }

private:
  std::shared_ptr<ITileStore> local_;
  std::shared_ptr<ITileStore> shared_;
  std::shared_ptr<LocalTier> tier_; // null: unbounded
};

} // namespace

std::unique_ptr<TieredTileStore> makeTieredTileStore(std::shared_ptr<ITileStore> local,
                                                     std::shared_ptr<ITileStore> shared,
                                                     LocalTierOptions tier) {
  return std::make_unique<TieredStore>(std::move(local), std::move(shared), tier);
}

} // namespace tellus
