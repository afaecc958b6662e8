#include "HeightDecode.hpp"

#include <tellus/codec/Png.hpp>
#include <tellus/planet/HeightStreamer.hpp>
#include <tellus/planet_gl/Renderer.hpp>

#include <vector>

namespace tellus::planet {

namespace {

/** A 16-bit (height + 32768) or 8-bit greyscale PNG's samples, row 0 at the top, as raw numbers. */
std::expected<std::vector<double>, std::string>
readGreyPng(std::span<const std::byte> bytes, int width, int height) {
  auto grey = codec::decodePngGrey(bytes, width, height);
  if (!grey) {
    const std::string& e = grey.error();
    if (e.starts_with("the PNG ")) return std::unexpected("the elevation " + e.substr(4));
    return std::unexpected(e);
  }
  std::vector<double> out;
  out.reserve(grey->samples.size());
  for (const std::uint16_t v : grey->samples)
    // tellus stores heights in 16-bit PNGs as height + 32768 (the proxy's encodeHeights /
    // decodeHeights), so that is undone here.
    out.push_back(grey->bitDepth == 16 ? static_cast<double>(v) - 32768.0 : static_cast<double>(v));
  return out;
}

} // namespace

std::expected<HeightTile, std::string> decodeHeights(const TileKey& key,
                                                     int width,
                                                     int height,
                                                     std::span<const std::byte> bytes,
                                                     std::string_view contentType,
                                                     const HeightEncoding& encoding) {
  if (contentType.starts_with("image/png")) {
    auto raw = readGreyPng(bytes, width, height);
    if (!raw) return std::unexpected(raw.error());
    return heightTileFromSamples(key, width, height, *raw, encoding);
  }
  return decodeHeightsBil16Only(key, width, height, bytes, contentType, encoding);
}

std::expected<HeightTile, std::string> decodeHeightTile(const TileKey& key,
                                                        int width,
                                                        int height,
                                                        std::span<const std::byte> bytes,
                                                        std::string_view contentType,
                                                        const HeightEncoding& encoding) {
  return decodeHeights(key, width, height, bytes, contentType, encoding);
}

} // namespace tellus::planet
