#pragma once
// Where tiles and descriptors live in the bucket, and what a ListObjectsV2 answer says.

#include <tellus/cache/CacheTypes.hpp>
#include <tellus/cache/TileStore.hpp>

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace tellus::s3 {

/** Keys under a prefix ("" or "a/b"): unencoded, '/'-separated. */
class KeyLayout {
public:
  explicit KeyLayout(std::string prefix);

  /** `<prefix>/<folder>/<hhhh>/<level>/<row>/<row>_<col>.<ext>`. */
  std::string tile(const TileLocation& at) const;
  /** `<prefix>/<folder>/dataset.txt`. */
  std::string descriptor(std::string_view folder) const;
  /** `<prefix>/<folder>/` (listing a dataset), or `<prefix>/` for "". */
  std::string folder(std::string_view folder) const;
  /** The four hex digits that spread `folder`'s tile `key` over key prefixes. */
  static std::string spread(std::string_view folder, const TileKey& key);

  /** A key listed under folder(f) as scan() reports it: "dataset.txt", a tile's
   * "level/row/row_col.ext" (its spread digits dropped when they are the right ones), or the
   * key's rest unchanged. */
  static std::string entryPath(std::string_view folder, std::string_view rest);
  /** The inverse of entryPath (removeEntry). */
  std::string keyOfEntry(std::string_view folder, std::string_view path) const;

private:
  std::string root_; ///< prefix + "/" or ""
};

struct ListedObject {
  std::string key;
  std::int64_t size = 0;
  UnixMillis modified = 0;
};

struct ListPage {
  std::vector<ListedObject> objects;
  std::vector<std::string> commonPrefixes;
  std::optional<std::string> nextToken; ///< when truncated
};

/** Parses a ListObjectsV2 answer; nullopt when it is not one. */
std::optional<ListPage> parseListPage(std::string_view xml);
/** "2024-03-20T18:00:00.000Z" as milliseconds since 1970; 0 when unreadable. */
UnixMillis parseIsoMillis(std::string_view text);

} // namespace tellus::s3
