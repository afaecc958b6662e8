#pragma once
/**
 * @file AtmosphereCache.hpp
 * @brief The atmosphere's precomputed tables (Atmosphere.hpp) kept on disk, so that a start-up
 * with the same atmosphere reads them (tens of milliseconds) instead of computing them (1.3-1.5 s
 * on two idle cores, 5-7 s on a loaded machine).
 *
 * One file per atmosphere: `<dir>/atmosphere-<key>.bin`, key = 16 hex digits of a 64-bit FNV-1a
 * hash of the format version, every AtmosphereParameters field and every AtmosphereTableSizes
 * field. The file: the magic "TELLUSAT", the format version (uint32), the parameters and the
 * sizes again (read back and compared exactly, so a hash collision cannot load another
 * atmosphere), the four tables' float counts and floats (transmittance, scattering, Mie,
 * Psi_ms), and an FNV-1a hash of everything before it. Little-endian as written by this machine
 * (a file from another byte order fails its checks and is recomputed).
 *
 * Reading never trusts the file: a missing, short, long, corrupt or foreign file gives an error
 * (and cachedAtmosphereTables recomputes and rewrites it). Writing is atomic: a temporary file in
 * the same folder, then rename(2), so a reader never sees half a file and two processes writing at
 * once leave one whole file. Where the folder cannot be written the tables are still computed
 * (the cache is an optimisation, never a reason to fail).
 *
 * Threads: the functions are reentrant; different processes may share the folder.
 */

#include <tellus/planet/Atmosphere.hpp>

#include <cstdint>
#include <expected>
#include <filesystem>
#include <string>

namespace tellus::planet {

/** The file format's version: bump it when the layout or the tables' meaning changes. */
inline constexpr std::uint32_t kAtmosphereCacheVersion = 1;

/** The cache key of an atmosphere's tables: 16 lower-case hex digits. */
std::string atmosphereCacheKey(const AtmosphereParameters& p, const AtmosphereTableSizes& s);

/** The file for those tables under `dir`. */
std::filesystem::path atmosphereCacheFile(const std::filesystem::path& dir,
                                          const AtmosphereParameters& p,
                                          const AtmosphereTableSizes& s);

/** Reads the tables of (p, s) from `file`; an error says why the file was not used. */
std::expected<AtmosphereTables, std::string> loadAtmosphereTables(const std::filesystem::path& file,
                                                                  const AtmosphereParameters& p,
                                                                  const AtmosphereTableSizes& s);

/** Writes `tables` to `file` atomically (temporary file + rename), creating its folder. */
std::expected<void, std::string> saveAtmosphereTables(const AtmosphereTables& tables,
                                                      const std::filesystem::path& file);

/** How cachedAtmosphereTables got its tables. */
struct AtmosphereCacheResult {
  AtmosphereTables tables;
  bool fromCache = false;
  std::string note; ///< why the cache was not used or not written ("" when all went well)
};

/** The tables of (p, s): read from `dir` when a whole file of theirs is there, else computed
 * (precompute(p, s, threads)) and written there. dir empty: always computed, nothing written. */
AtmosphereCacheResult cachedAtmosphereTables(const std::filesystem::path& dir,
                                             const AtmosphereParameters& p,
                                             const AtmosphereTableSizes& s = {},
                                             int threads = 0);

} // namespace tellus::planet
