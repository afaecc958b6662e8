#include <tellus/proxy/OgcExceptionFormat.hpp>
#include <tellus/proxy/Query.hpp>

namespace tellus {

namespace {

bool isAlpha(char c) noexcept {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z');
}

bool isSchemeChar(char c) noexcept {
  return isAlpha(c) || (c >= '0' && c <= '9') || c == '+' || c == '-' || c == '.';
}

// Ends a URL or a path.
bool isTerminator(char c) noexcept {
  switch (c) {
  case ' ':
  case '\t':
  case '\n':
  case '\r':
  case '"':
  case '\'':
  case '`':
  case '<':
  case '>':
  case ')':
  case ']':
  case '}':
    return true;
  default:
    return false;
  }
}

// May precede the start of a path.
bool isPathBoundary(char c) noexcept {
  switch (c) {
  case ' ':
  case '\t':
  case '\n':
  case '\r':
  case '"':
  case '\'':
  case '`':
  case '(':
  case '[':
  case '{':
  case '<':
  case '=':
  case ':':
  case ',':
  case ';':
    return true;
  default:
    return false;
  }
}

bool isTrailingPunctuation(char c) noexcept {
  return c == '.' || c == ',' || c == ';' || c == ':' || c == '!' || c == '?';
}

// End of the token starting at `from`, with trailing sentence punctuation left outside.
std::size_t tokenEnd(std::string_view s, std::size_t start, std::size_t from) {
  std::size_t end = from;
  while (end < s.size() && !isTerminator(s[end]))
    ++end;
  while (end > start + 1 && end > from && isTrailingPunctuation(s[end - 1]))
    --end;
  return end;
}

// Length of the URL starting at i ("scheme://..."), or 0.
std::size_t urlAt(std::string_view s, std::size_t i) {
  if (!isAlpha(s[i]) || (i > 0 && isSchemeChar(s[i - 1]))) return 0;
  std::size_t j = i;
  while (j < s.size() && isSchemeChar(s[j]))
    ++j;
  if (s.substr(j, 3) != "://") return 0;
  return tokenEnd(s, i, j + 3) - i;
}

// Length of the absolute path starting at i ("/x", "~/x", "C:\x", "\\x"), or 0.
std::size_t pathAt(std::string_view s, std::size_t i) {
  if (i > 0 && !isPathBoundary(s[i - 1])) return 0;
  const auto at = [&](std::size_t k) { return k < s.size() ? s[k] : ' '; };
  std::size_t bodyStart = 0;
  if (s[i] == '/' || s[i] == '\\') {
    bodyStart = i + 1;
  } else if (s[i] == '~' && at(i + 1) == '/') {
    bodyStart = i + 2;
  } else if (isAlpha(s[i]) && at(i + 1) == ':' && (at(i + 2) == '\\' || at(i + 2) == '/')) {
    bodyStart = i + 3;
  } else {
    return 0;
  }
  if (isTerminator(at(bodyStart))) return 0; // a lone "/" is punctuation, not a path
  return tokenEnd(s, i, bodyStart) - i;
}

std::string cutUtf8(std::string text, std::size_t maxBytes) {
  if (text.size() <= maxBytes) return text;
  std::size_t cut = maxBytes;
  while (cut > 0 && (static_cast<unsigned char>(text[cut]) & 0xC0u) == 0x80u)
    --cut;
  text.resize(cut);
  text += "...";
  return text;
}

} // namespace

std::string sanitizeForClient(std::string_view message) {
  std::string out;
  out.reserve(message.size());
  std::size_t i = 0;
  while (i < message.size()) {
    if (const std::size_t n = urlAt(message, i); n > 0) {
      out += "[url]";
      i += n;
    } else if (const std::size_t m = pathAt(message, i); m > 0) {
      out += "[path]";
      i += m;
    } else {
      out.push_back(message[i]);
      ++i;
    }
  }
  return out;
}

int wmsExceptionHttpStatus(std::string_view code) noexcept {
  if (code == ogc::kOperationNotSupported) return 501;
  for (const std::string_view client : {ogc::kLayerNotDefined,
                                        ogc::kInvalidCrs,
                                        ogc::kInvalidSrs,
                                        ogc::kInvalidFormat,
                                        ogc::kStyleNotDefined,
                                        ogc::kLayerNotQueryable,
                                        ogc::kInvalidPoint,
                                        ogc::kMissingDimensionValue,
                                        ogc::kInvalidDimensionValue,
                                        ogc::kMissingParameterValue,
                                        ogc::kInvalidParameterValue,
                                        ogc::kInvalidUpdateSequence,
                                        ogc::kCurrentUpdateSequence}) {
    if (code == client) return 400;
  }
  return 500;
}

FormattedResponse
formatWmsException(WmsVersion version, const OgcException& exception, bool httpStatusCodes) {
  FormattedResponse r;
  r.httpStatus = httpStatusCodes ? wmsExceptionHttpStatus(exception.code) : 200;
  std::string& b = r.body;
  b = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  if (version == WmsVersion::V111) {
    r.contentType = "application/vnd.ogc.se_xml";
    b += "<!DOCTYPE ServiceExceptionReport SYSTEM "
         "\"http://schemas.opengis.net/wms/1.1.1/WMS_exception_1_1_1.dtd\">\n";
    b += "<ServiceExceptionReport version=\"1.1.1\">\n";
  } else {
    r.contentType = "text/xml";
    b += "<ServiceExceptionReport version=\"1.3.0\" xmlns=\"http://www.opengis.net/ogc\" "
         "xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\" "
         "xsi:schemaLocation=\"http://www.opengis.net/ogc "
         "http://schemas.opengis.net/wms/1.3.0/exceptions_1_3_0.xsd\">\n";
  }
  b += "  <ServiceException";
  if (!exception.code.empty()) b += " code=\"" + xmlEscape(exception.code) + "\"";
  // WMS_exception_1_1_1.dtd declares no locator attribute (exceptions_1_3_0.xsd does).
  const std::string locator = cutUtf8(sanitizeForClient(exception.locator), 128);
  if (!locator.empty() && version == WmsVersion::V130)
    b += " locator=\"" + xmlEscape(locator) + "\"";
  b += ">";
  b += xmlEscape(cutUtf8(sanitizeForClient(exception.message), kMaxClientMessageBytes));
  b += "</ServiceException>\n";
  b += "</ServiceExceptionReport>\n";
  return r;
}

} // namespace tellus
