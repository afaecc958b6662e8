// Decoding value tiles: BIL in both byte orders and three sample types, 16-bit PNG, baseline TIFF
// (strips, tiles, Deflate, predictor, both byte orders), scale/offset/no-data, the bundled ETOPO
// TIFF; and hostile input refused without reading out of bounds (run under ASan too).
#include "TiffBuilder.hpp"

#include <tellus/values/ValueFormat.hpp>

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <fstream>
#include <iterator>

namespace tellus::values {
namespace {

using test::TiffBuilder;
using test::TiffSpec;

std::vector<std::byte> bytesOf(std::initializer_list<int> v) {
  std::vector<std::byte> out;
  for (int b : v)
    out.push_back(std::byte(b));
  return out;
}

ValueFormat bil(Encoding e, ByteOrder o = ByteOrder::Little) {
  ValueFormat f;
  f.container = Container::Bil;
  f.encoding = e;
  f.byteOrder = o;
  return f;
}

TEST(ValueDecode, BilInt16LittleAndBig) {
  auto le =
      decode(bytesOf({0x01, 0x00, 0xFF, 0xFF, 0x00, 0x80, 0xFF, 0x7F}), bil(Encoding::Int16), 2, 2);
  ASSERT_TRUE(le) << le.error();
  EXPECT_EQ(le->values, (std::vector<float>{1, -1, -32768, 32767}));
  auto be = decode(bytesOf({0x00, 0x01, 0xFF, 0xFE}), bil(Encoding::Int16, ByteOrder::Big), 2, 1);
  ASSERT_TRUE(be) << be.error();
  EXPECT_EQ(be->values, (std::vector<float>{1, -2}));
}

TEST(ValueDecode, BilUInt16AndFloat32) {
  auto u = decode(bytesOf({0xFF, 0xFF, 0x00, 0x80}), bil(Encoding::UInt16), 2, 1);
  ASSERT_TRUE(u);
  EXPECT_EQ(u->values, (std::vector<float>{65535, 32768}));
  const auto bits = std::bit_cast<std::uint32_t>(-1.5f);
  auto fl = decode(
      bytesOf({int(bits & 0xFF), int(bits >> 8 & 0xFF), int(bits >> 16 & 0xFF), int(bits >> 24)}),
      bil(Encoding::Float32),
      1,
      1);
  ASSERT_TRUE(fl);
  EXPECT_EQ(fl->values[0], -1.5f);
  auto fb = decode(
      bytesOf({int(bits >> 24), int(bits >> 16 & 0xFF), int(bits >> 8 & 0xFF), int(bits & 0xFF)}),
      bil(Encoding::Float32, ByteOrder::Big),
      1,
      1);
  ASSERT_TRUE(fb);
  EXPECT_EQ(fb->values[0], -1.5f);
}

TEST(ValueDecode, ScaleOffsetAndNoData) {
  ValueFormat f = bil(Encoding::Int16);
  f.scale = 0.01;
  f.offset = 20.0;
  f.noData = -32768.0;
  auto r = decode(bytesOf({0x64, 0x00, 0x00, 0x80}), f, 2, 1);
  ASSERT_TRUE(r);
  EXPECT_FLOAT_EQ(r->values[0], 21.0f);
  EXPECT_TRUE(std::isnan(r->values[1]));
}

TEST(ValueDecode, Float32NaNIsNoData) {
  const auto bits = std::bit_cast<std::uint32_t>(std::numeric_limits<float>::quiet_NaN());
  auto r = decode(
      bytesOf({int(bits & 0xFF), int(bits >> 8 & 0xFF), int(bits >> 16 & 0xFF), int(bits >> 24)}),
      bil(Encoding::Float32),
      1,
      1);
  ASSERT_TRUE(r);
  EXPECT_TRUE(std::isnan(r->values[0]));
}

TEST(ValueDecode, NamesAndMimeTypes) {
  EXPECT_EQ(parseEncoding("float32"), Encoding::Float32);
  EXPECT_EQ(parseEncoding(encodingName(Encoding::UInt16)), Encoding::UInt16);
  EXPECT_FALSE(parseEncoding("int32"));
  EXPECT_EQ(parseContainer("tiff"), Container::Tiff);
  EXPECT_FALSE(parseContainer("geotiff"));
  EXPECT_EQ(containerForMimeType("application/bil16"), Container::Bil);
  EXPECT_EQ(containerForMimeType("image/TIFF; subtype=float"), Container::Tiff);
  EXPECT_EQ(containerForMimeType("image/png"), Container::Png);
  EXPECT_FALSE(containerForMimeType("image/jpeg"));
}

// --- 16-bit PNG, built by hand (signature, IHDR, one IDAT of filter-0 rows, IEND) ---------------
void chunk(std::vector<std::byte>& out, const char* type, const std::vector<std::byte>& data) {
  auto put32 = [&](std::uint32_t v) {
    for (int s = 24; s >= 0; s -= 8)
      out.push_back(std::byte(v >> s & 0xFF));
  };
  put32(static_cast<std::uint32_t>(data.size()));
  const std::size_t start = out.size();
  for (int i = 0; i < 4; ++i)
    out.push_back(std::byte(type[i]));
  out.insert(out.end(), data.begin(), data.end());
  put32(static_cast<std::uint32_t>(crc32(0,
                                         reinterpret_cast<const Bytef*>(out.data() + start),
                                         static_cast<uInt>(out.size() - start))));
}

std::vector<std::byte> png16(int w, int h, const std::vector<std::uint16_t>& samples) {
  std::vector<std::byte> out = bytesOf({0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A});
  chunk(out, "IHDR", bytesOf({0, 0, 0, w, 0, 0, 0, h, 16, 0, 0, 0, 0}));
  std::vector<std::byte> raw;
  for (int y = 0; y < h; ++y) {
    raw.push_back(std::byte{0});
    for (int x = 0; x < w; ++x) {
      const std::uint16_t s = samples[std::size_t(y * w + x)];
      raw.push_back(std::byte(s >> 8));
      raw.push_back(std::byte(s & 0xFF));
    }
  }
  uLongf n = compressBound(static_cast<uLong>(raw.size()));
  std::vector<std::byte> z(n);
  compress(reinterpret_cast<Bytef*>(z.data()),
           &n,
           reinterpret_cast<const Bytef*>(raw.data()),
           static_cast<uLong>(raw.size()));
  z.resize(n);
  chunk(out, "IDAT", z);
  chunk(out, "IEND", {});
  return out;
}

TEST(ValueDecode, Png16AsUInt16OrInt16) {
  const auto png = png16(2, 1, {65535, 100});
  ValueFormat f;
  f.container = Container::Png;
  f.encoding = Encoding::UInt16;
  auto u = decode(png, f);
  ASSERT_TRUE(u) << u.error();
  EXPECT_EQ(u->width, 2);
  EXPECT_EQ(u->values, (std::vector<float>{65535, 100}));
  f.encoding = Encoding::Int16;
  auto s = decode(png, f, 2, 1);
  ASSERT_TRUE(s) << s.error();
  EXPECT_EQ(s->values, (std::vector<float>{-1, 100}));
  // tellus's own height PNGs: height + 32768 (UInt16 with offset -32768).
  f.encoding = Encoding::UInt16;
  f.offset = -32768.0;
  EXPECT_EQ(decode(png16(1, 1, {32768 + 812}), f)->values[0], 812.0f);
  EXPECT_FALSE(decode(png, f, 3, 1));
}

// --- TIFF ----------------------------------------------------------------------------------------
std::vector<std::uint32_t> ramp(int n, int start = -5) {
  std::vector<std::uint32_t> v;
  for (int i = 0; i < n; ++i)
    v.push_back(static_cast<std::uint16_t>(static_cast<std::int16_t>(start + i * 7)));
  return v;
}

void expectRamp(const std::expected<ValueRaster, std::string>& r, int w, int h) {
  ASSERT_TRUE(r) << r.error();
  ASSERT_EQ(r->width, w);
  ASSERT_EQ(r->height, h);
  for (int i = 0; i < w * h; ++i)
    EXPECT_EQ(r->values[std::size_t(i)], -5 + i * 7) << i;
}

ValueFormat tiff() {
  ValueFormat f;
  f.container = Container::Tiff;
  return f;
}

TEST(ValueDecode, TiffStripsBothByteOrdersRawAndDeflate) {
  for (const bool little : {true, false})
    for (const int compression : {1, 8})
      for (const int predictor : {1, 2}) {
        TiffSpec s{.little = little,
                   .width = 5,
                   .height = 3,
                   .compression = compression,
                   .predictor = predictor,
                   .rowsPerStrip = 2};
        SCOPED_TRACE(testing::Message() << little << compression << predictor);
        expectRamp(decode(TiffBuilder(s).build(ramp(15)), tiff(), 5, 3), 5, 3);
      }
}

TEST(ValueDecode, TiffTilesCutAtTheEdges) {
  TiffSpec s{.width = 20, .height = 18, .compression = 8, .tileWidth = 16, .tileHeight = 16};
  expectRamp(decode(TiffBuilder(s).build(ramp(360)), tiff()), 20, 18);
  s.little = false;
  s.compression = 1;
  expectRamp(decode(TiffBuilder(s).build(ramp(360)), tiff()), 20, 18);
}

TEST(ValueDecode, TiffUInt16AndFloat32) {
  TiffSpec u{.width = 2, .height = 1, .sampleFormat = 1};
  auto ru = decode(TiffBuilder(u).build({65535, 7}), tiff());
  ASSERT_TRUE(ru) << ru.error();
  EXPECT_EQ(ru->values, (std::vector<float>{65535, 7}));
  for (const bool little : {true, false}) {
    TiffSpec f{
        .little = little, .width = 2, .height = 1, .bits = 32, .sampleFormat = 3, .compression = 8};
    auto rf = decode(TiffBuilder(f).build({std::bit_cast<std::uint32_t>(3.25f),
                                           std::bit_cast<std::uint32_t>(-1e30f)}),
                     tiff());
    ASSERT_TRUE(rf) << rf.error();
    EXPECT_EQ(rf->values, (std::vector<float>{3.25f, -1e30f}));
  }
}

TEST(ValueDecode, TiffSizeMustMatchWhenGiven) {
  const auto t = TiffBuilder(TiffSpec{}).build(ramp(12));
  EXPECT_TRUE(decode(t, tiff(), 4, 3));
  auto wrong = decode(t, tiff(), 3, 4);
  ASSERT_FALSE(wrong);
  EXPECT_EQ(wrong.error(), "the TIFF is 4 x 3, not 3 x 4");
}

TEST(ValueDecode, BundledEtopoTiff) {
  std::ifstream in(std::string(TELLUS_TEST_DATA_DIR) + "/etopo20_int16.tif", std::ios::binary);
  ASSERT_TRUE(in);
  std::vector<char> chars((std::istreambuf_iterator<char>(in)), {});
  std::vector<std::byte> bytes(chars.size());
  std::memcpy(bytes.data(), chars.data(), chars.size());
  ValueFormat f = tiff();
  f.unit = "m";
  auto r = decode(bytes, f);
  ASSERT_TRUE(r) << r.error();
  EXPECT_EQ(r->width, 1080);
  EXPECT_EQ(r->height, 540);
  // Pixels as GDAL 3.6's gdallocationinfo reads them (Deflate, strips of 3 rows), exactly:
  // the Gulf of Guinea at the centre, the corners, land and sea.
  EXPECT_EQ(r->at(540, 270), -4811.0f);
  EXPECT_EQ(r->at(539, 269), -4905.0f);
  EXPECT_EQ(r->at(0, 0), -4272.0f);
  EXPECT_EQ(r->at(1079, 539), 2804.0f);
  EXPECT_EQ(r->at(300, 100), -35.0f);
  EXPECT_EQ(r->at(700, 450), -5201.0f);
  EXPECT_EQ(r->at(1000, 20), -2510.0f);
  // Arctic rows below sea level, Antarctic rows above (data/README.md).
  double top = 0, bottom = 0;
  for (int x = 0; x < 1080; ++x) {
    top += static_cast<double>(r->at(x, 0));
    bottom += static_cast<double>(r->at(x, 539));
  }
  EXPECT_LT(top / 1080, -3000.0);
  EXPECT_GT(bottom / 1080, 2000.0);
}

} // namespace
} // namespace tellus::values
