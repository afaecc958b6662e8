// libFuzzer target: bytes from an upstream or a cache file through the values module's decoders
// (issue 24): its own baseline TIFF reader (strips, tiles, Deflate, predictor, both byte orders),
// BIL in every sample type and byte order, 16-bit PNG; then the point sampler and the colour
// scale on what decoded. Besides the sanitizers, the documented shape of every success is checked.

#include "FuzzCheck.hpp"

#include <tellus/values/ColourScale.hpp>
#include <tellus/values/ValueFormat.hpp>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>

namespace {

using namespace tellus;

void check(const std::expected<values::ValueRaster, std::string>& r, int w, int h) {
  if (!r) {
    TELLUS_FUZZ_CHECK(!r.error().empty());
    return;
  }
  TELLUS_FUZZ_CHECK(r->width > 0 && r->height > 0);
  TELLUS_FUZZ_CHECK(r->width <= values::kMaxSide && r->height <= values::kMaxSide);
  TELLUS_FUZZ_CHECK(w <= 0 || (r->width == w && r->height == h));
  TELLUS_FUZZ_CHECK(r->values.size() ==
                    static_cast<std::size_t>(r->width) * static_cast<std::size_t>(r->height));
  const float v = values::sample(*r, r->width / 2.0, r->height / 2.0);
  const values::ColourScale scale{values::findColourMap("viridis"), -1.0, 1.0};
  const int index = values::colourIndex(scale, v);
  TELLUS_FUZZ_CHECK(index >= -1 && index <= 255);
  TELLUS_FUZZ_CHECK((index == -1) == std::isnan(v));
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::byte> bytes(reinterpret_cast<const std::byte*>(data), size);
  values::ValueFormat f;
  f.noData = -32768.0;
  f.container = values::Container::Tiff;
  check(values::decode(bytes, f), 0, 0);
  f.container = values::Container::Png;
  for (const auto e : {values::Encoding::Int16, values::Encoding::UInt16})
    f.encoding = e, check(values::decode(bytes, f), 0, 0);
  f.container = values::Container::Bil;
  for (const auto e : {values::Encoding::Int16, values::Encoding::Float32})
    for (const auto o : {values::ByteOrder::Little, values::ByteOrder::Big}) {
      f.encoding = e;
      f.byteOrder = o;
      const int side = static_cast<int>(
          std::sqrt(static_cast<double>(size / (e == values::Encoding::Float32 ? 4 : 2))));
      if (side > 0) check(values::decode(bytes, f, side, side), side, side);
    }
  return 0;
}
