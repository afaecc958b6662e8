#include "GlobeArgs.hpp"

#include "Context.hpp"

#include <tellus/cli/Values.hpp>
#include <tellus/planet/Geoid.hpp>

#include <algorithm>
#include <array>
#include <memory>

namespace tellus::commands {

std::vector<cli::OptionSpec> tileSourceOptions() {
  using K = cli::OptionKind;
  return {{"offline", K::Flag}, {"server", K::Value}, {"geoid", K::Value}};
}

std::vector<cli::OptionSpec> globeOptions() {
  using K = cli::OptionKind;
  return {{"camera", K::Value},
          {"size", K::Value},
          {"layer", K::Value},
          {"threshold", K::Value},
          {"earth", K::Value},
          {"no-terrain", K::Flag},
          {"no-fade-in", K::Flag},
          {"no-geomorph", K::Flag},
          {"exaggeration", K::Value},
          {"min-relief-px", K::Value},
          {"sun", K::Value},
          {"overlay", K::Value, true},
          {"dome", K::OptionalValue},
          {"dome-tilt", K::Value},
          {"dome-method", K::Value}};
}

std::expected<std::optional<EarthModel>, std::string> earthArg(const cli::Args& a) {
  const auto e = a.get("earth");
  if (!e) return std::nullopt;
  if (*e == "wgs84") return EarthModel::Wgs84;
  if (*e == "sphere") return EarthModel::Sphere;
  return std::unexpected(*e);
}

std::expected<DomeArgs, std::string> domeArgs(const cli::Args& a) {
  DomeArgs d;
  d.on = a.flag("dome");
  std::optional<std::string> fov;
  if (const auto v = a.get("dome"); v && !v->empty()) fov = *v;
  if (fov) {
    const auto v = cli::parseNumbers(*fov, 1, 1);
    if (!v || !((*v)[0] > 0.0 && (*v)[0] <= 220.0))
      return std::unexpected("--dome FOV must be in (0, 220] degrees, got '" + *fov + "'");
    d.fovDeg = (*v)[0];
  }
  if (const auto t = a.get("dome-tilt")) {
    const auto v = cli::parseNumbers(*t, 1, 1);
    if (!v || !((*v)[0] >= -180.0 && (*v)[0] <= 180.0))
      return std::unexpected("--dome-tilt must be in [-180, 180] degrees, got '" + *t + "'");
    d.tiltDeg = (*v)[0];
  }
  if (const auto m = a.get("dome-method")) {
    if (*m == "direct")
      d.method = planet::DomeMethod::Direct;
    else if (*m == "cube")
      d.method = planet::DomeMethod::Cube;
    else
      return std::unexpected("--dome-method must be direct or cube, got '" + *m + "'");
  }
  return d;
}

void applyRendererSettings(const RendererSettings& g,
                           const cli::Args& a,
                           planet::RendererOptions& ro,
                           EarthModel& earth) {
  earth = g.earth == EarthShape::Sphere ? EarthModel::Sphere : EarthModel::Wgs84;
  if (!a.get("threshold")) ro.lodThreshold = g.lodThreshold;
  ro.meshSize = g.meshSize;
  ro.verticalFovDeg = g.fovDeg;
  ro.textureBudgetBytes = static_cast<std::size_t>(g.textureBudget);
  ro.uploadBytesPerFrame = static_cast<std::size_t>(g.uploadPerFrame);
  ro.maxInFlight = static_cast<std::size_t>(g.maxInFlight);
  ro.maxSplitsPerFrame = g.maxSplitsPerFrame;
  ro.decodeThreads = g.decodeThreads;
  ro.overlaysPerPass = g.overlaysPerPass;
  ro.verticalExaggeration = g.terrain.exaggeration;
  ro.terrainClearanceM = g.terrain.clearanceM;
  ro.terrainMinReliefPx = g.terrain.minReliefPx;
  ro.sunLatLon = g.terrain.sun;
  ro.fadeInSeconds = a.flag("no-fade-in") ? 0.0 : g.fadeInS;
  ro.geomorph = g.geomorph && !a.flag("no-geomorph");
  if (const auto d = domeArgs(a); d && (d->on || g.dome.enabled)) {
    ro.dome = planet::DomeOptions{
        d->fovDeg.value_or(g.dome.fovDeg), d->tiltDeg.value_or(g.dome.tiltDeg), g.dome.faceScale};
    ro.dome->method = d->method.value_or(g.dome.method == DomeSettings::Method::Cube
                                             ? planet::DomeMethod::Cube
                                             : planet::DomeMethod::Direct);
    ro.dome->directMaxErrorPx = g.dome.directMaxErrorPx;
    // A domemaster is square: without --size, the smaller side of the default.
    if (!a.get("size")) ro.width = ro.height = std::min(ro.width, ro.height);
  }
}

namespace {

/** --mesh-size, --upload-per-frame and --vertices: the speed/accuracy sweep (bench/trade.sh). */
std::optional<std::string> applyTradeArgs(const cli::Args& a, planet::RendererOptions& ro) {
  if (auto e = a.get("mesh-size")) {
    const auto v = cli::parseNumbers(*e, 1, 1);
    const double d = v ? (*v)[0] : 0.0;
    const int n = d >= 3.0 && d <= 257.0 ? static_cast<int>(d) : 0; // no cast out of range
    if (!v || n == 0 || static_cast<double>(n) != d || ((n - 1) & (n - 2)) != 0)
      return "--mesh-size must be 2^k + 1 in [3, 257], got '" + *e + "'";
    ro.meshSize = n;
  }
  if (auto e = a.get("upload-per-frame")) {
    const auto v = cli::parseNumbers(*e, 1, 1);
    if (!v || !((*v)[0] >= 4096.0 && (*v)[0] <= 1e10))
      return "--upload-per-frame must be bytes in [4096, 1e10], got '" + *e + "'";
    ro.uploadBytesPerFrame = static_cast<std::size_t>((*v)[0]);
  }
  if (auto e = a.get("vertices")) {
    if (*e != "double" && *e != "float")
      return "--vertices must be double or float, got '" + *e + "'";
    ro.fp64Vertices = *e == "double";
  }
  return std::nullopt;
}

} // namespace

std::optional<std::string> applyTerrainArgs(const cli::Args& a, planet::RendererOptions& ro) {
  if (auto e = a.get("exaggeration")) {
    const auto v = cli::parseNumbers(*e, 1, 1);
    if (!v || !((*v)[0] > 0.0 && (*v)[0] <= 100.0))
      return "--exaggeration must be a number in (0, 100], got '" + *e + "'";
    ro.verticalExaggeration = (*v)[0];
  }
  if (auto e = a.get("min-relief-px")) {
    const auto v = cli::parseNumbers(*e, 1, 1);
    if (!v || !((*v)[0] >= 0.0 && (*v)[0] <= 100.0))
      return "--min-relief-px must be a number in [0, 100], got '" + *e + "'";
    ro.terrainMinReliefPx = (*v)[0];
  }
  if (auto e = a.get("edge-fixing")) {
    if (*e != "on" && *e != "off") return "--edge-fixing must be on or off, got '" + *e + "'";
    ro.fixEdges = *e == "on";
  }
  if (auto e = a.get("geoid"); e && *e != "on" && *e != "off")
    return "--geoid must be on or off, got '" + *e + "'";
  if (auto bad = applyTradeArgs(a, ro)) return bad;
  if (auto e = a.get("sun")) {
    const auto v = cli::parseNumbers(*e, 2, 2);
    if (!v || (*v)[0] < -90.0 || (*v)[0] > 90.0)
      return "--sun must be LAT,LON of the subsolar point, got '" + *e + "'";
    ro.sunLatLon = std::array<double, 2>{(*v)[0], (*v)[1]};
  }
  return std::nullopt;
}

std::optional<std::string>
applyGeoid(const cli::Args& a, bool configured, planet::RendererOptions& ro) {
  bool on = configured;
  if (auto g = a.get("geoid")) on = *g == "on"; // checked by applyTerrainArgs
  ro.verticalDatum = {};
  if (!on || (ro.elevationLayer.empty() && !a.get("elevation"))) return std::nullopt;
  auto geoid = Geoid::open(dataDir(a) / kGeoidFileName);
  if (!geoid) return geoid.error() + " (renderer.geoid: false or --geoid off draws without it)";
  ro.verticalDatum = VerticalDatum(std::make_shared<const Geoid>(std::move(*geoid)));
  return std::nullopt;
}

} // namespace tellus::commands
