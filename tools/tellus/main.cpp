// tellus: the composition root. Parses the command line against the command's options and runs
// it; the commands (tools/tellus/commands/, one file each) wire the cache, the proxy and the
// planet together from the configuration.

#include "commands/Commands.hpp"
#include "commands/Context.hpp"

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

std::optional<Command> findCommand(std::string_view name) {
  for (const auto make : {&seedCommand,
                          &cacheCommand,
                          &serveCommand,
                          &renderCommand,
                          &viewCommand,
                          &heightCommand,
                          &clusterCommand}) {
    Command c = make();
    if (c.name == name) return c;
  }
  return std::nullopt;
}

/** What the parser takes for a command: every command's --config, --cache and --data, then its
 * own options. */
cli::CommandSpec commandSpec(const Command& c) {
  using K = cli::OptionKind;
  std::vector<cli::OptionSpec> o = {{"config", K::Value}, {"cache", K::Value}, {"data", K::Value}};
  o.insert(o.end(), c.options.begin(), c.options.end());
  return cli::CommandSpec{std::string(c.name), std::move(o), c.maxPositional};
}

int run(int argc, char** argv) {
  if (argc < 2 || std::string_view(argv[1]) == "help" || std::string_view(argv[1]) == "--help") {
    std::fputs(kUsage, argc < 2 ? stderr : stdout);
    return argc < 2 ? kExitUsage : kExitOk;
  }
  const std::string_view name = argv[1];
  if (name == "--version") {
    std::printf("tellus %s\n", TELLUS_VERSION);
    return kExitOk;
  }
  const auto command = findCommand(name);
  if (!command) {
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
  auto parsed = cli::parse(commandSpec(*command), words);
  if (!parsed) {
    std::fprintf(stderr, "tellus %s: %s (tellus --help)\n", argv[1], parsed.error().c_str());
    return kExitUsage;
  }
  return command->run(*parsed);
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
