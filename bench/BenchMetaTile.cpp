// CPU per seeded tile of what tellus does with an upstream's JPEG answer (issue #4's seeding):
// one 512 px tile validated by a full decode (one GetMap per tile), against a 2048 x 1024 metatile
// of the same pixels (4 x 2 tiles) cut in the DCT domain, and decoded once + encoded per tile (the
// fallback for misaligned tiles and PNG). Real imagery: the bundled Blue Marble, JPEG quality 90,
// 4:2:0. Side by side in one run; per-tile times (items/s) are what to compare. Run with
// bench/run.sh.

#include <tellus/codec/Jpeg.hpp>
#include <tellus/codec/JpegSplit.hpp>
#include <tellus/proxy/ImageCodec.hpp>

#include <benchmark/benchmark.h>

#include <cstring>
#include <fstream>
#include <iterator>

using namespace tellus;

namespace {

constexpr int kCols = 4, kRows = 2, kTile = 512;

struct Fixture {
  std::vector<std::uint8_t> pixels;          // 2048 x 1024 RGB
  std::vector<std::byte> meta;               // the metatile as one JPEG
  std::vector<std::vector<std::byte>> tiles; // each 512 px tile as its own JPEG
};

const Fixture& fixture() {
  static const Fixture f = [] {
    Fixture x;
    std::ifstream in(TELLUS_BENCH_DATA_DIR "/bmng_2048x1024.jpg", std::ios::binary);
    const std::string raw((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const auto* b = reinterpret_cast<const std::byte*>(raw.data());
    auto decoded = decodeImagery(
        std::vector<std::byte>(b, b + raw.size()), "image/jpeg", kCols * kTile, kRows * kTile);
    if (!decoded) throw std::runtime_error("cannot read the Blue Marble: " + decoded.error());
    x.pixels = std::move(decoded->pixels);
    x.meta = *codec::encodeJpeg(kCols * kTile, kRows * kTile, 3, x.pixels.data());
    std::vector<std::uint8_t> tile(static_cast<std::size_t>(kTile) * kTile * 3);
    for (int r = 0; r < kRows; ++r)
      for (int c = 0; c < kCols; ++c) {
        for (int y = 0; y < kTile; ++y)
          std::memcpy(&tile[static_cast<std::size_t>(y) * kTile * 3],
                      &x.pixels[(static_cast<std::size_t>(r * kTile + y) * kCols * kTile +
                                 static_cast<std::size_t>(c * kTile)) *
                                3],
                      static_cast<std::size_t>(kTile) * 3);
        x.tiles.push_back(*codec::encodeJpeg(kTile, kTile, 3, tile.data()));
      }
    return x;
  }();
  return f;
}

/** Today's per-tile path: each fetched tile is decoded whole to validate it. */
void BM_PerTileValidate(benchmark::State& state) {
  const auto& f = fixture();
  std::vector<std::uint8_t> scratch;
  for (auto _ : state)
    for (const auto& t : f.tiles)
      benchmark::DoNotOptimize(codec::checkJpeg(t, kTile, kTile, scratch).has_value());
  state.SetItemsProcessed(state.iterations() * kCols * kRows);
  std::size_t bytes = 0;
  for (const auto& t : f.tiles)
    bytes += t.size();
  state.counters["bytes/tile"] = static_cast<double>(bytes) / (kCols * kRows);
}
BENCHMARK(BM_PerTileValidate)->Unit(benchmark::kMillisecond);

/** The metatile path: coefficients read once (the validation), 8 tiles written. */
void BM_MetaTileSplitDct(benchmark::State& state) {
  const auto& f = fixture();
  std::size_t bytes = 0;
  for (auto _ : state) {
    auto tiles = codec::splitJpegDct(f.meta, kCols, kRows, kTile, kTile);
    benchmark::DoNotOptimize(tiles->data());
    bytes = 0;
    for (const auto& t : *tiles)
      bytes += t.size();
  }
  state.SetItemsProcessed(state.iterations() * kCols * kRows);
  state.counters["bytes/tile"] = static_cast<double>(bytes) / (kCols * kRows);
}
BENCHMARK(BM_MetaTileSplitDct)->Unit(benchmark::kMillisecond);

/** The same with optimal Huffman tables per tile (an extra pass; smaller tiles). */
void BM_MetaTileSplitDctOptimized(benchmark::State& state) {
  const auto& f = fixture();
  std::size_t bytes = 0;
  for (auto _ : state) {
    auto tiles = codec::splitJpegDct(f.meta, kCols, kRows, kTile, kTile, true);
    bytes = 0;
    for (const auto& t : *tiles)
      bytes += t.size();
  }
  state.SetItemsProcessed(state.iterations() * kCols * kRows);
  state.counters["bytes/tile"] = static_cast<double>(bytes) / (kCols * kRows);
}
BENCHMARK(BM_MetaTileSplitDctOptimized)->Unit(benchmark::kMillisecond);

/** The fallback: the metatile decoded once, each tile encoded again (one more generation). */
void BM_MetaTileDecodeEncode(benchmark::State& state) {
  const auto& f = fixture();
  std::vector<std::uint8_t> pixels;
  std::vector<std::uint8_t> tile(static_cast<std::size_t>(kTile) * kTile * 3);
  for (auto _ : state) {
    (void)codec::checkJpeg(f.meta, kCols * kTile, kRows * kTile, pixels);
    for (int r = 0; r < kRows; ++r)
      for (int c = 0; c < kCols; ++c) {
        for (int y = 0; y < kTile; ++y)
          std::memcpy(&tile[static_cast<std::size_t>(y) * kTile * 3],
                      &pixels[(static_cast<std::size_t>(r * kTile + y) * kCols * kTile +
                               static_cast<std::size_t>(c * kTile)) *
                              3],
                      static_cast<std::size_t>(kTile) * 3);
        benchmark::DoNotOptimize(codec::encodeJpeg(kTile, kTile, 3, tile.data())->data());
      }
  }
  state.SetItemsProcessed(state.iterations() * kCols * kRows);
}
BENCHMARK(BM_MetaTileDecodeEncode)->Unit(benchmark::kMillisecond);

} // namespace

BENCHMARK_MAIN();
