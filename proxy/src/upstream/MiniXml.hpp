#pragma once
/**
 * @file MiniXml.hpp
 * @brief A small, strict XML reader for the documents tellus reads from upstreams (WMTS
 * capabilities): elements, attributes, character data, the five predefined entities and numeric
 * character references, CDATA, comments, processing instructions and a DOCTYPE without an internal
 * subset (skipped). Namespaces are not resolved: a name keeps its prefix and `local()` drops it,
 * which is all a reader of one well-known vocabulary needs.
 *
 * Limits against hostile input: at most 64 levels of nesting and 1,000,000 elements; no entity
 * other than the predefined ones is expanded (so no "billion laughs"); no external resource is
 * ever read. An error names the byte offset and what is wrong.
 */

#include <cstddef>
#include <expected>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace tellus::xml {

struct Element {
  std::string name; ///< as written, with its prefix ("ows:Identifier")
  std::vector<std::pair<std::string, std::string>> attributes; ///< names as written
  std::string text; ///< the character data directly inside, concatenated (entities expanded)
  std::vector<std::unique_ptr<Element>> children;

  /** The name without its prefix ("Identifier"). */
  std::string_view local() const noexcept;
  /** The first child with this local name, or nullptr. */
  const Element* child(std::string_view localName) const noexcept;
  /** Every child with this local name, in document order. */
  std::vector<const Element*> all(std::string_view localName) const;
  /** The first child's text with surrounding white space removed ("" when there is none). */
  std::string childText(std::string_view localName) const;
  /** An attribute by local name (prefix ignored), or nullptr. */
  const std::string* attribute(std::string_view localName) const noexcept;
};

/** Parses a whole document; the root element. */
std::expected<std::unique_ptr<Element>, std::string> parse(std::string_view document);

/** `s` without leading and trailing XML white space. */
std::string_view trim(std::string_view s) noexcept;

} // namespace tellus::xml
