#include <tellus/planet/Morph.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>

namespace tellus::planet {

double morphScale(double focalPx, double threshold, int tileHeightPx) noexcept {
  const double s = focalPx / (threshold * static_cast<double>(tileHeightPx));
  return std::isfinite(s) && s > 0.0 ? s : 0.0;
}

double morphFactor(double distanceM, double extentM, double scale) noexcept {
  const double range = extentM * scale;
  if (!(range > 0.0) || !std::isfinite(range) || !std::isfinite(distanceM)) return 0.0;
  return std::clamp(2.0 * distanceM / range - 1.0, 0.0, 1.0);
}

double morphExtentOf(const Geodesy& geodesy, const Sector& sector) noexcept {
  return 2.0 * (sector.north - sector.south) * (std::numbers::pi / 180.0) *
         geodesy.equatorialRadius();
}

void pinMorphBoundary(TerrainMesh& mesh) {
  const int n = mesh.n, rows = mesh.rows;
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const auto k = static_cast<std::int64_t>(i);
    const std::int64_t r = k / n, c = k % n;
    if (r >= rows || r == 0 || r == rows - 1 || c == 0 || c == n - 1)
      mesh.vertices[i].morphDelta = glm::dvec3(0.0);
  }
}

void setGridMorph(TerrainMesh& mesh, double extentM) {
  const int n = mesh.n;
  auto at = [&](int r, int c) -> TerrainVertex& {
    return mesh.vertices[static_cast<std::size_t>(r * n + c)];
  };
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) {
      TerrainVertex& v = at(r, c);
      v.morphExtentM = extentM;
      const bool oddR = (r & 1) != 0, oddC = (c & 1) != 0;
      glm::dvec3 target = v.position;
      if (oddR && oddC) // the parent cell's south-west to north-east diagonal
        target = 0.5 * (at(r - 1, c - 1).position + at(r + 1, c + 1).position);
      else if (oddC) // along the row
        target = 0.5 * (at(r, c - 1).position + at(r, c + 1).position);
      else if (oddR) // along the column
        target = 0.5 * (at(r - 1, c).position + at(r + 1, c).position);
      v.morphDelta = target - v.position;
    }
}

} // namespace tellus::planet
