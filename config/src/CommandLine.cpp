#include <tellus/config/CommandLine.hpp>

#include <algorithm>
#include <numeric>

namespace tellus::cli {

std::optional<std::string> Args::get(const std::string& name) const {
  const auto it = options.find(name);
  if (it == options.end()) return std::nullopt;
  return it->second;
}

std::vector<std::string> Args::all(const std::string& name) const {
  std::vector<std::string> v;
  for (auto [it, end] = options.equal_range(name); it != end; ++it)
    v.push_back(it->second);
  return v;
}

std::size_t editDistance(std::string_view a, std::string_view b) {
  // Three rows of the optimal-string-alignment table: i - 2, i - 1 and i.
  std::vector<std::size_t> prev2(b.size() + 1), prev(b.size() + 1), row(b.size() + 1);
  std::iota(prev.begin(), prev.end(), std::size_t{0});
  for (std::size_t i = 1; i <= a.size(); ++i) {
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      row[j] = std::min({prev[j] + 1, row[j - 1] + 1, prev[j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
        row[j] = std::min(row[j], prev2[j - 2] + 1);
    }
    std::swap(prev2, prev);
    std::swap(prev, row);
  }
  return prev[b.size()];
}

std::optional<std::string_view> closestName(std::string_view unknown,
                                            std::span<const std::string_view> known) {
  const std::size_t allowed = std::max<std::size_t>(1, unknown.size() / 3);
  std::optional<std::string_view> best;
  std::size_t bestDistance = allowed + 1;
  for (const std::string_view k : known) {
    const std::size_t d = editDistance(unknown, k);
    if (d < bestDistance) {
      bestDistance = d;
      best = k;
    }
  }
  if (best) return best;
  if (unknown.size() < 2) return std::nullopt;
  std::optional<std::string_view> prefixed;
  for (const std::string_view k : known) {
    if (!k.starts_with(unknown)) continue;
    if (prefixed) return std::nullopt; // ambiguous
    prefixed = k;
  }
  return prefixed;
}

namespace {

std::string unknownOption(const CommandSpec& spec, std::string_view given, std::string_view name) {
  std::vector<std::string_view> names;
  names.reserve(spec.options.size());
  for (const auto& o : spec.options)
    names.push_back(o.name);
  std::string msg = "unknown option " + std::string(given);
  if (const auto s = closestName(name, names)) msg += " (did you mean --" + std::string(*s) + "?)";
  return msg;
}

} // namespace

std::expected<Args, std::string> parse(const CommandSpec& spec, std::span<const std::string> args) {
  Args out;
  bool optionsEnded = false;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    const bool looksLikeOption = !optionsEnded && arg.size() > 1 && arg[0] == '-';
    if (!optionsEnded && arg == "--") {
      optionsEnded = true;
      continue;
    }
    if (!looksLikeOption) {
      if (out.positional.size() >= spec.maxPositional)
        return std::unexpected("unexpected argument '" + arg + "'");
      out.positional.push_back(arg);
      continue;
    }
    if (!arg.starts_with("--")) { // -layer, -h: single-dash options do not exist here
      const std::string_view name = std::string_view(arg).substr(1);
      return std::unexpected(unknownOption(spec, arg, name.substr(0, name.find('='))));
    }
    std::string_view name = std::string_view(arg).substr(2);
    std::optional<std::string> value;
    if (const auto eq = name.find('='); eq != std::string_view::npos) {
      value = std::string(name.substr(eq + 1));
      name = name.substr(0, eq);
    }
    const auto it = std::find_if(
        spec.options.begin(), spec.options.end(), [&](const auto& o) { return o.name == name; });
    if (name.empty() || it == spec.options.end())
      return std::unexpected(unknownOption(spec, "--" + std::string(name), name));
    const OptionSpec& o = *it;
    const std::string key(name);
    if (!o.repeatable && out.options.contains(key))
      return std::unexpected("--" + key + " is given more than once");
    switch (o.kind) {
    case OptionKind::Flag:
      if (value) return std::unexpected("--" + key + " takes no value, got '" + arg + "'");
      value = "";
      break;
    case OptionKind::Value:
      if (!value) {
        if (i + 1 >= args.size()) return std::unexpected("--" + key + " needs a value");
        value = args[++i];
      }
      break;
    case OptionKind::OptionalValue:
      if (!value) {
        if (i + 1 < args.size() && !args[i + 1].empty() && args[i + 1][0] != '-')
          value = args[++i];
        else
          value = "";
      }
      break;
    }
    out.options.emplace(key, std::move(*value));
  }
  return out;
}

} // namespace tellus::cli
