#include <tellus/cache/TimeRange.hpp>
#include <tellus/cli/LayerTimes.hpp>
#include <tellus/proxy/Wms.hpp>

#include <algorithm>

namespace tellus::cli {

std::expected<std::vector<std::string>, std::string>
layerTimes(const LayerConfig& layer, std::string_view text, std::size_t maxInstants) {
  const TimeDimension& dim = layer.time;
  if (!dim.enabled()) return std::unexpected("layer '" + layer.name + "' has no TIME dimension");
  if (text.find_first_of(",/") == std::string_view::npos) { // one instant: the WMS rule alone
    auto r = resolveTimeDimension(layer.name, dim.values, dim.period, dim.defaultValue, text);
    if (!r) return std::unexpected(r.error().message);
    return std::vector<std::string>{std::move(*r)};
  }
  auto instants = iso8601::expandTimes(text, dim.values, maxInstants);
  if (!instants) return std::unexpected("layer '" + layer.name + "': " + instants.error());
  std::vector<std::string> out;
  out.reserve(instants->size());
  for (const std::string& t : *instants) {
    auto r = resolveTimeDimension(layer.name, dim.values, dim.period, dim.defaultValue, t);
    if (!r)
      return std::unexpected("layer '" + layer.name + "' does not declare " + t + ": " +
                             r.error().message);
    // Two spellings of one instant are one time of the layer.
    if (std::find(out.begin(), out.end(), *r) == out.end()) out.push_back(std::move(*r));
  }
  return out;
}

} // namespace tellus::cli
