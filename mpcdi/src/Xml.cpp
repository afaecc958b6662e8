#include "Xml.hpp"

#include <algorithm>
#include <cctype>
#include <expat.h>
#include <limits>

namespace tellus::mpcdi::detail {
namespace {

struct Builder {
  std::unique_ptr<Element> root;
  std::vector<Element*> open; ///< the elements entered and not yet left

  static void start(void* self, const XML_Char* name, const XML_Char** attrs) {
    auto* b = static_cast<Builder*>(self);
    auto e = std::make_unique<Element>();
    e->name = name;
    for (int i = 0; attrs[i] != nullptr && attrs[i + 1] != nullptr; i += 2)
      e->attributes[attrs[i]] = attrs[i + 1];
    Element* raw = e.get();
    if (b->open.empty())
      b->root = std::move(e);
    else
      b->open.back()->children.push_back(std::move(e));
    b->open.push_back(raw);
  }
  static void end(void* self, const XML_Char*) {
    auto* b = static_cast<Builder*>(self);
    std::string& t = b->open.back()->text;
    const auto notSpace = [](unsigned char c) { return !std::isspace(c); };
    t.erase(t.begin(), std::find_if(t.begin(), t.end(), notSpace));
    t.erase(std::find_if(t.rbegin(), t.rend(), notSpace).base(), t.end());
    b->open.pop_back();
  }
  static void text(void* self, const XML_Char* s, int len) {
    auto* b = static_cast<Builder*>(self);
    if (!b->open.empty()) b->open.back()->text.append(s, static_cast<std::size_t>(len));
  }
};

bool equalNoCase(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) ==
                  std::tolower(static_cast<unsigned char>(y));
         });
}

} // namespace

const Element* Element::child(std::string_view n) const noexcept {
  for (const auto& c : children)
    if (c->name == n) return c.get();
  return nullptr;
}

std::vector<const Element*> Element::all(std::string_view n) const {
  std::vector<const Element*> out;
  for (const auto& c : children)
    if (c->name == n) out.push_back(c.get());
  return out;
}

const std::string* Element::attribute(std::string_view n) const noexcept {
  for (const auto& [k, v] : attributes)
    if (equalNoCase(k, n)) return &v;
  return nullptr;
}

std::expected<std::unique_ptr<Element>, std::string> parseXml(std::string_view text,
                                                              std::string_view origin) {
  if (text.size() > static_cast<std::size_t>(std::numeric_limits<int>::max()))
    return std::unexpected(std::string(origin) + ": too large");
  Builder b;
  XML_Parser p = XML_ParserCreate(nullptr);
  if (p == nullptr) return std::unexpected(std::string(origin) + ": out of memory");
  XML_SetUserData(p, &b);
  XML_SetElementHandler(p, &Builder::start, &Builder::end);
  XML_SetCharacterDataHandler(p, &Builder::text);
  const auto status = XML_Parse(p, text.data(), static_cast<int>(text.size()), XML_TRUE);
  std::string error;
  if (status != XML_STATUS_OK)
    error = std::string(origin) + ": not XML: " + XML_ErrorString(XML_GetErrorCode(p)) +
            " at line " + std::to_string(XML_GetCurrentLineNumber(p));
  XML_ParserFree(p);
  if (!error.empty()) return std::unexpected(error);
  if (!b.root) return std::unexpected(std::string(origin) + ": no root element");
  return std::move(b.root);
}

} // namespace tellus::mpcdi::detail
