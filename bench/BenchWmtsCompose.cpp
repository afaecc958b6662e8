// What a lat/long grid tile costs when composed from a WMTS upstream's tiles (issue 25): the
// upstream tiles it needs and the CPU of decoding, sampling and encoding them, for a Web Mercator
// (GoogleMapsCompatible, 256 px) set at several latitudes and, side by side, a lat/long set offset
// from the grid (512 px tiles, 1-4 per grid tile). Fetching is not measured (the network's), only
// counted. Run: build/bench/tellus_bench_wmts_compose.

#include "../proxy/src/upstream/WmtsCompose.hpp"

#include <tellus/codec/Jpeg.hpp>
#include <tellus/proxy/WmtsUpstream.hpp>

#include <benchmark/benchmark.h>

#include <cmath>
#include <string>

using namespace tellus;

namespace {

std::string
matrixXml(int id, const std::string& scale, const std::string& corner, int tile, int w, int h) {
  return "<TileMatrix><ows:Identifier>" + std::to_string(id) +
         "</ows:Identifier><ScaleDenominator>" + scale + "</ScaleDenominator><TopLeftCorner>" +
         corner + "</TopLeftCorner><TileWidth>" + std::to_string(tile) +
         "</TileWidth><TileHeight>" + std::to_string(tile) + "</TileHeight><MatrixWidth>" +
         std::to_string(w) + "</MatrixWidth><MatrixHeight>" + std::to_string(h) +
         "</MatrixHeight></TileMatrix>";
}

/** Layer "L" on set "merc" (zooms 0-7) or "geo" (one matrix of 9-degree 512 px tiles from 85.5 N,
 * half a tile off the grid). */
WmtsTiles bound(bool mercator) {
  std::string sets = "<TileMatrixSet><ows:Identifier>merc</ows:Identifier><ows:SupportedCRS>"
                     "urn:ogc:def:crs:EPSG::3857</ows:SupportedCRS>";
  for (int z = 0; z < 8; ++z) {
    char scale[32];
    std::snprintf(scale, sizeof scale, "%.10f", 559082264.0287178 / std::ldexp(1.0, z));
    sets += matrixXml(z, scale, "-20037508.34278925 20037508.34278925", 256, 1 << z, 1 << z);
  }
  sets += "</TileMatrixSet><TileMatrixSet><ows:Identifier>geo</ows:Identifier><ows:SupportedCRS>"
          "urn:ogc:def:crs:OGC:1.3:CRS84</ows:SupportedCRS>" +
          matrixXml(0, "6988528.300358973", "-184.5 85.5", 512, 41, 20) + "</TileMatrixSet>";
  const std::string doc =
      "<Capabilities xmlns=\"http://www.opengis.net/wmts/1.0\" "
      "xmlns:ows=\"http://www.opengis.net/ows/1.1\" version=\"1.0.0\"><Contents><Layer>"
      "<ows:Identifier>L</ows:Identifier><Format>image/jpeg</Format><TileMatrixSetLink>"
      "<TileMatrixSet>merc</TileMatrixSet></TileMatrixSetLink><TileMatrixSetLink><TileMatrixSet>"
      "geo</TileMatrixSet></TileMatrixSetLink><ResourceURL format=\"image/jpeg\" "
      "resourceType=\"tile\" template=\"http://x/{TileMatrix}/{TileRow}/{TileCol}.jpg\"/></Layer>" +
      sets + "</Contents></Capabilities>";
  auto caps = parseWmtsCapabilities(doc);
  if (!caps) std::abort();
  WmtsChoice c;
  c.layer = "L";
  c.format = "image/jpeg";
  c.tileMatrixSet = mercator ? "merc" : "geo";
  auto t = bindWmtsLayer(*caps, c, GridSpec{Sector{}, 36.0, 512, 512, 3});
  if (!t) std::abort();
  return *t;
}

std::vector<std::byte> jpegTile(int size, std::int64_t row, std::int64_t col) {
  std::vector<std::uint8_t> px(static_cast<std::size_t>(size * size * 3));
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      auto* p = &px[static_cast<std::size_t>((y * size + x) * 3)];
      p[0] = static_cast<std::uint8_t>((x + col * 37) & 255);
      p[1] = static_cast<std::uint8_t>((y + row * 53) & 255);
      p[2] = static_cast<std::uint8_t>(((x ^ y) >> 2) & 255);
    }
  return *codec::encodeJpeg(size, size, 3, px.data());
}

/** Level-2 grid tile (9 degrees, 512 px) of grid row `row`, column 20. */
void compose(benchmark::State& state, bool mercator) {
  const WmtsTiles t = bound(mercator);
  const int row = static_cast<int>(state.range(0));
  const TileKey key{2, row, 20};
  const Sector s{0.0, -90.0 + row * 9.0, 9.0, -90.0 + (row + 1) * 9.0};
  const auto sources = wmtsSourceTiles(t, key, s, 512, 512, "");
  std::vector<WmtsFetchedTile> fetched;
  for (const auto& src : sources)
    fetched.push_back(WmtsFetchedTile{src, jpegTile(mercator ? 256 : 512, src.row, src.col)});
  for (auto _ : state) {
    auto out = composeWmtsTile(t, key, s, 512, 512, fetched, "image/jpeg");
    if (!out) std::abort();
    benchmark::DoNotOptimize(out->data());
  }
  state.counters["upstream_tiles"] = static_cast<double>(sources.size());
  state.SetLabel("rows " + std::to_string(row * 9 - 90) + " to " + std::to_string(row * 9 - 81) +
                 " N");
}

void BM_WmtsComposeMercator(benchmark::State& state) {
  compose(state, true);
}
void BM_WmtsComposeLatLong(benchmark::State& state) {
  compose(state, false);
}

} // namespace

// 0-9 N, 27-36 N, 54-63 N, 72-81 N, 81-90 N.
BENCHMARK(BM_WmtsComposeMercator)
    ->Arg(10)
    ->Arg(13)
    ->Arg(16)
    ->Arg(18)
    ->Arg(19)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_WmtsComposeLatLong)->Arg(10)->Arg(16)->Arg(18)->Unit(benchmark::kMillisecond);
BENCHMARK_MAIN();
