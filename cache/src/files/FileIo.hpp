#pragma once
// Crash-safe file writes, plain reads and the names of temp files (private to cache/).

#include <tellus/cache/CacheError.hpp>
#include <tellus/cache/Clock.hpp>

#include <cstddef>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <sys/stat.h>
#include <vector>

namespace tellus::fileio {

/**
 * A temp file's name for `targetName` written by this process: `.<target>.<pid>-<start>.<n>.tmp`,
 * where `start` is this process's start time (clock ticks since boot, /proc/self/stat), so that
 * the name says which process owns it even after its pid is reused.
 */
std::string tempNameFor(const std::string& targetName);

/** True for temp names: `.<target>.<owner>.<n>.tmp` (owner `<pid>-<start>`, or `<pid>` as written
 * by earlier versions). */
bool isTempName(const std::string& fileName);

/** Whether the process that wrote a temp file of this name may still be writing it: true while a
 * process with its pid (and, for names that carry it, its start time) runs. A name that does not
 * parse counts as owned (never removed by a cleaner). */
bool tempOwnerAlive(const std::string& fileName);

/** Writes bytes to `temp` (created exclusively) and optionally fsyncs it; a `modified` above 0
 * becomes its mtime (the tile's version, TileLocation::fetchedAt). On failure the temp file is
 * removed. ENOSPC, EFBIG and EDQUOT give CacheErrc::DiskFull; messages name `target`. */
std::expected<void, CacheError> writeTemp(const std::filesystem::path& temp,
                                          std::span<const std::byte> bytes,
                                          bool fsyncFile,
                                          const std::filesystem::path& target,
                                          UnixMillis modified = 0);

/** One file of writeTemps. */
struct TempWrite {
  std::filesystem::path temp;
  std::span<const std::byte> bytes;
  std::filesystem::path target; ///< named by messages
  UnixMillis modified = 0;      ///< above 0: its mtime
};

/** A file's mtime in milliseconds, as writeTemp sets it. */
UnixMillis modifiedMillis(const struct stat& st) noexcept;

/** writeTemp for several files, all or none, their fsyncs together: every file written, then the
 * write-back of each started (sync_file_range), then each fsynced, so that the file system commits
 * them in one journal transaction instead of one each. On any failure every temp file is removed
 * and the first error returned. */
std::expected<void, CacheError> writeTemps(std::span<const TempWrite> files, bool fsyncFiles);

/**
 * Writes bytes to a temp file beside target (tempNameFor), optionally fsyncs it, and renames it
 * onto target. On any failure the temp file is removed and target is untouched. The target's
 * directory must exist.
 */
std::expected<void, CacheError> writeFileAtomic(const std::filesystem::path& target,
                                                std::span<const std::byte> bytes,
                                                bool fsyncFile);

/** Reads a whole file; nullopt if it is missing or its size is not expectedSize (when given). */
std::optional<std::vector<std::byte>> readFile(const std::filesystem::path& path,
                                               std::optional<std::size_t> expectedSize);

/** An errno as a cache error: ENOSPC, EFBIG and EDQUOT are DiskFull, the rest Io. */
CacheError errnoError(int err, const std::string& what, const std::filesystem::path& path);
/** Whether an errno means "no room": ENOSPC, EFBIG, EDQUOT. */
bool isNoSpace(int err) noexcept;

/** Makes SIGXFSZ (file size limit) an EFBIG error instead of process death; idempotent. */
void ignoreFileSizeSignal();

} // namespace tellus::fileio
