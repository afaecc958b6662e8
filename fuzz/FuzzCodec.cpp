// libFuzzer target: bytes from an upstream or a cache file through every decoder of the codec
// module (tellus::codec): the JPEG header probe, whole and region decodes, validation, the
// composer's YCbCr planes, the DCT-domain split, PNG pictures and grey samples. Every libjpeg
// error must come back through the module's one error wrapper as a value; besides the sanitizers,
// the documented shape of every success is checked (a violation traps).

#include "FuzzCheck.hpp"

#include <tellus/codec/Jpeg.hpp>
#include <tellus/codec/JpegSplit.hpp>
#include <tellus/codec/JpegYcc.hpp>
#include <tellus/codec/Png.hpp>

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace {

using namespace tellus;

// Larger images are real but only cost memory here: the fuzzer's RSS limit is 2 GiB.
constexpr long kMaxPixels = 1 << 20;

std::size_t area(int w, int h) {
  return static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
}

void fuzzJpeg(std::span<const std::byte> bytes) {
  const auto info = codec::probeJpeg(bytes);
  if (!info) return;
  TELLUS_FUZZ_CHECK(info->width > 0 && info->height > 0);
  const int w = info->width, h = info->height;
  if (static_cast<long>(w) * h > kMaxPixels) return;
  for (const int channels : {0, 4}) {
    const auto img =
        codec::decodeJpeg(bytes, {.channels = channels, .fancyUpsampling = channels != 0});
    if (!img) continue;
    TELLUS_FUZZ_CHECK(img->width == w && img->height == h);
    TELLUS_FUZZ_CHECK(img->pixels.size() == area(w, h) * static_cast<std::size_t>(img->channels));
  }
  std::vector<std::uint8_t> px;
  const bool checked = codec::checkJpeg(bytes, w, h, px).has_value();
  const auto whole = codec::decodeJpegInto(bytes, w, h, px);
  TELLUS_FUZZ_CHECK(!checked || whole.has_value());
  if (whole) TELLUS_FUZZ_CHECK(*whole == 3 && px.size() == area(w, h) * 3);
  const codec::Region region{w / 3, h / 3, w / 2 + 1, h / 2 + 1};
  (void)codec::decodeJpegInto(bytes, w, h, px, &region);
  if (w % 16 == 0 && h % 16 == 0) {
    std::vector<std::uint8_t> planes(area(w, h) * 3 / 2);
    std::uint8_t* y = planes.data();
    std::uint8_t* cb = y + area(w, h);
    std::uint8_t* cr = cb + area(w, h) / 4;
    std::string message;
    (void)codec::decodeJpegYcc(bytes, w, h, nullptr, y, cb, cr, message);
    (void)codec::decodeJpegYcc(bytes, w, h, &region, y, cb, cr, message);
    (void)codec::decodesFromSegments(bytes, w, h, region);
  }
  for (const int parts : {1, 2}) {
    if (w % parts != 0 || h % parts != 0) continue;
    const auto tiles = codec::splitJpegDct(bytes, parts, parts, w / parts, h / parts);
    if (!tiles) continue;
    TELLUS_FUZZ_CHECK(tiles->size() == static_cast<std::size_t>(parts * parts));
    for (const auto& tile : *tiles) {
      const auto t = codec::probeJpeg(tile);
      TELLUS_FUZZ_CHECK(t && t->width == w / parts && t->height == h / parts);
    }
  }
}

/** The size in a PNG's IHDR (the first chunk, right after the signature), or 0 x 0. */
std::pair<long, long> pngSize(std::span<const std::byte> b) {
  if (b.size() < 24) return {0, 0};
  const auto be32 = [&](std::size_t at) {
    long v = 0;
    for (std::size_t i = 0; i < 4; ++i)
      v = v << 8 | std::to_integer<long>(b[at + i]);
    return v;
  };
  return {be32(16), be32(20)};
}

void fuzzPng(std::span<const std::byte> bytes) {
  const auto [w, h] = pngSize(bytes);
  if (w <= 0 || h <= 0 || w > kMaxPixels || h > kMaxPixels || w * h > kMaxPixels) return;
  const auto img = codec::decodePng(bytes);
  if (img) {
    TELLUS_FUZZ_CHECK(img->width == w && img->height == h && img->channels == 4);
    TELLUS_FUZZ_CHECK(img->pixels.size() == area(img->width, img->height) * 4);
  }
  const int iw = static_cast<int>(w), ih = static_cast<int>(h);
  std::vector<std::uint8_t> px;
  const auto into = codec::decodePngInto(bytes, iw, ih, px);
  if (into)
    TELLUS_FUZZ_CHECK((*into == 3 || *into == 4) &&
                      px.size() == area(iw, ih) * static_cast<std::size_t>(*into));
  (void)codec::checkPng(bytes, iw, ih, px);
  const auto grey = codec::decodePngGrey(bytes, iw, ih);
  if (grey) {
    TELLUS_FUZZ_CHECK(grey->bitDepth == 8 || grey->bitDepth == 16);
    TELLUS_FUZZ_CHECK(grey->samples.size() == area(iw, ih));
  }
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::byte> bytes(reinterpret_cast<const std::byte*>(data), size);
  // Every decoder sees every input: a PNG given to the JPEG decoders is bad input too.
  fuzzJpeg(bytes);
  fuzzPng(bytes);
  return 0;
}
