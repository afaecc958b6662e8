// The geometric side of the speed/accuracy trade (issue #8, bench/trade.sh): how far the surface
// the renderer draws lies from the exact one, in metres, GL-free, with the renderer's own mesh
// builder (buildTerrainMesh) and GeographicLib (Geodesy, Geoid).
//
//   tellus_trade_geometry --data DIR [--etopo DATASET_DIR] > geometry.csv
//
// Rows (CSV, header first):
//   chord,<surface>,<view>,<lat>,<level>,<n>,<max_m>,<rms_m>
//     the node of the imagery grid (36-degree level zero) at that level containing the view's
//     centre, meshed with n x n vertices; every triangle of the mesh is sampled at 15 barycentric
//     points and each sample compared with the exact point at the same latitude/longitude:
//     surface "ellipsoid": toEcef(lat, lon, 0) on WGS84 (the chord error of the bare globe);
//     surface "terrain": toEcef(lat, lon, H(lat, lon)) with H the height field over every ETOPO
//     tile in DATASET_DIR (the deepest level held at each point: the data's own surface; the mesh
//     samples it at its vertices only).
//   sphere,<view>,<lat>,<displacement_m> the same lat/lon (height 0) on the sphere of radius R1
//     against WGS84: what --earth sphere moves the view's centre by; "all" is the largest anywhere.
//   geoid,<view>,<lat>,<max_abs_n_m> the largest |N| (EGM96) within 10 degrees of the view's
//   centre:
//     what --geoid off moves the terrain by there; "all" is the largest anywhere.
//   float,<view>,<lat>,<max_m> the largest error of the eye-relative position the OpenGL 3.3
//     vertex path computes (high/low float pairs, (high - eyeHigh) + (low - eyeLow) in float:
//     packVertices and eyeRelativeFloatPairs) against the exact double difference, for points
//     within 1 degree of the view's centre and the eye where bench/trade.sh puts the camera;
//   double,<view>,<lat>,<max_m> the same for the fp64 path (the double difference narrowed to one
//     float): what both paths share. (Until finding 7 of docs/ACCURACY.md was fixed, GCC 12 zeroed
//     the low floats and the float path's error was the position's rounding to one float, 0.25 m.)
#include <tellus/cache/TileGrid.hpp>
#include <tellus/planet/Geodesy.hpp>
#include <tellus/planet/Geoid.hpp>
#include <tellus/planet/GpuVertex.hpp>
#include <tellus/planet/Patch.hpp>
#include <tellus/planet/Terrain.hpp>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

using namespace tellus;
using namespace tellus::planet;
namespace fs = std::filesystem;

namespace {

struct View {
  const char* name;
  double lat, lon;
};
// The centres of bench/trade.sh's views.
constexpr View kViews[] = {{"global", 20.0, 10.0}, {"alps", 45.9, 7.5}, {"low", 46.5, 8.0}};

struct Error {
  double max = 0.0;
  double rms = 0.0;
};

Error meshError(const Geodesy& geo, const Sector& s, int n, const HeightFunction& height) {
  const TerrainMesh mesh = buildTerrainMesh(geo, s, n, height, {});
  double sum = 0.0, worst = 0.0;
  std::size_t count = 0;
  const auto grid = static_cast<std::uint32_t>(n * n);
  for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    const std::uint32_t v[3] = {mesh.indices[t], mesh.indices[t + 1], mesh.indices[t + 2]};
    if (v[0] >= grid || v[1] >= grid || v[2] >= grid) continue; // edge fans (none here)
    double lat[3], lon[3];
    glm::dvec3 p[3];
    for (int k = 0; k < 3; ++k) {
      const int row = static_cast<int>(v[k]) / n, col = static_cast<int>(v[k]) % n;
      lat[k] = edgeLerp(s.south, s.north, row, n);
      lon[k] = edgeLerp(s.west, s.east, col, n);
      p[k] = mesh.vertices[v[k]].position;
    }
    // 15 barycentric samples: the corners' neighbourhood, edge midpoints, the centroid.
    constexpr int kSteps = 4;
    for (int i = 0; i <= kSteps; ++i)
      for (int j = 0; i + j <= kSteps; ++j) {
        const double a = static_cast<double>(i) / kSteps, b = static_cast<double>(j) / kSteps,
                     c = 1.0 - a - b;
        const double la = a * lat[0] + b * lat[1] + c * lat[2];
        const double lo = a * lon[0] + b * lon[1] + c * lon[2];
        const glm::dvec3 drawn = a * p[0] + b * p[1] + c * p[2];
        const Ecef e = geo.toEcef(la, lo, height(la, lo));
        const double d = glm::length(drawn - glm::dvec3(e.x, e.y, e.z));
        worst = std::max(worst, d);
        sum += d * d;
        ++count;
      }
  }
  return {worst, count ? std::sqrt(sum / static_cast<double>(count)) : 0.0};
}

/** Every .bil tile of a cached ETOPO dataset folder (20-degree level zero, 150 x 150 BIL16, the
 * embedded default's grid), all levels: the height field reads the deepest held at each point. */
int loadEtopo(const fs::path& dir, HeightField& field) {
  int deepest = -1;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (!e.is_regular_file() || e.path().extension() != ".bil") continue;
    const std::string stem = e.path().stem().string(); // row_col, in level/row/
    const auto us = stem.find('_');
    if (us == std::string::npos) continue;
    const int level = std::stoi(e.path().parent_path().parent_path().filename().string());
    const TileKey key{level, std::stoll(stem.substr(0, us)), std::stoll(stem.substr(us + 1))};
    std::ifstream in(e.path(), std::ios::binary);
    const std::vector<char> raw((std::istreambuf_iterator<char>(in)), {});
    const auto bytes = std::as_bytes(std::span(raw.data(), raw.size()));
    HeightEncoding enc;
    enc.noData = -32768.0;
    auto tile = decodeBil16(key, 150, 150, bytes, enc);
    if (tile && field.insert(std::move(*tile))) deepest = std::max(deepest, level);
  }
  return deepest;
}

} // namespace

int main(int argc, char** argv) {
  fs::path data, etopo;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i];
    if (k == "--data") data = argv[i + 1];
    if (k == "--etopo") etopo = argv[i + 1];
  }
  if (data.empty()) {
    std::fprintf(stderr, "usage: tellus_trade_geometry --data DIR [--etopo DATASET_DIR]\n");
    return 2;
  }
  const Geodesy wgs(EarthModel::Wgs84), sphere(EarthModel::Sphere);
  GridSpec ispec; // the imagery's grid: where the quadtree's nodes are
  ispec.levelZeroDeltaDeg = 36.0;
  ispec.tileWidth = ispec.tileHeight = 512;
  ispec.numLevels = 12;
  const TileGrid igrid = *TileGrid::create(ispec);
  GridSpec espec;
  espec.levelZeroDeltaDeg = 20.0;
  espec.tileWidth = espec.tileHeight = 150;
  espec.numLevels = 12;
  HeightField field(*TileGrid::create(espec));
  int etopoLevel = -1;
  if (!etopo.empty()) {
    etopoLevel = loadEtopo(etopo, field);
    std::fprintf(stderr, "etopo: %zu tiles, levels up to %d\n", field.size(), etopoLevel);
  }
  std::printf("kind,surface,view,lat,level,n,max_m,rms_m\n");
  const HeightFunction flat = [](double, double) { return 0.0; };
  const HeightFunction terrain = [&](double la, double lo) { return field.heightAt(la, lo); };
  for (const View& v : kViews)
    for (int level = 0; level <= 10; ++level) {
      const TileKey key = *igrid.keyAt(v.lat, v.lon, level);
      const Sector s = igrid.sectorOf(key);
      for (const int n : {9, 17, 33, 65}) {
        const Error e = meshError(wgs, s, n, flat);
        std::printf(
            "chord,ellipsoid,%s,%.2f,%d,%d,%.4f,%.4f\n", v.name, v.lat, level, n, e.max, e.rms);
        if (etopoLevel >= 0 && field.levelAt(v.lat, v.lon) >= 0) {
          const Error t = meshError(wgs, s, n, terrain);
          std::printf(
              "chord,terrain,%s,%.2f,%d,%d,%.4f,%.4f\n", v.name, v.lat, level, n, t.max, t.rms);
        }
      }
    }
  auto sphereOff = [&](double lat) {
    const Ecef a = wgs.toEcef(lat, 0.0, 0.0), b = sphere.toEcef(lat, 0.0, 0.0);
    return std::hypot(a.x - b.x, a.y - b.y, a.z - b.z);
  };
  double sphereMax = 0.0;
  for (int i = -9000; i <= 9000; ++i)
    sphereMax = std::max(sphereMax, sphereOff(i * 0.01));
  for (const View& v : kViews)
    std::printf("sphere,ellipsoid,%s,%.2f,,,%.1f,\n", v.name, v.lat, sphereOff(v.lat));
  std::printf("sphere,ellipsoid,all,,,,%.1f,\n", sphereMax);
  auto geoid = Geoid::open(data / kGeoidFileName);
  if (!geoid) {
    std::fprintf(stderr, "%s\n", geoid.error().c_str());
    return 1;
  }
  auto maxN = [&](double lat0, double lon0, double r) {
    double m = 0.0;
    for (double la = std::max(-90.0, lat0 - r); la <= std::min(90.0, lat0 + r); la += 0.25)
      for (double lo = lon0 - r; lo <= lon0 + r; lo += 0.25)
        m = std::max(m, std::abs(geoid->undulationM(la, lo)));
    return m;
  };
  for (const View& v : kViews)
    std::printf("geoid,terrain,%s,%.2f,,,%.2f,\n", v.name, v.lat, maxN(v.lat, v.lon, 10.0));
  std::printf("geoid,terrain,all,,,,%.2f,\n", maxN(0.0, 0.0, 180.0));
  // The cameras of bench/trade.sh's views (lat, lon, altitude).
  constexpr double kEyes[][3] = {{20.0, 10.0, 7e6}, {44.0, 7.5, 1.5e5}, {46.4, 8.0, 1.2e4}};
  for (std::size_t i = 0; i < std::size(kViews); ++i) {
    const View& v = kViews[i];
    const Ecef eyeE = wgs.toEcef(kEyes[i][0], kEyes[i][1], kEyes[i][2]);
    const glm::dvec3 eye(eyeE.x, eyeE.y, eyeE.z);
    double pairs = 0.0, narrowed = 0.0;
    std::vector<float> packed;
    for (double la = v.lat - 1.0; la <= v.lat + 1.0; la += 0.01)
      for (double lo = v.lon - 1.0; lo <= v.lon + 1.0; lo += 0.01) {
        const Ecef e = wgs.toEcef(la, lo, 0.0);
        TerrainVertex t;
        t.position = glm::dvec3(e.x, e.y, e.z);
        t.normal = glm::vec3(0.0f, 0.0f, 1.0f);
        packed.clear();
        packVertices({&t, 1}, VertexPositions::FloatPairs, packed);
        const glm::dvec3 exact = t.position - eye;
        pairs = std::max(
            pairs, glm::length(glm::dvec3(eyeRelativeFloatPairs(packed.data(), eye)) - exact));
        narrowed = std::max(narrowed, glm::length(glm::dvec3(glm::vec3(exact)) - exact));
      }
    std::printf("float,ellipsoid,%s,%.2f,,,%.4f,\n", v.name, v.lat, pairs);
    std::printf("double,ellipsoid,%s,%.2f,,,%.4f,\n", v.name, v.lat, narrowed);
  }
  return 0;
}
