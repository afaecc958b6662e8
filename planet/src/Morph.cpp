#include <tellus/planet/Morph.hpp>

#include <algorithm>
#include <cmath>
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

double morphEdgeExtent(double extentM, const Sector& node, bool alongParallel) noexcept {
  if (!alongParallel) return extentM;
  return extentM * ((node.east - node.west) / (node.north - node.south));
}

void setGridMorph(TerrainMesh& mesh, double extentM, double rowEdgeExtentM) {
  const int n = mesh.n;
  auto at = [&](int r, int c) -> TerrainVertex& {
    return mesh.vertices[static_cast<std::size_t>(r * n + c)];
  };
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) {
      TerrainVertex& v = at(r, c);
      v.morphExtentM = r == 0 || r == n - 1 ? rowEdgeExtentM : extentM;
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
