// The PFM reader of tellus::mpcdi (Mpcdi.hpp).

#include <tellus/mpcdi/Mpcdi.hpp>

#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>

namespace tellus::mpcdi {
namespace {

bool isSpace(char c) {
  return std::isspace(static_cast<unsigned char>(c)) != 0;
}

/** The next whitespace-separated token from `at`, and the one whitespace byte after it. */
std::string_view token(std::string_view bytes, std::size_t& at) {
  while (at < bytes.size() && isSpace(bytes[at]))
    ++at;
  const std::size_t begin = at;
  while (at < bytes.size() && !isSpace(bytes[at]))
    ++at;
  const std::string_view t = bytes.substr(begin, at - begin);
  if (at < bytes.size()) ++at; // the single separator
  return t;
}

std::uint32_t swapBytes(std::uint32_t u) {
  return (u >> 24) | ((u >> 8) & 0xff00u) | ((u << 8) & 0xff0000u) | (u << 24);
}

} // namespace

std::expected<Pfm, std::string> parsePfm(std::string_view bytes, std::string_view origin) {
  const std::string o(origin);
  if (bytes.size() < 2 || bytes[0] != 'P' || (bytes[1] != 'F' && bytes[1] != 'f'))
    return std::unexpected(o + ": not a PFM (it must begin with \"PF\")");
  if (bytes[1] == 'f')
    return std::unexpected(o + ": a grey PFM (\"Pf\"); an MPCDI warp has three floats a texel");
  std::size_t at = 2;
  if (at >= bytes.size() || !isSpace(bytes[at]))
    return std::unexpected(o + ": not a PFM (it must begin with \"PF\")");
  Pfm pfm;
  const std::string_view w = token(bytes, at), h = token(bytes, at);
  for (const auto& [text, out] : {std::pair{w, &pfm.width}, std::pair{h, &pfm.height}}) {
    const auto r = std::from_chars(text.data(), text.data() + text.size(), *out);
    if (r.ec != std::errc() || r.ptr != text.data() + text.size() || *out < 1 || *out > 16384)
      return std::unexpected(o + ": PFM header: width and height must be integers in [1, 16384]");
  }
  // The scale: its sign gives the byte order. std::from_chars for double is in GCC 12.
  const std::string_view s = token(bytes, at);
  double scale = 0.0;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), scale);
  if (r.ec != std::errc() || r.ptr != s.data() + s.size() || scale == 0.0 || !std::isfinite(scale))
    return std::unexpected(o + ": PFM header: the scale must be a non-zero number");
  const bool little = scale < 0.0;
  const std::size_t texels =
      static_cast<std::size_t>(pfm.width) * static_cast<std::size_t>(pfm.height);
  const std::size_t need = texels * 3 * 4;
  const std::size_t have = bytes.size() - std::min(at, bytes.size());
  if (have < need)
    return std::unexpected(o + ": truncated: " + std::to_string(have) + " bytes of texels, " +
                           std::to_string(pfm.width) + " x " + std::to_string(pfm.height) +
                           " needs " + std::to_string(need));
  if (have > need)
    return std::unexpected(o + ": the size disagrees with the data: " + std::to_string(pfm.width) +
                           " x " + std::to_string(pfm.height) + " needs " + std::to_string(need) +
                           " bytes of texels, the file has " + std::to_string(have));
  pfm.xyz.resize(texels * 3);
  const std::size_t row = static_cast<std::size_t>(pfm.width) * 3;
  for (int y = 0; y < pfm.height; ++y) {
    // The file's first row is the image's bottom row.
    const std::size_t src = at + static_cast<std::size_t>(pfm.height - 1 - y) * row * 4;
    for (std::size_t i = 0; i < row; ++i) {
      std::uint32_t u = 0;
      std::memcpy(&u, bytes.data() + src + i * 4, 4);
      if ((std::endian::native == std::endian::little) != little) u = swapBytes(u);
      const float f = std::bit_cast<float>(u);
      if (std::isinf(f))
        return std::unexpected(o + ": texel (" + std::to_string(i / 3) + ", " + std::to_string(y) +
                               ") from the top left is infinite");
      pfm.xyz[static_cast<std::size_t>(y) * row + i] = f;
    }
  }
  return pfm;
}

} // namespace tellus::mpcdi
