#pragma once
/**
 * @file TilePath.hpp
 * @brief The on-disk tree: `<server>/<dataset folder>/<level>/<row>/<row>_<col>.<ext>` (World Wind
 * Java's layout, no zero padding), and the safe encoding of names into single path components.
 */

#include <tellus/cache/TileKey.hpp>

#include <optional>
#include <string>
#include <string_view>

namespace tellus {

/** Longest encoded path component; longer names are cut and suffixed with a hash of the whole. */
inline constexpr std::size_t kMaxNameComponent = 96;

/**
 * @brief Encodes an arbitrary name (server, dataset) as one safe path component.
 *
 * Keeps [A-Za-z0-9_-] and '.', percent-encodes every other byte (so '/', '\\', NUL, control
 * characters and non-ASCII cannot reach the file system), encodes a leading '.' (so "." and ".."
 * and hidden names cannot occur), maps the empty name to "%" and cuts names longer than
 * kMaxNameComponent bytes to a prefix plus a 16-hex-digit hash. Distinct inputs of at most
 * kMaxNameComponent/3 bytes give distinct outputs.
 */
std::string encodeNameComponent(std::string_view name);

/** Relative path of a tile inside its dataset folder: "level/row/row_col.ext". */
std::string tileRelativePath(const TileKey& key, std::string_view extension);

/** Parses "level/row/row_col.ext" (also with a trailing folder prefix stripped by the caller);
 * std::nullopt for anything else (zero padding, signs, mismatched rows, overflow, level >
 * kMaxLevel). */
std::optional<TileKey> parseTileRelativePath(std::string_view path,
                                             std::string* extension = nullptr);

/** 64-bit FNV-1a of a byte string (stable across platforms and runs; used in folder names). */
std::uint64_t stableHash64(std::string_view bytes) noexcept;

} // namespace tellus
