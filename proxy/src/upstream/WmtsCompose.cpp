// A grid tile composed from WMTS tiles (WmtsCompose.hpp).

#include "WmtsCompose.hpp"

#include "WmtsMercator.hpp"

#include <tellus/codec/Image.hpp>
#include <tellus/codec/Jpeg.hpp>
#include <tellus/codec/Png.hpp>
#include <tellus/proxy/MapBox.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <utility>

namespace tellus {

namespace {

/** One decoded source tile as RGBA. */
struct Rgba {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> px;
};

std::expected<Rgba, std::string> decodeRgba(std::span<const std::byte> bytes) {
  std::expected<codec::Image, std::string> img = std::unexpected("neither JPEG nor PNG");
  switch (codec::sniff(bytes)) {
  case codec::Format::Jpeg:
    img = codec::decodeJpeg(bytes);
    break;
  case codec::Format::Png:
    img = codec::decodePng(bytes);
    break;
  case codec::Format::Unknown:
    break;
  }
  if (!img) return std::unexpected(img.error());
  Rgba out{img->width, img->height, {}};
  const auto n = static_cast<std::size_t>(img->width) * static_cast<std::size_t>(img->height);
  out.px.resize(n * 4);
  const int ch = img->channels;
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint8_t* s = img->pixels.data() + i * static_cast<std::size_t>(ch);
    std::uint8_t* d = out.px.data() + i * 4;
    d[0] = s[0];
    d[1] = ch >= 3 ? s[1] : s[0];
    d[2] = ch >= 3 ? s[2] : s[0];
    d[3] = ch == 4 ? s[3] : ch == 2 ? s[1] : 255;
  }
  return out;
}

} // namespace

std::expected<std::vector<std::byte>, std::string>
composeWmtsTile(const WmtsTiles& tiles,
                const TileKey& key,
                const Sector& sector,
                int width,
                int height,
                std::span<const WmtsFetchedTile> fetched,
                std::string_view mimeType) {
  if (!wmtsComposed(tiles, key)) return std::unexpected("the level is not composed");
  const auto from = tiles.levels[static_cast<std::size_t>(key.level)].composeFrom;
  const WmtsMatrixGeometry& m = tiles.matrices[static_cast<std::size_t>(from)];
  std::map<std::pair<std::int64_t, std::int64_t>, Rgba> mosaic;
  std::int64_t r0 = INT64_MAX, r1 = INT64_MIN, c0 = INT64_MAX, c1 = INT64_MIN;
  for (const WmtsFetchedTile& f : fetched) {
    r0 = std::min(r0, f.source.row);
    r1 = std::max(r1, f.source.row);
    c0 = std::min(c0, f.source.col);
    c1 = std::max(c1, f.source.col);
    if (f.bytes.empty()) continue;
    auto rgba = decodeRgba(f.bytes);
    if (!rgba) return std::unexpected("upstream tile " + f.source.url + ": " + rgba.error());
    if (rgba->width != m.tileWidth || rgba->height != m.tileHeight)
      return std::unexpected("upstream tile " + f.source.url + " is " +
                             std::to_string(rgba->width) + " x " + std::to_string(rgba->height) +
                             " pixels, not " + std::to_string(m.tileWidth) + " x " +
                             std::to_string(m.tileHeight));
    mosaic.emplace(std::pair{f.source.row, f.source.col}, std::move(*rgba));
  }
  if (fetched.empty()) return std::unexpected("no upstream tile covers the tile");
  // Source pixels (global indices in the matrix) that the mosaic spans.
  const std::int64_t x0 = c0 * m.tileWidth, x1 = (c1 + 1) * m.tileWidth - 1;
  const std::int64_t y0 = r0 * m.tileHeight, y1 = (r1 + 1) * m.tileHeight - 1;
  const std::int64_t xMax = m.matrixWidth * m.tileWidth, yMax = m.matrixHeight * m.tileHeight;
  // A Web Mercator matrix covering the whole square repeats its edge pixels (they reach the
  // antimeridian and 85.0511 degrees); a regional one is transparent outside, as lat/long ones.
  const bool wholeSquare = tiles.mercator && m.matrixWidth == m.matrixHeight &&
                           (std::int64_t{1} << wmtsmercator::zoomOf(m)) == m.matrixWidth;
  const auto sample = [&](std::int64_t x, std::int64_t y, int c) -> double {
    if (wholeSquare) {
      x = std::clamp<std::int64_t>(x, 0, xMax - 1);
      y = std::clamp<std::int64_t>(y, 0, yMax - 1);
    }
    if (x < 0 || y < 0 || x >= xMax || y >= yMax) return 0.0; // outside the matrix: transparent
    x = std::clamp(x, x0, x1);
    y = std::clamp(y, y0, y1);
    const auto it = mosaic.find({y / m.tileHeight, x / m.tileWidth});
    if (it == mosaic.end()) return 0.0; // a tile the server does not have: transparent
    const auto& t = it->second;
    const auto i = (static_cast<std::size_t>(y % m.tileHeight) * static_cast<std::size_t>(t.width) +
                    static_cast<std::size_t>(x % m.tileWidth)) *
                   4;
    return t.px[i + static_cast<std::size_t>(c)];
  };
  const bool jpeg = mimeType == "image/jpeg";
  const int channels = jpeg ? 3 : 4;
  std::vector<std::uint8_t> out(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) *
                                static_cast<std::size_t>(channels));
  const double pxW = (sector.east - sector.west) / width;
  const double pxH = (sector.north - sector.south) / height;
  // Source pixel coordinates of the output's columns and rows: linear in lat/long sets; in Web
  // Mercator ones x of the longitude and y of the latitude (MapBox.hpp's formulas), rows beyond
  // the square (+-85.0511 degrees) left empty.
  std::vector<double> us(static_cast<std::size_t>(width));
  for (int x = 0; x < width; ++x) {
    const double lon = sector.west + (x + 0.5) * pxW;
    us[static_cast<std::size_t>(x)] =
        tiles.mercator ? wmtsmercator::columnOf(m, lon) : (lon - m.west) / m.pixelDeg - 0.5;
  }
  for (int y = 0; y < height; ++y) {
    const double lat = sector.north - (y + 0.5) * pxH;
    if (tiles.mercator && std::fabs(lat) > mercator::kMaxLatitude) continue; // nothing: zeros
    const double v =
        tiles.mercator ? wmtsmercator::rowOf(m, lat) : (m.north - lat) / m.pixelDeg - 0.5;
    const double vf = std::floor(v);
    const double fy = v - vf;
    const auto sy = static_cast<std::int64_t>(vf);
    for (int x = 0; x < width; ++x) {
      const double u = us[static_cast<std::size_t>(x)];
      const double uf = std::floor(u);
      const double fx = u - uf;
      const auto sx = static_cast<std::int64_t>(uf);
      // Premultiplied by alpha, so that a transparent neighbour does not darken the edge.
      double acc[4] = {0, 0, 0, 0};
      const double w[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
      const std::int64_t xs[4] = {sx, sx + 1, sx, sx + 1};
      const std::int64_t ys[4] = {sy, sy, sy + 1, sy + 1};
      for (int k = 0; k < 4; ++k) {
        if (w[k] == 0.0) continue; // not needed (and perhaps not fetched)
        const double a = sample(xs[k], ys[k], 3) / 255.0;
        for (int c = 0; c < 3; ++c)
          acc[c] += w[k] * a * sample(xs[k], ys[k], c);
        acc[3] += w[k] * a;
      }
      std::uint8_t* d =
          out.data() + (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                        static_cast<std::size_t>(x)) *
                           static_cast<std::size_t>(channels);
      for (int c = 0; c < 3; ++c)
        d[c] = static_cast<std::uint8_t>(
            std::clamp(std::lround(acc[3] > 0 ? acc[c] / acc[3] : 0.0), 0L, 255L));
      if (!jpeg)
        d[3] = static_cast<std::uint8_t>(std::clamp(std::lround(acc[3] * 255.0), 0L, 255L));
    }
  }
  auto encoded = jpeg ? codec::encodeJpeg(width, height, 3, out.data())
                      : codec::encodePng(width, height, 4, out.data());
  if (!encoded) return std::unexpected("cannot encode the composed tile: " + encoded.error());
  return std::move(*encoded);
}

} // namespace tellus
