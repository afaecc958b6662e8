#include <tellus/planet/Lod.hpp>

#include <array>
#include <cmath>

namespace tellus::planet {

LodResult
evaluateLod(const Camera& camera, const NodeGeometry& node, const LodParams& params) noexcept {
  LodResult r;
  if (params.tileWidthPx < 1 || params.tileHeightPx < 1 || !(params.threshold > 0.0) ||
      !std::isfinite(params.threshold))
    return r;
  const double halfW = 0.5 * static_cast<double>(camera.viewport().width);
  const double halfH = 0.5 * static_cast<double>(camera.viewport().height);
  std::array<glm::dvec2, 4> px{};
  for (std::size_t i = 0; i < 4; ++i) {
    const glm::dvec4 clip = camera.toClip(node.corners()[i]);
    // w is the distance in front of the eye; at or in front of the near plane means projectable.
    if (!(clip.w >= camera.nearM()) || !std::isfinite(clip.x) || !std::isfinite(clip.y)) {
      r.cornerBehindCamera = true;
      r.split = true;
      r.worstRatioSquared = 0.0;
      return r;
    }
    px[i] = {clip.x / clip.w * halfW, clip.y / clip.w * halfH};
  }
  const double limitW = static_cast<double>(params.tileWidthPx) * params.threshold;
  const double limitH = static_cast<double>(params.tileHeightPx) * params.threshold;
  const double limitW2 = limitW * limitW;
  const double limitH2 = limitH * limitH;
  // SW-SE and NW-NE run east-west; SE-NE and NW-SW north-south. A pole edge has length 0.
  struct Edge {
    std::size_t a, b;
    bool eastWest;
  };
  constexpr std::array<Edge, 4> edges{
      {{SW, SE, true}, {NW, NE, true}, {SE, NE, false}, {SW, NW, false}}};
  for (const Edge& e : edges) {
    const glm::dvec2 d = px[e.b] - px[e.a];
    const double len2 = d.x * d.x + d.y * d.y;
    const double ratio = len2 / (e.eastWest ? limitW2 : limitH2);
    if (ratio > r.worstRatioSquared) r.worstRatioSquared = ratio;
    if (len2 > (e.eastWest ? limitW2 : limitH2)) r.split = true;
  }
  return r;
}

} // namespace tellus::planet
