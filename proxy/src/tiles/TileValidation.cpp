#include "imaging/ImagingLoader.hpp"

#include <tellus/codec/Jpeg.hpp>
#include <tellus/codec/Png.hpp>
#include <tellus/proxy/TileValidation.hpp>

#include <algorithm>
#include <array>
#include <cstdint>
#include <initializer_list>
#include <optional>
#include <vector>

namespace tellus {

const char* toString(ImageKind kind) noexcept {
  switch (kind) {
  case ImageKind::Jpeg:
    return "JPEG";
  case ImageKind::Png:
    return "PNG";
  case ImageKind::Tiff:
    return "TIFF";
  case ImageKind::Gif:
    return "GIF";
  case ImageKind::Webp:
    return "WebP";
  case ImageKind::Xml:
    return "XML";
  case ImageKind::Html:
    return "HTML";
  case ImageKind::Unknown:
    return "unknown";
  }
  return "unknown";
}

namespace {

constexpr std::size_t kMaxMessage = 200;
constexpr std::size_t kMarkupProbe = 1024; ///< bytes looked at to tell HTML from XML

unsigned char at(std::span<const std::byte> b, std::size_t i) noexcept {
  return std::to_integer<unsigned char>(b[i]);
}

bool startsWith(std::span<const std::byte> b, std::initializer_list<unsigned char> magic) noexcept {
  if (b.size() < magic.size()) return false;
  std::size_t i = 0;
  for (unsigned char m : magic) {
    if (at(b, i++) != m) return false;
  }
  return true;
}

char lower(char c) noexcept {
  return (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c;
}

std::string lowered(std::string_view s) {
  std::string out(s);
  std::transform(out.begin(), out.end(), out.begin(), lower);
  return out;
}

bool isSpace(char c) noexcept {
  return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v';
}

std::string_view trim(std::string_view s) noexcept {
  while (!s.empty() && isSpace(s.front()))
    s.remove_prefix(1);
  while (!s.empty() && isSpace(s.back()))
    s.remove_suffix(1);
  return s;
}

/** The start of a document as ASCII-ish text: UTF-8 (BOM dropped) or UTF-16 (every other byte). */
std::string textPrefix(std::span<const std::byte> b, std::size_t limit) {
  std::string out;
  if (startsWith(b, {0xFF, 0xFE}) || startsWith(b, {0xFE, 0xFF})) {
    const std::size_t lowByte = at(b, 0) == 0xFF ? 0 : 1;
    for (std::size_t i = 2; i + 1 < b.size() && out.size() < limit; i += 2)
      out.push_back(static_cast<char>(at(b, i + lowByte)));
    return out;
  }
  const std::size_t start = startsWith(b, {0xEF, 0xBB, 0xBF}) ? 3 : 0;
  const std::size_t end = std::min(b.size(), start + limit);
  out.reserve(end - start);
  for (std::size_t i = start; i < end; ++i)
    out.push_back(static_cast<char>(at(b, i)));
  return out;
}

/** The media type without parameters, lower case: "Image/PNG; mode=8bit" -> "image/png". */
std::string mediaType(std::string_view contentType) {
  const auto semi = contentType.find(';');
  return lowered(trim(contentType.substr(0, semi)));
}

std::string canonicalImageType(std::string t) {
  if (t == "image/jpg" || t == "image/pjpeg") return "image/jpeg";
  if (t == "image/x-png") return "image/png";
  if (t == "image/tif" || t == "image/x-tiff") return "image/tiff";
  return t;
}

ImageKind kindOfMime(std::string_view canonical) noexcept {
  if (canonical == "image/jpeg") return ImageKind::Jpeg;
  if (canonical == "image/png") return ImageKind::Png;
  if (canonical == "image/tiff") return ImageKind::Tiff;
  if (canonical == "image/gif") return ImageKind::Gif;
  if (canonical == "image/webp") return ImageKind::Webp;
  return ImageKind::Unknown;
}

bool isBilType(std::string_view t) noexcept {
  return t == "application/bil16" || t == "application/bil" || t == "image/bil";
}

std::string decodeEntities(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] != '&') {
      out.push_back(s[i]);
      continue;
    }
    const auto semi = s.find(';', i);
    if (semi == std::string_view::npos || semi - i > 10) {
      out.push_back('&');
      continue;
    }
    const std::string_view ent = s.substr(i + 1, semi - i - 1);
    char c = 0;
    if (ent == "lt")
      c = '<';
    else if (ent == "gt")
      c = '>';
    else if (ent == "amp")
      c = '&';
    else if (ent == "quot")
      c = '"';
    else if (ent == "apos")
      c = '\'';
    else if (ent.size() > 1 && ent[0] == '#') {
      unsigned long v = 0;
      const bool hex = ent[1] == 'x' || ent[1] == 'X';
      bool ok = ent.size() > (hex ? 2u : 1u);
      for (char d : ent.substr(hex ? 2 : 1)) {
        int digit = -1;
        if (d >= '0' && d <= '9') digit = d - '0';
        if (hex && lower(d) >= 'a' && lower(d) <= 'f') digit = lower(d) - 'a' + 10;
        if (digit < 0 || v > 0x10FFFF) {
          ok = false;
          break;
        }
        v = v * (hex ? 16u : 10u) + static_cast<unsigned long>(digit);
      }
      if (!ok) {
        out.push_back('&');
        continue;
      }
      c = (v >= 0x20 && v < 0x7F) ? static_cast<char>(v) : '?';
    } else {
      out.push_back('&');
      continue;
    }
    out.push_back(c);
    i = semi;
  }
  return out;
}

/** Replaces every "scheme://..." and "www...." with "[url]". */
std::string removeUrls(std::string_view s) {
  auto schemeChar = [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '+' ||
           c == '.' || c == '-';
  };
  auto urlEnd = [&](std::size_t from) {
    std::size_t e = from;
    while (e < s.size() && !isSpace(s[e]) && s[e] != '"' && s[e] != '\'' && s[e] != '<' &&
           s[e] != '>')
      ++e;
    return e;
  };
  std::string out;
  out.reserve(s.size());
  std::size_t i = 0;
  while (i < s.size()) {
    const auto sep = s.find("://", i);
    const auto www = lowered(s.substr(i)).find("www.");
    const std::size_t wwwAt = www == std::string::npos ? std::string_view::npos : i + www;
    if (sep == std::string_view::npos && wwwAt == std::string_view::npos) {
      out.append(s.substr(i));
      break;
    }
    std::size_t begin = 0;
    std::size_t end = 0;
    if (sep != std::string_view::npos && (wwwAt == std::string_view::npos || sep < wwwAt)) {
      begin = sep;
      while (begin > i && schemeChar(s[begin - 1]))
        --begin;
      end = urlEnd(sep + 3);
    } else {
      begin = wwwAt;
      end = urlEnd(wwwAt);
    }
    out.append(s.substr(i, begin - i));
    out.append("[url]");
    i = end;
  }
  return out;
}

/** Collapses whitespace and control bytes, drops URLs and keeps at most kMaxMessage bytes (never
 * cutting a UTF-8 sequence). */
std::string sanitise(std::string_view raw) {
  raw = raw.substr(0, 4096); // plenty for 200 characters; bounds the work on hostile bodies
  const std::string noUrls = removeUrls(decodeEntities(raw));
  std::string out;
  out.reserve(std::min(noUrls.size(), kMaxMessage));
  bool space = false;
  for (char c : noUrls) {
    const auto u = static_cast<unsigned char>(c);
    if (u < 0x20 || u == 0x7F) {
      space = true;
      continue;
    }
    if (c == ' ') {
      space = true;
      continue;
    }
    if (space && !out.empty()) out.push_back(' ');
    space = false;
    out.push_back(c);
  }
  if (out.size() > kMaxMessage) {
    std::size_t cut = kMaxMessage;
    while (cut > 0 && (static_cast<unsigned char>(out[cut]) & 0xC0) == 0x80)
      --cut;
    out.resize(cut);
  }
  return out;
}

/** The content of the first element named `name` (any namespace prefix) and its `code`/
 * `exceptionCode` attribute; nullopt when there is no such element. */
std::optional<std::string> elementText(std::string_view doc, std::string_view name) {
  std::size_t pos = 0;
  while ((pos = doc.find(name, pos)) != std::string_view::npos) {
    const std::size_t after = pos + name.size();
    std::size_t open = pos;
    // "<name" or "<prefix:name", followed by whitespace, '>' or '/'.
    if (open > 0 && doc[open - 1] == ':') {
      open -= 1;
      while (open > 0 && doc[open - 1] != '<' && doc[open - 1] != '/' && !isSpace(doc[open - 1]) &&
             doc[open - 1] != '>')
        --open;
    }
    const bool opening = open > 0 && doc[open - 1] == '<';
    const bool ends =
        after < doc.size() && (isSpace(doc[after]) || doc[after] == '>' || doc[after] == '/');
    if (!opening || !ends) {
      pos = after;
      continue;
    }
    const auto tagEnd = doc.find('>', after);
    if (tagEnd == std::string_view::npos) return std::nullopt;
    const std::string_view tag = doc.substr(after, tagEnd - after);
    std::string code;
    for (std::string_view attr :
         {std::string_view("exceptionCode=\""), std::string_view("code=\"")}) {
      const auto a = tag.find(attr);
      if (a == std::string_view::npos) continue;
      const auto q = tag.find('"', a + attr.size());
      if (q != std::string_view::npos) code = tag.substr(a + attr.size(), q - a - attr.size());
      break;
    }
    std::string text;
    if (tagEnd == 0 || doc[tagEnd - 1] != '/') {
      std::string_view rest = doc.substr(tagEnd + 1);
      // Text, CDATA sections and nested elements' text up to the closing tag of this element.
      const std::string closing = "</" + std::string(doc.substr(open, after - open));
      const auto close = rest.find(closing);
      rest = rest.substr(0, close);
      for (std::size_t i = 0; i < rest.size();) {
        if (rest.substr(i).starts_with("<![CDATA[")) {
          const auto e = rest.find("]]>", i + 9);
          text.append(rest.substr(i + 9, e == std::string_view::npos ? e : e - i - 9));
          if (e == std::string_view::npos) break;
          i = e + 3;
        } else if (rest[i] == '<') {
          const auto e = rest.find('>', i);
          if (e == std::string_view::npos) break;
          text.push_back(' ');
          i = e + 1;
        } else {
          text.push_back(rest[i++]);
        }
      }
    }
    const std::string_view t = trim(text);
    if (!code.empty()) return t.empty() ? code : code + ": " + std::string(t);
    return std::string(t);
  }
  return std::nullopt;
}

/** All text of a document, tags dropped. */
std::string allText(std::string_view doc) {
  std::string text;
  bool inTag = false;
  for (char c : doc) {
    if (c == '<') {
      inTag = true;
      text.push_back(' ');
    } else if (c == '>') {
      inTag = false;
    } else if (!inTag) {
      text.push_back(c);
    }
  }
  return text;
}

std::string sizeText(int w, int h) {
  return std::to_string(w) + "x" + std::to_string(h);
}

/** Decodes a whole JPEG or PNG (the proxy's own libjpeg-turbo and libpng: no OpenImageIO) or TIFF
 * (in the imaging module, loaded on the first call) and checks its size. */
std::expected<void, std::string>
decodeImage(std::span<const std::byte> bytes, ImageKind kind, int width, int height) {
  if (kind == ImageKind::Jpeg || kind == ImageKind::Png) {
    thread_local std::vector<std::uint8_t> scratch; // a worker validates many tiles of one size
    auto checked = kind == ImageKind::Jpeg ? codec::checkJpeg(bytes, width, height, scratch)
                                           : codec::checkPng(bytes, width, height, scratch);
    if (scratch.capacity() > (8u << 20)) scratch = {};
    if (!checked) return std::unexpected(sanitise(checked.error()));
    return {};
  }
  auto api = imaging::table();
  if (!api)
    return std::unexpected(std::string("cannot decode ") + toString(kind) + ": " + api.error());
  // By format name: OpenImageIO 2.4 would look for a file on disk otherwise.
  const char* format = kind == ImageKind::Jpeg ? "jpeg" : kind == ImageKind::Png ? "png" : "tiff";
  TellusImagingDecodeResult shape{};
  imaging::ErrorSink errors;
  switch ((*api)->decodeImage(
      bytes.data(), bytes.size(), format, width, height, &shape, errors.get())) {
  case TELLUS_IMAGING_OK:
    return {};
  case TELLUS_IMAGING_NO_CODEC:
    return std::unexpected(std::string("no decoder for ") + toString(kind));
  case TELLUS_IMAGING_OPEN_FAILED:
    return std::unexpected(std::string("cannot decode ") + toString(kind) + ": " +
                           sanitise(errors.error()));
  case TELLUS_IMAGING_SHAPE:
    if (shape.width != width || shape.height != height) {
      return std::unexpected(std::string(toString(kind)) + " is " +
                             sizeText(shape.width, shape.height) + ", expected " +
                             sizeText(width, height));
    }
    return std::unexpected(std::string(toString(kind)) + " has an unusable channel count");
  case TELLUS_IMAGING_READ_FAILED:
    return std::unexpected(
        std::string(toString(kind)) + " does not decode: " +
        (errors.error().empty() ? std::string("read failed") : sanitise(errors.error())));
  default:
    return std::unexpected(std::string("cannot decode ") + toString(kind) + ": " +
                           sanitise(errors.error()));
  }
}

/** The end-of-image marker: libjpeg pads a truncated JPEG with grey and only warns. */
bool jpegComplete(std::span<const std::byte> b) noexcept {
  // EOI (FF D9), possibly followed by a little padding some encoders append.
  const std::size_t from = b.size() > 256 ? b.size() - 256 : 0;
  for (std::size_t i = b.size(); i-- > from + 1;) {
    if (at(b, i) == 0xD9 && at(b, i - 1) == 0xFF) return true;
    if (at(b, i) != 0x00 && at(b, i) != 0xFF && at(b, i) != '\n' && at(b, i) != '\r' &&
        at(b, i) != ' ')
      return false;
  }
  return false;
}

} // namespace

ImageKind sniff(std::span<const std::byte> b) noexcept {
  if (startsWith(b, {0xFF, 0xD8, 0xFF})) return ImageKind::Jpeg;
  if (startsWith(b, {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A})) return ImageKind::Png;
  if (startsWith(b, {'I', 'I', 0x2A, 0x00}) || startsWith(b, {'M', 'M', 0x00, 0x2A}) ||
      startsWith(b, {'I', 'I', 0x2B, 0x00}) || startsWith(b, {'M', 'M', 0x00, 0x2B}))
    return ImageKind::Tiff;
  if (startsWith(b, {'G', 'I', 'F', '8', '7', 'a'}) ||
      startsWith(b, {'G', 'I', 'F', '8', '9', 'a'}))
    return ImageKind::Gif;
  if (b.size() >= 12 && startsWith(b, {'R', 'I', 'F', 'F'}) && at(b, 8) == 'W' && at(b, 9) == 'E' &&
      at(b, 10) == 'B' && at(b, 11) == 'P')
    return ImageKind::Webp;
  try {
    const std::string text = lowered(textPrefix(b, kMarkupProbe));
    const std::string_view t = trim(text);
    if (!t.starts_with('<')) return ImageKind::Unknown;
    if (t.find("<html") != std::string_view::npos ||
        t.find("<!doctype html") != std::string_view::npos)
      return ImageKind::Html;
    return ImageKind::Xml;
  } catch (...) {
    return ImageKind::Unknown;
  }
}

std::string serviceExceptionText(std::span<const std::byte> body) {
  const std::string doc = textPrefix(body, 64 * 1024);
  for (std::string_view name :
       {std::string_view("ServiceException"), std::string_view("ExceptionText")}) {
    if (auto text = elementText(doc, name)) {
      std::string s = sanitise(*text);
      if (!s.empty()) return s;
    }
  }
  if (doc.find("ServiceException") != std::string::npos ||
      doc.find("ExceptionReport") != std::string::npos) {
    std::string s = sanitise(allText(doc));
    return s.empty() ? std::string("ServiceException") : s;
  }
  return {};
}

std::expected<ImageKind, std::string> validateImageResponse(const FetchResponse& response,
                                                            std::string_view expectedMime) {
  if (response.status != 200)
    return std::unexpected("upstream status " + std::to_string(response.status) + ", not 200");
  const std::span<const std::byte> body(response.body);
  if (body.empty()) return std::unexpected(std::string("empty body"));

  const ImageKind kind = sniff(body);
  // BIL has no magic number: a tile whose first sample's low byte is '<' (a height of 60 m)
  // sniffs as markup. Sent as BIL where BIL is expected and holding no service exception, it is
  // taken as the samples it says it is.
  const bool bilAsBil = isBilType(canonicalImageType(mediaType(expectedMime))) &&
                        isBilType(canonicalImageType(mediaType(response.contentType)));
  if (kind == ImageKind::Xml || kind == ImageKind::Html) {
    const std::string text = serviceExceptionText(body);
    if (!text.empty()) return std::unexpected("upstream ServiceException: " + text);
    if (!bilAsBil)
      return std::unexpected(std::string("upstream sent ") + toString(kind) + " instead of a tile");
  }

  const std::string got = canonicalImageType(mediaType(response.contentType));
  const std::string want = canonicalImageType(mediaType(expectedMime));
  const std::string gotShown = sanitise(got.empty() ? std::string("(none)") : got);

  if (isBilType(want)) {
    if (!isBilType(got) && got != "application/octet-stream")
      return std::unexpected("content type " + gotShown + ", expected " + want);
    return kind;
  }

  if (!got.starts_with("image/"))
    return std::unexpected("content type " + gotShown + " is not an image");
  if (got != want) return std::unexpected("content type " + gotShown + ", expected " + want);
  const ImageKind wantKind = kindOfMime(want);
  if (kind == ImageKind::Unknown) return std::unexpected(std::string("body is not a known image"));
  if (wantKind != ImageKind::Unknown && kind != wantKind) {
    return std::unexpected(std::string("body is ") + toString(kind) + ", content type says " +
                           want);
  }
  if (kind == ImageKind::Jpeg && !jpegComplete(body))
    return std::unexpected(std::string("JPEG is truncated (no end-of-image marker)"));
  return kind;
}

std::expected<void, std::string> validateTile(const FetchResponse& response,
                                              std::string_view expectedMime,
                                              int expectedWidth,
                                              int expectedHeight) {
  if (response.status == 200 && !response.body.empty() &&
      (expectedWidth <= 0 || expectedHeight <= 0 || expectedWidth > 16384 ||
       expectedHeight > 16384))
    return std::unexpected("expected size " + sizeText(expectedWidth, expectedHeight) +
                           " out of range");
  auto kind = validateImageResponse(response, expectedMime);
  if (!kind) return std::unexpected(kind.error());
  const std::span<const std::byte> body(response.body);
  if (isBilType(canonicalImageType(mediaType(expectedMime)))) {
    const auto expectedBytes =
        static_cast<std::size_t>(expectedWidth) * static_cast<std::size_t>(expectedHeight) * 2;
    if (body.size() != expectedBytes) {
      return std::unexpected("bil16 tile has " + std::to_string(body.size()) + " bytes, expected " +
                             std::to_string(expectedBytes) + " (" +
                             sizeText(expectedWidth, expectedHeight) + ")");
    }
    return {};
  }
  if (*kind == ImageKind::Jpeg || *kind == ImageKind::Png || *kind == ImageKind::Tiff)
    return decodeImage(body, *kind, expectedWidth, expectedHeight);
  return {}; // GIF, WebP: the magic and the content type agree; not decoded here
}

} // namespace tellus
