#include <tellus/proxy/TileValidation.hpp>

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

using namespace tellus;
using namespace std::literals;

namespace {

std::vector<std::byte> bytes(std::string_view s) {
  std::vector<std::byte> v(s.size());
  std::memcpy(v.data(), s.data(), s.size());
  return v;
}

/**
 * A 16-bit signed grey baseline TIFF (one uncompressed strip), as an elevation upstream sends.
 * Written by hand: OpenImageIO's TIFF writer starts its worker pool, whose threads it never joins,
 * and ThreadSanitizer then reports OpenImageIO's own bookkeeping in later calls.
 */
std::vector<std::byte> tiff16(int width, int height) {
  std::vector<std::byte> out;
  auto u16 = [&](unsigned v) {
    out.push_back(static_cast<std::byte>(v & 0xFF));
    out.push_back(static_cast<std::byte>((v >> 8) & 0xFF));
  };
  auto u32 = [&](unsigned v) {
    u16(v & 0xFFFF);
    u16(v >> 16);
  };
  const auto w = static_cast<unsigned>(width);
  const auto h = static_cast<unsigned>(height);
  constexpr unsigned kEntries = 10;
  const unsigned dataOffset = 8 + 2 + kEntries * 12 + 4;
  out.push_back(std::byte{'I'});
  out.push_back(std::byte{'I'});
  u16(42);
  u32(8);
  u16(kEntries);
  auto entry = [&](unsigned tag, unsigned type, unsigned value) {
    u16(tag);
    u16(type);
    u32(1);
    if (type == 3) { // SHORT, left-justified in the value field
      u16(value);
      u16(0);
    } else {
      u32(value);
    }
  };
  entry(256, 3, w);          // ImageWidth
  entry(257, 3, h);          // ImageLength
  entry(258, 3, 16);         // BitsPerSample
  entry(259, 3, 1);          // Compression: none
  entry(262, 3, 1);          // PhotometricInterpretation: BlackIsZero
  entry(273, 4, dataOffset); // StripOffsets
  entry(277, 3, 1);          // SamplesPerPixel
  entry(278, 3, h);          // RowsPerStrip
  entry(279, 4, w * h * 2);  // StripByteCounts
  entry(339, 3, 2);          // SampleFormat: signed integer
  u32(0);                    // no next IFD
  for (unsigned i = 0; i < w * h; ++i)
    u16(static_cast<unsigned>(static_cast<std::uint16_t>(static_cast<int>(i % 4000) - 2000)));
  return out;
}

/** A real image encoded by OpenImageIO into memory: 8-bit RGB JPEG or PNG ("tif": tiff16). */
std::vector<std::byte> encode(const std::string& format, int width, int height) {
  if (format == "tif") return tiff16(width, height);
  OIIO::ImageSpec spec(width, height, 3, OIIO::TypeDesc::UINT8);
  std::vector<std::uint8_t> pixels(static_cast<std::size_t>(width) *
                                   static_cast<std::size_t>(height) * 3);
  for (std::size_t i = 0; i < pixels.size(); ++i)
    pixels[i] = static_cast<std::uint8_t>((i * 7) % 251);
  std::vector<unsigned char> buffer;
  OIIO::Filesystem::IOVecOutput vec(buffer);
  auto out = OIIO::ImageOutput::create(format);
  EXPECT_TRUE(out) << OIIO::geterror();
  if (!out) return {};
  out->threads(1);
  EXPECT_TRUE(out->set_ioproxy(&vec));
  const bool ok = out->open("tile." + format, spec) &&
                  out->write_image(OIIO::TypeDesc::UINT8, pixels.data()) && out->close();
  EXPECT_TRUE(ok) << out->geterror();
  std::vector<std::byte> result(buffer.size());
  std::memcpy(result.data(), buffer.data(), buffer.size());
  return result;
}

FetchResponse response(std::vector<std::byte> body, std::string contentType, int status = 200) {
  FetchResponse r;
  r.status = status;
  r.contentType = std::move(contentType);
  r.body = std::move(body);
  return r;
}

/** validateTile, with the error in the failure message. */
::testing::AssertionResult valid(const FetchResponse& r, std::string_view mime, int w, int h) {
  auto v = validateTile(r, mime, w, h);
  if (v) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << v.error();
}

const char* kServiceException =
    "\xEF\xBB\xBF  \n<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
    "<ServiceExceptionReport version=\"1.1.1\">\n"
    "  <ServiceException code=\"LayerNotDefined\">\n"
    "    msWMSLoadGetMapParams(): WMS server error. Invalid layer(s) given in the LAYERS\n"
    "    parameter. See http://internal.example:8081/cgi-bin/mapserv?map=/srv/secret.map &amp; "
    "more\n"
    "  </ServiceException>\n"
    "</ServiceExceptionReport>\n";

} // namespace

TEST(TileValidation, SniffsMagicBytes) {
  EXPECT_EQ(sniff(encode("jpg", 8, 8)), ImageKind::Jpeg);
  EXPECT_EQ(sniff(encode("png", 8, 8)), ImageKind::Png);
  EXPECT_EQ(sniff(encode("tif", 8, 8)), ImageKind::Tiff);
  EXPECT_EQ(sniff(bytes("MM\x00\x2A\x00\x00\x00\x08"sv)), ImageKind::Tiff);
  EXPECT_EQ(sniff(bytes("GIF89a\x01\x00\x01\x00")), ImageKind::Gif);
  EXPECT_EQ(sniff(bytes("RIFF\x10\x00\x00\x00WEBPVP8 "sv)), ImageKind::Webp);
  EXPECT_EQ(sniff(bytes(kServiceException)), ImageKind::Xml);
  EXPECT_EQ(sniff(bytes("\r\n\t <ServiceExceptionReport/>")), ImageKind::Xml);
  EXPECT_EQ(sniff(bytes("<!DOCTYPE HTML PUBLIC \"-//W3C//DTD HTML 4.01//EN\"><HTML>")),
            ImageKind::Html);
  EXPECT_EQ(sniff(bytes("  <html><body>502 Bad Gateway</body></html>")), ImageKind::Html);
  // UTF-16 with a byte-order mark.
  EXPECT_EQ(sniff(bytes("\xFF\xFE<\x00?\x00x\x00m\x00l\x00"sv)), ImageKind::Xml);
  EXPECT_EQ(sniff(bytes("plain text error")), ImageKind::Unknown);
  EXPECT_EQ(sniff({}), ImageKind::Unknown);
  EXPECT_EQ(sniff(bytes("\xFF\xD8")), ImageKind::Unknown); // too short to be sure
}

TEST(TileValidation, AcceptsRealJpegPngAndTiffTiles) {
  EXPECT_TRUE(valid(response(encode("jpg", 64, 32), "image/jpeg"), "image/jpeg", 64, 32));
  EXPECT_TRUE(valid(response(encode("png", 64, 32), "image/png"), "image/png; mode=8bit", 64, 32));
  EXPECT_TRUE(
      valid(response(encode("png", 16, 16), "Image/PNG; charset=binary"), "image/png", 16, 16));
  EXPECT_TRUE(valid(response(encode("jpg", 16, 16), "image/jpg"), "image/jpeg", 16, 16));
  EXPECT_TRUE(valid(response(encode("tif", 32, 16), "image/tiff"), "image/tiff", 32, 16));
}

TEST(TileValidation, ServiceExceptionWithStatus200AndAnImageTypeIsAnError) {
  auto r = validateTile(response(bytes(kServiceException), "image/png"), "image/png", 512, 512);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("ServiceException"), std::string::npos) << r.error();
  EXPECT_NE(r.error().find("LayerNotDefined"), std::string::npos) << r.error();
  EXPECT_NE(r.error().find("Invalid layer(s) given in the LAYERS parameter"), std::string::npos)
      << r.error();
  EXPECT_EQ(r.error().find("http://"), std::string::npos) << r.error();
  EXPECT_EQ(r.error().find("internal.example"), std::string::npos) << r.error();
  EXPECT_EQ(r.error().find('\n'), std::string::npos) << r.error();
  EXPECT_NE(r.error().find("& more"), std::string::npos) << r.error(); // entities decoded
}

TEST(TileValidation, ExceptionTextIsShortenedAndOwsReportsAreRead) {
  const std::string longText(1000, 'w');
  const std::string doc = "<ServiceExceptionReport><ServiceException><![CDATA[" + longText +
                          "]]></ServiceException></ServiceExceptionReport>";
  const std::string text = serviceExceptionText(bytes(doc));
  EXPECT_EQ(text.size(), 200u);
  const std::string ows =
      "<?xml version=\"1.0\"?><ows:ExceptionReport xmlns:ows=\"http://www.opengis.net/ows/1.1\">"
      "<ows:Exception exceptionCode=\"TileOutOfRange\"><ows:ExceptionText>Row 99 is out of "
      "range</ows:ExceptionText></ows:Exception></ows:ExceptionReport>";
  auto r = validateTile(response(bytes(ows), "application/xml"), "image/jpeg", 256, 256);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("Row 99 is out of range"), std::string::npos) << r.error();
  EXPECT_EQ(serviceExceptionText(bytes("<a>no exception here</a>")), "");
}

TEST(TileValidation, HtmlErrorPageIsAnError) {
  auto r = validateTile(
      response(bytes("<html><head><title>502 Bad Gateway</title></head></html>"), "image/jpeg"),
      "image/jpeg",
      256,
      256);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("HTML"), std::string::npos) << r.error();
}

TEST(TileValidation, WrongSizeIsAnError) {
  auto r = validateTile(response(encode("png", 32, 32), "image/png"), "image/png", 512, 512);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("32x32"), std::string::npos) << r.error();
  EXPECT_NE(r.error().find("512x512"), std::string::npos) << r.error();
}

TEST(TileValidation, TruncatedImagesDoNotDecode) {
  auto jpeg = encode("jpg", 128, 128);
  jpeg.resize(jpeg.size() / 2);
  auto r = validateTile(response(jpeg, "image/jpeg"), "image/jpeg", 128, 128);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("JPEG"), std::string::npos) << r.error();

  // Cut short, with an end-of-image marker glued on: the decoder still notices.
  jpeg.push_back(std::byte{0xFF});
  jpeg.push_back(std::byte{0xD9});
  auto padded = validateTile(response(jpeg, "image/jpeg"), "image/jpeg", 128, 128);
  ASSERT_FALSE(padded);
  EXPECT_NE(padded.error().find("does not decode"), std::string::npos) << padded.error();

  auto tiff = encode("tif", 128, 128);
  tiff.resize(tiff.size() / 2);
  auto t = validateTile(response(tiff, "image/tiff"), "image/tiff", 128, 128);
  ASSERT_FALSE(t);
  EXPECT_NE(t.error().find("TIFF"), std::string::npos) << t.error();

  auto png = encode("png", 128, 128);
  png.resize(png.size() / 2);
  auto p = validateTile(response(png, "image/png"), "image/png", 128, 128);
  ASSERT_FALSE(p);
  EXPECT_NE(p.error().find("PNG"), std::string::npos) << p.error();
}

TEST(TileValidation, ContentTypeMustMatchTheRequestAndTheBytes) {
  const auto png = encode("png", 16, 16);
  EXPECT_FALSE(validateTile(response(png, "image/jpeg"), "image/jpeg", 16, 16)); // bytes say PNG
  EXPECT_FALSE(validateTile(response(png, "image/png"), "image/jpeg", 16, 16));  // not asked for
  EXPECT_FALSE(validateTile(response(png, "text/plain"), "image/png", 16, 16));
  EXPECT_FALSE(validateTile(response(png, ""), "image/png", 16, 16));
  EXPECT_FALSE(validateTile(response(bytes("garbage bytes"), "image/png"), "image/png", 16, 16));
}

TEST(TileValidation, Bil16MustHaveExactlyTwoBytesPerSample) {
  const std::vector<std::byte> good(150 * 150 * 2);
  for (const char* type :
       {"application/bil16", "application/bil", "image/bil", "application/octet-stream"}) {
    EXPECT_TRUE(valid(response(good, type), "application/bil16", 150, 150)) << type;
  }
  auto shorter = validateTile(response(std::vector<std::byte>(150 * 150 * 2 - 2), "image/bil"),
                              "application/bil16",
                              150,
                              150);
  ASSERT_FALSE(shorter);
  EXPECT_NE(shorter.error().find("45000"), std::string::npos) << shorter.error();
  EXPECT_FALSE(validateTile(response(good, "image/png"), "application/bil16", 150, 150));
  // A first sample of 60 ('<' then 0) is no markup when it comes as BIL (issue 24).
  std::vector<std::byte> lt(150 * 150 * 2, std::byte{0});
  lt[0] = std::byte{'<'};
  EXPECT_TRUE(valid(response(lt, "application/bil16"), "application/bil16", 150, 150));
  EXPECT_FALSE(valid(response(lt, "text/xml"), "application/bil16", 150, 150));
  EXPECT_FALSE(validateTile(
      response(bytes(kServiceException), "application/bil16"), "application/bil16", 150, 150));
}

TEST(TileValidation, EmptyBodyAndNon200AreErrors) {
  EXPECT_FALSE(validateTile(response({}, "image/png"), "image/png", 16, 16));
  const auto png = encode("png", 16, 16);
  EXPECT_FALSE(validateTile(response(png, "image/png", 304), "image/png", 16, 16));
  EXPECT_FALSE(validateTile(response(png, "image/png", 404), "image/png", 16, 16));
  EXPECT_FALSE(validateTile(response(png, "image/png"), "image/png", 0, 16));
}
