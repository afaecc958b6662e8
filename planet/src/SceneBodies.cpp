#include <tellus/planet/Geodesy.hpp>
#include <tellus/planet/SceneBodies.hpp>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace tellus::planet {

std::optional<astro::EphemerisBody> sceneBodyOf(const Body& body) noexcept {
  return astro::ephemerisBodyByName(body.name);
}

BodyPlacement
placeBody(astro::EphemerisBody frame, astro::EphemerisBody other, double unixSeconds) noexcept {
  if (frame == other) return {};
  const glm::dmat3 toFrame = astro::celestialToBodyFixed(frame, unixSeconds);
  const glm::dmat3 fromOther = glm::transpose(astro::celestialToBodyFixed(other, unixSeconds));
  const glm::dvec3 offset = astro::bodyPositionCelestial(other, unixSeconds) -
                            astro::bodyPositionCelestial(frame, unixSeconds);
  return {toFrame * offset, toFrame * fromOther};
}

DistantGlobe::DistantGlobe(const Body& body, int slices, int stacks) : body_(body) {
  if (slices < 8 || stacks < 4) throw std::invalid_argument("a distant globe needs 8 x 4 quads");
  const Geodesy g(body_);
  const auto columns = static_cast<unsigned>(slices + 1);
  for (int j = 0; j <= stacks; ++j) {
    const double lat = -90.0 + 180.0 * j / stacks;
    for (int i = 0; i <= slices; ++i) {
      const double lon = -180.0 + 360.0 * i / slices;
      const Ecef p = g.toEcef(lat, lon, 0.0);
      const Ecef n = g.surfaceNormal(lat, lon);
      fixed_.emplace_back(p.x, p.y, p.z);
      normals_.emplace_back(n.x, n.y, n.z);
      uv_.emplace_back(static_cast<float>(i) / static_cast<float>(slices),
                       static_cast<float>(j) / static_cast<float>(stacks));
    }
  }
  slices_ = slices;
  for (int stride = 1; stride <= 8; stride *= 2) {
    if (stride > 1 && (slices % stride != 0 || stacks % stride != 0 || slices / stride < 8 ||
                       stacks / stride < 4))
      break;
    const auto k = static_cast<unsigned>(stride);
    const auto rows = static_cast<unsigned>(stacks) / k, cols = static_cast<unsigned>(slices) / k;
    std::vector<unsigned> idx;
    for (unsigned j = 0; j < rows; ++j)
      for (unsigned i = 0; i < cols; ++i) {
        const unsigned a = j * k * columns + i * k, b = a + k, c = a + k * columns, d = c + k;
        if (j > 0) idx.insert(idx.end(), {a, b, d}); // the south pole's row is a point
        if (j + 1 < rows) idx.insert(idx.end(), {a, d, c});
      }
    indices_.push_back(std::move(idx));
  }
}

const std::vector<unsigned>& DistantGlobe::indices(int stride) const noexcept {
  std::size_t k = 0;
  while (k + 1 < indices_.size() && (2 << k) <= stride)
    ++k;
  return stride >= 1 && (1 << k) == stride ? indices_[k] : indices_[0];
}

int DistantGlobe::strideFor(double radiusPx) const noexcept {
  const double needed = std::numbers::pi * std::sqrt(5.0 * std::max(radiusPx, 0.0));
  int stride = 1;
  while (2 * stride <= (1 << (indices_.size() - 1)) && slices_ / (2 * stride) >= needed)
    stride *= 2;
  return stride;
}

void DistantGlobe::cameraRelative(const BodyPlacement& placement,
                                  const glm::dvec3& eye,
                                  std::vector<float>& out,
                                  int stride) const {
  out.resize(fixed_.size() * 8);
  const glm::dvec3 centre = placement.centre - eye; // double: the only large subtraction
  const std::size_t step = stride > 1 ? static_cast<std::size_t>(stride) : 1;
  const std::size_t row = rowLength();
  for (std::size_t j = 0; j * row < fixed_.size(); j += step)
    for (std::size_t i = j * row; i < (j + 1) * row; i += step) {
      float* o = out.data() + i * 8;
      const glm::dvec3 p = centre + placement.rotation * fixed_[i];
      const glm::dvec3 n = placement.rotation * normals_[i];
      o[0] = static_cast<float>(p.x);
      o[1] = static_cast<float>(p.y);
      o[2] = static_cast<float>(p.z);
      o[3] = static_cast<float>(n.x);
      o[4] = static_cast<float>(n.y);
      o[5] = static_cast<float>(n.z);
      o[6] = uv_[i].x;
      o[7] = uv_[i].y;
    }
}

} // namespace tellus::planet
