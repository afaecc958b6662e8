#include "imaging/ImagingLoader.hpp"

#include <tellus/proxy/ImagingModule.hpp>

#include <atomic>
#include <cstdlib>
#include <cstring>
#include <dlfcn.h>
#include <mutex>

#ifndef TELLUS_IMAGING_MODULE_NAME
#error "proxy/CMakeLists.txt defines TELLUS_IMAGING_MODULE_NAME for this file"
#endif

namespace tellus {

namespace fs = std::filesystem;

namespace {

std::string cannotLoad(const fs::path& file, const std::string& why) {
  return "cannot load the imaging module " + file.string() + ": " + why;
}

std::string dlerrorText() {
  const char* e = ::dlerror();
  return e ? std::string(e) : std::string("unknown error");
}

/** dlopen()s one file and checks its table; the handle is kept on success (never closed: the
 * module's code and OpenImageIO stay mapped for the life of the process). */
std::expected<const TellusImagingTable*, std::string> openModule(const fs::path& file) {
  ::dlerror();
  void* handle = ::dlopen(file.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle) return std::unexpected(cannotLoad(file, dlerrorText()));
  void* symbol = ::dlsym(handle, TELLUS_IMAGING_TABLE_SYMBOL);
  if (!symbol) {
    auto error = cannotLoad(file, dlerrorText());
    ::dlclose(handle);
    return std::unexpected(error);
  }
  TellusImagingTableFn entry = nullptr;
  static_assert(sizeof(entry) == sizeof(symbol));
  std::memcpy(&entry, &symbol, sizeof(entry)); // object to function pointer, as POSIX allows
  const TellusImagingTable* t = entry();
  if (!t || t->abiVersion != TELLUS_IMAGING_ABI_VERSION || t->size < sizeof(TellusImagingTable)) {
    const std::string got = t ? std::to_string(t->abiVersion) : std::string("none");
    ::dlclose(handle);
    return std::unexpected(cannotLoad(file,
                                      "it has version " + got + " of the function table, this " +
                                          "tellus needs version " +
                                          std::to_string(TELLUS_IMAGING_ABI_VERSION)));
  }
  if (!t->encodeImage || !t->encodeHeightsTiff || !t->drawBlank || !t->probeRaster ||
      !t->readRaster || !t->decodeImage) {
    ::dlclose(handle);
    return std::unexpected(cannotLoad(file, "its function table is incomplete"));
  }
  return t;
}

struct Loaded {
  std::once_flag once;
  std::atomic<bool> loaded{false};
  const TellusImagingTable* table = nullptr;
  fs::path file;
  std::string error;
};

Loaded& state() {
  static Loaded s;
  return s;
}

/**
 * Encodes and decodes a small JPEG and PNG once, inside the call_once that every user of the module
 * passes. OpenImageIO 2.4 builds some of its tables (image attribute and tag names) on first use
 * without a lock that ThreadSanitizer sees; two threads encoding their first JPEGs at once were
 * reported as a race inside it. Built here, before any other thread can call in, they are only
 * read afterwards.
 */
void warmUp(const TellusImagingTable& t) {
  std::uint8_t pixels[8 * 8 * 3] = {};
  for (const char* format : {"jpeg", "png"}) {
    imaging::BytesSink bytes;
    if (t.encodeImage(format, 8, 8, 3, pixels, bytes.get()) != TELLUS_IMAGING_OK) continue;
    TellusImagingDecodeResult shape{};
    imaging::ErrorSink errors;
    (void)t.decodeImage(bytes.bytes.data(), bytes.bytes.size(), format, 8, 8, &shape, errors.get());
  }
}

void load(Loaded& s) {
  const auto candidates = imagingModuleCandidates();
  std::error_code ec;
  fs::path file;
  for (const auto& c : candidates) {
    if (fs::exists(c, ec)) {
      file = c;
      break;
    }
  }
  const bool found = !file.empty();
  if (!found) file = candidates.back(); // for dlopen's own words
  auto t = openModule(file);
  if (!t) {
    s.error = t.error();
    if (!found && candidates.size() > 1) {
      s.error += " (looked for it in";
      for (const auto& c : candidates)
        s.error += " " + c.string();
      s.error += "; TELLUS_IMAGING_MODULE names it)";
    }
    return;
  }
  s.table = *t;
  s.file = file;
  warmUp(**t);
  s.loaded.store(true, std::memory_order_release);
}

} // namespace

namespace imaging {

std::expected<const TellusImagingTable*, std::string> table() {
  Loaded& s = state();
  std::call_once(s.once, [&] { load(s); });
  if (!s.table) return std::unexpected(s.error);
  return s.table;
}

void* Sink::allocateThunk(void* context, std::size_t size) noexcept {
  try {
    return static_cast<Sink*>(context)->allocate(size);
  } catch (...) {
    return nullptr;
  }
}

void Sink::failThunk(void* context, const char* message, std::size_t length) noexcept {
  try {
    static_cast<Sink*>(context)->error_.assign(message, length);
  } catch (...) {
  }
}

void* BytesSink::allocate(std::size_t size) {
  bytes.resize(size);
  return bytes.data();
}

} // namespace imaging

bool imagingModuleLoaded() noexcept {
  return state().loaded.load(std::memory_order_acquire);
}

std::expected<fs::path, std::string> loadImagingModule() {
  auto t = imaging::table();
  if (!t) return std::unexpected(t.error());
  return state().file;
}

std::vector<fs::path> imagingModuleCandidates() {
  if (const char* env = std::getenv("TELLUS_IMAGING_MODULE"); env && *env) return {fs::path(env)};
  std::vector<fs::path> candidates;
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec && exe.has_parent_path()) {
    const fs::path dir = exe.parent_path();
    candidates.push_back(dir / TELLUS_IMAGING_MODULE_NAME);
    candidates.push_back(dir.parent_path() / "lib" / "tellus" / TELLUS_IMAGING_MODULE_NAME);
  }
  candidates.emplace_back(TELLUS_IMAGING_MODULE_BUILD_PATH);
  return candidates;
}

std::expected<void, std::string> checkImagingModule(const fs::path& file) {
  auto t = openModule(file);
  if (!t) return std::unexpected(t.error());
  return {};
}

} // namespace tellus
