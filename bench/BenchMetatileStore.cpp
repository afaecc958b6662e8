// Storing a 4x4 metatile's 16 tiles in a real TileCache (SQLite index, files fsynced) on the disk
// WORK_DIR is on (issue 27: the metatile burst waits for the last of its 16 tiles). Side by side in
// one run, alternating, each way on fresh tiles:
//   put x16, 1 thread   16 put() one after another (an fsync and a commit each);
//   put x16, 2 threads  8 each on two threads (tellus serve before putMany: two storing workers);
//   put + putMany(15)   the asked-for tile's put() on one thread, the other 15 in one putMany()
//                       on another (tellus serve now, TileMetaFetch.cpp);
//   put, then putMany(15) the same on one thread, one after the other;
//   putMany(16)         all 16 at once.
// Prints the median and the 90th percentile of the wall time until the last tile is committed,
// and each way's ratio to "put x16, 2 threads".
//
// Usage: tellus_bench_metatile_store WORK_DIR [ROUNDS] [TILE_BYTES]  (WORK_DIR created, removed)

#include <tellus/cache/TileCache.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <string>
#include <thread>
#include <vector>

using namespace tellus;
namespace fs = std::filesystem;
using Steady = std::chrono::steady_clock;

namespace {

struct Way {
  const char* name;
  std::function<void(TileCache&, DatasetId, const std::vector<TileCache::TileBytes>&)> store;
  std::vector<double> ms;
};

void must(const std::expected<void, CacheError>& r) {
  if (!r) {
    std::fprintf(stderr, "store failed: %s\n", r.error().message.c_str());
    std::exit(1);
  }
}

void putRange(TileCache& c,
              DatasetId id,
              const std::vector<TileCache::TileBytes>& t,
              std::size_t from,
              std::size_t to) {
  for (std::size_t i = from; i < to; ++i)
    must(c.put(id, t[i].key, t[i].bytes, {}));
}

double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  const auto i = static_cast<std::size_t>(p * static_cast<double>(v.size() - 1) + 0.5);
  return v[i];
}

} // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s WORK_DIR [ROUNDS] [TILE_BYTES]\n", argv[0]);
    return 2;
  }
  const fs::path work = argv[1];
  const int rounds = argc > 2 ? std::atoi(argv[2]) : 40;
  const std::size_t tileBytes = argc > 3 ? std::strtoul(argv[3], nullptr, 10) : 30000;
  fs::remove_all(work);
  TileCache::Options o;
  o.root = work / "cache";
  o.fsyncTiles = true;
  auto opened = TileCache::open(o);
  if (!opened) {
    std::fprintf(stderr, "cannot open the cache: %s\n", opened.error().message.c_str());
    return 1;
  }
  TileCache& cache = **opened;
  DatasetSpec spec;
  spec.server = "bench";
  spec.name = "metatiles";
  spec.grid = GridSpec{Sector{}, 36.0, 512, 512, 12};
  spec.mimeType = "image/jpeg";
  spec.extension = "jpg";
  const auto id = cache.registerDataset(spec);
  if (!id) return 1;

  std::vector<Way> ways = {
      {"put x16, 1 thread",
       [](TileCache& c, DatasetId d, const auto& t) { putRange(c, d, t, 0, t.size()); },
       {}},
      {"put x16, 2 threads",
       [](TileCache& c, DatasetId d, const auto& t) {
         std::jthread other([&] { putRange(c, d, t, t.size() / 2, t.size()); });
         putRange(c, d, t, 0, t.size() / 2);
       },
       {}},
      {"put + putMany(15)",
       [](TileCache& c, DatasetId d, const auto& t) {
         std::jthread other([&] { must(c.putMany(d, std::span(t).subspan(1), {})); });
         putRange(c, d, t, 0, 1);
       },
       {}},
      {"put, then putMany(15)",
       [](TileCache& c, DatasetId d, const auto& t) {
         putRange(c, d, t, 0, 1);
         must(c.putMany(d, std::span(t).subspan(1), {}));
       },
       {}},
      {"putMany(16)",
       [](TileCache& c, DatasetId d, const auto& t) { must(c.putMany(d, t, {})); },
       {}},
  };
  std::vector<std::byte> bytes(tileBytes);
  for (std::size_t i = 0; i < bytes.size(); ++i)
    bytes[i] = static_cast<std::byte>((i * 131) & 0xFF);
  std::int64_t metatile = 0; // level 8: 1,280 x 640 tiles, 320 x 160 metatiles
  for (int r = 0; r < rounds; ++r) {
    for (Way& w : ways) {
      const std::int64_t row0 = (metatile / 320) * 4, col0 = (metatile % 320) * 4;
      ++metatile;
      std::vector<TileCache::TileBytes> tiles;
      for (std::int64_t dr = 0; dr < 4; ++dr)
        for (std::int64_t dc = 0; dc < 4; ++dc)
          tiles.push_back(TileCache::TileBytes{TileKey{8, row0 + dr, col0 + dc}, bytes});
      const auto start = Steady::now();
      w.store(cache, *id, tiles);
      w.ms.push_back(std::chrono::duration<double, std::milli>(Steady::now() - start).count());
    }
  }
  const double base = percentile(ways[1].ms, 0.5);
  std::printf("%d rounds, 16 tiles of %zu bytes, fsync on, %s\n", rounds, tileBytes, work.c_str());
  std::printf("%-22s %10s %10s %22s\n", "way", "p50 ms", "p90 ms", "p50 / put x16 2 thr");
  for (const Way& w : ways)
    std::printf("%-22s %10.2f %10.2f %22.2f\n",
                w.name,
                percentile(w.ms, 0.5),
                percentile(w.ms, 0.9),
                percentile(w.ms, 0.5) / base);
  opened->reset();
  fs::remove_all(work);
  return 0;
}
