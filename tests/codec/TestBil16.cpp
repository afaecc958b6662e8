// BIL16 (tellus/codec/Bil16.hpp): little-endian signed 16-bit samples whatever the host.

#include <tellus/codec/Bil16.hpp>

#include <gtest/gtest.h>

#include <limits>

using namespace tellus;

TEST(Bil16, BytesAreLittleEndianSigned) {
  const std::vector<std::int16_t> h{0, 1, -1, 0x0102, -32768, 32767};
  const auto bytes = codec::encodeBil16(3, 2, h.data());
  ASSERT_EQ(bytes.size(), 12u);
  const std::vector<int> want{
      0x00, 0x00, 0x01, 0x00, 0xFF, 0xFF, 0x02, 0x01, 0x00, 0x80, 0xFF, 0x7F};
  for (std::size_t i = 0; i < want.size(); ++i)
    EXPECT_EQ(std::to_integer<int>(bytes[i]), want[i]) << i;
  const auto back = codec::decodeBil16(bytes, 3, 2);
  ASSERT_TRUE(back) << back.error();
  EXPECT_EQ(*back, h);
}

TEST(Bil16, TheSizeMustBeExactlyTwoBytesASample) {
  const std::vector<std::byte> odd(2 * 15 + 1);
  const auto e = codec::decodeBil16(odd, 5, 3);
  ASSERT_FALSE(e);
  EXPECT_EQ(e.error(), "the bil16 tile has 31 bytes, not 30");
  EXPECT_FALSE(codec::decodeBil16(std::vector<std::byte>(28), 5, 3));
  EXPECT_FALSE(codec::decodeBil16({}, -1, 3));
  EXPECT_TRUE(codec::encodeBil16(-1, 3, nullptr).empty());
}

TEST(Bil16Extremes, EveryValueOddSizesAndEmptyTiles) {
  // All 65536 values in a 256 x 256 tile, then odd and one-sample shapes.
  std::vector<std::int16_t> all(65536);
  for (std::size_t i = 0; i < all.size(); ++i)
    all[i] =
        static_cast<std::int16_t>(static_cast<int>(i) + std::numeric_limits<std::int16_t>::min());
  EXPECT_EQ(*codec::decodeBil16(codec::encodeBil16(256, 256, all.data()), 256, 256), all);
  for (const auto& [w, h] : {std::pair{1, 1},
                             std::pair{150, 150},
                             std::pair{151, 149},
                             std::pair{65536, 1},
                             std::pair{1, 65535}}) {
    std::vector<std::int16_t> v(static_cast<std::size_t>(w) * static_cast<std::size_t>(h));
    for (std::size_t i = 0; i < v.size(); ++i)
      v[i] = static_cast<std::int16_t>(i * 37 - 20000);
    const auto bytes = codec::encodeBil16(w, h, v.data());
    EXPECT_EQ(bytes.size(), v.size() * 2);
    EXPECT_EQ(*codec::decodeBil16(bytes, w, h), v) << w << "x" << h;
  }
  // A width or height of 0 is an empty tile.
  const auto empty = codec::decodeBil16({}, 0, 150);
  ASSERT_TRUE(empty);
  EXPECT_TRUE(empty->empty());
}
