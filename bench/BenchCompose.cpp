// GetMap composition, the CPU of one 1024x768 map from 512-pixel tiles (the peers' arbitrary-box
// benchmark size): the sampling alone, and decode + sample + encode as tellus serve does it.
// Side by side in one run; ratios are what to compare. Run with bench/run.sh.

#include <tellus/cache/TileGrid.hpp>
#include <tellus/codec/JpegYcc.hpp>
#include <tellus/proxy/Compose.hpp>
#include <tellus/proxy/ImageCodec.hpp>
#include <tellus/values/ValueFormat.hpp>

#include <benchmark/benchmark.h>

#include <algorithm>
#include <array>
#include <limits>
#include <map>
#include <memory>
#include <tuple>

using namespace tellus;

namespace {

TileGrid grid() {
  return *TileGrid::create(GridSpec{Sector{}, 36.0, 512, 512, 4});
}

/** A smooth colour field, so the JPEGs are realistic in size. */
std::vector<std::uint8_t> tilePixels(const TileKey& k) {
  std::vector<std::uint8_t> px(512 * 512 * 3);
  for (int y = 0; y < 512; ++y)
    for (int x = 0; x < 512; ++x) {
      auto* p = &px[static_cast<std::size_t>((y * 512 + x) * 3)];
      p[0] = static_cast<std::uint8_t>((x + k.col * 37) & 255);
      p[1] = static_cast<std::uint8_t>((y + k.row * 53) & 255);
      p[2] = static_cast<std::uint8_t>(((x ^ y) >> 2) & 255);
    }
  return px;
}

// A 60 x 45 degree box over 1024 x 768 pixels: level 1 (18-degree tiles), 5 x 4 tiles.
const Sector kBox{-100.3, 10.2, -40.3, 55.2};

void BM_SampleOnly(benchmark::State& state) {
  const TileGrid g = grid();
  const int level = composeLevel(g, kBox, 1024, 768, 0);
  const auto keys = *composeTiles(g, kBox, 1024, 768, level, 256);
  std::map<std::tuple<std::int64_t, std::int64_t>, std::vector<std::uint8_t>> pixels;
  std::map<std::tuple<std::int64_t, std::int64_t>, TileSamples> views;
  for (const auto& t : keys) {
    auto& p = pixels[{t.key.row, t.key.col}] = tilePixels(t.key);
    views[{t.key.row, t.key.col}] = TileSamples{512, 512, 3, p.data(), nullptr};
  }
  const TileLookup lookup = [&](const TileKey& k) -> const TileSamples* {
    const auto it = views.find({k.row, k.col});
    return k.level == level && it != views.end() ? &it->second : nullptr;
  };
  std::vector<std::uint8_t> canvas(1024 * 768 * 3);
  for (auto _ : state) {
    composeImagery(g, kBox, 1024, 768, level, 0, lookup, 1.0, canvas, 3);
    benchmark::DoNotOptimize(canvas.data());
  }
  state.counters["tiles"] = static_cast<double>(keys.size());
}
BENCHMARK(BM_SampleOnly)->Unit(benchmark::kMillisecond);

void BM_DecodeSampleEncodeJpeg(benchmark::State& state) {
  const TileGrid g = grid();
  const int level = composeLevel(g, kBox, 1024, 768, 0);
  const auto keys = *composeTiles(g, kBox, 1024, 768, level, 256);
  std::map<std::tuple<std::int64_t, std::int64_t>, std::vector<std::byte>> jpegs;
  std::map<std::tuple<std::int64_t, std::int64_t>, std::array<std::int32_t, 4>> regions;
  for (const auto& t : keys) {
    const auto px = tilePixels(t.key);
    jpegs[{t.key.row, t.key.col}] = *encodeImage("image/jpeg", 512, 512, 3, px.data());
    regions[{t.key.row, t.key.col}] = t.region;
  }
  std::vector<std::uint8_t> canvas(1024 * 768 * 3);
  std::size_t bytes = 0;
  for (auto _ : state) {
    std::map<std::tuple<std::int64_t, std::int64_t>,
             std::pair<std::vector<std::uint8_t>, TileSamples>>
        decoded;
    for (const auto& [rc, jpeg] : jpegs) {
      auto& [px, view] = decoded[rc];
      const auto ch = decodeImageryInto(jpeg, "image/jpeg", 512, 512, px, &regions[rc]);
      view = TileSamples{512, 512, *ch, px.data(), nullptr};
    }
    const TileLookup lookup = [&](const TileKey& k) -> const TileSamples* {
      const auto it = decoded.find({k.row, k.col});
      return k.level == level && it != decoded.end() ? &it->second.second : nullptr;
    };
    composeImagery(g, kBox, 1024, 768, level, 0, lookup, 1.0, canvas, 3);
    const auto out = encodeImage("image/jpeg", 1024, 768, 3, canvas.data());
    bytes = out->size();
    benchmark::DoNotOptimize(out->data());
  }
  state.counters["tiles"] = static_cast<double>(keys.size());
  state.counters["jpeg_bytes"] = static_cast<double>(bytes);
}
BENCHMARK(BM_DecodeSampleEncodeJpeg)->Unit(benchmark::kMillisecond);

/** The tiles of kBox as JPEG (quality 90, 4:2:0; `restart`: with restart markers, as tellus seeds
 * them, else as an upstream's may be) with the regions of the YCbCr path. */
struct YccFixture {
  TileGrid g = grid();
  int level = composeLevel(g, kBox, 1024, 768, 0);
  std::vector<ComposeTile> keys = *composeTilesYcc(g, kBox, 1024, 768, level, 256);
  ChromaLayout chroma = *chromaLayout(g, kBox, 1024, 768);
  std::map<std::tuple<std::int64_t, std::int64_t>, std::vector<std::byte>> jpegs;
  struct Planes {
    std::vector<std::uint8_t> px = std::vector<std::uint8_t>(512 * 512 * 3 / 2);
    TileSamples view[3];
  };
  std::map<std::tuple<std::int64_t, std::int64_t>, Planes> planes;
  std::vector<std::uint8_t> out[3];
  explicit YccFixture(bool restart = false) {
    for (const auto& t : keys) {
      const auto px = tilePixels(t.key);
      jpegs[{t.key.row, t.key.col}] = *encodeImage("image/jpeg", 512, 512, 3, px.data(), restart);
      auto& p = planes[{t.key.row, t.key.col}];
      p.view[0] = TileSamples{512, 512, 1, p.px.data(), nullptr};
      p.view[1] = TileSamples{256, 256, 1, p.px.data() + 512 * 512, nullptr};
      p.view[2] = TileSamples{256, 256, 1, p.px.data() + 512 * 512 + 256 * 256, nullptr};
    }
  }
  void decode() {
    for (const auto& t : keys) {
      auto& p = planes[{t.key.row, t.key.col}];
      std::string message;
      codec::decodeJpegYcc(jpegs[{t.key.row, t.key.col}],
                           512,
                           512,
                           &t.region,
                           p.px.data(),
                           p.px.data() + 512 * 512,
                           p.px.data() + 512 * 512 + 256 * 256,
                           message);
    }
  }
  void sample() {
    for (int plane = 0; plane < 3; ++plane) {
      const TileLookup lookup = [&](const TileKey& k) -> const TileSamples* {
        const auto it = planes.find({k.row, k.col});
        return k.level == level && it != planes.end() ? &it->second.view[plane] : nullptr;
      };
      if (plane == 0) {
        composeImagery(g, kBox, 1024, 768, level, 0, lookup, 1.0, out[0], 1);
      } else {
        composeImagery(chroma.grid,
                       chroma.box,
                       chroma.width,
                       chroma.height,
                       level,
                       0,
                       lookup,
                       1.0,
                       out[plane],
                       1);
      }
    }
  }
  std::size_t encode() {
    const auto jpeg = codec::encodeJpegYcc(1024, 768, out[0].data(), out[1].data(), out[2].data());
    benchmark::DoNotOptimize(jpeg->data());
    return jpeg->size();
  }
};

void BM_YccDecodeOnly(benchmark::State& state) {
  YccFixture f;
  for (auto _ : state)
    f.decode();
  state.counters["tiles"] = static_cast<double>(f.keys.size());
}
BENCHMARK(BM_YccDecodeOnly)->Unit(benchmark::kMillisecond);

/** The same tiles with restart markers: the regions decoded from the segments around them. */
void BM_YccDecodeOnlySegments(benchmark::State& state) {
  YccFixture f(true);
  for (auto _ : state)
    f.decode();
  state.counters["tiles"] = static_cast<double>(f.keys.size());
}
BENCHMARK(BM_YccDecodeOnlySegments)->Unit(benchmark::kMillisecond);

void BM_YccSampleOnly(benchmark::State& state) {
  YccFixture f;
  f.decode();
  for (auto _ : state) {
    f.sample();
    benchmark::DoNotOptimize(f.out[0].data());
  }
}
BENCHMARK(BM_YccSampleOnly)->Unit(benchmark::kMillisecond);

void BM_YccEncodeOnly(benchmark::State& state) {
  YccFixture f;
  f.decode();
  f.sample();
  for (auto _ : state)
    benchmark::DoNotOptimize(f.encode());
}
BENCHMARK(BM_YccEncodeOnly)->Unit(benchmark::kMillisecond);

void BM_YccDecodeSampleEncodeJpeg(benchmark::State& state) {
  YccFixture f;
  std::size_t bytes = 0;
  for (auto _ : state) {
    f.decode();
    f.sample();
    bytes = f.encode();
  }
  state.counters["tiles"] = static_cast<double>(f.keys.size());
  state.counters["jpeg_bytes"] = static_cast<double>(bytes);
}
BENCHMARK(BM_YccDecodeSampleEncodeJpeg)->Unit(benchmark::kMillisecond);

} // namespace

// ---- value layers (issue 24): the same map from value tiles, coloured per pixel ---------------

/** BIL16 value tiles of the same smooth field (hundredths of a unit, as a scale of 0.01 reads). */
std::vector<std::int16_t> tileValues(const TileKey& k) {
  std::vector<std::int16_t> v(512 * 512);
  for (int y = 0; y < 512; ++y)
    for (int x = 0; x < 512; ++x)
      v[static_cast<std::size_t>(y * 512 + x)] =
          static_cast<std::int16_t>((x + k.col * 37) * 10 - (y + k.row * 53) * 7);
  return v;
}

const values::ValueFormat kBil16{values::Container::Bil,
                                 values::Encoding::Int16,
                                 values::ByteOrder::Little,
                                 0.01,
                                 0.0,
                                 -32768.0,
                                 "K"};

/** The same map as BM_SampleOnly from value tiles: values sampled, then coloured (turbo). */
void BM_ValuesSampleColour(benchmark::State& state) {
  const TileGrid g = grid();
  const int level = composeLevel(g, kBox, 1024, 768, 0);
  const auto keys = *composeTiles(g, kBox, 1024, 768, level, 256);
  std::map<std::tuple<std::int64_t, std::int64_t>, std::vector<float>> tiles;
  std::map<std::tuple<std::int64_t, std::int64_t>, TileSamples> views;
  for (const auto& t : keys) {
    const auto raw = tileValues(t.key);
    auto& v = tiles[{t.key.row, t.key.col}];
    for (const std::int16_t r : raw)
      v.push_back(static_cast<float>(r * 0.01));
    views[{t.key.row, t.key.col}] = TileSamples{512, 512, 1, nullptr, nullptr, v.data()};
  }
  const TileLookup lookup = [&](const TileKey& k) -> const TileSamples* {
    const auto it = views.find({k.row, k.col});
    return k.level == level && it != views.end() ? &it->second : nullptr;
  };
  const values::ColourScale scale{values::findColourMap("turbo"), -30.0, 60.0};
  std::vector<std::uint8_t> canvas(1024 * 768 * 3);
  std::vector<float> sampled;
  for (auto _ : state) {
    sampled.assign(1024 * 768, std::numeric_limits<float>::quiet_NaN());
    composeValues(g, kBox, 1024, 768, level, 0, lookup, sampled);
    drawValuesAsColours(sampled, scale, 1.0, canvas, 3);
    benchmark::DoNotOptimize(canvas.data());
  }
  state.counters["tiles"] = static_cast<double>(keys.size());
}
BENCHMARK(BM_ValuesSampleColour)->Unit(benchmark::kMillisecond);

// ---- Web Mercator against lat/long: the same area and size, 1024 x 768 ----------------------

// The northern box: 60 x 25 degrees up to 80 N, where a Mercator pixel is 5.8 times shorter in
// latitude than in longitude.
const Sector kNorthBox{-100.3, 55.0, -40.3, 80.0};

/** Argument 0: kBox in EPSG:4326, 1: kBox in EPSG:3857 (its corners projected, rows evenly in
 * y), 2 and 3: kNorthBox. */
MapBox boxOfArgument(std::int64_t arg) {
  using namespace mercator;
  const Sector& b = arg < 2 ? kBox : kNorthBox;
  if (arg % 2 == 0) return b;
  return mercatorBox(Sector{
      xOfLongitude(b.west), yOfLatitude(b.south), xOfLongitude(b.east), yOfLatitude(b.north)});
}

using LevelKey = std::tuple<std::int32_t, std::int64_t, std::int64_t>;

/** The tiles of every band of a map (each band's level), with the regions sampled. */
std::map<LevelKey, std::array<std::int32_t, 4>> bandTiles(const TileGrid& g,
                                                          const std::vector<ComposeBand>& bands) {
  std::map<LevelKey, std::array<std::int32_t, 4>> tiles;
  for (const ComposeBand& b : bands) {
    const auto keys = composeTiles(g, b.box, 1024, 768, b.level, 256);
    for (const auto& t : *keys) {
      auto [it, fresh] = tiles.try_emplace({t.key.level, t.key.row, t.key.col}, t.region);
      if (!fresh)
        it->second = {std::min(it->second[0], t.region[0]),
                      std::min(it->second[1], t.region[1]),
                      std::max(it->second[2], t.region[2]),
                      std::max(it->second[3], t.region[3])};
    }
  }
  return tiles;
}

/** BM_SampleOnly's map in either CRS: its rows in bands, each from its own level (one band in
 * lat/long). */
void BM_SampleOnlyCrs(benchmark::State& state) {
  const TileGrid g = grid();
  const MapBox box = boxOfArgument(state.range(0));
  const auto bands = composeBands(g, box, 1024, 768, 0);
  const auto tiles = bandTiles(g, bands);
  std::map<LevelKey, std::vector<std::uint8_t>> pixels;
  std::map<LevelKey, TileSamples> views;
  for (const auto& [k, region] : tiles) {
    auto& p = pixels[k] = tilePixels(TileKey{std::get<0>(k), std::get<1>(k), std::get<2>(k)});
    views[k] = TileSamples{512, 512, 3, p.data(), nullptr};
  }
  const TileLookup lookup = [&](const TileKey& k) -> const TileSamples* {
    const auto it = views.find({k.level, k.row, k.col});
    return it != views.end() ? &it->second : nullptr;
  };
  std::vector<std::uint8_t> canvas(1024 * 768 * 3);
  for (auto _ : state) {
    for (const ComposeBand& b : bands)
      composeImagery(g, b.box, 1024, 768, b.level, 0, lookup, 1.0, canvas, 3);
    benchmark::DoNotOptimize(canvas.data());
  }
  state.counters["tiles"] = static_cast<double>(tiles.size());
  state.counters["bands"] = static_cast<double>(bands.size());
}
BENCHMARK(BM_SampleOnlyCrs)->DenseRange(0, 3)->Unit(benchmark::kMillisecond);

/** BM_DecodeSampleEncodeJpeg's map in either CRS (the RGB path, as a map of several bands). */
void BM_DecodeSampleEncodeJpegCrs(benchmark::State& state) {
  const TileGrid g = grid();
  const MapBox box = boxOfArgument(state.range(0));
  const auto bands = composeBands(g, box, 1024, 768, 0);
  auto regions = bandTiles(g, bands);
  std::map<LevelKey, std::vector<std::byte>> jpegs;
  for (const auto& [k, region] : regions) {
    const auto px = tilePixels(TileKey{std::get<0>(k), std::get<1>(k), std::get<2>(k)});
    jpegs[k] = *encodeImage("image/jpeg", 512, 512, 3, px.data());
  }
  std::vector<std::uint8_t> canvas(1024 * 768 * 3);
  for (auto _ : state) {
    std::map<LevelKey, std::pair<std::vector<std::uint8_t>, TileSamples>> decoded;
    for (const auto& [k, jpeg] : jpegs) {
      auto& [px, view] = decoded[k];
      const auto ch = decodeImageryInto(jpeg, "image/jpeg", 512, 512, px, &regions[k]);
      view = TileSamples{512, 512, *ch, px.data(), nullptr};
    }
    const TileLookup lookup = [&](const TileKey& k) -> const TileSamples* {
      const auto it = decoded.find({k.level, k.row, k.col});
      return it != decoded.end() ? &it->second.second : nullptr;
    };
    for (const ComposeBand& b : bands)
      composeImagery(g, b.box, 1024, 768, b.level, 0, lookup, 1.0, canvas, 3);
    const auto out = encodeImage("image/jpeg", 1024, 768, 3, canvas.data());
    benchmark::DoNotOptimize(out->data());
  }
  state.counters["tiles"] = static_cast<double>(regions.size());
  state.counters["bands"] = static_cast<double>(bands.size());
}
BENCHMARK(BM_DecodeSampleEncodeJpegCrs)->DenseRange(0, 3)->Unit(benchmark::kMillisecond);

/** A picture layer's whole map in PNG: PNG tiles decoded, sampled, the map encoded as PNG. */
void BM_DecodeSampleEncodePng(benchmark::State& state) {
  const TileGrid g = grid();
  const int level = composeLevel(g, kBox, 1024, 768, 0);
  const auto keys = *composeTiles(g, kBox, 1024, 768, level, 256);
  std::map<std::tuple<std::int64_t, std::int64_t>, std::vector<std::byte>> pngs;
  for (const auto& t : keys) {
    const auto px = tilePixels(t.key);
    pngs[{t.key.row, t.key.col}] = *encodeImage("image/png", 512, 512, 3, px.data());
  }
  std::vector<std::uint8_t> canvas(1024 * 768 * 3);
  for (auto _ : state) {
    std::map<std::tuple<std::int64_t, std::int64_t>,
             std::pair<std::vector<std::uint8_t>, TileSamples>>
        decoded;
    for (const auto& [rc, png] : pngs) {
      auto& [px, view] = decoded[rc];
      const auto ch = decodeImageryInto(png, "image/png", 512, 512, px, nullptr);
      view = TileSamples{512, 512, *ch, px.data(), nullptr};
    }
    const TileLookup lookup = [&](const TileKey& k) -> const TileSamples* {
      const auto it = decoded.find({k.row, k.col});
      return k.level == level && it != decoded.end() ? &it->second.second : nullptr;
    };
    composeImagery(g, kBox, 1024, 768, level, 0, lookup, 1.0, canvas, 3);
    const auto out = encodeImage("image/png", 1024, 768, 3, canvas.data());
    benchmark::DoNotOptimize(out->data());
  }
}
BENCHMARK(BM_DecodeSampleEncodePng)->Unit(benchmark::kMillisecond);

/** The value layer's whole map in PNG: BIL16 tiles decoded to values, sampled, coloured, encoded
 * (what GetMap with a STYLES colour map does). Against BM_DecodeSampleEncodePng: the issue's
 * goal is at most 1.1x. */
void BM_ValuesDecodeSampleColourEncodePng(benchmark::State& state) {
  const TileGrid g = grid();
  const int level = composeLevel(g, kBox, 1024, 768, 0);
  const auto keys = *composeTiles(g, kBox, 1024, 768, level, 256);
  std::map<std::tuple<std::int64_t, std::int64_t>, std::vector<std::byte>> bils;
  for (const auto& t : keys) {
    const auto v = tileValues(t.key);
    bils[{t.key.row, t.key.col}] = *encodeHeights("application/bil16", 512, 512, v.data());
  }
  const values::ColourScale scale{values::findColourMap("turbo"), -30.0, 60.0};
  std::vector<std::uint8_t> canvas(1024 * 768 * 3);
  std::vector<float> sampled;
  for (auto _ : state) {
    std::map<std::tuple<std::int64_t, std::int64_t>, std::pair<values::ValueRaster, TileSamples>>
        decoded;
    for (const auto& [rc, bil] : bils) {
      auto& [raster, view] = decoded[rc];
      raster = *values::decode(bil, kBil16, 512, 512);
      view = TileSamples{512, 512, 1, nullptr, nullptr, raster.values.data()};
    }
    const TileLookup lookup = [&](const TileKey& k) -> const TileSamples* {
      const auto it = decoded.find({k.row, k.col});
      return k.level == level && it != decoded.end() ? &it->second.second : nullptr;
    };
    sampled.assign(1024 * 768, std::numeric_limits<float>::quiet_NaN());
    composeValues(g, kBox, 1024, 768, level, 0, lookup, sampled);
    std::fill(canvas.begin(), canvas.end(), std::uint8_t{255});
    drawValuesAsColours(sampled, scale, 1.0, canvas, 3);
    const auto out = encodeImage("image/png", 1024, 768, 3, canvas.data());
    benchmark::DoNotOptimize(out->data());
  }
}
BENCHMARK(BM_ValuesDecodeSampleColourEncodePng)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
