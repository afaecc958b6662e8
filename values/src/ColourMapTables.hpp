#pragma once
// The generated tables (ColourMapTables.cpp, tools/values/make_colourmaps.py).

#include <tellus/values/ColourMap.hpp>

namespace tellus::values::detail {

extern const ColourTable k_viridis;
extern const ColourTable k_magma;
extern const ColourTable k_cividis;
extern const ColourTable k_coolwarm;
extern const ColourTable k_twilight;
extern const ColourTable k_turbo;
extern const ColourTable k_terrain;

} // namespace tellus::values::detail
