// Hits from the shared S3 store against hits from the local tier (issue 27): the latency of one
// ITileStore::open of a cached tile (p50, p99) and the CPU it costs, this process's and the S3
// server's (the pids in s3.env, from /proc). The store alone, below the cache's remembered open
// files: what a miss of the instance's RowCache costs on each tier. Rounds alternate the two.
//
// Usage: tellus_bench_s3_hits S3_ENV_FILE WORK_DIR [TILES] [READS_PER_ROUND] [ROUNDS]
// (bench/s3/run.sh starts the server and calls it.)

#include <tellus/cache/TileFile.hpp>
#include <tellus/cache_s3/S3TileStore.hpp>
#include <tellus/cache_s3/TieredTileStore.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

using namespace tellus;
using Steady = std::chrono::steady_clock;

namespace {

std::map<std::string, std::string> readEnv(const std::string& file) {
  std::map<std::string, std::string> env;
  std::ifstream in(file);
  for (std::string line; std::getline(in, line);) {
    const auto eq = line.find('=');
    if (eq == std::string::npos) continue;
    std::string v = line.substr(eq + 1);
    if (v.size() >= 2 && v.front() == '"') v = v.substr(1, v.size() - 2);
    env[line.substr(0, eq)] = v;
  }
  return env;
}

double processCpuSeconds() {
  timespec ts{};
  ::clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

/** utime + stime of the server's processes, in seconds. */
double serverCpuSeconds(const std::vector<int>& pids) {
  const double tick = static_cast<double>(::sysconf(_SC_CLK_TCK));
  double total = 0;
  for (const int pid : pids) {
    std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
    std::string all((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const auto close = all.rfind(')');
    if (close == std::string::npos) continue;
    std::istringstream rest(all.substr(close + 2));
    std::string field;
    std::vector<std::string> f;
    while (rest >> field)
      f.push_back(field);
    if (f.size() > 12) total += (std::stod(f[11]) + std::stod(f[12])) / tick; // utime, stime
  }
  return total;
}

struct Figures {
  std::vector<double> micros;
  double clientCpu = 0;
  double serverCpu = 0;
  std::size_t reads = 0;
};

double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0
                   : v[std::min(v.size() - 1,
                                static_cast<std::size_t>(p * static_cast<double>(v.size())))];
}

} // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s S3_ENV_FILE WORK_DIR [TILES] [READS] [ROUNDS]\n", argv[0]);
    return 2;
  }
  auto env = readEnv(argv[1]);
  const std::filesystem::path work = argv[2];
  const int tiles = argc > 3 ? std::atoi(argv[3]) : 200;
  const int reads = argc > 4 ? std::atoi(argv[4]) : 2000;
  const int rounds = argc > 5 ? std::atoi(argv[5]) : 3;
  std::vector<int> pids;
  std::istringstream ps(env["S3_PIDS"]);
  for (int p; ps >> p;)
    pids.push_back(p);

  S3TileStoreOptions o;
  o.endpoint = env["S3_ENDPOINT"];
  o.region = env["S3_REGION"];
  o.location = S3Url{env["S3_BUCKET"], "bench-" + std::to_string(::getpid())};
  o.credentials = S3Credentials{env["AWS_ACCESS_KEY_ID"], env["AWS_SECRET_ACCESS_KEY"]};
  o.localFolder = work / "s3-local";
  auto s3 = openS3TileStore(o);
  if (!s3) {
    std::fprintf(stderr, "%s\n", s3.error().message.c_str());
    return 1;
  }
  std::shared_ptr<ITileStore> shared = std::move(*s3);
  std::shared_ptr<ITileStore> local =
      std::move(*openFileTileStore(FileTileStoreOptions{work / "tier", false, false}));
  auto tiered = makeTieredTileStore(local, shared);
  (void)tiered->prepareDataset("bench/bm");

  // A JPEG-sized tile (20 KiB) each, stored through the tiers (both hold every tile).
  std::vector<std::byte> body(20 * 1024);
  std::mt19937 rng(7);
  for (auto& b : body)
    b = static_cast<std::byte>(rng());
  std::vector<TileLocation> at;
  for (int i = 0; i < tiles; ++i)
    at.push_back(TileLocation{"bench/bm", "jpg", TileKey{8, i / 64, i % 64}});
  for (const auto& a : at) {
    body[0] = static_cast<std::byte>(a.key.col);
    auto staged = tiered->stage(a, body);
    if (!staged || !(*staged)->install()) {
      std::fprintf(stderr, "cannot store the fixture\n");
      return 1;
    }
    (*staged)->finish(true);
  }
  const auto size = static_cast<std::int64_t>(body.size());

  std::map<std::string, Figures> figures;
  auto run = [&](const std::string& name, ITileStore& store) {
    auto& f = figures[name];
    std::uniform_int_distribution<int> pick(0, tiles - 1);
    const double c0 = processCpuSeconds();
    const double s0 = serverCpuSeconds(pids);
    for (int i = 0; i < reads; ++i) {
      const auto t0 = Steady::now();
      auto t = store.open(at[static_cast<std::size_t>(pick(rng))], size);
      const auto t1 = Steady::now();
      if (!t) {
        std::fprintf(stderr, "%s: a stored tile was not found\n", name.c_str());
        std::exit(1);
      }
      f.micros.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
    }
    f.clientCpu += processCpuSeconds() - c0;
    f.serverCpu += serverCpuSeconds(pids) - s0;
    f.reads += static_cast<std::size_t>(reads);
  };
  for (int r = 0; r < rounds; ++r) {
    run("shared store (S3 GET)", *shared);
    run("local tier (file tree)", *local);
  }
  std::printf("| tier | reads | p50 | p99 | client CPU per read | S3 server CPU per read |\n");
  std::printf("|---|---|---|---|---|---|\n");
  for (const auto& [name, f] : figures) {
    const double n = static_cast<double>(f.reads);
    std::printf("| %s | %zu | %.1f us | %.1f us | %.1f us | %.1f us |\n",
                name.c_str(),
                f.reads,
                percentile(f.micros, 0.5),
                percentile(f.micros, 0.99),
                f.clientCpu / n * 1e6,
                f.serverCpu / n * 1e6);
  }
  for (const auto& a : at)
    tiered->remove(a);
  return 0;
}
