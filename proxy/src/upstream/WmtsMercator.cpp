// Web Mercator upstream matrix sets on a lat/long grid (WmtsMercator.hpp).

#include "WmtsMercator.hpp"

#include <tellus/proxy/MapBox.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>

namespace tellus::wmtsmercator {

namespace {

constexpr double kPixelMetres = 0.00028; ///< OGC WMTS 1.0.0's standardized rendering pixel
constexpr double kCornerToleranceM = 1.0;
constexpr double kSpanToleranceTiles = 1e-3;

std::string number(double v) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

} // namespace

bool isMercatorCrs(std::string_view crs) noexcept {
  const std::size_t cut = crs.find_last_of(":/");
  if (cut == std::string_view::npos) return false;
  const std::string_view code = crs.substr(cut + 1);
  std::string upper;
  for (const char c : crs.substr(0, cut))
    upper += (c >= 'a' && c <= 'z') ? static_cast<char>(c - 32) : c;
  if (upper.find("OSGEO") != std::string::npos) return code == "41001";
  if (upper.find("EPSG") == std::string::npos && upper.find("ESRI") == std::string::npos)
    return false;
  return code == "3857" || code == "900913" || code == "3785" || code == "102100" ||
         code == "102113";
}

std::expected<std::vector<WmtsMatrixGeometry>, std::string>
matrices(const UpstreamTileMatrixSet& set) {
  std::vector<WmtsMatrixGeometry> out;
  const std::string what = "tile matrix set '" + set.identifier + "' (" + set.crs + ")";
  if (set.matrices.empty()) return std::unexpected(what + " has no matrices");
  for (const UpstreamTileMatrix& m : set.matrices) {
    const std::string mw = what + ": matrix '" + m.identifier + "'";
    if (std::fabs(m.topLeftX + mercator::kMaxY) > kCornerToleranceM ||
        std::fabs(m.topLeftY - mercator::kMaxY) > kCornerToleranceM)
      return std::unexpected(mw + " has its top-left corner at " + number(m.topLeftX) + " " +
                             number(m.topLeftY) +
                             ", not at the Web Mercator square's (-20037508.34 20037508.34)");
    if (m.tileWidth < 1 || m.tileWidth != m.tileHeight)
      return std::unexpected(mw + " has tiles of " + std::to_string(m.tileWidth) + " x " +
                             std::to_string(m.tileHeight) +
                             " pixels: Web Mercator tiles are square");
    const double pixel = m.scaleDenominator * kPixelMetres;
    const double tiles = 2.0 * mercator::kMaxY / (pixel * m.tileWidth); // tiles across the square
    const double zoom = std::round(std::log2(tiles));
    if (!(pixel > 0.0) || zoom < 0.0 || zoom > 30.0 ||
        std::fabs(tiles - std::ldexp(1.0, static_cast<int>(zoom))) > kSpanToleranceTiles)
      return std::unexpected(mw + " has tiles of " + number(pixel * m.tileWidth) +
                             " m: the square's side over a power of two is expected (scale " +
                             number(m.scaleDenominator) + ", " + std::to_string(m.tileWidth) +
                             " px)");
    const double n = std::ldexp(1.0, static_cast<int>(zoom));
    if (m.matrixWidth < 1 || m.matrixHeight < 1 || static_cast<double>(m.matrixWidth) > n ||
        static_cast<double>(m.matrixHeight) > n)
      return std::unexpected(mw + " is " + std::to_string(m.matrixWidth) + " x " +
                             std::to_string(m.matrixHeight) + " tiles: zoom " + number(zoom) +
                             " has " + number(n) + " x " + number(n));
    WmtsMatrixGeometry g;
    g.identifier = m.identifier;
    g.originX = m.topLeftX;
    g.originY = m.topLeftY;
    g.pixelMetres = pixel;
    g.west = mercator::longitudeOfX(m.topLeftX);
    g.north = mercator::kMaxLatitude;
    g.pixelDeg = mercator::longitudeOfX(pixel); // the longitude span, the same at every latitude
    g.tileWidth = m.tileWidth;
    g.tileHeight = m.tileHeight;
    g.matrixWidth = m.matrixWidth;
    g.matrixHeight = m.matrixHeight;
    out.push_back(std::move(g));
  }
  return out;
}

int zoomOf(const WmtsMatrixGeometry& m) noexcept {
  return static_cast<int>(
      std::lround(std::log2(2.0 * mercator::kMaxY / (m.pixelMetres * m.tileWidth))));
}

double columnOf(const WmtsMatrixGeometry& m, double lon) noexcept {
  return (mercator::xOfLongitude(lon) - m.originX) / m.pixelMetres - 0.5;
}

double rowOf(const WmtsMatrixGeometry& m, double lat) noexcept {
  return (m.originY - mercator::yOfLatitude(lat)) / m.pixelMetres - 0.5;
}

TileRange sourceRange(const WmtsMatrixGeometry& m, const Sector& s, int width, int height) {
  TileRange out;
  if (width < 1 || height < 1) return out;
  const double pxW = (s.east - s.west) / width;
  const double pxH = (s.north - s.south) / height;
  // The rows whose centres lie inside the square (the others are drawn as nothing).
  const auto latOf = [&](int j) { return s.north - (j + 0.5) * pxH; };
  int jTop = 0, jBottom = height - 1;
  while (jTop < height && latOf(jTop) > mercator::kMaxLatitude)
    ++jTop;
  while (jBottom >= 0 && latOf(jBottom) < -mercator::kMaxLatitude)
    --jBottom;
  if (jTop > jBottom) return out;
  // (A millionth of a pixel of slack: a weight that small is no reason to fetch a tile.)
  const auto lo = [](double v) { return std::floor(v + 1e-6); };
  const auto hi = [](double v) { return std::ceil(v - 1e-6); };
  const double u0 = lo(columnOf(m, s.west + 0.5 * pxW));
  const double u1 = hi(columnOf(m, s.east - 0.5 * pxW));
  const double v0 = lo(rowOf(m, latOf(jTop)));
  const double v1 = hi(rowOf(m, latOf(jBottom)));
  const double mw = static_cast<double>(m.matrixWidth) * m.tileWidth;
  const double mh = static_cast<double>(m.matrixHeight) * m.tileHeight;
  if (u1 < 0 || v1 < 0 || u0 >= mw || v0 >= mh) return out;
  // Samples past the matrix's edges repeat its edge pixels, or are transparent for a regional
  // matrix (composeWmtsTile): the range is clamped to it, no tile beyond the antimeridian or the
  // square is asked for.
  const auto tileOf = [](double px, double max, std::int32_t size) {
    return static_cast<std::int64_t>(std::clamp(px, 0.0, max - 1) / size);
  };
  out.c0 = tileOf(u0, mw, m.tileWidth);
  out.c1 = tileOf(u1, mw, m.tileWidth);
  out.r0 = tileOf(v0, mh, m.tileHeight);
  out.r1 = tileOf(v1, mh, m.tileHeight);
  return out;
}

} // namespace tellus::wmtsmercator
