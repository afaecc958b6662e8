#include "tiles/MetaTile.hpp"

#include <tellus/codec/Jpeg.hpp>
#include <tellus/codec/JpegSplit.hpp>
#include <tellus/codec/Png.hpp>

#include <algorithm>
#include <cstring>

namespace tellus {

TileBlock metaTileOf(const TileGrid& grid, const TileKey& key, std::int32_t n) noexcept {
  n = std::max<std::int32_t>(1, n);
  const std::int64_t rowsAll = grid.rowCount(key.level);
  const std::int64_t colsAll = grid.colCount(key.level);
  std::int64_t r0 = key.row - key.row % n;
  std::int64_t c0 = key.col - key.col % n;
  std::int64_t r1 = std::min(r0 + n, rowsAll); // exclusive: the globe's last row / column
  std::int64_t c1 = std::min(c0 + n, colsAll);
  // A partial dataset's valid tiles are one rectangle per level: keep the run around the key.
  auto valid = [&](std::int64_t r, std::int64_t c) {
    return grid.isValid(TileKey{key.level, r, c});
  };
  while (r0 < key.row && !valid(r0, key.col))
    ++r0;
  while (r1 - 1 > key.row && !valid(r1 - 1, key.col))
    --r1;
  while (c0 < key.col && !valid(key.row, c0))
    ++c0;
  while (c1 - 1 > key.col && !valid(key.row, c1 - 1))
    --c1;
  return TileBlock{
      key.level, r0, c0, static_cast<std::int32_t>(r1 - r0), static_cast<std::int32_t>(c1 - c0)};
}

TileBlock boundingBlock(std::span<const TileKey> keys) noexcept {
  std::int64_t r0 = keys.front().row, r1 = r0, c0 = keys.front().col, c1 = c0;
  for (const auto& k : keys) {
    r0 = std::min(r0, k.row);
    r1 = std::max(r1, k.row);
    c0 = std::min(c0, k.col);
    c1 = std::max(c1, k.col);
  }
  return TileBlock{keys.front().level,
                   r0,
                   c0,
                   static_cast<std::int32_t>(r1 - r0 + 1),
                   static_cast<std::int32_t>(c1 - c0 + 1)};
}

Sector blockSector(const TileGrid& grid, const TileBlock& b) noexcept {
  const Sector sw = grid.sectorOf(TileKey{b.level, b.row0, b.col0});
  const Sector ne = grid.sectorOf(TileKey{b.level, b.row0 + b.rows - 1, b.col0 + b.cols - 1});
  return Sector{sw.west, sw.south, ne.east, ne.north};
}

namespace {

std::expected<DecodedMetaTile, std::string> decodeMetaTile(std::span<const std::byte> body,
                                                           ImageKind kind,
                                                           int cols,
                                                           int rows,
                                                           int tileWidth,
                                                           int tileHeight) {
  DecodedMetaTile d{kind, cols, rows, tileWidth, tileHeight, {}};
  // The validation's own decoders (a warning is a failure): JPEG into RGB, PNG into RGBA.
  const int width = cols * tileWidth, height = rows * tileHeight;
  auto checked = kind == ImageKind::Jpeg ? codec::checkJpeg(body, width, height, d.pixels)
                                         : codec::checkPng(body, width, height, d.pixels);
  if (!checked) return std::unexpected(checked.error());
  return d;
}

std::expected<SplitTiles, std::string> checkedSplit(std::span<const std::byte> body,
                                                    ImageKind kind,
                                                    int cols,
                                                    int rows,
                                                    int tileWidth,
                                                    int tileHeight,
                                                    bool lazily) {
  if (cols <= 0 || rows <= 0 || tileWidth <= 0 || tileHeight <= 0 ||
      static_cast<long>(cols) * tileWidth > 16384 || static_cast<long>(rows) * tileHeight > 16384)
    return std::unexpected(std::string("metatile size out of range"));
  if (kind == ImageKind::Jpeg) {
    auto cut = codec::splitJpegDct(body, cols, rows, tileWidth, tileHeight);
    if (cut) return SplitTiles{std::move(*cut), MetaSplit::Dct, nullptr};
    if (cut.error().code == codec::JpegSplitErrc::Invalid)
      return std::unexpected(cut.error().message);
  } else if (kind != ImageKind::Png) {
    return std::unexpected(std::string("metatiles of ") + toString(kind) + " are not split");
  }
  auto decoded = decodeMetaTile(body, kind, cols, rows, tileWidth, tileHeight);
  if (!decoded) return std::unexpected(decoded.error());
  SplitTiles out;
  out.how = MetaSplit::Decoded;
  out.decoded = std::make_shared<const DecodedMetaTile>(std::move(*decoded));
  if (lazily) return out;
  const std::size_t n = static_cast<std::size_t>(cols) * static_cast<std::size_t>(rows);
  out.tiles.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    auto encoded = encodeMetaTilePart(*out.decoded, i);
    if (!encoded) return std::unexpected(encoded.error());
    out.tiles.push_back(std::move(*encoded));
  }
  out.decoded.reset();
  return out;
}

} // namespace

std::expected<std::vector<std::byte>, std::string> encodeMetaTilePart(const DecodedMetaTile& d,
                                                                      std::size_t index) {
  const int channels = d.kind == ImageKind::Jpeg ? 3 : 4;
  const auto tw = static_cast<std::size_t>(d.tileWidth);
  const auto th = static_cast<std::size_t>(d.tileHeight);
  const auto ch = static_cast<std::size_t>(channels);
  const auto cols = static_cast<std::size_t>(d.cols);
  const std::size_t tr = index / cols, tc = index % cols;
  std::vector<std::uint8_t> tile(tw * th * ch);
  const std::size_t rowBytes = tw * ch;
  const std::size_t stride = cols * rowBytes;
  const std::uint8_t* from = d.pixels.data() + tr * th * stride + tc * rowBytes;
  for (std::size_t y = 0; y < th; ++y)
    std::memcpy(tile.data() + y * rowBytes, from + y * stride, rowBytes);
  if (d.kind == ImageKind::Jpeg)
    return codec::encodeJpeg(d.tileWidth,
                             d.tileHeight,
                             3,
                             tile.data(),
                             {.restartInterval = codec::kTileRestartInterval});
  bool opaque = true;
  for (std::size_t i = 3; i < tile.size() && opaque; i += 4)
    opaque = tile[i] == 255;
  if (opaque) { // RGB in place: a smaller file for the same pixels
    for (std::size_t i = 0, o = 0; i < tile.size(); i += 4, o += 3) {
      tile[o] = tile[i];
      tile[o + 1] = tile[i + 1];
      tile[o + 2] = tile[i + 2];
    }
  }
  return codec::encodePng(d.tileWidth, d.tileHeight, opaque ? 3 : 4, tile.data());
}

std::expected<SplitTiles, std::string> splitMetaTile(std::span<const std::byte> body,
                                                     ImageKind kind,
                                                     int cols,
                                                     int rows,
                                                     int tileWidth,
                                                     int tileHeight) {
  return checkedSplit(body, kind, cols, rows, tileWidth, tileHeight, false);
}

std::expected<SplitTiles, std::string> splitMetaTileLazily(std::span<const std::byte> body,
                                                           ImageKind kind,
                                                           int cols,
                                                           int rows,
                                                           int tileWidth,
                                                           int tileHeight) {
  return checkedSplit(body, kind, cols, rows, tileWidth, tileHeight, true);
}

} // namespace tellus
