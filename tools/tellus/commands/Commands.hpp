#pragma once
/**
 * @file Commands.hpp
 * @brief The commands of `tellus`, one file each (Seed.cpp, Cache.cpp, Serve.cpp, Render.cpp,
 * View.cpp, Height.cpp): what options each takes and what it does. main.cpp parses the command
 * line against a command's options and runs it; nothing else is shared but Context.hpp.
 */

#include <tellus/config/CommandLine.hpp>

#include <cstddef>
#include <string_view>
#include <vector>

namespace tellus::commands {

struct Command {
  std::string_view name;
  /** What the command takes besides --config, --cache and --data (every command's): anything
   * else is refused (exit 2) with a suggestion, never ignored. */
  std::vector<cli::OptionSpec> options;
  std::size_t maxPositional = 0; ///< `cache <subcommand>`: 1
  /** Runs the parsed command line; the process's exit code (Context.hpp). */
  int (*run)(const cli::Args& args) = nullptr;
};

Command seedCommand();
Command cacheCommand();
Command serveCommand();
Command renderCommand();
Command viewCommand();
Command heightCommand();
Command clusterCommand(); ///< issue 28: the dome's projector channels over MPI

/** `tellus --help`: every command and its options. */
extern const char* const kUsage;

} // namespace tellus::commands
