#include <tellus/codec/Image.hpp>

namespace tellus::codec {

Format sniff(std::span<const std::byte> bytes) noexcept {
  if (bytes.size() >= 3 && bytes[0] == std::byte{0xFF} && bytes[1] == std::byte{0xD8} &&
      bytes[2] == std::byte{0xFF})
    return Format::Jpeg;
  if (bytes.size() >= 8 && bytes[0] == std::byte{0x89} && bytes[1] == std::byte{'P'} &&
      bytes[2] == std::byte{'N'} && bytes[3] == std::byte{'G'})
    return Format::Png;
  return Format::Unknown;
}

} // namespace tellus::codec
