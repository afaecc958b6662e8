#include <tellus/proxy/OgcExceptionFormat.hpp>
#include <tellus/proxy/Query.hpp>

#include <algorithm>

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

char lowerAscii(char c) noexcept {
  return (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c;
}

// A name that says its value is a secret: api_key, apikey, X-Api-Key, access_token, password,
// client_secret, signature, sig, auth, session ...
bool credentialName(std::string_view name) {
  std::string n;
  for (char c : name)
    if (c != '-' && c != '_' && c != '.') n.push_back(lowerAscii(c));
  if (n == "sig" || n == "key" || n == "pwd" || n == "pass") return true;
  for (std::string_view w : {"apikey",
                             "token",
                             "secret",
                             "passw",
                             "auth",
                             "signature",
                             "session",
                             "credential",
                             "accesskey",
                             "privatekey"}) {
    if (n.find(w) != std::string::npos) return true;
  }
  return n.ends_with("key");
}

bool isNameChar(char c) noexcept {
  return isAlpha(c) || (c >= '0' && c <= '9') || c == '_' || c == '-' || c == '.';
}

// May precede a key=value pair or a bare credential.
bool isWordBoundary(char c) noexcept {
  return isPathBoundary(c) || c == '?' || c == '&' || c == '/';
}

// Ends the value of a key=value pair.
bool endsValue(char c) noexcept {
  return isTerminator(c) || c == '&' || c == ',' || c == ';';
}

// "name=value" or "name: value" whose name says it is a secret, starting at i: the length of the
// name and its separator (the value follows), or 0.
std::size_t credentialAt(std::string_view s, std::size_t i) {
  if (i > 0 && !isWordBoundary(s[i - 1])) return 0;
  std::size_t j = i;
  while (j < s.size() && isNameChar(s[j]))
    ++j;
  if (j == i || j >= s.size() || !credentialName(s.substr(i, j - i))) return 0;
  if (s[j] == '=') return j + 1 - i;
  if (s[j] == ':' && j + 1 < s.size() && s[j + 1] == ' ') return j + 2 - i;
  return 0;
}

// An HTTP authorisation scheme followed by its credentials ("Bearer abc", "Basic dXNlcg=="),
// starting at i: the length of the scheme and the blank, or 0.
std::size_t authSchemeAt(std::string_view s, std::size_t i) {
  if (i > 0 && !isWordBoundary(s[i - 1])) return 0;
  for (std::string_view scheme : {"bearer ", "basic ", "digest "}) {
    if (s.size() - i <= scheme.size()) continue;
    bool same = true;
    for (std::size_t k = 0; k < scheme.size() && same; ++k)
      same = lowerAscii(s[i + k]) == scheme[k];
    if (same && !isTerminator(s[i + scheme.size()])) return scheme.size();
  }
  return 0;
}

// "user:password@host..." without a scheme, starting at i: the length of the whole token, or 0.
std::size_t userinfoAt(std::string_view s, std::size_t i) {
  if (i > 0 && !isWordBoundary(s[i - 1])) return 0;
  if (!isNameChar(s[i])) return 0;
  bool colon = false;
  const std::size_t end = std::min(s.size(), i + 512); // user:password@ is short
  for (std::size_t j = i; j < end && !isTerminator(s[j]) && s[j] != '/'; ++j) {
    if (s[j] == ':') colon = true;
    if (s[j] == '@') return colon && j > i ? tokenEnd(s, i, j + 1) - i : 0;
  }
  return 0;
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
  const auto skipValue = [&](std::size_t from) {
    while (from < message.size() && !endsValue(message[from]))
      ++from;
    return from;
  };
  while (i < message.size()) {
    if (const std::size_t n = urlAt(message, i); n > 0) {
      out += "[url]";
      i += n;
    } else if (const std::size_t m = pathAt(message, i); m > 0) {
      out += "[path]";
      i += m;
    } else if (const std::size_t u = userinfoAt(message, i); u > 0) {
      out += "[url]";
      i += u;
    } else if (const std::size_t c = credentialAt(message, i); c > 0) {
      out.append(message.substr(i, c));
      out += "[redacted]";
      std::size_t value = i + c; // "Authorization: Bearer abc": the scheme and its credentials
      value += authSchemeAt(message, value);
      i = skipValue(value);
    } else if (const std::size_t a = authSchemeAt(message, i); a > 0) {
      out.append(message.substr(i, a));
      out += "[redacted]";
      i = skipValue(i + a);
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
