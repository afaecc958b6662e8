#pragma once
// Writes sample .mpcdi files for the tests (libzip): the five-channel dome of
// docs/design/cluster.md as a "3d" (3D simulation) calibration with identity warps, and the
// pieces to spoil one.

#include <tellus/planet/Channels.hpp>

#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace tellus::mpcdi::test {

/** The dome of the cluster tests: four around at elevation 20 (110 x 90 degrees, 100s x 70s
 * pixels) and one at the zenith (100 x 100, 70s x 70s). */
std::vector<planet::Channel> fiveChannelDome(int scale);

/** A little-endian PFM of width x height texels (xyz rows from the top; stored bottom first). */
std::string pfm(int width, int height, const std::vector<float>& xyzTopFirst);

/** The 3D points (10 m out along each texel centre's direction; x right, y up, -z forward) of
 * a width x height warp over the channel: the warp that changes nothing. */
std::vector<float> identityWarp3d(const planet::Channel& c, int width, int height);

/** The region's XML (frustum from the channel) and its fileset's. */
std::string regionXml(const planet::Channel& c);
std::string filesetXml(const std::string& region,
                       const std::string& warpPath,
                       const std::string& alphaPath = "",
                       double gamma = 2.2);
std::string
documentXml(const std::string& profile, const std::string& regions, const std::string& filesets);

/** A zip of these entries (name -> bytes). */
void writeZip(const std::filesystem::path& file, const std::map<std::string, std::string>& entries);

/** The dome as an MPCDI file's entries: mpcdi.xml, NAME.pfm (warpTexels x warpTexels * 0.7) and,
 * with alpha, NAME-alpha.png (a soft 8-bit edge). */
std::map<std::string, std::string> domeEntries(int scale, int warpTexels, bool alpha);

} // namespace tellus::mpcdi::test
