// MPCDI regions as tellus channels (Regions.hpp; docs/design/cluster.md "VESA MPCDI").

#include "Regions.hpp"

#include <tellus/planet/ChannelWarp.hpp>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>

namespace tellus::mpcdi::detail {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kMaxHalfFov = 85.0;  ///< planet::Channel's fields of view are at most 170 degrees
constexpr double kDisplayGamma = 2.2; ///< the gamma of the PNGs tellus writes (sRGB-like)

/** Row-major index of (x, y) in rows of `width`. */
std::size_t at(int x, int y, int width) {
  return static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
         static_cast<std::size_t>(x);
}

std::unexpected<std::string> fail(const std::string& origin, const std::string& what) {
  return std::unexpected(origin + ": " + what);
}

std::string channelName(const std::string& id) {
  std::string n = id.substr(0, 64);
  for (char& c : n)
    if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-'))
      c = '_';
  return n.empty() ? std::string("region") : n;
}

/** The texel's direction in dome coordinates, NaN where the warp has no content. */
std::expected<std::vector<glm::dvec3>, std::string>
directions(Profile profile, const RegionInput& r, const std::string& origin) {
  const Pfm& p = r.warp;
  std::vector<glm::dvec3> out(at(0, p.height, p.width));
  std::size_t valid = 0;
  for (std::size_t i = 0; i < out.size(); ++i) {
    const auto x = static_cast<double>(p.xyz[i * 3]), y = static_cast<double>(p.xyz[i * 3 + 1]),
               z = static_cast<double>(p.xyz[i * 3 + 2]);
    const auto pw = static_cast<std::size_t>(p.width);
    const std::string where =
        "texel (" + std::to_string(i % pw) + ", " + std::to_string(i / pw) + ") from the top left";
    const bool nx = std::isnan(x), ny = std::isnan(y), nz = std::isnan(z);
    // 2D media uses x and y only (the third float is free); 3D simulation all three.
    const bool allNaN = profile == Profile::Media2d ? nx && ny : nx && ny && nz;
    const bool anyNaN = profile == Profile::Media2d ? nx || ny : nx || ny || nz;
    if (allNaN) {
      out[i] = glm::dvec3(kNaN);
      continue;
    }
    if (anyNaN) return fail(origin, where + " is NaN in part only (NaN marks no content)");
    if (profile == Profile::Media2d) {
      // The buffer is the domemaster: an angular fisheye of 180 degrees, its top the azimuth 0.
      const double dx = 2.0 * x - 1.0, dy = 1.0 - 2.0 * y;
      const double rad = std::hypot(dx, dy);
      if (rad > 1.0) {
        out[i] = glm::dvec3(kNaN); // off the dome: the projector shows nothing there
        continue;
      }
      out[i] = planet::domeDirection(std::atan2(dx, dy) / kDeg, 90.0 * (1.0 - rad));
    } else {
      const glm::dvec3 d = glm::dvec3(x, y, z) - r.frame.pos;
      const glm::dvec3 c{
          glm::dot(d, r.frame.right), glm::dot(d, r.frame.up), glm::dot(d, r.frame.forward)};
      if (glm::length(c) < 1e-12) return fail(origin, where + " is at the eye");
      out[i] = glm::normalize(domeFromMpcdi(c));
    }
    ++valid;
  }
  if (valid == 0) return fail(origin, "no texel of the warp has content (all NaN)");
  return out;
}

/** Half-angle tangents grown to the projector's aspect (tellus's pixels are square). */
void toAspect(double& hx, double& hy, int width, int height) {
  const double a = static_cast<double>(width) / height;
  if (hx / hy < a)
    hx = hy * a;
  else
    hy = hx / a;
}

std::string setView(planet::Channel& c, double hx, double hy) {
  toAspect(hx, hy, c.width, c.height);
  c.hfovDeg = 2.0 * std::atan(hx) / kDeg;
  c.vfovDeg = 2.0 * std::atan(hy) / kDeg;
  if (c.hfovDeg > 2.0 * kMaxHalfFov || c.vfovDeg > 2.0 * kMaxHalfFov)
    return "the view needs " + std::to_string(c.hfovDeg) + " x " + std::to_string(c.vfovDeg) +
           " degrees at square pixels; a channel sees at most 170";
  return {};
}

/** The 3D simulation profile: the frustum gives the view. */
std::string viewFromFrustum(planet::Channel& c, const Frustum& f) {
  if (f.pitch < -90.0 || f.pitch > 90.0) return "frustum: pitch outside [-90, 90]";
  if (!(f.left < f.right) || !(f.down < f.up) || f.left <= -90.0 || f.right >= 90.0 ||
      f.down <= -90.0 || f.up >= 90.0)
    return "frustum: the angles must satisfy -90 < leftAngle < rightAngle < 90 and -90 < "
           "downAngle < upAngle < 90";
  c.azimuthDeg = -f.yaw;
  c.elevationDeg = f.pitch;
  c.rollDeg = f.roll;
  const bool symmetric = std::abs(f.left + f.right) < 1e-6 && std::abs(f.up + f.down) < 1e-6;
  const double tx = std::tan(f.right * kDeg), ty = std::tan(f.up * kDeg);
  const double square = (tx / ty) / (static_cast<double>(c.width) / c.height);
  if (symmetric && std::abs(square - 1.0) <= 0.01) {
    c.hfovDeg = f.right - f.left;
    c.vfovDeg = f.up - f.down;
    return {};
  }
  // Off-axis or not square: the symmetric frustum around the same axis that holds it. The warp
  // (3D points, projected into this frustum) puts every projector pixel where it belongs.
  return setView(c, std::max(std::tan(-f.left * kDeg), tx), std::max(std::tan(-f.down * kDeg), ty));
}

/** The 2D media profile: the view that holds every direction the warp reaches. */
std::string viewFromDirections(planet::Channel& c, const std::vector<glm::dvec3>& dirs) {
  glm::dvec3 sum(0.0);
  for (const glm::dvec3& d : dirs)
    if (!std::isnan(d.x)) sum += d;
  if (glm::length(sum) < 1e-9) return "the warp's directions have no centre";
  const glm::dvec3 centre = glm::normalize(sum);
  c.elevationDeg = std::asin(std::clamp(-centre.z, -1.0, 1.0)) / kDeg;
  c.azimuthDeg = std::atan2(centre.x, centre.y) / kDeg;
  c.rollDeg = 0.0;
  const planet::ChannelFrame f = planet::channelFrame(c);
  double hx = 1e-6, hy = 1e-6;
  for (const glm::dvec3& d : dirs) {
    if (std::isnan(d.x)) continue;
    const double z = glm::dot(d, f.forward);
    if (z < std::cos(kMaxHalfFov * kDeg)) return "the warp spans more than 170 degrees";
    hx = std::max(hx, std::abs(glm::dot(d, f.right)) / z);
    hy = std::max(hy, std::abs(glm::dot(d, f.up)) / z);
  }
  return setView(c, hx, hy);
}

/** Bilinear over cell-centred samples (a PFM's texels), linear beyond the outer centres. */
glm::dvec2 sampleCentred(const std::vector<glm::dvec2>& uv, int w, int h, double tx, double ty) {
  const int i0 = std::clamp(static_cast<int>(std::floor(tx)), 0, w - 2);
  const int j0 = std::clamp(static_cast<int>(std::floor(ty)), 0, h - 2);
  const double fx = tx - i0, fy = ty - j0;
  auto uvAt = [&](int i, int j) { return uv[at(i, j, w)]; };
  return (uvAt(i0, j0) * (1 - fx) + uvAt(i0 + 1, j0) * fx) * (1 - fy) +
         (uvAt(i0, j0 + 1) * (1 - fx) + uvAt(i0 + 1, j0 + 1) * fx) * fy;
}

/** The alpha map at the projector's size (bilinear when it differs), its gamma undone for the
 * PNGs tellus writes: weight = stored ^ (gammaEmbedded / 2.2). */
std::vector<float> weights(const Alpha& a, int width, int height) {
  std::vector<float> w(at(0, height, width));
  const double power = a.gammaEmbedded / kDisplayGamma;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      double v;
      if (a.width == width && a.height == height) {
        v = static_cast<double>(a.stored[at(x, y, width)]);
      } else {
        const double sx = std::clamp((x + 0.5) * a.width / width - 0.5, 0.0, a.width - 1.0);
        const double sy = std::clamp((y + 0.5) * a.height / height - 0.5, 0.0, a.height - 1.0);
        const int x0 = std::min(static_cast<int>(sx), std::max(a.width - 2, 0));
        const int y0 = std::min(static_cast<int>(sy), std::max(a.height - 2, 0));
        const int x1 = std::min(x0 + 1, a.width - 1), y1 = std::min(y0 + 1, a.height - 1);
        const double fx = sx - x0, fy = sy - y0;
        auto s = [&](int i, int j) { return static_cast<double>(a.stored[at(i, j, a.width)]); };
        v = (s(x0, y0) * (1 - fx) + s(x1, y0) * fx) * (1 - fy) +
            (s(x0, y1) * (1 - fx) + s(x1, y1) * fx) * fy;
      }
      w[at(x, y, width)] =
          static_cast<float>(power == 1.0 ? v : std::pow(std::clamp(v, 0.0, 1.0), power));
    }
  return w;
}

} // namespace

glm::dvec3 domeFromMpcdi(const glm::dvec3& c) noexcept {
  return {-c.x, c.z, -c.y};
}

std::expected<planet::Channel, std::string>
makeChannel(Profile profile, const RegionInput& r, const std::string& origin) {
  planet::Channel c;
  c.name = channelName(r.id);
  c.width = r.width;
  c.height = r.height;
  const Pfm& pfm = r.warp;
  if (pfm.width < 2 || pfm.height < 2)
    return fail(origin,
                "the warp is " + std::to_string(pfm.width) + " x " + std::to_string(pfm.height) +
                    " texels; at least 2 x 2 are needed");
  auto dirs = directions(profile, r, origin);
  if (!dirs) return std::unexpected(dirs.error());
  std::string bad;
  if (profile == Profile::Simulation3d) {
    if (!r.frustum) return fail(origin, "no frustum (the 3D simulation profile needs one)");
    bad = viewFromFrustum(c, *r.frustum);
  } else {
    bad = viewFromDirections(c, *dirs);
  }
  if (!bad.empty()) return fail(origin, bad);

  // Each texel's point of the rendered image (0..1 from the top left); NaN: no content.
  std::vector<glm::dvec2> uv(dirs->size());
  for (std::size_t i = 0; i < uv.size(); ++i) {
    glm::dvec2 px;
    if (!std::isnan((*dirs)[i].x) && planet::projectToChannel(c, (*dirs)[i], px))
      uv[i] = {px.x / c.renderedWidth(), px.y / c.renderedHeight()};
    else
      uv[i] = glm::dvec2(kNaN);
  }
  // The texels sit at the centres of a grid over the projector's image; planet::WarpMesh's
  // vertices at its corners: the mesh is the texels' map resampled there.
  auto mesh = std::make_shared<planet::WarpMesh>();
  mesh->columns = pfm.width;
  mesh->rows = pfm.height;
  mesh->uv.resize(uv.size());
  bool gaps = false;
  for (int j = 0; j < mesh->rows; ++j)
    for (int i = 0; i < mesh->columns; ++i) {
      const double tx = static_cast<double>(i) / (mesh->columns - 1) * pfm.width - 0.5;
      const double ty = static_cast<double>(j) / (mesh->rows - 1) * pfm.height - 0.5;
      const glm::dvec2 v = sampleCentred(uv, pfm.width, pfm.height, tx, ty);
      gaps = gaps || std::isnan(v.x);
      mesh->uv[at(i, j, mesh->columns)] = v;
    }
  std::vector<float> mask;
  if (r.alpha) mask = weights(*r.alpha, c.width, c.height);
  if (gaps) {
    // The projector's pixels whose cell of the mesh touches a texel with no content show black
    // (the blend mask's 0); the mesh's NaN vertices are then given a finite point.
    if (mask.empty()) mask.assign(at(0, c.height, c.width), 1.0f);
    for (int py = 0; py < c.height; ++py)
      for (int px = 0; px < c.width; ++px) {
        const double gx =
            std::clamp((px + 0.5) / c.width * (mesh->columns - 1), 0.0, mesh->columns - 1.0);
        const double gy =
            std::clamp((py + 0.5) / c.height * (mesh->rows - 1), 0.0, mesh->rows - 1.0);
        const int i0 = std::min(static_cast<int>(gx), mesh->columns - 2);
        const int j0 = std::min(static_cast<int>(gy), mesh->rows - 2);
        for (int dj = 0; dj < 2; ++dj)
          for (int di = 0; di < 2; ++di)
            if (std::isnan(mesh->uv[at(i0 + di, j0 + dj, mesh->columns)].x))
              mask[at(px, py, c.width)] = 0.0f;
      }
    for (glm::dvec2& v : mesh->uv)
      if (std::isnan(v.x) || std::isnan(v.y)) v = {0.5, 0.5};
  }
  c.warpMesh = std::move(mesh);
  if (!mask.empty()) c.blendMask = std::make_shared<const std::vector<float>>(std::move(mask));
  return c;
}

} // namespace tellus::mpcdi::detail
