#include <tellus/cli/StatsJson.hpp>

#include <nlohmann/json.hpp>

#include <cstdint>

namespace tellus::cli {
namespace {

using Json = nlohmann::ordered_json; // members in the order written

Json levelJson(const LevelStats& l) {
  return {{"level", l.level}, {"tiles", l.tiles}, {"absent", l.absent}, {"bytes", l.bytes}};
}

Json datasetJson(const DatasetStats& d) {
  Json levels = Json::array();
  for (const LevelStats& l : d.levels)
    levels.push_back(levelJson(l));
  Json j;
  j["id"] = d.dataset.id;
  j["server"] = d.dataset.spec.server;
  j["name"] = d.dataset.spec.name;
  j["folder"] = d.dataset.folder;
  j["format"] = d.dataset.spec.mimeType;
  j["time"] = d.dataset.spec.time;
  j["pinned"] = d.dataset.spec.pinned;
  j["body"] = d.dataset.spec.body; // issue 26: the same name on two bodies is two datasets
  j["tiles"] = d.tiles;
  j["bytes"] = d.bytes;
  j["levels"] = std::move(levels);
  return j;
}

} // namespace

std::string cacheStatsJson(const std::string& root, std::span<const DatasetStats> datasets) {
  std::int64_t tiles = 0;
  std::int64_t bytes = 0;
  Json list = Json::array();
  for (const DatasetStats& d : datasets) {
    tiles += d.tiles;
    bytes += d.bytes;
    list.push_back(datasetJson(d));
  }
  Json j;
  j["root"] = root;
  j["tiles"] = tiles;
  j["bytes"] = bytes;
  j["datasets"] = std::move(list);
  return j.dump(-1, ' ', false, Json::error_handler_t::replace) + "\n";
}

} // namespace tellus::cli
