#include <tellus/planet/GpuVertex.hpp>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstring>

namespace tellus::planet {

SplitDouble splitDouble(double v) noexcept {
  SplitDouble s;
  s.high = static_cast<float>(v);
  s.low = static_cast<float>(v - static_cast<double>(s.high));
  return s;
}

void packVertices(std::span<const TerrainVertex> vertices,
                  VertexPositions mode,
                  std::vector<float>& out) {
  out.reserve(out.size() + vertices.size() * kFloatsPerVertex);
  for (const TerrainVertex& p : vertices) {
    assert(std::isfinite(p.position.x) && std::isfinite(p.position.y) &&
           std::isfinite(p.position.z));
    assert(std::isfinite(p.normal.x) && std::isfinite(p.normal.y) && std::isfinite(p.normal.z));
    assert(std::abs(glm::length(glm::dvec3(p.normal)) - 1.0) < 1e-3);
    assert(p.uvNode.x >= 0.0 && p.uvNode.x <= 1.0 && p.uvNode.y >= 0.0 && p.uvNode.y <= 1.0);
    assert(std::isfinite(p.morphDelta.x) && std::isfinite(p.morphDelta.y) &&
           std::isfinite(p.morphDelta.z) && std::isfinite(p.morphExtentM));
    float pos[6];
    if (mode == VertexPositions::Doubles) {
      static_assert(sizeof(pos) == 3 * sizeof(double));
      std::memcpy(pos, &p.position[0], sizeof(double));
      std::memcpy(pos + 2, &p.position[1], sizeof(double));
      std::memcpy(pos + 4, &p.position[2], sizeof(double));
    } else {
      for (int i = 0; i < 3; ++i) {
        const SplitDouble s = splitDouble(p.position[i]);
        pos[i] = s.high;
        pos[3 + i] = s.low;
        assert(std::isfinite(s.high) && std::isfinite(s.low));
        assert(std::abs(static_cast<double>(s.high) + static_cast<double>(s.low) - p.position[i]) <=
               1e-6 * std::max(1.0, std::abs(p.position[i])));
      }
    }
    out.insert(out.end(),
               {pos[0],
                pos[1],
                pos[2],
                pos[3],
                pos[4],
                pos[5],
                p.normal.x,
                p.normal.y,
                p.normal.z,
                static_cast<float>(p.uvNode.x),
                static_cast<float>(p.uvNode.y),
                static_cast<float>(p.morphDelta.x),
                static_cast<float>(p.morphDelta.y),
                static_cast<float>(p.morphDelta.z),
                static_cast<float>(p.morphExtentM)});
  }
}

glm::vec3 eyeRelativeFloatPairs(const float* packedPosition, const glm::dvec3& eye) noexcept {
  glm::vec3 r;
  for (int i = 0; i < 3; ++i) {
    const SplitDouble e = splitDouble(eye[i]);
    // The shader's order: (high - eyeHigh) + (low - eyeLow), each step rounded to float.
    const float highDiff = packedPosition[i] - e.high;
    const float lowDiff = packedPosition[3 + i] - e.low;
    r[i] = highDiff + lowDiff;
  }
  return r;
}

std::array<float, 4> uvUniform(const UvTransform& uv) noexcept {
  const std::array<float, 4> u{static_cast<float>(uv.scale.x),
                               static_cast<float>(uv.scale.y),
                               static_cast<float>(uv.offset.x),
                               static_cast<float>(uv.offset.y)};
  assert(std::isfinite(u[0]) && std::isfinite(u[1]) && std::isfinite(u[2]) && std::isfinite(u[3]));
  return u;
}

} // namespace tellus::planet
