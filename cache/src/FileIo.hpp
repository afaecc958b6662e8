#pragma once
// Crash-safe file writes and plain reads (private to cache/).

#include <tellus/cache/CacheError.hpp>

#include <cstddef>
#include <expected>
#include <filesystem>
#include <optional>
#include <span>
#include <vector>

namespace tellus::fileio {

/**
 * Writes bytes to `<dir of target>/.<target name>.<pid>.<n>.tmp`, optionally fsyncs it, and renames
 * it onto target. On any failure the temp file is removed and target is untouched. ENOSPC, EFBIG
 * and EDQUOT give CacheErrc::DiskFull. The target's directory must exist.
 */
std::expected<void, CacheError> writeFileAtomic(const std::filesystem::path& target,
                                                std::span<const std::byte> bytes,
                                                bool fsyncFile);

/** Reads a whole file; nullopt if it is missing or its size is not expectedSize (when given). */
std::optional<std::vector<std::byte>> readFile(const std::filesystem::path& path,
                                               std::optional<std::size_t> expectedSize);

/** True for names written by writeFileAtomic before their rename (".name.pid.n.tmp"). */
bool isTempName(const std::string& fileName);

/** Makes SIGXFSZ (file size limit) an EFBIG error instead of process death; idempotent. */
void ignoreFileSizeSignal();

} // namespace tellus::fileio
