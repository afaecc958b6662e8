// Damaged bytes through every decoder of the module: truncated at every length and corrupted at
// random, each must answer with a value (an image or an error), never crash, hang or leak (the
// sanitizer builds run these too). This is what the one libjpeg error wrapper is for.

#include "CodecTestSupport.hpp"

#include <tellus/codec/Jpeg.hpp>
#include <tellus/codec/Png.hpp>

#include <gtest/gtest.h>

#include <random>

using namespace tellus;
using test::testPixels;

namespace {

/** Every decoder that takes JPEG bytes, on `bytes` said to be w x h; how many gave an error. */
int decodeJpegEveryWay(const codec::Bytes& bytes, int w, int h) {
  std::vector<std::uint8_t> px;
  const codec::Region r{w / 4, h / 4, w / 2, h / 2};
  int errors = 0;
  errors += !codec::probeJpeg(bytes).has_value();
  errors += !codec::decodeJpeg(bytes, {.channels = 4}).has_value();
  errors += !codec::decodeJpeg(bytes, {.channels = 0, .fancyUpsampling = false}).has_value();
  errors += !codec::decodeJpegInto(bytes, w, h, px).has_value();
  errors += !codec::decodeJpegInto(bytes, w, h, px, &r).has_value();
  errors += !codec::checkJpeg(bytes, w, h, px).has_value();
  return errors;
}

int decodePngEveryWay(const codec::Bytes& bytes, int w, int h) {
  std::vector<std::uint8_t> px;
  int errors = 0;
  errors += !codec::decodePng(bytes).has_value();
  errors += !codec::decodePngInto(bytes, w, h, px).has_value();
  errors += !codec::checkPng(bytes, w, h, px).has_value();
  errors += !codec::decodePngGrey(bytes, w, h).has_value();
  return errors;
}

/** `bytes` with `count` random bytes replaced (the first two kept, so that it still looks like
 * the format to whoever sniffs). */
codec::Bytes corrupted(const codec::Bytes& bytes, std::mt19937& rng, int count) {
  codec::Bytes out = bytes;
  std::uniform_int_distribution<std::size_t> at(2, out.size() - 1);
  std::uniform_int_distribution<int> value(0, 255);
  for (int i = 0; i < count; ++i)
    out[at(rng)] = static_cast<std::byte>(value(rng));
  return out;
}

} // namespace

TEST(CorruptInput, JpegTruncatedAtEveryLengthIsAnErrorOrAnImage) {
  for (const int channels : {1, 3}) {
    const auto px = testPixels(48, 40, channels);
    const auto jpeg = *codec::encodeJpeg(48, 40, channels, px.data(), {.restartInterval = 2});
    int errors = 0;
    for (std::size_t n = 0; n < jpeg.size(); ++n)
      errors += decodeJpegEveryWay(
          codec::Bytes(jpeg.begin(), jpeg.begin() + static_cast<std::ptrdiff_t>(n)), 48, 40);
    EXPECT_GT(errors, 0);
    EXPECT_EQ(decodeJpegEveryWay(jpeg, 48, 40), 0);
  }
}

TEST(CorruptInput, JpegWithRandomBytesReplacedIsAnErrorOrAnImage) {
  const auto px = testPixels(64, 48, 3);
  const auto jpeg = *codec::encodeJpeg(64, 48, 3, px.data(), {.restartInterval = 4});
  std::mt19937 rng(2024);
  int errors = 0;
  for (int k = 0; k < 400; ++k)
    errors += decodeJpegEveryWay(corrupted(jpeg, rng, 1 + k % 8), 64, 48);
  EXPECT_GT(errors, 0);
}

TEST(CorruptInput, PngTruncatedAtEveryLengthIsAnError) {
  const auto px = testPixels(24, 20, 4);
  const auto png = *codec::encodePng(24, 20, 4, px.data());
  for (std::size_t n = 0; n < png.size(); ++n) {
    const codec::Bytes part(png.begin(), png.begin() + static_cast<std::ptrdiff_t>(n));
    std::vector<std::uint8_t> out;
    const int errors = decodePngEveryWay(part, 24, 20);
    // Cut before the end chunk (IEND, 12 bytes): the samples or their checksum are missing.
    if (n + 12 < png.size()) {
      EXPECT_EQ(errors, 4) << n;
    }
  }
  const std::vector<std::uint16_t> grey(24 * 20, 40000);
  const auto png16 = test::handWrittenPng(24, 20, 16, 0, grey);
  ASSERT_TRUE(codec::decodePngGrey(png16, 24, 20));
  for (std::size_t n = 0; n + 12 < png16.size(); ++n) // all but IEND: the samples are cut
    EXPECT_FALSE(codec::decodePngGrey(
        codec::Bytes(png16.begin(), png16.begin() + static_cast<std::ptrdiff_t>(n)), 24, 20))
        << n;
}

TEST(CorruptInput, PngWithRandomBytesReplacedIsAnErrorOrAnImage) {
  const auto px = testPixels(32, 16, 3);
  const auto png = *codec::encodePng(32, 16, 3, px.data());
  const std::vector<std::uint16_t> grey(32 * 16, 1234);
  const auto png16 = test::handWrittenPng(32, 16, 16, 0, grey);
  std::mt19937 rng(7);
  int errors = 0;
  for (int k = 0; k < 300; ++k) {
    errors += decodePngEveryWay(corrupted(png, rng, 1 + k % 5), 32, 16);
    errors += decodePngEveryWay(corrupted(png16, rng, 1 + k % 5), 32, 16);
  }
  EXPECT_GT(errors, 0);
}
