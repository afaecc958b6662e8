#pragma once
/**
 * @file Channels.hpp
 * @brief The dome as projector channels (issue 28, docs/design/cluster.md): a channel is one
 * projector's view out of the dome's centre, a pinhole frustum pointed at a direction of the dome,
 * and its resolution; read from tellus's own small JSON format. GL-free.
 *
 * Dome coordinates: the frame of the domemaster (Fisheye in Camera.hpp): the axis (the zenith of
 * a planetarium dome, the image's centre), the image's up and right. A direction is an azimuth
 * (degrees from the image's up towards its right: clockwise on the domemaster) and an elevation
 * (degrees up from the rim's plane: 90 is the axis). A channel looks along its centre direction
 * with a symmetric frustum of hfov x vfov degrees; with roll 0 its up is the direction of rising
 * elevation (at the zenith: the limit of that, away from the azimuth), and roll turns its up
 * towards its right by that many degrees. Pixels are square: the rendered image's aspect must
 * match tan(hfov / 2) / tan(vfov / 2) within 1%.
 *
 * Vectors in dome coordinates are GL eye-space style, as Dome.hpp's cube frame: x the image's
 * right, y its up, z back (the dome's axis is -z); a channel's right is forward x up.
 */

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <expected>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace tellus::planet {

struct WarpMesh; // ChannelWarp.hpp

struct Channel {
  std::string name; ///< [A-Za-z0-9_-]+, unique in a configuration (file names)
  double azimuthDeg = 0.0;
  double elevationDeg = 0.0; ///< [-90, 90]
  double hfovDeg = 90.0;     ///< (0, 170]
  double vfovDeg = 90.0;     ///< (0, 170]
  double rollDeg = 0.0;
  int width = 640; ///< [1, 16384]: the projector's pixels (what the warp and blend put out)
  int height = 640;
  /** The rendered image's size, when it is not the projector's (0: the projector's): rendered
   * larger and warped down is sharper after a warp that magnifies parts of the image (SGCT's
   * viewport resolution, MPCDI's buffer against its region). Without a warp the projector shows
   * the rendered image scaled, so their aspects must agree. */
  int renderWidth = 0;
  int renderHeight = 0;
  int renderedWidth() const noexcept { return renderWidth > 0 ? renderWidth : width; }
  int renderedHeight() const noexcept { return renderHeight > 0 ? renderHeight : height; }
  /** Optional (empty: none): the warp mesh (ChannelWarp.hpp, JSON) and the blend mask (a PNG of
   * width x height) applied to the rendered image; relative paths are taken from the
   * configuration file's folder by readChannels. */
  std::filesystem::path warp;
  std::filesystem::path blend;
  /** Or the warp mesh and the blend mask (width x height weights) already in memory: a VESA
   * MPCDI file's (tellus::mpcdi, mpcdi/include/tellus/mpcdi/Mpcdi.hpp). Used before the files. */
  std::shared_ptr<const WarpMesh> warpMesh;
  std::shared_ptr<const std::vector<float>> blendMask;
};

/** A channel's frame in dome coordinates: where it looks, its image's up and right (right =
 * forward x up). Unit vectors. */
struct ChannelFrame {
  glm::dvec3 forward{0.0, 0.0, -1.0};
  glm::dvec3 up{0.0, 1.0, 0.0};
  glm::dvec3 right{1.0, 0.0, 0.0};
};

/** The unit direction of (azimuth, elevation) in dome coordinates. */
glm::dvec3 domeDirection(double azimuthDeg, double elevationDeg) noexcept;
ChannelFrame channelFrame(const Channel& channel) noexcept;
/** Where a dome direction lands in the channel's rendered image (renderedWidth() x
 * renderedHeight()): pixels from the top-left corner (x right,
 * y down; pixel centres at +0.5), the pinhole map of the frustum. False when the direction is at
 * or behind the channel's image plane; true also outside the image (px beyond [0, size]). */
bool projectToChannel(const Channel& channel, const glm::dvec3& domeDir, glm::dvec2& px) noexcept;
/** The direction of an image point (pixels as projectToChannel) in dome coordinates. */
glm::dvec3 channelPixelDirection(const Channel& channel, const glm::dvec2& px) noexcept;

/** Parses a channel configuration (docs/design/cluster.md):
 * {"channels": [{"name", "azimuth", "elevation", "hfov", "vfov", "roll", "width", "height",
 * "render", "warp", "blend"}]} (roll optional, 0; render optional [width, height]; warp and blend
 * optional file names). Unknown keys, missing
 * or out-of-range values, duplicate names and pixels that are not square are refused; the message
 * says which channel and key. `origin` prefixes messages (the file). */
std::expected<std::vector<Channel>, std::string> parseChannels(std::string_view json,
                                                               std::string_view origin = "");
/** Reads and parses a file; messages begin with its path. Relative warp and blend paths are
 * made relative to the file's folder. */
std::expected<std::vector<Channel>, std::string> readChannels(const std::filesystem::path& file);

} // namespace tellus::planet
