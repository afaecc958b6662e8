#include "ColourMapTables.hpp"

#include <tellus/values/ColourMap.hpp>

#include <array>

namespace tellus::values {

namespace {

const std::array<ColourMap, 7> kMaps = {{
    {"viridis", "Viridis (sequential, perceptually uniform)", &detail::k_viridis},
    {"magma", "Magma (sequential, perceptually uniform)", &detail::k_magma},
    {"cividis", "Cividis (sequential, for colour vision deficiency)", &detail::k_cividis},
    {"coolwarm", "Cool to warm (diverging, Moreland 2009)", &detail::k_coolwarm},
    {"twilight", "Twilight (cyclic)", &detail::k_twilight},
    {"turbo", "Turbo (rainbow, Google)", &detail::k_turbo},
    {"terrain", "Terrain with bathymetry (cmocean topo; 0 m at the middle)", &detail::k_terrain},
}};

} // namespace

std::span<const ColourMap> colourMaps() noexcept {
  return kMaps;
}

const ColourMap* findColourMap(std::string_view name) noexcept {
  for (const ColourMap& map : kMaps)
    if (map.name == name) return &map;
  return nullptr;
}

} // namespace tellus::values
