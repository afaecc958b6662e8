#pragma once
// mpcdi.xml as a small element tree (expat; PRIVATE to tellus::mpcdi).

#include <expected>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace tellus::mpcdi::detail {

struct Element {
  std::string name;
  std::map<std::string, std::string> attributes;
  std::string text; ///< the character data directly inside, whitespace trimmed at both ends
  std::vector<std::unique_ptr<Element>> children;

  /** The first child named NAME, or null. */
  const Element* child(std::string_view name) const noexcept;
  std::vector<const Element*> all(std::string_view name) const;
  /** An attribute by name, its case ignored (MPCDI writers spell xResolution Xresolution too). */
  const std::string* attribute(std::string_view name) const noexcept;
};

/** The document's root element; "ORIGIN: not XML: <expat's message> at line N" when malformed. */
std::expected<std::unique_ptr<Element>, std::string> parseXml(std::string_view text,
                                                              std::string_view origin);

} // namespace tellus::mpcdi::detail
