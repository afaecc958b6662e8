#pragma once
// Private to the config module: reading YAML with errors that point at the file, line, column and
// dotted key. yaml-cpp stays inside the config module's sources; its exceptions and ours (Failure)
// never leave parseDocument() (Parse.cpp), which turns every problem into a ConfigError. The
// sections of the document are read in ParseServer.cpp, ParseRenderer.cpp, ParseUpstreams.cpp and
// ParseLayers.cpp (ParseSections.hpp) with the scalar readers below.

#include "ConfigInternal.hpp"

#include <yaml-cpp/yaml.h>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <initializer_list>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace tellus::detail::yaml {

namespace fs = std::filesystem;

/** Thrown inside the parser only; caught in parseDocument. */
struct Failure {
  ConfigError error;
};

/** What a node is, for messages: "a mapping", "a list", "'text'" or "nothing". */
std::string describe(const YAML::Node& n);

/** "a, b, c". */
std::string join(std::initializer_list<std::string_view> names);

/** Where the values came from: the file's name and the mark of every key path read so far. */
class Reader {
public:
  explicit Reader(std::string file) : file_(std::move(file)) {}

  [[noreturn]] void fail(const YAML::Mark& m, std::string key, std::string message) const {
    ConfigError e;
    e.file = file_;
    if (!m.is_null()) {
      e.line = m.line + 1;
      e.column = m.column + 1;
    }
    e.key = std::move(key);
    e.message = std::move(message);
    throw Failure{std::move(e)};
  }

  void remember(const std::string& key, const YAML::Mark& m) { marks_.insert_or_assign(key, m); }

  /** The mark of the key, or of its nearest parent that was read. */
  YAML::Mark markFor(std::string key) const {
    for (;;) {
      if (const auto it = marks_.find(key); it != marks_.end()) return it->second;
      if (key.empty()) return YAML::Mark::null_mark();
      const auto cut = key.find_last_of(".[");
      key = cut == std::string::npos ? std::string() : key.substr(0, cut);
    }
  }

private:
  std::string file_;
  std::map<std::string, YAML::Mark> marks_;
};

/** "parent.key" ("key" at the top level). */
std::string childPath(const std::string& parent, std::string_view key);

/** "parent[i]". */
std::string indexPath(const std::string& parent, std::size_t i);

/** A mapping with a fixed set of keys: unknown and repeated keys are errors. */
class Map {
public:
  Map(Reader& r,
      const YAML::Node& node,
      std::string path,
      const YAML::Mark& where,
      std::initializer_list<std::string_view> allowed);

  const std::string& path() const noexcept { return path_; }
  const YAML::Mark& mark() const noexcept { return mark_; }
  std::string path(std::string_view key) const { return childPath(path_, key); }

  bool has(std::string_view key) const { return find(key) != nullptr; }
  /** The value of a key that is present and not null; remembers its mark. */
  std::optional<YAML::Node> get(std::string_view key) const;

  /** The value of a required key. */
  YAML::Node need(std::string_view key) const;

  /** Where a key is written (the key itself), for errors about keys that do not apply. */
  YAML::Mark keyMark(std::string_view key) const {
    const Entry* e = find(key);
    return e ? e->keyMark : mark_;
  }

  /** The value of a key for nested mappings: the node (may be null) and where to point. */
  std::pair<YAML::Node, YAML::Mark> child(std::string_view key) const {
    const Entry* e = find(key);
    if (!e) return {YAML::Node(YAML::NodeType::Null), mark_};
    return {e->value, e->keyMark};
  }

private:
  struct Entry {
    std::string key;
    YAML::Mark keyMark;
    YAML::Node value;
  };
  const Entry* find(std::string_view key) const {
    for (const auto& e : entries_) {
      if (e.key == key) return &e;
    }
    return nullptr;
  }

  Reader& r_;
  std::string path_;
  YAML::Mark mark_;
  std::vector<Entry> entries_;
};

// ---- scalars ------------------------------------------------------------------------------------

std::string text(Reader& r,
                 const YAML::Node& n,
                 const std::string& path,
                 std::string_view expected = "a string");

std::int64_t integer(
    Reader& r, const YAML::Node& n, const std::string& path, std::int64_t min, std::int64_t max);

std::int32_t int32(Reader& r, const YAML::Node& n, const std::string& path);

/** A number; YAML's .nan / .inf are read as such, and rejected unless allowNonFinite. */
double number(Reader& r, const YAML::Node& n, const std::string& path, bool allowNonFinite = false);

bool boolean(Reader& r, const YAML::Node& n, const std::string& path);

std::chrono::milliseconds duration(Reader& r, const YAML::Node& n, const std::string& path);

std::uint64_t size(Reader& r, const YAML::Node& n, const std::string& path);

/** The index of the name the node gives. */
std::size_t choice(Reader& r,
                   const YAML::Node& n,
                   const std::string& path,
                   std::initializer_list<std::string_view> names);

/** The elements of a list (null = none). */
std::vector<YAML::Node> list(Reader& r, const YAML::Node& n, const std::string& path);

/** A path from the configuration: "~" and "~/" at the start are $HOME, relative ones are relative
 * to base. */
fs::path resolvePath(const std::string& text, const fs::path& base);

} // namespace tellus::detail::yaml
