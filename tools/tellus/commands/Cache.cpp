// `tellus cache stats|verify|rebuild|prune|export|import`: inspects and maintains the cache.

#include "Commands.hpp"
#include "Context.hpp"
#include "Purge.hpp"

#include <tellus/cache/GeoPackage.hpp>
#include <tellus/cli/StatsJson.hpp>
#include <tellus/cli/Values.hpp>
#include <tellus/proxy/HttpCaching.hpp>

#include <algorithm>
#include <cstdio>
#include <limits>
#include <map>
#include <string>
#include <string_view>
#include <vector>

namespace fs = std::filesystem;

namespace tellus::commands {
namespace {

using cli::humanBytes;

/** `cache <subcommand>`: the subcommand is known and every option given is one of its own (a
 * `--json` on prune is a mistake, not something to ignore). The error text, or nothing. */
std::optional<std::string> checkSubcommand(const cli::Args& a) {
  static const std::map<std::string, std::vector<std::string>, std::less<>> own = {
      {"stats", {"json"}},
      {"verify", {}},
      {"rebuild", {}},
      {"prune", {"older-than", "layer", "include-pinned", "dry-run"}},
      {"export", {"gpkg", "layer", "levels"}},
      {"import", {"gpkg", "layer"}}};
  if (a.positional.empty()) return "say stats, verify, rebuild, prune, export or import";
  const auto sub = own.find(a.positional.front());
  if (sub == own.end()) {
    std::vector<std::string_view> names;
    for (const auto& [n, _] : own)
      names.push_back(n);
    std::string msg = "unknown subcommand '" + a.positional.front() + "'";
    if (const auto s = cli::closestName(a.positional.front(), names))
      msg += " (did you mean " + std::string(*s) + "?)";
    return msg;
  }
  for (const auto& [k, v] : a.options) {
    if (k == "config" || k == "cache" || k == "data") continue;
    if (std::find(sub->second.begin(), sub->second.end(), k) == sub->second.end())
      return "--" + k + " is not an option of cache " + sub->first;
  }
  return std::nullopt;
}

void printStatsText(const TileCache& cache,
                    const std::vector<DatasetStats>& st,
                    std::int64_t totalTiles,
                    std::int64_t totalBytes) {
  std::printf("cache %s: %lld tiles, %s\n",
              cache.root().c_str(),
              static_cast<long long>(totalTiles),
              humanBytes(totalBytes).c_str());
  for (const auto& d : st) {
    std::printf("  %s/%s  %s%s%s  %lld tiles  %s\n",
                d.dataset.spec.server.c_str(),
                d.dataset.spec.name.c_str(),
                d.dataset.spec.mimeType.c_str(),
                d.dataset.spec.time.empty() ? "" : ("  time " + d.dataset.spec.time).c_str(),
                d.dataset.spec.pinned ? "  pinned" : "",
                static_cast<long long>(d.tiles),
                humanBytes(d.bytes).c_str());
    for (const auto& l : d.levels) {
      std::printf("    level %2d: %8lld tiles%s  %s\n",
                  l.level,
                  static_cast<long long>(l.tiles),
                  l.absent ? (" (" + std::to_string(l.absent) + " absent)").c_str() : "",
                  humanBytes(l.bytes).c_str());
    }
  }
}

int stats(Context& ctx, bool json) {
  auto st = ctx.cache->stats();
  if (!st) {
    std::fprintf(stderr, "tellus cache stats: %s\n", st.error().message.c_str());
    return kExitError;
  }
  std::int64_t totalTiles = 0;
  std::int64_t totalBytes = 0;
  for (const auto& d : *st) {
    totalTiles += d.tiles;
    totalBytes += d.bytes;
  }
  if (json)
    std::fputs(cli::cacheStatsJson(ctx.cache->root().string(), *st).c_str(), stdout);
  else
    printStatsText(*ctx.cache, *st, totalTiles, totalBytes);
  return kExitOk;
}

int verify(Context& ctx) {
  auto r = ctx.cache->verify();
  if (!r) {
    std::fprintf(stderr, "tellus cache verify: %s\n", r.error().message.c_str());
    return kExitError;
  }
  std::printf("index integrity: %s\n", r->integrity.c_str());
  auto list = [](const char* what, const std::vector<std::string>& v) {
    std::printf("%s: %zu\n", what, v.size());
    for (std::size_t i = 0; i < v.size() && i < 20; ++i)
      std::printf("  %s\n", v[i].c_str());
    if (v.size() > 20) std::printf("  ... and %zu more\n", v.size() - 20);
  };
  list("files without index rows", r->filesWithoutRows);
  list("index rows without files", r->rowsWithoutFiles);
  list("size mismatches", r->sizeMismatches);
  list("stray temp files", r->strayTempFiles);
  if (r->tempFilesInUse > 0) {
    std::printf("temp files of running writers: %lld (not a problem)\n",
                static_cast<long long>(r->tempFilesInUse));
  }
  std::printf(r->ok() ? "cache is consistent\n"
                      : "cache has problems: `tellus cache rebuild` repairs the index\n");
  return r->ok() ? kExitOk : kExitProblems;
}

int rebuild(Context& ctx) {
  auto n = ctx.cache->rebuild();
  if (!n) {
    std::fprintf(stderr, "tellus cache rebuild: %s\n", n.error().message.c_str());
    return kExitError;
  }
  std::printf("index rebuilt from the tree: %lld tiles\n", static_cast<long long>(*n));
  return kExitOk;
}

/** export or import one layer as an OGC GeoPackage. */
int geoPackage(Context& ctx, const cli::Args& a, const std::string& sub) {
  const std::string name = a.all("layer").front();
  const auto* layer = ctx.config.layer(name);
  if (!layer) {
    std::fprintf(stderr, "tellus cache %s: no layer '%s'\n", sub.c_str(), name.c_str());
    return kExitUsage;
  }
  auto id = ctx.cache->registerDataset(layer->dataset);
  if (!id) {
    std::fprintf(stderr, "tellus cache %s: %s\n", sub.c_str(), id.error().message.c_str());
    return kExitError;
  }
  const fs::path file = *a.get("gpkg");
  std::int32_t from = 0, to = std::numeric_limits<std::int32_t>::max();
  if (auto l = a.get("levels")) {
    auto r = cli::parseLevels(*l);
    if (!r) {
      std::fprintf(
          stderr, "tellus cache export: --levels must be A or A-B, got '%s'\n", l->c_str());
      return kExitUsage;
    }
    from = r->first;
    to = r->second;
  }
  auto r = sub == "export" ? exportGeoPackage(*ctx.cache, *id, file, from, to)
                           : importGeoPackage(*ctx.cache, *id, file);
  if (!r) {
    std::fprintf(stderr, "tellus cache %s: %s\n", sub.c_str(), r.error().message.c_str());
    return kExitError;
  }
  std::printf("%s %s: %lld tiles (%s), levels %d-%d, %s\n",
              sub == "export" ? "exported" : "imported",
              name.c_str(),
              static_cast<long long>(r->tiles),
              humanBytes(r->bytes).c_str(),
              r->minLevel,
              r->maxLevel,
              file.c_str());
  return kExitOk;
}

/** prune --layer NAME: a layer that neither the configuration nor the cache knows is a typo:
 * refused rather than removing nothing (or, before, everything). False after saying why. */
bool pruneLayerKnown(Context& ctx, const std::string& name) {
  const auto held = ctx.cache->datasets();
  if (ctx.config.layer(name) != nullptr ||
      std::any_of(held.begin(), held.end(), [&](const auto& d) { return d.spec.name == name; }))
    return true;
  std::vector<std::string_view> names;
  for (const auto& l : ctx.config.layers)
    names.push_back(l.name);
  for (const auto& d : held)
    names.push_back(d.spec.name);
  const auto guess = cli::closestName(name, names);
  std::fprintf(stderr,
               "tellus cache prune: no layer '%s' in the configuration or the cache%s\n",
               name.c_str(),
               guess ? (" (did you mean " + std::string(*guess) + "?)").c_str() : "");
  return false;
}

/** Says what goes before it goes: which layers, which of their tiles, how many. Adds the
 * surrogate keys of each dataset (its layer's, at its time) to `keys`, for the CDN's purge. */
bool printPrunable(Context& ctx,
                   const PruneOptions& po,
                   const cli::Args& a,
                   std::vector<std::string>& keys) {
  const auto doomed = ctx.cache->prunable(po);
  if (!doomed) {
    std::fprintf(stderr, "tellus cache prune: %s\n", doomed.error().message.c_str());
    return false;
  }
  for (const auto& d : *doomed) {
    if (d.tiles == 0) continue;
    std::string k = layerKey(d.dataset.spec.name, d.dataset.spec.time);
    if (std::find(keys.begin(), keys.end(), k) == keys.end()) keys.push_back(std::move(k));
  }
  std::int64_t doomedTiles = 0;
  std::int64_t doomedBytes = 0;
  for (const auto& d : *doomed) {
    doomedTiles += d.tiles;
    doomedBytes += d.bytes;
  }
  std::printf("%s tiles fetched more than %s ago from %s%s: %lld tiles, %s\n",
              a.flag("dry-run") ? "would remove" : "removing",
              a.get("older-than")->c_str(),
              po.datasetName ? ("layer " + *po.datasetName).c_str() : "EVERY layer",
              po.includePinned ? " (pinned ones too)" : " (pinned layers kept)",
              static_cast<long long>(doomedTiles),
              humanBytes(doomedBytes).c_str());
  for (const auto& d : *doomed) {
    std::printf("  %s/%s%s%s: %lld tiles, %s\n",
                d.dataset.spec.server.c_str(),
                d.dataset.spec.name.c_str(),
                d.dataset.spec.time.empty() ? "" : " time ",
                d.dataset.spec.time.c_str(),
                static_cast<long long>(d.tiles),
                humanBytes(d.bytes).c_str());
  }
  return true;
}

int prune(Context& ctx, const cli::Args& a, std::chrono::milliseconds olderThan) {
  PruneOptions po;
  po.olderThan = olderThan;
  po.datasetName = a.get("layer");
  po.includePinned = a.flag("include-pinned");
  if (po.datasetName && !pruneLayerKnown(ctx, *po.datasetName)) return kExitUsage;
  std::vector<std::string> keys;
  if (!printPrunable(ctx, po, a, keys)) return kExitError;
  if (a.flag("dry-run")) return kExitOk;
  auto n = ctx.cache->prune(po);
  if (!n) {
    std::fprintf(stderr, "tellus cache prune: %s\n", n.error().message.c_str());
    return kExitError;
  }
  std::printf("pruned %lld tiles\n", static_cast<long long>(*n));
  // The shared caches in front of `tellus serve` forget what is gone (server.cdn.purge).
  if (*n > 0 && !purgeCdn(ctx.config, keys, "cache prune")) return kExitError;
  return kExitOk;
}

int runCache(const cli::Args& a) {
  if (auto err = checkSubcommand(a)) {
    std::fprintf(stderr, "tellus cache: %s (tellus --help)\n", err->c_str());
    return kExitUsage;
  }
  const std::string& sub = a.positional[0];
  std::optional<std::chrono::milliseconds> olderThan;
  if (sub == "prune") {
    const auto d = a.get("older-than");
    olderThan = d ? cli::parseDuration(*d) : std::nullopt;
    if (!olderThan) {
      std::fprintf(stderr,
                   "tellus cache prune: --older-than DURATION is required (e.g. 30d, 12h)\n");
      return kExitUsage;
    }
  } else if ((sub == "export" || sub == "import") &&
             (!a.get("gpkg") || a.all("layer").size() != 1)) {
    std::fprintf(
        stderr, "tellus cache %s: --gpkg FILE and one --layer NAME are required\n", sub.c_str());
    return kExitUsage;
  }
  auto ctx = setUp(a);
  if (!ctx) return kExitError;
  if (sub == "stats") return stats(*ctx, a.flag("json"));
  if (sub == "export" || sub == "import") return geoPackage(*ctx, a, sub);
  if (sub == "verify") return verify(*ctx);
  if (sub == "rebuild") return rebuild(*ctx);
  return prune(*ctx, a, *olderThan);
}

} // namespace

Command cacheCommand() {
  using K = cli::OptionKind;
  // The union of the subcommands' options; checkSubcommand narrows it to the one given.
  return {"cache",
          {{"json", K::Flag},
           {"older-than", K::Value},
           {"layer", K::Value},
           {"include-pinned", K::Flag},
           {"dry-run", K::Flag},
           {"gpkg", K::Value},
           {"levels", K::Value}},
          1,
          &runCache};
}

} // namespace tellus::commands
