#pragma once
/**
 * @file CommandLine.hpp
 * @brief The one option parser of every `tellus` command: each command declares the options it
 * takes, and anything else (a misspelt option, a flag given a value, an option given twice that
 * may be given once, a stray argument) is a usage error that names the argument and suggests the
 * option that was probably meant. A typo must never fall back to a default: `tellus cache prune
 * --layr fake` once pruned every layer.
 */

#include <cstddef>
#include <expected>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace tellus::cli {

/** How an option takes its value. */
enum class OptionKind {
  Flag,          ///< `--dry-run`; `--dry-run=x` is an error
  Value,         ///< `--levels 0-3` or `--levels=0-3`; the next argument is taken whatever it is
                 ///< (`--bbox -10,-5,10,5`, `--camera -33,151,1e6`)
  OptionalValue, ///< `--dome`, `--dome=200` or `--dome 200`: the next argument is taken as the
                 ///< value only when it does not begin with '-'
};

struct OptionSpec {
  std::string_view name; ///< without the leading "--"
  OptionKind kind = OptionKind::Value;
  bool repeatable = false; ///< `--layer a --layer b`; otherwise a second one is an error
};

/** What a command (or `cache <subcommand>`) takes. */
struct CommandSpec {
  std::string name; ///< "seed", "cache prune": how errors name the command
  std::vector<OptionSpec> options;
  std::size_t maxPositional = 0; ///< arguments that are not options (a subcommand, ...)
};

/** A parsed command line: options by name (without "--") in the order given, and positionals. */
struct Args {
  std::vector<std::string> positional;
  std::multimap<std::string, std::string> options;

  bool flag(const std::string& name) const { return options.contains(name); }
  std::optional<std::string> get(const std::string& name) const;
  std::vector<std::string> all(const std::string& name) const;
};

/**
 * @brief Parses `args` (the words after the command) against `spec`. `--` ends the options: what
 * follows is positional. `--help` is never an option here (the caller looks for it first).
 * @return the arguments, or one line that says what is wrong, names the argument, and for an
 * unknown option suggests the closest known one ("unknown option --layr (did you mean
 * --layer?)").
 */
std::expected<Args, std::string> parse(const CommandSpec& spec, std::span<const std::string> args);

/** The known name closest to `unknown` when it is close enough to be a typo (an edit distance of
 * at most a third of its length, transpositions counting one, at least one), or a name that
 * `unknown` is a prefix of when there is exactly one; std::nullopt otherwise. */
std::optional<std::string_view> closestName(std::string_view unknown,
                                            std::span<const std::string_view> known);

/** The optimal-string-alignment distance: insertions, deletions, substitutions and transpositions
 * of two neighbours, each counting one. */
std::size_t editDistance(std::string_view a, std::string_view b);

} // namespace tellus::cli
