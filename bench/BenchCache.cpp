/**
 * @file BenchCache.cpp
 * @brief Benchmarks of the SQLite-indexed tile cache against the goals of the cache issue:
 *
 * - BM_Lookup: peek() latency (index only) p50/p99/p999 with 1,000,000 tiles indexed, side by side
 *   with a 1,000-tile cache, with a raw SQLite lookup on the same index (the floor) and with a raw
 *   lookup on a memory-mapped connection (a tuning the cache does not apply). Goal: p99 < 50 us
 *   with 1,000,000 tiles. Args: threads, and the cache's read connections (2 threads on 1
 *   connection shows what happens when the reader pool is smaller than the number of readers).
 *   The index is in the OS page cache (it has just been written): these are warm lookups.
 * - BM_Get: get() latency (index + file read) on tiles that have files, 1M vs 1K tiles.
 * - BM_Open: TileCache::open, the first lookup and destruction of a 1,000,000-tile cache vs an
 *   empty one. Goal: the same time (no scan at start-up).
 * - BM_Put: put() throughput vs writing the same files into the same layout with plain
 *   open/write/[fsync]/close/rename. Goal: >= 0.8x. Also reports the absolute extra cost per tile,
 *   which, unlike the ratio, does not depend on how expensive creating a file is on the machine.
 *
 * The machine these run on is noisy (shared 2-vCPU VM), so every comparison is made inside ONE
 * benchmark, interleaving the sides (chunk by chunk or round by round, alternating who goes first),
 * and reported as a ratio. Latencies are measured per call with steady_clock and reported as
 * benchmark counters; each benchmark runs a fixed amount of work (Iterations(1), manual time = wall
 * time of the whole paired measurement). A summary with the ratios against the goals is printed
 * after the run.
 *
 * The 1,000,000-row index is built once per run by one bulk SQLite insert into the real schema
 * (a million put() calls would write a million files); only a subset of its rows have files.
 * Everything is written below $TELLUS_BENCH_DIR (default: the system temp dir) in a fresh
 * directory that is removed at exit (bench/run.sh also removes it when interrupted).
 */

#include <tellus/cache/Dataset.hpp>
#include <tellus/cache/TileCache.hpp>
#include <tellus/cache/TileGrid.hpp>
#include <tellus/cache/TilePath.hpp>

#include <benchmark/benchmark.h>
#include <sqlite3.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cinttypes>
#include <cstdarg>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <filesystem>
#include <latch>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <span>
#include <string>
#include <thread>
#include <unistd.h>
#include <unordered_set>
#include <vector>

namespace {

namespace fs = std::filesystem;
using tellus::CacheLookup;
using tellus::DatasetId;
using tellus::DatasetSpec;
using tellus::TileCache;
using tellus::TileKey;
using Clock = std::chrono::steady_clock;

constexpr std::int64_t kBigRows = 1'000'000;
constexpr std::int64_t kSmallRows = 1'000;
constexpr std::size_t kBigFiles = 2'000;       // rows of the 1M index that also have a file
constexpr std::size_t kTileBytes = 20 * 1024;  // every file the benchmarks write
constexpr std::int32_t kFixtureFirstLevel = 8; // fixture rows are spread over levels 8..11
constexpr std::int32_t kFixtureLevels = 4;
constexpr std::int32_t kPutLevel = 12; // put benchmarks write level 12 only (never a fixture file)

// ------------------------------------------------------------------------------------------------
// Small helpers

std::optional<fs::path> gWorkspace;
std::vector<std::string> gSummary; // printed after the run

void removeWorkspace() {
  if (!gWorkspace) return;
  std::error_code ec;
  fs::remove_all(*gWorkspace, ec);
  gWorkspace.reset();
}

[[noreturn]] void die(const std::string& msg) {
  std::fprintf(stderr, "tellus_bench_cache: %s\n", msg.c_str());
  removeWorkspace();
  std::exit(2);
}

/** The run's private directory (created on first use, removed at exit). */
const fs::path& workspace() {
  if (!gWorkspace) {
    const char* env = std::getenv("TELLUS_BENCH_DIR");
    const fs::path base = env && *env ? fs::path(env) : fs::temp_directory_path();
    std::error_code ec;
    fs::create_directories(base, ec);
    std::string templ = (base / "tellus-bench-XXXXXX").string();
    if (::mkdtemp(templ.data()) == nullptr) die("cannot create a directory in " + base.string());
    gWorkspace = fs::path(templ);
  }
  return *gWorkspace;
}

/** A new, not yet existing path in the workspace. */
fs::path freshDir(const std::string& tag) {
  static std::atomic<int> counter{0};
  return workspace() / (tag + "-" + std::to_string(counter.fetch_add(1)));
}

DatasetSpec benchSpec() {
  DatasetSpec s;
  s.server = "bench.invalid";
  s.name = "bluemarble";
  s.grid.levelZeroDeltaDeg = 36.0; // 5 x 10 tiles at level 0, whole globe
  s.grid.tileWidth = 512;
  s.grid.tileHeight = 512;
  s.grid.numLevels = 13;
  s.mimeType = "image/jpeg";
  s.extension = "jpg";
  return s;
}

const tellus::TileGrid& benchGrid() {
  static const tellus::TileGrid grid = [] {
    auto g = tellus::TileGrid::create(benchSpec().grid);
    if (!g) die("bad benchmark grid: " + g.error());
    return *g;
  }();
  return grid;
}

std::vector<std::byte> randomBytes(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<std::byte> out(n);
  for (std::size_t i = 0; i < n; i += 8) {
    const std::uint64_t v = rng();
    std::memcpy(out.data() + i, &v, std::min<std::size_t>(8, n - i));
  }
  return out;
}

/** 16 different tile payloads of kTileBytes random bytes (incompressible, like JPEG). */
const std::vector<std::vector<std::byte>>& payloads() {
  static const std::vector<std::vector<std::byte>> pool = [] {
    std::vector<std::vector<std::byte>> p;
    for (std::uint64_t i = 0; i < 16; ++i)
      p.push_back(randomBytes(kTileBytes, 0xB17E5 + i));
    return p;
  }();
  return pool;
}

double seconds(Clock::duration d) {
  return std::chrono::duration<double>(d).count();
}
std::int64_t nanos(Clock::duration d) {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(d).count();
}

std::unique_ptr<TileCache> openCache(const fs::path& root,
                                     bool fsyncTiles = false,
                                     int readConnections = 4,
                                     bool writeBehind = false) {
  TileCache::Options o;
  o.root = root;
  o.fsyncTiles = fsyncTiles;
  o.indexWriteBehind = writeBehind;
  o.readConnections = readConnections;
  auto c = TileCache::open(o);
  if (!c) die("cannot open cache " + root.string() + ": " + c.error().message);
  return std::move(*c);
}

/** Latency percentiles (nearest rank) of a sample, in microseconds. */
struct Percentiles {
  double p50 = 0, p90 = 0, p99 = 0, p999 = 0, max = 0, mean = 0;
  std::size_t n = 0;
};

Percentiles percentiles(std::vector<std::int64_t> ns) {
  Percentiles p;
  p.n = ns.size();
  if (ns.empty()) return p;
  std::sort(ns.begin(), ns.end());
  auto at = [&](double q) {
    const auto rank = static_cast<std::size_t>(q * static_cast<double>(ns.size()) + 0.999999);
    return static_cast<double>(ns[std::clamp<std::size_t>(rank, 1, ns.size()) - 1]) / 1000.0;
  };
  p.p50 = at(0.50);
  p.p90 = at(0.90);
  p.p99 = at(0.99);
  p.p999 = at(0.999);
  p.max = static_cast<double>(ns.back()) / 1000.0;
  double sum = 0;
  for (const auto v : ns)
    sum += static_cast<double>(v);
  p.mean = sum / static_cast<double>(ns.size()) / 1000.0;
  return p;
}

[[gnu::format(printf, 1, 2)]] std::string format(const char* fmt, ...) {
  char buf[2048];
  std::va_list args;
  va_start(args, fmt);
  std::vsnprintf(buf, sizeof buf, fmt, args);
  va_end(args);
  return buf;
}

void summary(std::string line) {
  gSummary.push_back(std::move(line));
}

// ------------------------------------------------------------------------------------------------
// Fixtures: caches with N indexed tiles, built once per run

struct Fixture {
  fs::path root;
  DatasetId id = 0;
  std::vector<TileKey> keys;     // every indexed key, in random order
  std::vector<TileKey> fileKeys; // the keys whose file exists (kTileBytes bytes each)
};

void execOrDie(sqlite3* db, const char* sqlText) {
  char* err = nullptr;
  if (sqlite3_exec(db, sqlText, nullptr, nullptr, &err) != SQLITE_OK) {
    const std::string msg = err ? err : sqlite3_errmsg(db);
    sqlite3_free(err);
    die(std::string("SQL failed (") + sqlText + "): " + msg);
  }
}

/**
 * Creates a cache with `rows` indexed tiles spread over levels 8..11, the first `files` of them
 * with real files. The schema and the dataset row come from TileCache itself; the tile rows are
 * bulk-inserted into its `tiles` table (the `usage` counters follow through the schema's triggers).
 */
Fixture
makeFixture(const std::string& tag, std::int64_t rows, std::size_t files, std::uint64_t seed) {
  const auto started = Clock::now();
  Fixture f;
  f.root = freshDir(tag);
  const DatasetSpec spec = benchSpec();
  {
    auto cache = openCache(f.root);
    auto id = cache->registerDataset(spec);
    if (!id) die("registerDataset: " + id.error().message);
    f.id = *id;
  } // closed: the bulk insert below is the only connection

  const auto& grid = benchGrid();
  std::mt19937_64 rng(seed);
  const auto n = static_cast<std::size_t>(rows);
  std::unordered_set<TileKey, tellus::TileKeyHash> seen;
  seen.reserve(n * 2);
  f.keys.reserve(n);
  while (f.keys.size() < n) {
    const std::int32_t level =
        kFixtureFirstLevel + static_cast<std::int32_t>(f.keys.size() % kFixtureLevels);
    const TileKey k{
        level,
        static_cast<std::int64_t>(rng() % static_cast<std::uint64_t>(grid.rowCount(level))),
        static_cast<std::int64_t>(rng() % static_cast<std::uint64_t>(grid.colCount(level)))};
    if (seen.insert(k).second) f.keys.push_back(k);
  }
  seen.clear();
  std::shuffle(f.keys.begin(), f.keys.end(), rng);

  // Files for the first `files` keys.
  files = std::min(files, n);
  f.fileKeys.assign(f.keys.begin(), f.keys.begin() + static_cast<std::ptrdiff_t>(files));
  const fs::path dsDir = f.root / tellus::datasetFolder(spec);
  std::unordered_set<TileKey, tellus::TileKeyHash> withFile(f.fileKeys.begin(), f.fileKeys.end());
  for (std::size_t i = 0; i < f.fileKeys.size(); ++i) {
    const fs::path p = dsDir / tellus::tileRelativePath(f.fileKeys[i], spec.extension);
    std::error_code ec;
    fs::create_directories(p.parent_path(), ec);
    const auto& bytes = payloads()[i % payloads().size()];
    const int fd = ::open(p.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0 || ::write(fd, bytes.data(), bytes.size()) != static_cast<ssize_t>(bytes.size())) {
      die("cannot write fixture file " + p.string());
    }
    ::close(fd);
  }

  // The rows, in primary-key order, in one transaction.
  sqlite3* db = nullptr;
  if (sqlite3_open_v2((f.root / "index.sqlite").c_str(), &db, SQLITE_OPEN_READWRITE, nullptr) !=
      SQLITE_OK) {
    die("cannot open fixture index: " + std::string(sqlite3_errmsg(db)));
  }
  {
    sqlite3_stmt* v = nullptr;
    sqlite3_prepare_v2(db, "PRAGMA user_version", -1, &v, nullptr);
    const bool ok = v && sqlite3_step(v) == SQLITE_ROW && sqlite3_column_int(v, 0) == 2;
    sqlite3_finalize(v);
    if (!ok) die("the cache schema is not version 2: update makeFixture() in bench/BenchCache.cpp");
  }
  // The bulk load does not need crash safety; WAL mode is restored afterwards (it is persistent).
  execOrDie(db,
            "PRAGMA journal_mode = DELETE; PRAGMA synchronous = OFF; PRAGMA cache_size = -262144;");
  execOrDie(db, "BEGIN");
  sqlite3_stmt* ins = nullptr;
  if (sqlite3_prepare_v2(
          db,
          "INSERT INTO tiles(dataset, level, row, col, state, bytes, content_type, etag, "
          "last_modified, expires, fetched_at, last_access, retry_after) "
          "VALUES (?1, ?2, ?3, ?4, 1, ?5, 'image/jpeg', ?6, "
          "'Tue, 01 Apr 2025 12:00:00 GMT', NULL, ?7, ?8, NULL)",
          -1,
          &ins,
          nullptr) != SQLITE_OK) {
    die("cannot prepare the fixture insert (schema changed?): " + std::string(sqlite3_errmsg(db)));
  }
  std::vector<TileKey> sorted = f.keys;
  std::sort(sorted.begin(), sorted.end());
  const tellus::UnixMillis now = tellus::unixMillisNow();
  constexpr std::int64_t kMonthMs = 30LL * 24 * 3600 * 1000;
  for (const TileKey& k : sorted) {
    const std::int64_t bytes = withFile.contains(k)
                                   ? static_cast<std::int64_t>(kTileBytes)
                                   : 12'000 + static_cast<std::int64_t>(rng() % 16'000);
    const std::string etag = format("\"%016" PRIx64 "\"", rng());
    const std::int64_t fetched = now - static_cast<std::int64_t>(rng() % kMonthMs);
    const std::int64_t access =
        fetched + static_cast<std::int64_t>(rng() % static_cast<std::uint64_t>(now - fetched + 1));
    sqlite3_bind_int64(ins, 1, f.id);
    sqlite3_bind_int64(ins, 2, k.level);
    sqlite3_bind_int64(ins, 3, k.row);
    sqlite3_bind_int64(ins, 4, k.col);
    sqlite3_bind_int64(ins, 5, bytes);
    sqlite3_bind_text(ins, 6, etag.data(), static_cast<int>(etag.size()), nullptr); // SQLITE_STATIC
    sqlite3_bind_int64(ins, 7, fetched);
    sqlite3_bind_int64(ins, 8, access);
    if (sqlite3_step(ins) != SQLITE_DONE) die("fixture insert: " + std::string(sqlite3_errmsg(db)));
    sqlite3_reset(ins);
  }
  sqlite3_finalize(ins);
  execOrDie(db, "COMMIT");
  execOrDie(db, "PRAGMA journal_mode = WAL");
  {
    sqlite3_stmt* c = nullptr;
    sqlite3_prepare_v2(db, "SELECT tiles FROM usage WHERE dataset = ?1", -1, &c, nullptr);
    sqlite3_bind_int64(c, 1, f.id);
    const bool ok = c && sqlite3_step(c) == SQLITE_ROW && sqlite3_column_int64(c, 0) == rows;
    sqlite3_finalize(c);
    if (!ok) die("fixture: the usage counter does not match the inserted rows");
  }
  sqlite3_close(db);
  std::error_code ec;
  const auto indexBytes = fs::file_size(f.root / "index.sqlite", ec);
  std::fprintf(stderr,
               "[fixture] %s: %" PRId64
               " indexed tiles (%zu with files), index %.1f MiB, built in %.1f s\n",
               tag.c_str(),
               rows,
               files,
               ec ? 0.0 : static_cast<double>(indexBytes) / 1048576.0,
               seconds(Clock::now() - started));
  return f;
}

const Fixture& bigFixture() {
  static const Fixture f = makeFixture("cache-1M", kBigRows, kBigFiles, 1);
  return f;
}
const Fixture& smallFixture() {
  static const Fixture f =
      makeFixture("cache-1K", kSmallRows, static_cast<std::size_t>(kSmallRows), 2);
  return f;
}
const Fixture& emptyFixture() {
  static const Fixture f = makeFixture("cache-empty", 0, 0, 3);
  return f;
}

/** Runs body(t) on `threads` threads started together; returns the wall time from start to join. */
template <class Body> Clock::duration runThreads(int threads, Body body) {
  std::latch go(1);
  std::vector<std::thread> pool;
  pool.reserve(static_cast<std::size_t>(threads));
  for (int t = 0; t < threads; ++t) {
    pool.emplace_back([&go, &body, t] {
      go.wait();
      body(t);
    });
  }
  const auto t0 = Clock::now();
  go.count_down();
  for (auto& th : pool)
    th.join();
  return Clock::now() - t0;
}

// ------------------------------------------------------------------------------------------------
// 1. Lookup latency: peek() on 1M vs 1K indexed tiles, plus the raw SQLite floor

/** The statement TileCache's read connections prepare, on a connection of our own. */
struct RawLookup {
  sqlite3* db = nullptr;
  sqlite3_stmt* stmt = nullptr;
  /** `pragma`: run once on the connection (e.g. to try a tuning the cache does not apply). */
  explicit RawLookup(const fs::path& index, const char* pragma = nullptr) {
    if (sqlite3_open_v2(index.c_str(), &db, SQLITE_OPEN_READONLY | SQLITE_OPEN_NOMUTEX, nullptr) !=
            SQLITE_OK ||
        (pragma && sqlite3_exec(db, pragma, nullptr, nullptr, nullptr) != SQLITE_OK) ||
        sqlite3_prepare_v3(db,
                           "SELECT state, bytes, content_type, etag, last_modified, expires, "
                           "fetched_at, retry_after FROM tiles "
                           "WHERE dataset = ?1 AND level = ?2 AND row = ?3 AND col = ?4",
                           -1,
                           SQLITE_PREPARE_PERSISTENT,
                           &stmt,
                           nullptr) != SQLITE_OK) {
      die("raw lookup: " + std::string(sqlite3_errmsg(db)));
    }
  }
  ~RawLookup() {
    sqlite3_finalize(stmt);
    sqlite3_close(db);
  }
  RawLookup(const RawLookup&) = delete;
  RawLookup& operator=(const RawLookup&) = delete;
  /** Steps and reads every column without copying; true for a row. */
  bool lookup(DatasetId id, const TileKey& k) {
    sqlite3_bind_int64(stmt, 1, id);
    sqlite3_bind_int64(stmt, 2, k.level);
    sqlite3_bind_int64(stmt, 3, k.row);
    sqlite3_bind_int64(stmt, 4, k.col);
    const bool row = sqlite3_step(stmt) == SQLITE_ROW;
    if (row) {
      std::int64_t sink = 0;
      for (int c = 0; c < 8; ++c)
        sink += sqlite3_column_bytes(stmt, c) + sqlite3_column_int64(stmt, c);
      benchmark::DoNotOptimize(sink);
    }
    sqlite3_reset(stmt);
    return row;
  }
};

void setLatencyCounters(benchmark::State& state, const std::string& suffix, const Percentiles& p) {
  state.counters["p50_us_" + suffix] = p.p50;
  state.counters["p99_us_" + suffix] = p.p99;
  state.counters["p999_us_" + suffix] = p.p999;
}

/** Args: threads, read connections of the caches. */
void BM_Lookup(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(0));
  const int conns = static_cast<int>(state.range(1));
  const Fixture& big = bigFixture();
  const Fixture& small = smallFixture();
  // With fewer pooled connections than threads the pool churns (see RESULTS.md): fewer samples.
  const std::size_t perThread = conns < threads ? 20'000 : 100'000;
  constexpr std::size_t kChunk = 256;
  constexpr std::size_t kWarmup = 5'000;

  auto bigCache = openCache(big.root, false, conns);
  auto smallCache = openCache(small.root, false, conns);
  std::vector<std::vector<std::int64_t>> bigNs(static_cast<std::size_t>(threads)),
      smallNs(static_cast<std::size_t>(threads)), rawNs(static_cast<std::size_t>(threads)),
      mmapNs(static_cast<std::size_t>(threads));
  std::atomic<std::int64_t> wrong{0};

  Clock::duration wall{};
  for (auto _ : state) {
    wall = runThreads(threads, [&](int t) {
      const auto ti = static_cast<std::size_t>(t);
      RawLookup raw(big.root / "index.sqlite");
      // What memory-mapped reads would give (TileCache's read connections do not set mmap_size).
      RawLookup rawMmap(big.root / "index.sqlite", "PRAGMA mmap_size = 1073741824");
      std::mt19937_64 rng(1000 + static_cast<std::uint64_t>(t));
      auto pick = [&rng](const std::vector<TileKey>& keys) { return keys[rng() % keys.size()]; };
      auto peekOne = [&](TileCache& c, const Fixture& f, std::vector<std::int64_t>* out) {
        const TileKey k = pick(f.keys);
        const auto t0 = Clock::now();
        auto r = c.peek(f.id, k);
        const auto t1 = Clock::now();
        if (!r || r->kind != CacheLookup::Kind::Hit) wrong.fetch_add(1);
        if (out) out->push_back(nanos(t1 - t0));
      };
      auto rawOne = [&](RawLookup& conn, std::vector<std::int64_t>* out) {
        const TileKey k = pick(big.keys);
        const auto t0 = Clock::now();
        const bool hit = conn.lookup(big.id, k);
        const auto t1 = Clock::now();
        if (!hit) wrong.fetch_add(1);
        if (out) out->push_back(nanos(t1 - t0));
      };
      for (std::size_t i = 0; i < kWarmup; ++i) {
        peekOne(*bigCache, big, nullptr);
        peekOne(*smallCache, small, nullptr);
        rawOne(raw, nullptr);
        rawOne(rawMmap, nullptr);
      }
      bigNs[ti].reserve(perThread);
      smallNs[ti].reserve(perThread);
      rawNs[ti].reserve(perThread);
      mmapNs[ti].reserve(perThread);
      // Interleaved in chunks so that the four series see the same machine noise.
      for (std::size_t done = 0; done < perThread; done += kChunk) {
        const std::size_t n = std::min(kChunk, perThread - done);
        for (std::size_t i = 0; i < n; ++i)
          peekOne(*bigCache, big, &bigNs[ti]);
        for (std::size_t i = 0; i < n; ++i)
          peekOne(*smallCache, small, &smallNs[ti]);
        for (std::size_t i = 0; i < n; ++i)
          rawOne(raw, &rawNs[ti]);
        for (std::size_t i = 0; i < n; ++i)
          rawOne(rawMmap, &mmapNs[ti]);
      }
    });
    state.SetIterationTime(seconds(wall));
  }
  if (wrong.load() != 0) {
    state.SkipWithError("a lookup of an indexed tile did not return Hit");
    return;
  }
  auto merged = [](std::vector<std::vector<std::int64_t>>& parts) {
    std::vector<std::int64_t> all;
    for (auto& p : parts)
      all.insert(all.end(), p.begin(), p.end());
    return all;
  };
  const Percentiles pb = percentiles(merged(bigNs));
  const Percentiles ps = percentiles(merged(smallNs));
  const Percentiles pr = percentiles(merged(rawNs));
  const Percentiles pm = percentiles(merged(mmapNs));
  setLatencyCounters(state, "1M", pb);
  setLatencyCounters(state, "1K", ps);
  setLatencyCounters(state, "raw1M", pr);
  setLatencyCounters(state, "raw1M_mmap", pm);
  state.counters["p99_ratio_1M_vs_1K"] = pb.p99 / ps.p99;
  state.SetItemsProcessed(static_cast<std::int64_t>(pb.n + ps.n + pr.n + pm.n));
  summary(format("lookup peek(), %d thread(s), %d read conn(s), %zu samples/series:\n"
                 "    1M tiles: p50 %.2f us  p99 %.2f us  p999 %.2f us  max %.0f us\n"
                 "    1K tiles: p50 %.2f us  p99 %.2f us  p999 %.2f us  max %.0f us\n"
                 "    raw SQLite on the 1M index: p50 %.2f us  p99 %.2f us  p999 %.2f us\n"
                 "    raw SQLite + mmap_size:     p50 %.2f us  p99 %.2f us  p999 %.2f us\n"
                 "    p99 1M/1K = %.2fx; peek overhead over raw SQLite at p50 = %.2f us; "
                 "goal p99 < 50 us: %s (%.1f%% of the budget)",
                 threads,
                 conns,
                 pb.n,
                 pb.p50,
                 pb.p99,
                 pb.p999,
                 pb.max,
                 ps.p50,
                 ps.p99,
                 ps.p999,
                 ps.max,
                 pr.p50,
                 pr.p99,
                 pr.p999,
                 pm.p50,
                 pm.p99,
                 pm.p999,
                 pb.p99 / ps.p99,
                 pb.p50 - pr.p50,
                 pb.p99 < 50.0 ? "MET" : "MISSED",
                 pb.p99 / 50.0 * 100.0));
}

// ------------------------------------------------------------------------------------------------
// 2. get() latency (index + file read + last-access bookkeeping) on tiles with files

/** Args: threads. */
void BM_Get(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(0));
  const Fixture& big = bigFixture();
  const Fixture& small = smallFixture();
  constexpr std::size_t kPerThread = 30'000;
  constexpr std::size_t kChunk = 256;
  auto bigCache = openCache(big.root);
  auto smallCache = openCache(small.root);
  std::vector<std::vector<std::int64_t>> bigNs(static_cast<std::size_t>(threads)),
      smallNs(static_cast<std::size_t>(threads));
  std::atomic<std::int64_t> wrong{0};
  Clock::duration wall{};
  for (auto _ : state) {
    wall = runThreads(threads, [&](int t) {
      const auto ti = static_cast<std::size_t>(t);
      std::mt19937_64 rng(2000 + static_cast<std::uint64_t>(t));
      auto getOne = [&](TileCache& c, const Fixture& f, std::vector<std::int64_t>* out) {
        const TileKey k = f.fileKeys[rng() % f.fileKeys.size()];
        const auto t0 = Clock::now();
        auto r = c.get(f.id, k);
        const auto t1 = Clock::now();
        if (!r || r->kind != CacheLookup::Kind::Hit || r->bytes.size() != kTileBytes)
          wrong.fetch_add(1);
        if (out) out->push_back(nanos(t1 - t0));
      };
      for (std::size_t i = 0; i < 2'000; ++i) {
        getOne(*bigCache, big, nullptr);
        getOne(*smallCache, small, nullptr);
      }
      for (std::size_t done = 0; done < kPerThread; done += kChunk) {
        for (std::size_t i = 0; i < kChunk; ++i)
          getOne(*bigCache, big, &bigNs[ti]);
        for (std::size_t i = 0; i < kChunk; ++i)
          getOne(*smallCache, small, &smallNs[ti]);
      }
    });
    state.SetIterationTime(seconds(wall));
  }
  if (wrong.load() != 0) {
    state.SkipWithError("a get() of a tile with a file did not return its bytes");
    return;
  }
  std::vector<std::int64_t> b, s;
  for (auto& p : bigNs)
    b.insert(b.end(), p.begin(), p.end());
  for (auto& p : smallNs)
    s.insert(s.end(), p.begin(), p.end());
  const Percentiles pb = percentiles(std::move(b));
  const Percentiles ps = percentiles(std::move(s));
  setLatencyCounters(state, "1M", pb);
  setLatencyCounters(state, "1K", ps);
  state.counters["p99_ratio_1M_vs_1K"] = pb.p99 / ps.p99;
  state.SetItemsProcessed(static_cast<std::int64_t>(pb.n + ps.n));
  summary(format("get() of a 20 KiB tile (index + file read), %d thread(s), %zu samples/series:\n"
                 "    1M tiles: p50 %.2f us  p99 %.2f us  p999 %.2f us\n"
                 "    1K tiles: p50 %.2f us  p99 %.2f us  p999 %.2f us\n"
                 "    p99 1M/1K = %.2fx",
                 threads,
                 pb.n,
                 pb.p50,
                 pb.p99,
                 pb.p999,
                 ps.p50,
                 ps.p99,
                 ps.p999,
                 pb.p99 / ps.p99));
}

// ------------------------------------------------------------------------------------------------
// 3. Open time: 1M-tile cache vs empty cache

void BM_Open(benchmark::State& state) {
  const Fixture& big = bigFixture();
  const Fixture& empty = emptyFixture();
  constexpr int kRounds = 100;
  const TileKey bigKey = big.keys.front();
  const TileKey emptyKey{kFixtureFirstLevel, 0, 0};
  // Both indexes start with no WAL (the fixtures end with a checkpoint; the last close deletes it).
  for (const Fixture* f : {&big, &empty}) {
    if (fs::exists(f->root / "index.sqlite-wal"))
      die("fixture index has a WAL left: not comparable");
  }
  std::vector<std::int64_t> openNs[2], peekNs[2], closeNs[2];
  std::int64_t wrong = 0;
  Clock::duration wall{};
  for (auto _ : state) {
    const auto w0 = Clock::now();
    for (int r = 0; r < kRounds; ++r) {
      for (int side = 0; side < 2; ++side) {
        const int which = (r % 2 == 0) ? side : 1 - side; // alternate who goes first
        const Fixture& f = which == 0 ? big : empty;
        const auto t0 = Clock::now();
        auto cache = openCache(f.root);
        const auto t1 = Clock::now();
        auto hit =
            cache->peek(f.id, which == 0 ? bigKey : emptyKey); // first lookup: makes a reader
        const auto t2 = Clock::now();
        cache.reset();
        const auto t3 = Clock::now();
        const auto expected = which == 0 ? CacheLookup::Kind::Hit : CacheLookup::Kind::Miss;
        if (!hit || hit->kind != expected) ++wrong;
        const auto wi = static_cast<std::size_t>(which);
        openNs[wi].push_back(nanos(t1 - t0));
        peekNs[wi].push_back(nanos(t2 - t1));
        closeNs[wi].push_back(nanos(t3 - t2));
      }
    }
    wall = Clock::now() - w0;
    state.SetIterationTime(seconds(wall));
  }
  if (wrong != 0) {
    state.SkipWithError("the first lookup after open gave a wrong answer");
    return;
  }
  const Percentiles ob = percentiles(openNs[0]), oe = percentiles(openNs[1]);
  const Percentiles fb = percentiles(peekNs[0]), fe = percentiles(peekNs[1]);
  const Percentiles cb = percentiles(closeNs[0]), ce = percentiles(closeNs[1]);
  std::vector<std::int64_t> totalB, totalE;
  for (std::size_t i = 0; i < openNs[0].size(); ++i) {
    totalB.push_back(openNs[0][i] + peekNs[0][i] + closeNs[0][i]);
    totalE.push_back(openNs[1][i] + peekNs[1][i] + closeNs[1][i]);
  }
  const Percentiles tb = percentiles(totalB), te = percentiles(totalE);
  state.counters["open_p50_us_1M"] = ob.p50;
  state.counters["open_p50_us_empty"] = oe.p50;
  state.counters["open_ratio_p50"] = ob.p50 / oe.p50;
  state.counters["total_p50_us_1M"] = tb.p50;
  state.counters["total_p50_us_empty"] = te.p50;
  state.counters["total_ratio_p50"] = tb.p50 / te.p50;
  summary(format("open + first peek + close, %d interleaved rounds (p50 / p90, us):\n"
                 "    open():        1M %.0f / %.0f   empty %.0f / %.0f   ratio p50 %.2fx\n"
                 "    first peek():  1M %.0f / %.0f   empty %.0f / %.0f   ratio p50 %.2fx\n"
                 "    destruction:   1M %.0f / %.0f   empty %.0f / %.0f   ratio p50 %.2fx\n"
                 "    all three:     1M %.0f / %.0f   empty %.0f / %.0f   ratio p50 %.2fx "
                 "(goal: the same time, 1.00x)",
                 kRounds,
                 ob.p50,
                 ob.p90,
                 oe.p50,
                 oe.p90,
                 ob.p50 / oe.p50,
                 fb.p50,
                 fb.p90,
                 fe.p50,
                 fe.p90,
                 fb.p50 / fe.p50,
                 cb.p50,
                 cb.p90,
                 ce.p50,
                 ce.p90,
                 cb.p50 / ce.p50,
                 tb.p50,
                 tb.p90,
                 te.p50,
                 te.p90,
                 tb.p50 / te.p50));
}

// ------------------------------------------------------------------------------------------------
// 4. Put throughput vs plain write + rename of the same files

/** The baseline: the same files in the same layout, written as put() writes them but no index. */
class PlainWriter {
public:
  PlainWriter(fs::path datasetDir, bool fsyncFiles)
      : dir_(std::move(datasetDir)), fsync_(fsyncFiles) {}

  bool write(const TileKey& key, std::span<const std::byte> bytes) {
    const fs::path target = dir_ / tellus::tileRelativePath(key, "jpg");
    if (!ensureDir(target.parent_path())) return false;
    std::string name(1, '.');
    name.append(target.filename().native());
    name.append(1, '.').append(std::to_string(::getpid()));
    name.append(1, '.').append(std::to_string(counter_.fetch_add(1)));
    name.append(".tmp");
    const fs::path temp = target.parent_path() / name;
    const int fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (fd < 0) return false;
    const auto* p = reinterpret_cast<const char*>(bytes.data());
    std::size_t left = bytes.size();
    while (left > 0) {
      const ssize_t n = ::write(fd, p, left);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) {
        ::close(fd);
        return false;
      }
      p += n;
      left -= static_cast<std::size_t>(n);
    }
    if (fsync_ && ::fsync(fd) != 0) {
      ::close(fd);
      return false;
    }
    if (::close(fd) != 0) return false;
    return ::rename(temp.c_str(), target.c_str()) == 0;
  }

private:
  bool ensureDir(const fs::path& d) {
    {
      std::lock_guard lock(mutex_);
      if (known_.contains(d.native())) return true;
    }
    std::error_code ec;
    fs::create_directories(d, ec);
    if (ec) return false;
    std::lock_guard lock(mutex_);
    known_.insert(d.native());
    return true;
  }

  fs::path dir_;
  bool fsync_;
  std::mutex mutex_;
  std::unordered_set<std::string> known_;
  std::atomic<std::uint64_t> counter_{0};
};

/** A rows x cols block of level-12 keys, as a seeder writes them. */
std::vector<TileKey> blockKeys(std::int64_t firstRow, std::int64_t rows, std::int64_t cols) {
  std::vector<TileKey> keys;
  for (std::int64_t r = 0; r < rows; ++r) {
    for (std::int64_t c = 0; c < cols; ++c)
      keys.push_back(TileKey{kPutLevel, firstRow + r, 1000 + c});
  }
  return keys;
}

/**
 * Args: fsync (0/1), threads, target (0 = a fresh cache, 1 = the 1M-tile cache), write-behind
 * (0 = put() returns when its row is committed, 1 = TileCache::Options::indexWriteBehind).
 *
 * Each round writes the same block of keys once through put() and once with PlainWriter into its
 * own fresh directory; the two sides alternate in chunks of tiles (and who goes first alternates),
 * so both see the same machine noise. Opening the cache and registering the dataset are not timed;
 * closing it (the final WAL checkpoint) is timed separately and reported.
 */
void BM_Put(benchmark::State& state) {
  const bool fsyncOn = state.range(0) != 0;
  const int threads = static_cast<int>(state.range(1));
  const bool intoBig = state.range(2) != 0;
  const bool writeBehind = state.range(3) != 0;
  const int rounds = fsyncOn ? 2 : 3;
  const std::int64_t blockRows = fsyncOn ? 20 : 40;
  const std::int64_t blockCols = fsyncOn ? 20 : 50;
  const std::size_t chunk = fsyncOn ? 50 : 100;
  const auto& pool = payloads();
  const DatasetSpec spec = benchSpec();
  const Fixture* big = intoBig ? &bigFixture() : nullptr;
  static std::int64_t nextBigRow = 100; // puts into the 1M cache always add new rows

  double cacheSec = 0, plainSec = 0, closeSec = 0;
  std::vector<double> roundRatios;
  std::vector<std::int64_t> closeNs;
  std::int64_t tiles = 0;
  std::atomic<std::int64_t> failures{0};
  for (auto _ : state) {
    for (int r = 0; r < rounds; ++r) {
      std::int64_t firstRow = 100;
      if (intoBig) {
        firstRow = nextBigRow;
        nextBigRow += blockRows;
      }
      const std::vector<TileKey> keys = blockKeys(firstRow, blockRows, blockCols);

      const fs::path cacheRoot = intoBig ? big->root : freshDir("put-cache");
      auto cache = openCache(cacheRoot, fsyncOn, 4, writeBehind);
      DatasetId id = 0;
      if (intoBig) {
        id = big->id;
      } else {
        auto reg = cache->registerDataset(spec);
        if (!reg) die("registerDataset: " + reg.error().message);
        id = *reg;
      }
      const fs::path plainRoot = freshDir("put-plain");
      std::error_code ec;
      fs::create_directories(plainRoot / tellus::datasetFolder(spec), ec);
      PlainWriter writer(plainRoot / tellus::datasetFolder(spec), fsyncOn);
      ::sync(); // both sides start from a clean page cache

      double cacheRound = 0, plainRound = 0;
      for (std::size_t begin = 0, c = 0; begin < keys.size(); begin += chunk, ++c) {
        const std::size_t end = std::min(keys.size(), begin + chunk);
        auto share = [&](int t, auto&& one) { // thread t writes keys begin+t, begin+t+T ...
          for (std::size_t i = begin + static_cast<std::size_t>(t); i < end;
               i += static_cast<std::size_t>(threads)) {
            if (!one(keys[i], std::span<const std::byte>(pool[i % pool.size()])))
              failures.fetch_add(1);
          }
        };
        for (int side = 0; side < 2; ++side) {
          const bool cacheSide = ((c + static_cast<std::size_t>(r)) % 2 == 0) == (side == 0);
          if (cacheSide) {
            cacheRound += seconds(runThreads(threads, [&](int t) {
              share(t, [&](const TileKey& k, std::span<const std::byte> b) {
                return cache->put(id, k, b, tellus::TileMeta{}).has_value();
              });
            }));
          } else {
            plainRound += seconds(runThreads(threads, [&](int t) {
              share(t, [&](const TileKey& k, std::span<const std::byte> b) {
                return writer.write(k, b);
              });
            }));
          }
        }
      }
      const auto c0 = Clock::now();
      cache.reset(); // the last close checkpoints the WAL: reported, not in the ratio
      closeNs.push_back(nanos(Clock::now() - c0));
      closeSec += seconds(Clock::now() - c0);
      // The files stay until the workspace is removed at exit: on an ext4 without a journal (this
      // VM's) creating inodes right after deleting thousands gets several times slower
      // (recently_deleted() skips inodes freed in the last ~30 s), which would dilute the ratio.

      cacheSec += cacheRound;
      plainSec += plainRound;
      roundRatios.push_back(plainRound /
                            cacheRound); // (tiles/s through the cache) / (plain tiles/s)
      tiles += static_cast<std::int64_t>(keys.size());
    }
    state.SetIterationTime(cacheSec + plainSec);
  }
  if (failures.load() != 0) {
    state.SkipWithError("a write failed");
    return;
  }
  std::sort(roundRatios.begin(), roundRatios.end());
  const double cacheRate = static_cast<double>(tiles) / cacheSec;
  const double plainRate = static_cast<double>(tiles) / plainSec;
  const double withClose = plainSec / (cacheSec + closeSec);
  const Percentiles cl = percentiles(closeNs);
  state.counters["put_tiles_per_s"] = cacheRate;
  state.counters["plain_tiles_per_s"] = plainRate;
  state.counters["ratio"] = cacheRate / plainRate;
  state.counters["ratio_with_close"] = withClose;
  // The cache's cost on top of the file write, per tile (wall time): unlike the ratio, it does not
  // depend on how expensive creating a file happens to be on the machine at the time.
  const double overheadUs = (cacheSec - plainSec) / static_cast<double>(tiles) * 1e6;
  state.counters["overhead_us_per_tile"] = overheadUs;
  summary(format("put() of %d x %" PRId64 " x 20 KiB tiles into %s%s, fsync %s, %d thread(s), "
                 "interleaved in chunks of %zu:\n"
                 "    put(): %.0f tiles/s   plain write%s+rename: %.0f tiles/s   "
                 "(put costs %+.0f us/tile more)\n"
                 "    ratio %.2fx (rounds: min %.2fx, max %.2fx; counting the close: %.2fx); "
                 "goal >= 0.8x: %s\n"
                 "    (cache close after a round, not in the ratio: p50 %.1f ms)",
                 rounds,
                 blockRows * blockCols,
                 intoBig ? "the 1M-tile cache" : "a fresh cache",
                 writeBehind ? " (index write-behind)" : "",
                 fsyncOn ? "on" : "off",
                 threads,
                 chunk,
                 cacheRate,
                 fsyncOn ? "+fsync" : "",
                 plainRate,
                 overheadUs,
                 cacheRate / plainRate,
                 roundRatios.front(),
                 roundRatios.back(),
                 withClose,
                 cacheRate / plainRate >= 0.8 ? "MET" : "MISSED",
                 cl.p50 / 1000.0));
}

// Registration order is run order: the open benchmark first (nothing has touched the indexes yet),
// puts into the 1M cache last (they add rows to it).
BENCHMARK(BM_Open)->Iterations(1)->UseManualTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Lookup)
    ->ArgNames({"threads", "readconns"})
    ->Args({1, 4})
    ->Args({2, 4})
    ->Args({2, 1})
    ->Iterations(1)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Get)->ArgName("threads")->Arg(1)->Arg(2)->Iterations(1)->UseManualTime()->Unit(
    benchmark::kMillisecond);
BENCHMARK(BM_Put)
    ->ArgNames({"fsync", "threads", "into1M", "writebehind"})
    ->Args({0, 1, 0, 0})
    ->Args({0, 4, 0, 0})
    ->Args({1, 1, 0, 0})
    ->Args({1, 4, 0, 0})
    ->Args({0, 1, 0, 1})
    ->Args({0, 4, 0, 1})
    ->Args({1, 1, 0, 1})
    ->Args({0, 1, 1, 0})
    ->Args({0, 4, 1, 0})
    ->Args({0, 1, 1, 1})
    ->Iterations(1)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);

} // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  if (!gSummary.empty()) {
    std::printf(
        "\n==== tellus cache benchmarks: summary (ratios are measured side by side) ====\n");
    for (const auto& line : gSummary)
      std::printf("%s\n", line.c_str());
  }
  removeWorkspace();
  return 0;
}
