#pragma once
// An MPCDI region turned into a channel: its view, its warp as a mesh over the rendered image and
// its blend mask (PRIVATE to tellus::mpcdi; docs/design/cluster.md "VESA MPCDI").

#include <tellus/mpcdi/Mpcdi.hpp>

#include <glm/vec3.hpp>

#include <optional>
#include <string>
#include <vector>

namespace tellus::mpcdi::detail {

enum class Profile { Media2d, Simulation3d };

struct Frustum {
  double yaw = 0, pitch = 0, roll = 0;          ///< degrees: turn right, tilt up, right wing down
  double left = 0, right = 0, up = 0, down = 0; ///< degrees, left and down negative
};

/** The file's axes: where MPCDI's right (pitch axis), up (minus the yaw axis) and forward (the
 * roll axis) point in the coordinates of the 3D warp, and the eye's position there. */
struct Frame {
  glm::dvec3 pos{0.0, 0.0, 0.0};
  glm::dvec3 right{1.0, 0.0, 0.0};
  glm::dvec3 up{0.0, 1.0, 0.0};
  glm::dvec3 forward{0.0, 0.0, -1.0};
};

/** An alpha map's samples in [0, 1] as stored (its embedded gamma not yet undone). */
struct Alpha {
  int width = 0;
  int height = 0;
  std::vector<float> stored;
  double gammaEmbedded = 2.2;
};

struct RegionInput {
  std::string id;
  int width = 0; ///< the projector's pixels (xResolution, yResolution)
  int height = 0;
  std::optional<Frustum> frustum; ///< required by the 3D simulation profile
  Frame frame;
  Pfm warp;
  std::optional<Alpha> alpha;
};

/** The channel of one region; messages begin with `origin` (the file and the region). */
std::expected<planet::Channel, std::string>
makeChannel(Profile profile, const RegionInput& region, const std::string& origin);

/** MPCDI's directions in tellus's dome coordinates (Channels.hpp): MPCDI forward (yaw 0, pitch 0)
 * is azimuth 0 on the rim, up is the dome's axis, right is azimuth 270 (a viewer under the dome
 * facing azimuth 0 has azimuth 90 on the left). */
glm::dvec3 domeFromMpcdi(const glm::dvec3& rightUpForward) noexcept;

} // namespace tellus::mpcdi::detail
