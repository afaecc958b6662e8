#include "GlobeArgs.hpp"

#include "Context.hpp"

#include <tellus/cache/Clock.hpp>
#include <tellus/cli/Values.hpp>
#include <tellus/planet/Geoid.hpp>
#include <tellus/planet/SceneTime.hpp>
#include <tellus/planet/StarCatalogue.hpp>

#include <algorithm>
#include <array>
#include <memory>

namespace tellus::commands {

std::vector<cli::OptionSpec> tileSourceOptions() {
  using K = cli::OptionKind;
  return {{"offline", K::Flag}, {"server", K::Value}, {"geoid", K::Value}, {"body", K::Value}};
}

std::vector<cli::OptionSpec> globeOptions() {
  using K = cli::OptionKind;
  return {{"camera", K::Value},
          {"bodies", K::Value}, // the scene's other bodies (issue 26): render and view only
          {"size", K::Value},
          {"layer", K::Value},
          {"threshold", K::Value},
          {"earth", K::Value},
          {"no-terrain", K::Flag},
          {"no-stars", K::Flag},
          {"no-atmosphere", K::Flag},
          {"no-fade-in", K::Flag},
          {"no-geomorph", K::Flag},
          {"exaggeration", K::Value},
          {"min-relief-px", K::Value},
          {"sun", K::Value},
          {"overlay", K::Value, true},
          {"dome", K::OptionalValue},
          {"dome-tilt", K::Value},
          {"dome-method", K::Value},
          {"time", K::Value},
          {"no-sun", K::Flag},
          {"no-night", K::Flag},
          {"legend", K::Flag},
          {"no-legend", K::Flag},
          {"atmosphere-resolution", K::Value}};
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

std::optional<planet::RendererOptions::Atmosphere> atmosphereOptions(const AtmosphereSettings& s) {
  if (!s.enabled) return std::nullopt;
  planet::RendererOptions::Atmosphere a;
  auto& p = a.parameters;
  const auto vec = [](const std::array<double, 3>& v) { return glm::dvec3(v[0], v[1], v[2]); };
  a.exposure = s.exposure;
  a.resolutionDivisor = s.resolutionDivisor;
  p.bottomRadiusM = s.bottomRadius; // 0: the body's (AtmospherePass)
  p.topAltitudeM = s.topAltitude;
  p.rayleighScattering = vec(s.rayleighScattering);
  p.rayleighScaleHeightM = s.rayleighScaleHeight;
  p.mieScattering = s.mieScattering;
  p.mieExtinction = s.mieExtinction;
  p.mieScaleHeightM = s.mieScaleHeight;
  p.miePhaseG = s.mieG;
  p.ozoneAbsorption = vec(s.ozoneAbsorption);
  p.ozoneCentreM = s.ozoneCentre;
  p.ozoneHalfWidthM = s.ozoneHalfWidth;
  p.sunAngularRadiusRad = s.sunAngularRadius;
  p.solarIrradiance = vec(s.solarIrradiance);
  p.groundAlbedo = vec(s.groundAlbedo);
  p.muSMin = s.minSunCosine;
  return a;
}

void applyRendererSettings(const RendererSettings& g,
                           const cli::Args& a,
                           planet::RendererOptions& ro,
                           EarthModel& earth) {
  earth = g.earth == EarthShape::Sphere ? EarthModel::Sphere : EarthModel::Wgs84;
  if (!a.get("threshold")) ro.lodThreshold = g.lodThreshold;
  ro.meshSize = g.meshSize;
  ro.verticalFovDeg = g.fovDeg;
  ro.overviewLayer = g.overview;
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
  ro.sunlight = g.sunlight && !a.flag("no-sun");
  ro.starMagnitudeLimit = g.stars.magnitudeLimit;
  ro.starBrightness = g.stars.brightness;
  ro.atmosphere = atmosphereOptions(g.atmosphere);
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
  if (a.flag("no-atmosphere")) ro.atmosphere.reset();
  if (auto e = a.get("atmosphere-resolution")) {
    const auto divisor = atmosphereResolutionDivisor(*e);
    if (!divisor) return "--atmosphere-resolution must be full, half or quarter, got '" + *e + "'";
    if (ro.atmosphere) ro.atmosphere->resolutionDivisor = *divisor;
  }
  if (auto e = a.get("sun")) {
    const auto v = cli::parseNumbers(*e, 2, 2);
    if (!v || (*v)[0] < -90.0 || (*v)[0] > 90.0)
      return "--sun must be LAT,LON of the subsolar point, got '" + *e + "'";
    ro.sunLatLon = std::array<double, 2>{(*v)[0], (*v)[1]};
  }
  return std::nullopt;
}

std::optional<std::string> applySceneTime(const cli::Args& a,
                                          const std::string& configured,
                                          std::string_view fallback,
                                          planet::RendererOptions& ro) {
  const bool given = a.get("time").has_value();
  const std::string text = given                ? *a.get("time")
                           : configured.empty() ? std::string(fallback)
                                                : configured;
  const double now = static_cast<double>(unixMillisNow()) / 1000.0;
  const auto t = planet::parseSceneTime(text, now);
  if (!t) return (given ? "--time: " : "renderer.time: ") + t.error();
  ro.timeUnixSeconds = *t;
  return std::nullopt;
}

void hideNightLayers(const cli::Args& a, bool configured, planet::RendererOptions& ro) {
  // Without sunlight there is no night side to show them on: hidden, they are not even fetched.
  if (configured && !a.flag("no-night") && (ro.sunlight || ro.sunLatLon)) return;
  for (planet::LayerOptions& o : ro.overlays)
    if (o.night) o.visible = false;
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

std::optional<std::string>
applyStars(const cli::Args& a, const StarsSettings& configured, planet::RendererOptions& ro) {
  using namespace planet;
  ro.stars.reset();
  if (!configured.enabled || a.flag("no-stars")) return std::nullopt;
  auto catalogue = StarCatalogue::open(dataDir(a) / kStarCatalogueFileName);
  if (!catalogue)
    return catalogue.error() + " (renderer.stars.enabled: false or --no-stars draws without stars)";
  ro.stars = std::make_shared<const StarCatalogue>(std::move(*catalogue));
  return std::nullopt;
}

} // namespace tellus::commands
