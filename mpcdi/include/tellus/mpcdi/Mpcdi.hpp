#pragma once
/**
 * @file Mpcdi.hpp
 * @brief VESA MPCDI (Multiple Projection Common Data Interchange) read into the dome's channels
 * (issue 28, docs/design/cluster.md "VESA MPCDI"). An .mpcdi file is a zip holding mpcdi.xml
 * (display > buffer > region, each region a projector: its resolution and, in the "3D simulation"
 * profile, its frustum) and per region a geometry warp (a PFM) and an alpha map (a PNG). Each
 * region becomes a planet::Channel: its view and size, and its warp mesh and blend mask in memory
 * (Channel::warpMesh, Channel::blendMask). Profiles "2d" (2D media) and "3d" (3D simulation);
 * others are refused.
 */

#include <tellus/planet/Channels.hpp>

#include <cstddef>
#include <expected>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace tellus::mpcdi {

/** A Portable Float Map of three floats a texel (MPCDI's geometry warp), rows from the top (the
 * file stores them from the bottom, as every PFM). */
struct Pfm {
  int width = 0;
  int height = 0;
  std::vector<float> xyz; ///< width * height * 3, row-major from the top row
};

/** "PF", width, height, the scale (negative: little-endian floats, positive: big-endian), one
 * whitespace byte, then exactly width x height x 3 floats. Refused with ORIGIN and what is wrong:
 * not a PFM, a grey one ("Pf"), a bad header, fewer bytes than the header says (truncated) or more
 * (the size disagrees). NaN texels are kept (MPCDI: no content there); infinities are refused. */
std::expected<Pfm, std::string> parsePfm(std::string_view bytes, std::string_view origin);

/** The channels of an .mpcdi file, one per region (in document order; a region's id with every
 * character outside A-Z a-z 0-9 _ - turned into _ is the channel's name). Messages begin with the
 * file's path and name the part that is wrong (the entry, the region, the element). */
std::expected<std::vector<planet::Channel>, std::string>
readMpcdi(const std::filesystem::path& file);

} // namespace tellus::mpcdi
