// A small strict XML reader (MiniXml.hpp).

#include "MiniXml.hpp"

#include <cstdint>

namespace tellus::xml {

namespace {

constexpr int kMaxDepth = 64;
constexpr std::size_t kMaxElements = 1'000'000;

bool isSpace(char c) noexcept {
  return c == ' ' || c == '\t' || c == '\n' || c == '\r';
}

bool isNameChar(char c) noexcept {
  const auto u = static_cast<unsigned char>(c);
  return u >= 0x80 || (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
         c == '_' || c == ':' || c == '-' || c == '.';
}

void appendUtf8(std::string& out, std::uint32_t cp) {
  if (cp < 0x80) {
    out += static_cast<char>(cp);
  } else if (cp < 0x800) {
    out += static_cast<char>(0xC0 | (cp >> 6));
    out += static_cast<char>(0x80 | (cp & 0x3F));
  } else if (cp < 0x10000) {
    out += static_cast<char>(0xE0 | (cp >> 12));
    out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
    out += static_cast<char>(0x80 | (cp & 0x3F));
  } else {
    out += static_cast<char>(0xF0 | (cp >> 18));
    out += static_cast<char>(0x80 | ((cp >> 12) & 0x3F));
    out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
    out += static_cast<char>(0x80 | (cp & 0x3F));
  }
}

class Parser {
public:
  explicit Parser(std::string_view doc) : s_(doc) {}

  std::expected<std::unique_ptr<Element>, std::string> document() {
    if (s_.starts_with("\xEF\xBB\xBF")) i_ = 3; // a UTF-8 byte order mark
    if (!misc()) return std::unexpected(error_);
    if (i_ >= s_.size() || s_[i_] != '<') return fail("expected the root element");
    auto root = element(0);
    if (!root) return std::unexpected(error_);
    if (!misc()) return std::unexpected(error_);
    if (i_ != s_.size()) return fail("text after the root element");
    return root;
  }

private:
  std::string_view s_;
  std::size_t i_ = 0;
  std::size_t elements_ = 0;
  std::string error_;

  std::unexpected<std::string> fail(const std::string& what) {
    error_ = "XML: " + what + " at byte " + std::to_string(i_);
    return std::unexpected(error_);
  }
  bool bad(const std::string& what) {
    (void)fail(what);
    return false;
  }

  bool skipUntil(std::string_view end, const char* what) {
    const std::size_t at = s_.find(end, i_);
    if (at == std::string_view::npos) return bad(std::string("unterminated ") + what);
    i_ = at + end.size();
    return true;
  }

  /** White space, comments, processing instructions and a DOCTYPE, outside the root. */
  bool misc() {
    for (;;) {
      while (i_ < s_.size() && isSpace(s_[i_]))
        ++i_;
      const std::string_view rest = s_.substr(i_);
      if (rest.starts_with("<?")) {
        if (!skipUntil("?>", "processing instruction")) return false;
      } else if (rest.starts_with("<!--")) {
        if (!skipUntil("-->", "comment")) return false;
      } else if (rest.starts_with("<!DOCTYPE")) {
        const std::size_t end = s_.find('>', i_);
        if (end == std::string_view::npos) return bad("unterminated DOCTYPE");
        if (s_.substr(i_, end - i_).find('[') != std::string_view::npos)
          return bad("a DOCTYPE with an internal subset is not read");
        i_ = end + 1;
      } else {
        return true;
      }
    }
  }

  std::string name() {
    const std::size_t start = i_;
    while (i_ < s_.size() && isNameChar(s_[i_]))
      ++i_;
    return std::string(s_.substr(start, i_ - start));
  }

  /** Character data up to `stop` (not consumed), references expanded, into `out`. */
  bool chars(char stop, std::string& out) {
    while (i_ < s_.size() && s_[i_] != stop) {
      const char c = s_[i_];
      if (c == '<') return bad("'<' in an attribute value");
      if (c != '&') {
        out += c;
        ++i_;
        continue;
      }
      const std::size_t semi = s_.find(';', i_);
      if (semi == std::string_view::npos || semi - i_ > 12) return bad("a bad reference");
      const std::string_view ref = s_.substr(i_ + 1, semi - i_ - 1);
      if (ref == "lt")
        out += '<';
      else if (ref == "gt")
        out += '>';
      else if (ref == "amp")
        out += '&';
      else if (ref == "quot")
        out += '"';
      else if (ref == "apos")
        out += '\'';
      else if (ref.size() > 1 && ref[0] == '#') {
        const bool hex = ref[1] == 'x';
        std::uint32_t cp = 0;
        const std::string_view digits = ref.substr(hex ? 2 : 1);
        if (digits.empty()) return bad("a bad character reference");
        for (const char d : digits) {
          int v = -1;
          if (d >= '0' && d <= '9')
            v = d - '0';
          else if (hex && d >= 'a' && d <= 'f')
            v = d - 'a' + 10;
          else if (hex && d >= 'A' && d <= 'F')
            v = d - 'A' + 10;
          if (v < 0) return bad("a bad character reference");
          cp = cp * (hex ? 16 : 10) + static_cast<std::uint32_t>(v);
          if (cp > 0x10FFFF) return bad("a character reference out of range");
        }
        if (cp == 0) return bad("a reference to character 0");
        appendUtf8(out, cp);
      } else {
        return bad("an undeclared entity '&" + std::string(ref) + ";'");
      }
      i_ = semi + 1;
    }
    return true;
  }

  std::unique_ptr<Element> element(int depth) {
    if (depth >= kMaxDepth) return (void)bad("elements nested too deep"), nullptr;
    if (++elements_ > kMaxElements) return (void)bad("too many elements"), nullptr;
    ++i_; // '<'
    auto e = std::make_unique<Element>();
    e->name = name();
    if (e->name.empty()) return (void)bad("expected an element name"), nullptr;
    for (;;) {
      const std::size_t before = i_;
      while (i_ < s_.size() && isSpace(s_[i_]))
        ++i_;
      if (i_ >= s_.size()) return (void)bad("unterminated start tag"), nullptr;
      if (s_.substr(i_).starts_with("/>")) {
        i_ += 2;
        return e;
      }
      if (s_[i_] == '>') {
        ++i_;
        break;
      }
      if (i_ == before) return (void)bad("expected white space before an attribute"), nullptr;
      std::string an = name();
      if (an.empty()) return (void)bad("expected an attribute name"), nullptr;
      while (i_ < s_.size() && isSpace(s_[i_]))
        ++i_;
      if (i_ >= s_.size() || s_[i_] != '=') return (void)bad("expected '='"), nullptr;
      ++i_;
      while (i_ < s_.size() && isSpace(s_[i_]))
        ++i_;
      if (i_ >= s_.size() || (s_[i_] != '"' && s_[i_] != '\''))
        return (void)bad("expected a quoted attribute value"), nullptr;
      const char q = s_[i_++];
      std::string value;
      if (!chars(q, value)) return nullptr;
      if (i_ >= s_.size()) return (void)bad("unterminated attribute value"), nullptr;
      ++i_;
      for (const auto& [n, v] : e->attributes)
        if (n == an) return (void)bad("attribute '" + an + "' given twice"), nullptr;
      e->attributes.emplace_back(std::move(an), std::move(value));
    }
    // Content.
    for (;;) {
      if (i_ >= s_.size()) return (void)bad("unterminated element <" + e->name + ">"), nullptr;
      const std::string_view rest = s_.substr(i_);
      if (rest.starts_with("</")) {
        i_ += 2;
        const std::string end = name();
        if (end != e->name) return (void)bad("</" + end + "> closes <" + e->name + ">"), nullptr;
        while (i_ < s_.size() && isSpace(s_[i_]))
          ++i_;
        if (i_ >= s_.size() || s_[i_] != '>') return (void)bad("expected '>'"), nullptr;
        ++i_;
        return e;
      }
      if (rest.starts_with("<!--")) {
        if (!skipUntil("-->", "comment")) return nullptr;
      } else if (rest.starts_with("<![CDATA[")) {
        const std::size_t end = s_.find("]]>", i_);
        if (end == std::string_view::npos) return (void)bad("unterminated CDATA"), nullptr;
        e->text.append(s_.substr(i_ + 9, end - i_ - 9));
        i_ = end + 3;
      } else if (rest.starts_with("<?")) {
        if (!skipUntil("?>", "processing instruction")) return nullptr;
      } else if (rest.starts_with("<")) {
        auto child = element(depth + 1);
        if (!child) return nullptr;
        e->children.push_back(std::move(child));
      } else {
        while (i_ < s_.size() && s_[i_] != '<') {
          const std::size_t lt = s_.find_first_of("<&", i_);
          const std::size_t end = lt == std::string_view::npos ? s_.size() : lt;
          e->text.append(s_.substr(i_, end - i_));
          i_ = end;
          if (i_ < s_.size() && s_[i_] == '&' && !chars('<', e->text)) return nullptr;
        }
      }
    }
  }
};

} // namespace

std::string_view Element::local() const noexcept {
  const std::size_t colon = name.find(':');
  return colon == std::string::npos ? std::string_view(name)
                                    : std::string_view(name).substr(colon + 1);
}

const Element* Element::child(std::string_view localName) const noexcept {
  for (const auto& c : children)
    if (c->local() == localName) return c.get();
  return nullptr;
}

std::vector<const Element*> Element::all(std::string_view localName) const {
  std::vector<const Element*> out;
  for (const auto& c : children)
    if (c->local() == localName) out.push_back(c.get());
  return out;
}

std::string Element::childText(std::string_view localName) const {
  const Element* c = child(localName);
  return c ? std::string(trim(c->text)) : std::string();
}

const std::string* Element::attribute(std::string_view localName) const noexcept {
  for (const auto& [n, v] : attributes) {
    const std::size_t colon = n.find(':');
    const std::string_view l =
        colon == std::string::npos ? std::string_view(n) : std::string_view(n).substr(colon + 1);
    if (l == localName) return &v;
  }
  return nullptr;
}

std::string_view trim(std::string_view s) noexcept {
  while (!s.empty() && isSpace(s.front()))
    s.remove_prefix(1);
  while (!s.empty() && isSpace(s.back()))
    s.remove_suffix(1);
  return s;
}

std::expected<std::unique_ptr<Element>, std::string> parse(std::string_view document) {
  return Parser(document).document();
}

} // namespace tellus::xml
