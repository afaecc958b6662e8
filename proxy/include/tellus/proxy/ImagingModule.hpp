#pragma once
/**
 * @file ImagingModule.hpp
 * @brief The imaging module (libtellus_imaging.so, OpenImageIO inside) that the proxy loads with
 * dlopen() the first time a tile has to be decoded or encoded.
 *
 * `encodeImage`, `blankImage`, TIFF heights, `LocalRasterSource` pixels and `validateTile`'s decode
 * load it on demand; nothing else does, so a `tellus serve` that only answers cached tiles never
 * maps OpenImageIO (about 121 MiB of RSS). Where it is looked for, in order:
 *
 *  1. `$TELLUS_IMAGING_MODULE` (a file; when set, the only place looked at);
 *  2. next to the running executable, then `<executable's folder>/../lib/tellus/`;
 *  3. the module's absolute path in the build tree (so tests and `build/tools/tellus/tellus` run
 *     without installing).
 */

#include <expected>
#include <filesystem>
#include <string>
#include <vector>

namespace tellus {

/** Whether this process has loaded the imaging module (for tests and diagnostics). */
bool imagingModuleLoaded() noexcept;

/** Loads the imaging module now if it is not loaded (thread-safe; tried once per process):
 * the file loaded, or "cannot load the imaging module <path>: <why>". */
std::expected<std::filesystem::path, std::string> loadImagingModule();

/** Where the module is looked for, in order (what loadImagingModule() tries). */
std::vector<std::filesystem::path> imagingModuleCandidates();

/** Opens a module file and checks its function table and version without making it this
 * process's imaging module (diagnostics, tests). The file stays mapped. */
std::expected<void, std::string> checkImagingModule(const std::filesystem::path& file);

} // namespace tellus
