// tellus: the composition root. Parses the command line and runs one subcommand; the commands
// (tools/tellus/commands/, one file each) build the configuration and wire the cache, the proxy and
// the planet together.

#include "commands/Commands.hpp"

#include <tellus/config/CommandLine.hpp>

#include <cstdio>
#include <exception>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

using namespace tellus;
using namespace tellus::commands;

namespace {

/** The options of every command: what is not listed here is refused (exit 2) with a
 * suggestion, never ignored. */
std::optional<cli::CommandSpec> commandSpec(std::string_view cmd) {
  using cli::OptionKind;
  using K = OptionKind;
  std::vector<cli::OptionSpec> o = {{"config", K::Value}, {"cache", K::Value}, {"data", K::Value}};
  auto add = [&](std::initializer_list<cli::OptionSpec> more) { o.insert(o.end(), more); };
  std::size_t positional = 0;
  if (cmd == "seed") {
    add({{"layer", K::Value, true},
         {"levels", K::Value},
         {"bbox", K::Value},
         {"dry-run", K::Flag},
         {"time", K::Value},
         {"concurrency", K::Value},
         {"rate", K::Value},
         {"retries", K::Value},
         {"refresh", K::Flag},
         {"meta-tiles", K::Value}});
  } else if (cmd == "cache") {
    // The union of the subcommands' options; checkCacheSubcommand narrows it to the one given.
    add({{"json", K::Flag},
         {"older-than", K::Value},
         {"layer", K::Value},
         {"include-pinned", K::Flag},
         {"dry-run", K::Flag},
         {"gpkg", K::Value},
         {"levels", K::Value}});
    positional = 1;
  } else if (cmd == "serve") {
    add({{"listen", K::Value},
         {"threads", K::Value},
         {"offline", K::Flag},
         {"log-level", K::Value},
         {"access-log", K::Value}});
  } else if (cmd == "render" || cmd == "view" || cmd == "height") {
    add({{"offline", K::Flag}, {"server", K::Value}, {"geoid", K::Value}});
    if (cmd == "height") {
      add({{"lat", K::Value}, {"lon", K::Value}, {"elevation", K::Value}, {"datum", K::Value}});
    } else {
      add({{"camera", K::Value},
           {"size", K::Value},
           {"layer", K::Value},
           {"threshold", K::Value},
           {"earth", K::Value},
           {"no-terrain", K::Flag},
           {"exaggeration", K::Value},
           {"min-relief-px", K::Value},
           {"sun", K::Value},
           {"overlay", K::Value, true},
           {"dome", K::OptionalValue},
           {"dome-tilt", K::Value},
           {"dome-method", K::Value}});
    }
    if (cmd == "render") {
      add({{"out", K::Value},
           {"wait-complete", K::OptionalValue},
           {"background", K::Value},
           {"stats", K::Value},
           {"path", K::Value},
           {"frames", K::Value},
           {"fps", K::Value},
           {"repeat", K::Value},
           {"edge-fixing", K::Value},
           {"mesh-size", K::Value},
           {"upload-per-frame", K::Value},
           {"vertices", K::Value}});
    }
    if (cmd == "view") add({{"exit-after", K::Value}});
  } else {
    return std::nullopt;
  }
  return cli::CommandSpec{std::string(cmd), std::move(o), positional};
}

int run(int argc, char** argv) {
  if (argc < 2 || std::string_view(argv[1]) == "help" || std::string_view(argv[1]) == "--help") {
    std::fputs(kUsage, argc < 2 ? stderr : stdout);
    return argc < 2 ? kExitUsage : kExitOk;
  }
  const std::string_view cmd = argv[1];
  if (cmd == "--version") {
    std::printf("tellus %s\n", TELLUS_VERSION);
    return kExitOk;
  }
  const auto spec = commandSpec(cmd);
  if (!spec) {
    std::fprintf(stderr, "tellus: unknown command '%s'\n%s", argv[1], kUsage);
    return kExitUsage;
  }
  const std::vector<std::string> words(argv + 2, argv + argc);
  for (const auto& w : words) {
    if (w == "--") break;
    if (w == "--help" || w == "-h") {
      std::fputs(kUsage, stdout);
      return kExitOk;
    }
  }
  auto parsed = cli::parse(*spec, words);
  if (!parsed) {
    std::fprintf(stderr, "tellus %s: %s (tellus --help)\n", argv[1], parsed.error().c_str());
    return kExitUsage;
  }
  const Args& a = *parsed;
  if (cmd == "cache") {
    if (auto err = checkCacheSubcommand(a)) {
      std::fprintf(stderr, "tellus cache: %s (tellus --help)\n", err->c_str());
      return kExitUsage;
    }
  }
  if (cmd == "seed") return cmdSeed(a);
  if (cmd == "cache") return cmdCache(a);
  if (cmd == "serve") return cmdServe(a);
  if (cmd == "render") return cmdRender(a);
  if (cmd == "view") return cmdView(a);
  if (cmd == "height") return cmdHeight(a);
  std::fprintf(stderr, "tellus: unknown command '%s'\n%s", argv[1], kUsage);
  return kExitUsage;
}

} // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tellus: %s\n", e.what());
    return kExitError;
  }
}
