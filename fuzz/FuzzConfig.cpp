// libFuzzer target: arbitrary YAML text through parseConfig (yaml-cpp, the typed reading and the
// validation). It must never throw, crash or hang; a configuration it accepts must pass validate()
// again, and an error must say what is wrong. Relative paths resolve against config/examples/, so
// the seeds (config/examples/*.yaml) find the bundled data and get past validation.

#include "FuzzCheck.hpp"

#include <tellus/cache/TileGrid.hpp>
#include <tellus/config/Config.hpp>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string_view>

#ifndef TELLUS_FUZZ_CONFIG_BASE_DIR
#error "fuzz/CMakeLists.txt defines TELLUS_FUZZ_CONFIG_BASE_DIR"
#endif

namespace {

/** Configurations are files a person writes; far larger inputs only slow the search down. */
constexpr std::size_t kMaxInputBytes = 64 * 1024;

void checkConfig(const tellus::Config& c) {
  TELLUS_FUZZ_CHECK(tellus::validate(c).has_value());
  TELLUS_FUZZ_CHECK(!c.layers.empty());
  TELLUS_FUZZ_CHECK(!c.cache.root.empty());
  for (const auto& l : c.layers) {
    TELLUS_FUZZ_CHECK(c.layer(l.name) != nullptr);
    TELLUS_FUZZ_CHECK(c.upstream(l.upstream) != nullptr);
    TELLUS_FUZZ_CHECK(tellus::TileGrid::create(l.dataset.grid).has_value());
    TELLUS_FUZZ_CHECK(!l.dataset.extension.empty());
    TELLUS_FUZZ_CHECK(!l.time.enabled() || !l.time.defaultValue.empty());
    TELLUS_FUZZ_CHECK(l.time.period.empty() ||
                      l.time.values.size() <= tellus::TimeDimension::kMaxExpandedValues);
  }
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > kMaxInputBytes) return 0;
  static const std::filesystem::path baseDir = TELLUS_FUZZ_CONFIG_BASE_DIR;
  const std::string_view yaml(reinterpret_cast<const char*>(data), size);
  try {
    const auto config = tellus::parseConfig(yaml, "fuzz.yaml", baseDir);
    if (config) {
      checkConfig(*config);
    } else {
      const tellus::ConfigError& e = config.error();
      TELLUS_FUZZ_CHECK(!e.message.empty());
      TELLUS_FUZZ_CHECK(e.file == "fuzz.yaml");
      TELLUS_FUZZ_CHECK(e.line >= 0 && e.column >= 0);
      TELLUS_FUZZ_CHECK(!e.toString().empty());
    }
  } catch (...) {
    // parseConfig promises never to throw.
    TELLUS_FUZZ_CHECK(false && "parseConfig threw");
  }
  return 0;
}
