// The bounded local tier's own costs (issue 27, `cache.s3.local_tier_limit`, TieredTileStore.hpp):
// the start's scan of a tree of N tile files (and the memory its record takes), a local hit
// through the tiered store with and without the record (over all N tiles in a scattered order,
// and over 1,000), the clean stop that saves the record's order and the scan that reads it, and
// an eviction of half the tree. The shared store is one that holds nothing:
// none of these reaches it.
//
// Usage: tellus_bench_local_tier WORK_DIR [FILES]   (WORK_DIR is created and removed)

#include <tellus/cache/TileFile.hpp>
#include <tellus/cache/TilePath.hpp>
#include <tellus/cache_s3/TieredTileStore.hpp>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

using namespace tellus;
namespace fs = std::filesystem;
using Steady = std::chrono::steady_clock;

namespace {

/** A shared store with nothing in it. */
class EmptyStore final : public ITileStore {
public:
  Result prepareDataset(std::string_view) override { return {}; }
  std::optional<std::string> readDescriptor(std::string_view) override { return std::nullopt; }
  Result writeDescriptor(std::string_view, std::string_view) override { return {}; }
  std::optional<StoredTile> open(const TileLocation&, std::int64_t) override {
    return std::nullopt;
  }
  std::optional<TileStat> stat(const TileLocation&) override { return std::nullopt; }
  std::expected<std::shared_ptr<StagedTile>, CacheError>
  stage(const TileLocation&, std::span<const std::byte>) override {
    return std::unexpected(CacheError{CacheErrc::Io, "nothing is stored here"});
  }
  std::shared_ptr<StagedRemoval> stageRemoval(const TileLocation&) override { return nullptr; }
  void remove(const TileLocation&) override {}
  Result lockChanges(std::chrono::milliseconds) override { return {}; }
  void unlockChanges() override {}
  std::optional<DiskSpace> freeSpace() const override { return std::nullopt; }
  std::size_t removeDeadTemps(std::string_view) override { return 0; }
  std::vector<std::string> datasetFolders() override { return {}; }
  void scan(std::string_view, const EntryVisitor&) override {}
  void removeEntry(std::string_view, std::string_view) override {}
};

double msSince(Steady::time_point start) {
  return std::chrono::duration<double, std::milli>(Steady::now() - start).count();
}

long residentKiB() {
  std::ifstream statm("/proc/self/statm");
  long size = 0;
  long resident = 0;
  statm >> size >> resident;
  return resident * (::sysconf(_SC_PAGESIZE) / 1024);
}

constexpr std::string_view kFolder = "srv/ds-00000001";
constexpr int kColumns = 1000;
constexpr std::int64_t kTileBytes = 100;

TileLocation at(int i) {
  return TileLocation{kFolder, "jpg", TileKey{12, i / kColumns, i % kColumns}};
}

/** Microseconds per local hit over the first `span` tiles, in a scattered order. */
double hitMicros(ITileStore& store, int span) {
  constexpr int kReads = 200000;
  const auto start = Steady::now();
  for (int r = 0; r < kReads; ++r) {
    if (!store.open(at(static_cast<int>((static_cast<long long>(r) * 7919) % span)), kTileBytes))
      std::abort();
  }
  return msSince(start) * 1000.0 / kReads;
}

} // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s WORK_DIR [FILES]\n", argv[0]);
    return 2;
  }
  const fs::path root = argv[1];
  const int files = argc > 2 ? std::atoi(argv[2]) : 100000;
  fs::remove_all(root);
  const char bytes[kTileBytes] = {};
  auto start = Steady::now();
  for (int i = 0; i < files; ++i) {
    const fs::path p = root / kFolder / tileRelativePath(at(i).key, "jpg");
    if (i % kColumns == 0) fs::create_directories(p.parent_path());
    const int fd = ::open(p.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0 || ::write(fd, bytes, sizeof bytes) != static_cast<ssize_t>(sizeof bytes))
      std::abort();
    ::close(fd);
  }
  std::printf("tree: %d files of %lld bytes written in %.0f ms\n",
              files,
              static_cast<long long>(kTileBytes),
              msSince(start));

  std::shared_ptr<ITileStore> local =
      std::move(*openFileTileStore(FileTileStoreOptions{root, false, false}));
  auto shared = std::make_shared<EmptyStore>();
  {
    const long before = residentKiB();
    start = Steady::now();
    auto bounded = makeTieredTileStore(local, shared, LocalTierOptions{1ULL << 40, 0.9, root, {}});
    const double opened = msSince(start);
    bounded->settle();
    const double scanned = msSince(start);
    const auto s = bounded->localTier();
    std::printf("scan: %llu files, %llu bytes recorded; open %.2f ms, scan done after %.0f ms; "
                "resident +%ld KiB (%.0f bytes a file)\n",
                static_cast<unsigned long long>(s.files),
                static_cast<unsigned long long>(s.bytes),
                opened,
                scanned,
                residentKiB() - before,
                static_cast<double>(residentKiB() - before) * 1024.0 / files);
    auto plain = makeTieredTileStore(local, shared);
    for (const int span : {files, std::min(files, 1000)}) {
      const double a = hitMicros(*plain, span);
      const double b = hitMicros(*bounded, span);
      const double c = hitMicros(*plain, span);
      const double d = hitMicros(*bounded, span);
      std::printf("local hit over %d tiles: %.2f, %.2f us without the record; %.2f, %.2f us with "
                  "it\n",
                  span,
                  a,
                  c,
                  b,
                  d);
    }
    // A clean stop writes the record's order of use; the next start's scan reads it.
    plain.reset();
    start = Steady::now();
    bounded.reset();
    const double stopped = msSince(start);
    std::error_code ec;
    const auto orderBytes = fs::file_size(root / ".local-tier-order", ec);
    start = Steady::now();
    auto again = makeTieredTileStore(local, shared, LocalTierOptions{1ULL << 40, 0.9, root, {}});
    again->settle();
    std::printf("clean stop: the order of use written in %.0f ms (%llu bytes); the next scan, "
                "reading it, done after %.0f ms\n",
                stopped,
                static_cast<unsigned long long>(ec ? 0 : orderBytes),
                msSince(start));
  }
  {
    start = Steady::now();
    const auto half = static_cast<std::uint64_t>(files) * kTileBytes / 2;
    auto bounded = makeTieredTileStore(local, shared, LocalTierOptions{half, 0.9, root, {}});
    bounded->settle();
    const auto s = bounded->localTier();
    std::printf("scan and eviction to 90 %% of half: %llu files (%llu bytes) removed, %llu bytes "
                "left, in %.0f ms\n",
                static_cast<unsigned long long>(s.evictions),
                static_cast<unsigned long long>(s.evictedBytes),
                static_cast<unsigned long long>(s.bytes),
                msSince(start));
  }
  fs::remove_all(root);
  return 0;
}
