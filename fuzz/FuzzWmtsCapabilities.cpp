// libFuzzer target: a WMTS upstream's capabilities (parseWmtsCapabilities over the MiniXml reader)
// and what is made of them (bindWmtsLayer onto a 36-degree grid, tile URLs, the source tiles of
// composed levels). Whatever the bytes, no crash, no sanitizer report; a bound layer has one
// matrix per grid level, a URL made for a key of the grid is never empty, a composed tile needs
// at most 64 source tiles, all inside the matrix.

#include "FuzzCheck.hpp"

#include <tellus/proxy/WmtsUpstream.hpp>

#include <cstddef>
#include <cstdint>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace tellus;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  auto caps = parseWmtsCapabilities(text);
  if (!caps) {
    TELLUS_FUZZ_CHECK(!caps.error().empty());
    return 0;
  }
  for (const WmtsLayer& l : caps->layers) {
    for (const std::string& format : l.formats) {
      WmtsChoice c;
      c.layer = l.identifier;
      c.format = format;
      c.capabilitiesUrl = "http://fuzz.example/wmts?REQUEST=GetCapabilities";
      for (const std::int32_t levels : {1, 3}) {
        auto t = bindWmtsLayer(*caps, c, GridSpec{Sector{}, 36.0, 512, 512, levels});
        if (!t) continue;
        TELLUS_FUZZ_CHECK(t->levels.size() == static_cast<std::size_t>(levels));
        for (std::int32_t level = 0; level < levels; ++level) {
          for (const TileKey k : {TileKey{level, 0, 0}, TileKey{level, (5 << level) - 1, 3}}) {
            const auto url = wmtsTileUrl(*t, k, "2014-02-07");
            TELLUS_FUZZ_CHECK(!url || !url->empty());
            TELLUS_FUZZ_CHECK(!url || !wmtsComposed(*t, k));
            const double d = 36.0 / (1 << level);
            const Sector s{-180.0 + static_cast<double>(k.col) * d,
                           -90.0 + static_cast<double>(k.row) * d,
                           -180.0 + static_cast<double>(k.col + 1) * d,
                           -90.0 + static_cast<double>(k.row + 1) * d};
            const auto sources = wmtsSourceTiles(*t, k, s, 512, 512, "");
            TELLUS_FUZZ_CHECK(sources.size() <= 64);
            for (const auto& src : sources)
              TELLUS_FUZZ_CHECK(src.row >= 0 && src.col >= 0 && !src.url.empty());
          }
        }
      }
    }
  }
  return 0;
}
