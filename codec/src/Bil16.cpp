#include <tellus/codec/Bil16.hpp>

namespace tellus::codec {

std::expected<std::vector<std::int16_t>, std::string>
decodeBil16(std::span<const std::byte> bytes, int width, int height) {
  if (width < 0 || height < 0) return std::unexpected("bad image shape");
  const auto n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  if (bytes.size() != n * 2)
    return std::unexpected("the bil16 tile has " + std::to_string(bytes.size()) + " bytes, not " +
                           std::to_string(n * 2));
  std::vector<std::int16_t> heights(n);
  for (std::size_t k = 0; k < n; ++k) {
    const auto lo = static_cast<std::uint16_t>(bytes[2 * k]);
    const auto hi = static_cast<std::uint16_t>(bytes[2 * k + 1]);
    heights[k] = static_cast<std::int16_t>(static_cast<std::uint16_t>(lo | (hi << 8)));
  }
  return heights;
}

Bytes encodeBil16(int width, int height, const std::int16_t* heights) {
  if (width < 0 || height < 0 || !heights) return {};
  const auto n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  Bytes out(n * 2);
  for (std::size_t k = 0; k < n; ++k) { // little-endian whatever the host
    const auto u = static_cast<std::uint16_t>(heights[k]);
    out[2 * k] = static_cast<std::byte>(u & 0xFF);
    out[2 * k + 1] = static_cast<std::byte>(u >> 8);
  }
  return out;
}

} // namespace tellus::codec
