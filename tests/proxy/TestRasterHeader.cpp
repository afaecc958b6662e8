// The raster header reader (tellus/proxy/RasterHeader.hpp) that lets a local raster open without
// decoding and without the imaging module: real files, what OpenImageIO says of the same files,
// hand-made headers, and malformed, truncated and randomly corrupted ones.

#include "../support/ImageFiles.hpp"
#include "../support/TempDir.hpp"

#include <tellus/proxy/RasterHeader.hpp>

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <initializer_list>
#include <random>
#include <string>
#include <vector>

using namespace tellus;
using test::readAll;
using test::writeAll;
using test::writeWithOiio;
namespace fs = std::filesystem;

namespace {

const fs::path kData = TELLUS_TEST_DATA_DIR;
const fs::path kBlueMarble = kData / "bmng_2048x1024.jpg";
const fs::path kEtopo = kData / "etopo20_int16.tif";

/** A classic TIFF with one IFD and no pixel data (enough for a header reader); entries are
 * (tag, type, count, value) with values of SHORT/LONG inline. */
struct TiffEntry {
  unsigned tag;
  unsigned type;
  unsigned count;
  unsigned value;
};
std::vector<std::byte>
tiffHeader(const std::vector<TiffEntry>& entries, bool bigEndian = false, unsigned ifdOffset = 8) {
  std::vector<std::byte> out;
  auto put8 = [&](unsigned v) { out.push_back(static_cast<std::byte>(v & 0xFF)); };
  auto u16 = [&](unsigned v) {
    if (bigEndian) {
      put8(v >> 8);
      put8(v);
    } else {
      put8(v);
      put8(v >> 8);
    }
  };
  auto u32 = [&](unsigned v) {
    if (bigEndian) {
      u16(v >> 16);
      u16(v & 0xFFFF);
    } else {
      u16(v & 0xFFFF);
      u16(v >> 16);
    }
  };
  put8(bigEndian ? 'M' : 'I');
  put8(bigEndian ? 'M' : 'I');
  u16(42);
  u32(ifdOffset);
  while (out.size() < ifdOffset)
    put8(0);
  u16(static_cast<unsigned>(entries.size()));
  for (const auto& e : entries) {
    u16(e.tag);
    u16(e.type);
    u32(e.count);
    if (e.type == 3 && e.count == 1) {
      u16(e.value);
      u16(0);
    } else {
      u32(e.value);
    }
  }
  u32(0);
  return out;
}

/** A TIFF whose first IFD offset points past its end. */
std::vector<std::byte> tiffPointingPastItsEnd() {
  auto b = tiffHeader({{256, 3, 1, 8}, {257, 3, 1, 8}});
  b[4] = std::byte{0xA0};
  b[5] = std::byte{0x0F}; // 4000
  return b;
}

/** Grey Int16 (BlackIsZero, SampleFormat 2) like the bundled ETOPO file. */
std::vector<TiffEntry> int16Tiff(unsigned w, unsigned h) {
  return {{256, 3, 1, w},
          {257, 4, 1, h},
          {258, 3, 1, 16},
          {262, 3, 1, 1},
          {277, 3, 1, 1},
          {339, 3, 1, 2}};
}

/** A PNG signature and chunks (CRCs are not checked by a header reader: zeros). */
std::vector<std::byte> pngWith(unsigned w,
                               unsigned h,
                               unsigned depth,
                               unsigned colour,
                               const std::vector<std::string>& moreChunks = {"IDAT", "IEND"}) {
  std::vector<std::byte> out;
  auto put8 = [&](unsigned v) { out.push_back(static_cast<std::byte>(v & 0xFF)); };
  auto u32 = [&](unsigned v) {
    put8(v >> 24);
    put8(v >> 16);
    put8(v >> 8);
    put8(v);
  };
  for (unsigned c : {0x89u, 'P' + 0u, 'N' + 0u, 'G' + 0u, 0x0Du, 0x0Au, 0x1Au, 0x0Au})
    put8(c);
  auto chunk = [&](const std::string& type, const std::vector<unsigned>& data) {
    u32(static_cast<unsigned>(data.size()));
    for (char c : type)
      put8(static_cast<unsigned char>(c));
    for (unsigned d : data)
      put8(d);
    u32(0);
  };
  chunk("IHDR", {w >> 24, w >> 16, w >> 8, w, h >> 24, h >> 16, h >> 8, h, depth, colour, 0, 0, 0});
  for (const auto& c : moreChunks)
    chunk(c, c == "IEND" ? std::vector<unsigned>{} : std::vector<unsigned>{1, 2, 3});
  return out;
}

std::vector<std::byte> bytesOf(std::initializer_list<unsigned> v) {
  std::vector<std::byte> b;
  for (unsigned x : v)
    b.push_back(static_cast<std::byte>(x));
  return b;
}

/** A JPEG's markers: SOI, an APP0 segment, then a frame header. */
std::vector<std::byte>
jpegWith(unsigned sof, unsigned precision, unsigned w, unsigned h, unsigned components) {
  auto b = bytesOf({0xFF,
                    0xD8,
                    0xFF,
                    0xE0,
                    0x00,
                    0x04,
                    'x',
                    'y',
                    0xFF,
                    0xFF,
                    sof,
                    0x00,
                    8 + 3 * components,
                    precision,
                    h >> 8,
                    h & 0xFF,
                    w >> 8,
                    w & 0xFF,
                    components});
  for (unsigned c = 0; c < components; ++c) {
    for (unsigned x : {c + 1, 0x11u, 0u})
      b.push_back(static_cast<std::byte>(x));
  }
  for (unsigned x : {0xFFu, 0xD9u})
    b.push_back(static_cast<std::byte>(x));
  return b;
}

std::string headerError(const std::vector<std::byte>& b) {
  auto r = parseRasterHeader(b);
  return r ? std::string() : r.error();
}

} // namespace

TEST(RasterHeader, ReadsTheBundledFiles) {
  auto bm = readRasterHeader(kBlueMarble);
  ASSERT_TRUE(bm) << bm.error();
  ASSERT_TRUE(*bm);
  EXPECT_STREQ((*bm)->format, "JPEG");
  EXPECT_EQ((*bm)->width, 2048);
  EXPECT_EQ((*bm)->height, 1024);
  EXPECT_EQ((*bm)->channels, 3);
  EXPECT_EQ((*bm)->sampleType, SampleType::UInt8);
  auto et = readRasterHeader(kEtopo);
  ASSERT_TRUE(et) << et.error();
  ASSERT_TRUE(*et);
  EXPECT_STREQ((*et)->format, "TIFF");
  EXPECT_EQ((*et)->width, 1080);
  EXPECT_EQ((*et)->height, 540);
  EXPECT_EQ((*et)->channels, 1);
  EXPECT_EQ((*et)->sampleType, SampleType::Int16);
  EXPECT_STREQ(toString((*et)->sampleType), "int16");
}

TEST(RasterHeader, AgreesWithOpenImageIO) {
  test::TempDir dir("hdr");
  struct Case {
    const char* name;
    int channels;
    OIIO::TypeDesc type;
  };
  const Case cases[] = {{"g8.png", 1, OIIO::TypeDesc::UINT8},
                        {"ga8.png", 2, OIIO::TypeDesc::UINT8},
                        {"rgb8.png", 3, OIIO::TypeDesc::UINT8},
                        {"rgba8.png", 4, OIIO::TypeDesc::UINT8},
                        {"rgb16.png", 3, OIIO::TypeDesc::UINT16},
                        {"g.jpg", 1, OIIO::TypeDesc::UINT8},
                        {"rgb.jpg", 3, OIIO::TypeDesc::UINT8}};
  for (const auto& c : cases) {
    const fs::path file = dir.path() / c.name;
    writeWithOiio(file, 37, 19, c.channels, c.type);
    auto in = OIIO::ImageInput::open(file.string());
    ASSERT_TRUE(in) << OIIO::geterror();
    const OIIO::ImageSpec& spec = in->spec();
    auto h = readRasterHeader(file);
    ASSERT_TRUE(h) << h.error();
    ASSERT_TRUE(*h) << c.name;
    EXPECT_EQ((*h)->width, spec.width) << c.name;
    EXPECT_EQ((*h)->height, spec.height) << c.name;
    EXPECT_EQ((*h)->channels, spec.nchannels) << c.name;
    EXPECT_EQ((*h)->sampleType == SampleType::UInt16, spec.format == OIIO::TypeDesc::UINT16)
        << c.name;
  }
}

TEST(RasterHeader, TiffInBothByteOrders) {
  for (bool big : {false, true}) {
    auto h = parseRasterHeader(tiffHeader(int16Tiff(1080, 540), big));
    ASSERT_TRUE(h) << h.error();
    ASSERT_TRUE(*h);
    EXPECT_EQ((*h)->width, 1080);
    EXPECT_EQ((*h)->height, 540);
    EXPECT_EQ((*h)->channels, 1);
    EXPECT_EQ((*h)->sampleType, SampleType::Int16);
  }
  // RGB 8-bit with BitsPerSample as three values stored after the IFD; the IFD not at 8.
  auto rgb = tiffHeader(
      {{256, 4, 1, 300}, {257, 4, 1, 200}, {258, 3, 3, 200}, {262, 3, 1, 2}, {277, 3, 1, 3}},
      false,
      12);
  rgb.resize(200);
  for (std::size_t i = 0; i < 3; ++i)
    rgb.insert(rgb.end(), {std::byte{8}, std::byte{0}});
  auto h = parseRasterHeader(rgb);
  ASSERT_TRUE(h) << h.error();
  ASSERT_TRUE(*h);
  EXPECT_EQ((*h)->channels, 3);
  EXPECT_EQ((*h)->sampleType, SampleType::UInt8);
  // Float32 heights.
  auto f = parseRasterHeader(tiffHeader(
      {{256, 3, 1, 10}, {257, 3, 1, 10}, {258, 3, 1, 32}, {262, 3, 1, 1}, {339, 3, 1, 3}}));
  ASSERT_TRUE(f && *f);
  EXPECT_EQ((*f)->sampleType, SampleType::Float32);
}

TEST(RasterHeader, VariantsItDoesNotModelGoToTheImagingModule) {
  // Palette and tRNS PNGs, low bit depths: the decoder expands them.
  EXPECT_FALSE(parseRasterHeader(pngWith(8, 8, 8, 3)).value());
  EXPECT_FALSE(parseRasterHeader(pngWith(8, 8, 4, 0)).value());
  EXPECT_FALSE(parseRasterHeader(pngWith(8, 8, 8, 2, {"tRNS", "IDAT", "IEND"})).value());
  EXPECT_TRUE(parseRasterHeader(pngWith(8, 8, 8, 2, {"IDAT", "tRNS", "IEND"})).value());
  // 12-bit, lossless and CMYK JPEGs; a height given later (DNL).
  EXPECT_FALSE(parseRasterHeader(jpegWith(0xC1, 12, 8, 8, 3)).value());
  EXPECT_FALSE(parseRasterHeader(jpegWith(0xC3, 8, 8, 8, 3)).value());
  EXPECT_FALSE(parseRasterHeader(jpegWith(0xC0, 8, 8, 8, 4)).value());
  EXPECT_FALSE(parseRasterHeader(jpegWith(0xC0, 8, 8, 0, 3)).value());
  EXPECT_TRUE(parseRasterHeader(jpegWith(0xC2, 8, 8, 8, 1)).value()); // progressive grey
  // Palette, CMYK and bilevel TIFFs, no photometric tag, BigTIFF.
  auto withPhotometric = [](unsigned p) {
    return tiffHeader({{256, 3, 1, 8}, {257, 3, 1, 8}, {258, 3, 1, 8}, {262, 3, 1, p}});
  };
  EXPECT_TRUE(parseRasterHeader(withPhotometric(1)).value());
  EXPECT_FALSE(parseRasterHeader(withPhotometric(3)).value());
  EXPECT_FALSE(parseRasterHeader(withPhotometric(5)).value());
  EXPECT_FALSE(
      parseRasterHeader(tiffHeader({{256, 3, 1, 8}, {257, 3, 1, 8}, {262, 3, 1, 1}})).value());
  EXPECT_FALSE(parseRasterHeader(tiffHeader({{256, 3, 1, 8}, {257, 3, 1, 8}})).value());
  EXPECT_FALSE(
      parseRasterHeader(bytesOf({'I', 'I', 43, 0, 8, 0, 0, 0, 16, 0, 0, 0, 0, 0, 0, 0})).value());
  // Not an image format it knows at all.
  EXPECT_FALSE(parseRasterHeader(bytesOf({'B', 'M', 0, 0, 0, 0})).value());
  EXPECT_FALSE(parseRasterHeader({}).value());
}

TEST(RasterHeaderExtremes, MalformedAndTruncatedHeadersAreClearErrors) {
  // JPEG: cut inside the APP segments of the real file, before the frame header.
  auto bm = readAll(kBlueMarble);
  ASSERT_GT(bm.size(), 8000u); // its frame header is at 6706
  std::vector<std::byte> cut(bm.begin(), bm.begin() + 100);
  EXPECT_NE(headerError(cut).find("truncated JPEG header"), std::string::npos) << headerError(cut);
  EXPECT_NE(headerError(jpegWith(0xC0, 8, 0, 8, 3)).find("malformed JPEG header: width 0"),
            std::string::npos);
  auto sosFirst = bytesOf({0xFF, 0xD8, 0xFF, 0xDA, 0x00, 0x02});
  EXPECT_NE(headerError(sosFirst).find("before a frame header"), std::string::npos);
  auto shortSof = jpegWith(0xC0, 8, 8, 8, 3);
  shortSof[12] = std::byte{4}; // SOF length 4
  EXPECT_NE(headerError(shortSof).find("malformed JPEG header"), std::string::npos);

  // PNG.
  auto png = pngWith(8, 8, 8, 2);
  EXPECT_NE(headerError({png.begin(), png.begin() + 20}).find("truncated PNG header"),
            std::string::npos);
  EXPECT_NE(headerError(pngWith(8, 8, 3, 2)).find("bit depth 3 with colour type 2"),
            std::string::npos);
  EXPECT_NE(headerError(pngWith(0, 8, 8, 2)).find("size 0x8"), std::string::npos);
  EXPECT_NE(headerError(pngWith(8, 8, 8, 2, {"IEND"})).find("no image data"), std::string::npos);
  EXPECT_NE(headerError(pngWith(8, 8, 8, 2, {})).find("truncated PNG header"), std::string::npos);
  auto notIhdr = png;
  notIhdr[12] = std::byte{'X'};
  EXPECT_NE(headerError(notIhdr).find("not a 13-byte IHDR"), std::string::npos);

  // TIFF.
  EXPECT_NE(headerError(tiffPointingPastItsEnd()).find("truncated TIFF header"), std::string::npos);
  auto empty = tiffHeader({});
  EXPECT_NE(headerError(empty).find("empty IFD"), std::string::npos);
  EXPECT_NE(headerError(tiffHeader({{257, 3, 1, 8}, {258, 3, 1, 8}, {262, 3, 1, 1}}))
                .find("no ImageWidth"),
            std::string::npos);
  EXPECT_NE(headerError(tiffHeader({{256, 2, 1, 8}, {257, 3, 1, 8}})).find("has type 2"),
            std::string::npos);
  EXPECT_NE(headerError(tiffHeader({{256, 3, 1, 0}, {257, 3, 1, 8}})).find("size 0x8"),
            std::string::npos);
  EXPECT_NE(headerError(tiffHeader({{256, 3, 1, 8}, {257, 3, 1, 8}, {258, 3, 3, 5000}}))
                .find("values of tag 258"),
            std::string::npos);
  auto cutIfd = tiffHeader(int16Tiff(8, 8));
  cutIfd.resize(30);
  EXPECT_NE(headerError(cutIfd).find("truncated TIFF header"), std::string::npos);

  // Every prefix of the three kinds either parses, defers or fails; none crashes.
  for (const auto& whole : {std::vector<std::byte>(bm.begin(), bm.begin() + 8000),
                            pngWith(8, 8, 8, 6),
                            tiffHeader(int16Tiff(8, 8), true)}) {
    for (std::size_t n = 0; n <= whole.size(); ++n)
      (void)parseRasterHeader({whole.begin(), whole.begin() + static_cast<std::ptrdiff_t>(n)});
  }
}

TEST(RasterHeaderExtremes, RandomCorruptionNeverCrashes) {
  auto bm = readAll(kBlueMarble);
  const std::vector<std::vector<std::byte>> seeds = {
      std::vector<std::byte>(bm.begin(), bm.begin() + 8000),
      pngWith(640, 480, 8, 6, {"gAMA", "tRNS", "IDAT", "IEND"}),
      tiffHeader(int16Tiff(1080, 540), false),
      tiffHeader({{256, 4, 1, 300}, {257, 4, 1, 200}, {258, 3, 3, 100}, {262, 3, 1, 2}}, true)};
  std::mt19937 rng(1234);
  int parsed = 0;
  for (int round = 0; round < 4000; ++round) {
    auto b = seeds[static_cast<std::size_t>(round) % seeds.size()];
    const int flips = 1 + static_cast<int>(rng() % 4);
    for (int f = 0; f < flips; ++f) {
      const std::size_t at = rng() % std::min<std::size_t>(b.size(), 64);
      b[at] = static_cast<std::byte>(rng());
    }
    if (rng() % 3 == 0) b.resize(rng() % (b.size() + 1));
    auto r = parseRasterHeader(b);
    if (r && *r) {
      ++parsed;
      EXPECT_GT((*r)->width, 0);
      EXPECT_GT((*r)->height, 0);
      EXPECT_GT((*r)->channels, 0);
    }
  }
  EXPECT_GT(parsed, 0);
}

TEST(RasterHeader, FilesThatCannotBeRead) {
  test::TempDir dir("hdrf");
  auto missing = readRasterHeader(dir.path() / "missing.jpg");
  ASSERT_FALSE(missing);
  EXPECT_NE(missing.error().find("cannot open"), std::string::npos);
  EXPECT_NE(missing.error().find("missing.jpg"), std::string::npos);
  auto folder = readRasterHeader(dir.path());
  ASSERT_FALSE(folder);
  EXPECT_NE(folder.error().find("not a regular file"), std::string::npos);
  writeAll(dir.path() / "cut.tif", tiffPointingPastItsEnd());
  auto cut = readRasterHeader(dir.path() / "cut.tif");
  ASSERT_FALSE(cut);
  EXPECT_NE(cut.error().find("cut.tif: truncated TIFF header"), std::string::npos) << cut.error();
  std::ofstream(dir.path() / "text.txt") << "not an image";
  auto text = readRasterHeader(dir.path() / "text.txt");
  ASSERT_TRUE(text);
  EXPECT_FALSE(*text);
}
