#include "RawSamples.hpp"

#include <tellus/codec/Png.hpp>
#include <tellus/values/ValueFormat.hpp>

#include <bit>
#include <cmath>
#include <cstdint>
#include <string>

namespace tellus::values {

namespace {

using Error = std::unexpected<std::string>;
using detail::RawSamples;

std::size_t sampleBytes(Encoding e) noexcept {
  return e == Encoding::Float32 ? 4 : 2;
}

std::expected<RawSamples, std::string>
readBil(std::span<const std::byte> bytes, const ValueFormat& format, int width, int height) {
  if (width <= 0 || height <= 0) return Error("a BIL tile needs its width and height");
  const std::size_t size = sampleBytes(format.encoding);
  const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  if (bytes.size() != n * size)
    return Error("the BIL tile has " + std::to_string(bytes.size()) + " bytes, not " +
                 std::to_string(n * size));
  const bool little = format.byteOrder == ByteOrder::Little;
  RawSamples out{width, height, format.encoding, std::vector<float>(n)};
  for (std::size_t i = 0; i < n; ++i) {
    std::uint32_t raw = 0;
    for (std::size_t b = 0; b < size; ++b) {
      const auto byte = static_cast<std::uint32_t>(bytes[i * size + (little ? size - 1 - b : b)]);
      raw = (raw << 8) | byte;
    }
    if (format.encoding == Encoding::Float32)
      out.samples[i] = std::bit_cast<float>(raw);
    else if (format.encoding == Encoding::UInt16)
      out.samples[i] = static_cast<float>(raw);
    else
      out.samples[i] =
          static_cast<float>(std::bit_cast<std::int16_t>(static_cast<std::uint16_t>(raw)));
  }
  return out;
}

std::expected<RawSamples, std::string>
readPng(std::span<const std::byte> bytes, const ValueFormat& format, int width, int height) {
  if (format.encoding == Encoding::Float32) return Error("a PNG holds no Float32 samples");
  // decodePngGrey wants the size: read it from the IHDR chunk (bytes 16-23) when not given.
  if ((width <= 0 || height <= 0) && bytes.size() >= 24) {
    auto be32 = [&](std::size_t at) {
      std::uint32_t v = 0;
      for (std::size_t k = 0; k < 4; ++k)
        v = (v << 8) | static_cast<std::uint32_t>(bytes[at + k]);
      return v;
    };
    if (be32(16) > kMaxSide || be32(20) > kMaxSide)
      return Error("the PNG is larger than " + std::to_string(kMaxSide) + " pixels");
    width = static_cast<int>(be32(16));
    height = static_cast<int>(be32(20));
  }
  auto grey = codec::decodePngGrey(bytes, width, height);
  if (!grey) return Error(grey.error());
  if (grey->bitDepth != 16) return Error("the PNG is 8-bit; value PNGs must be 16-bit greyscale");
  RawSamples out{width, height, format.encoding, std::vector<float>(grey->samples.size())};
  for (std::size_t i = 0; i < grey->samples.size(); ++i) {
    const std::uint16_t s = grey->samples[i];
    out.samples[i] = format.encoding == Encoding::UInt16
                         ? static_cast<float>(s)
                         : static_cast<float>(std::bit_cast<std::int16_t>(s));
  }
  return out;
}

std::expected<RawSamples, std::string>
readContainer(std::span<const std::byte> bytes, const ValueFormat& format, int width, int height) {
  if (width > kMaxSide || height > kMaxSide)
    return Error("a value tile larger than " + std::to_string(kMaxSide) + " pixels is refused");
  switch (format.container) {
  case Container::Bil:
    return readBil(bytes, format, width, height);
  case Container::Png:
    return readPng(bytes, format, width, height);
  case Container::Tiff: {
    auto tiff = detail::readTiff(bytes);
    if (tiff && width > 0 && height > 0 && (tiff->width != width || tiff->height != height))
      return Error("the TIFF is " + std::to_string(tiff->width) + " x " +
                   std::to_string(tiff->height) + ", not " + std::to_string(width) + " x " +
                   std::to_string(height));
    return tiff;
  }
  }
  return Error("unknown container");
}

} // namespace

std::expected<ValueRaster, std::string>
decode(std::span<const std::byte> bytes, const ValueFormat& format, int width, int height) {
  auto raw = readContainer(bytes, format, width, height);
  if (!raw) return Error(raw.error());
  ValueRaster out{raw->width, raw->height, std::move(raw->samples)};
  const bool hasNoData = format.noData.has_value();
  const double noData = format.noData.value_or(0.0);
  for (float& v : out.values) {
    if (std::isnan(v) || (hasNoData && static_cast<double>(v) == noData))
      v = std::numeric_limits<float>::quiet_NaN();
    else
      v = static_cast<float>(static_cast<double>(v) * format.scale + format.offset);
  }
  return out;
}

} // namespace tellus::values
