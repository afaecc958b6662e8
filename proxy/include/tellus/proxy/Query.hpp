#pragma once
/**
 * @file Query.hpp
 * @brief Protocol-neutral parsing of a URL query string (`a=1&b=2`): percent-decoding, case-
 * insensitive keys, bounded sizes. Pure functions, no sockets.
 */

#include <cstddef>
#include <expected>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace tellus {

/** Most parameters one query may hold (duplicates and key-only parameters count). */
inline constexpr std::size_t kMaxQueryParams = 100;

/**
 * @brief The decoded parameters of one query string.
 *
 * Keys are stored lower-case (ASCII), values decoded and verbatim. When a key occurs more than
 * once the first value wins and the key is marked as duplicated. Entries keep the order of their
 * first occurrence. Views returned by get() point into this object and stay valid while it lives
 * and is not modified or moved.
 */
class QueryParams {
public:
  struct Entry {
    std::string key;             ///< lower-case
    std::string value;           ///< decoded, first occurrence
    std::size_t occurrences = 1; ///< how often the key occurred
    bool conflicting = false;    ///< a later occurrence had another value than the first
  };

  /** The value of a key (compared ASCII case-insensitively), or std::nullopt when absent. A key
   * without '=' (`&styles&`) has an empty value. */
  std::optional<std::string_view> get(std::string_view lowerKey) const noexcept;
  bool contains(std::string_view lowerKey) const noexcept { return find(lowerKey) != nullptr; }
  /** True when the key occurred more than once (its first value is the one get() returns). */
  bool isDuplicated(std::string_view lowerKey) const noexcept;
  /** True when any key occurred more than once. */
  bool hasDuplicates() const noexcept;
  /** True when the key occurred more than once with different values (`WIDTH=1&WIDTH=2`; the
   * same value repeated is no conflict). */
  bool isConflicting(std::string_view lowerKey) const noexcept;

  std::size_t size() const noexcept { return entries_.size(); }
  bool empty() const noexcept { return entries_.empty(); }
  const std::vector<Entry>& entries() const noexcept { return entries_; }

  /** Adds a parameter as parseQuery does (key lower-cased, first value wins). For callers that
   * build parameters from another source (a form body, a test). */
  void add(std::string_view key, std::string_view value);
  /** As add(), taking the strings (no copies). */
  void take(std::string&& key, std::string&& value);

private:
  const Entry* find(std::string_view key) const noexcept;
  std::vector<Entry> entries_;
};

/**
 * @brief Parses a URL query string (without the '?'; one leading '?' is tolerated).
 *
 * Parameters are separated by '&'; empty segments are skipped; a parameter without '=' has an
 * empty value; a parameter with an empty key is ignored. Keys and values are percent-decoded with
 * '+' as space. Fails (with a message that does not echo the input) when the query is longer
 * than maxQueryBytes, a decoded key or value is longer than maxParamBytes, there are more than
 * kMaxQueryParams parameters, a percent escape is invalid (`%`, `%4`, `%zz`) or a NUL byte occurs
 * (raw or as `%00`).
 */
std::expected<QueryParams, std::string> parseQuery(std::string_view query,
                                                   std::size_t maxParamBytes = 2048,
                                                   std::size_t maxQueryBytes = 16384);

/** Decodes `%XX` escapes (hex digits of either case) and, when plusIsSpace, '+' as ' '. Fails for
 * an invalid or truncated escape and for NUL bytes (raw or decoded). */
std::expected<std::string, std::string> percentDecode(std::string_view text,
                                                      bool plusIsSpace = true);

/**
 * @brief Escapes text for XML element content and attribute values.
 *
 * `& < > " '` become entities, CR becomes `&#13;`; TAB and LF stay. Bytes XML 1.0 cannot carry
 * (other control characters, invalid or overlong UTF-8, surrogates, U+FFFE/U+FFFF) become '?', so
 * the result is always well-formed UTF-8 character data.
 */
std::string xmlEscape(std::string_view text);

} // namespace tellus
