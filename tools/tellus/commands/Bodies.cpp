#include "Bodies.hpp"

#include <algorithm>

namespace tellus::commands {

std::expected<std::string, std::string> chooseBody(const cli::Args& a, const Config* config) {
  const std::string name = a.get("body")       ? *a.get("body")
                           : config != nullptr ? config->renderer.body
                                               : std::string("earth");
  const bool known =
      config != nullptr ? config->knowsBody(name) : planet::builtinBody(name).has_value();
  if (known) return name;
  std::string list;
  for (const std::string_view b : kBuiltinBodies)
    list += (list.empty() ? "" : ", ") + std::string(b);
  if (config != nullptr)
    for (const auto& b : config->bodies)
      list += ", " + b.name;
  return std::unexpected("--body must name a body (" + list + "), got '" + name + "'");
}

std::expected<std::vector<std::string>, std::string> chooseSceneBodies(const cli::Args& a,
                                                                       const Config* config) {
  std::vector<std::string> names;
  if (const auto list = a.get("bodies")) {
    std::string rest = *list;
    for (std::size_t at = 0; at <= rest.size();) {
      const std::size_t comma = std::min(rest.find(',', at), rest.size());
      names.push_back(rest.substr(at, comma - at));
      at = comma + 1;
    }
  } else if (config != nullptr) {
    names = config->renderer.bodies;
  }
  for (const std::string& n : names)
    if (n != "earth" && n != "moon" && n != "mars")
      return std::unexpected("--bodies must list earth, moon or mars (the bodies with an "
                             "ephemeris), got '" +
                             n + "'");
  return names;
}

void addSceneBodies(planet::RendererOptions& ro,
                    const std::vector<std::string>& names,
                    const std::filesystem::path& dataDir,
                    EarthModel earth) {
  for (const std::string& n : names) {
    planet::RendererOptions::SceneBody b{resolveBody(n, nullptr, earth), {}, {128, 128, 128}};
    const char* image = n == "earth"  ? "bmng_2048x1024.jpg"
                        : n == "moon" ? "moon_2048x1024.jpg"
                                      : "mars_512x256.jpg";
    if (n == "earth") b.colour = {10, 20, 60};
    if (n == "mars") b.colour = {170, 100, 60};
    if (std::filesystem::exists(dataDir / image)) b.globalImage = dataDir / image;
    ro.sceneBodies.push_back(std::move(b));
  }
}

planet::Body bodyFromConfig(const BodyConfig& c) {
  planet::Body b;
  b.name = c.name;
  b.radiusA = c.radii[0];
  b.radiusB = c.radii[1];
  b.radiusC = c.radii[2];
  b.rotation.poleRaDeg = c.poleRa;
  b.rotation.poleRaDegPerCentury = c.poleRaRate;
  b.rotation.poleDecDeg = c.poleDec;
  b.rotation.poleDecDegPerCentury = c.poleDecRate;
  b.rotation.primeMeridianDeg = c.primeMeridian;
  b.rotation.rotationDegPerDay = c.rotationRate;
  b.iauCrsCode = c.iauCode;
  b.reliefBoundM = c.reliefBound;
  if (c.atmosphere) {
    const AtmosphereSettings& s = *c.atmosphere;
    planet::AtmosphereParameters p;
    p.bottomRadiusM = s.bottomRadius > 0.0 ? s.bottomRadius : c.radii[0];
    p.topAltitudeM = s.topAltitude;
    p.rayleighScattering = {
        s.rayleighScattering[0], s.rayleighScattering[1], s.rayleighScattering[2]};
    p.rayleighScaleHeightM = s.rayleighScaleHeight;
    p.mieScattering = s.mieScattering;
    p.mieExtinction = s.mieExtinction;
    p.mieScaleHeightM = s.mieScaleHeight;
    p.miePhaseG = s.mieG;
    p.ozoneAbsorption = {s.ozoneAbsorption[0], s.ozoneAbsorption[1], s.ozoneAbsorption[2]};
    p.ozoneCentreM = s.ozoneCentre;
    p.ozoneHalfWidthM = s.ozoneHalfWidth;
    p.sunAngularRadiusRad = s.sunAngularRadius;
    p.solarIrradiance = {s.solarIrradiance[0], s.solarIrradiance[1], s.solarIrradiance[2]};
    p.groundAlbedo = {s.groundAlbedo[0], s.groundAlbedo[1], s.groundAlbedo[2]};
    p.muSMin = s.minSunCosine;
    b.atmosphere = p;
  }
  return b;
}

planet::Body resolveBody(const std::string& name, const Config* config, EarthModel earth) {
  if (name == "earth")
    return earth == EarthModel::Sphere ? planet::earthSphereBody() : planet::earthBody();
  if (auto b = planet::builtinBody(name)) return *b;
  if (config != nullptr)
    if (const BodyConfig* c = config->body(name)) return bodyFromConfig(*c);
  return planet::earthBody(); // chooseBody refused any other name
}

std::optional<DatasetSpec> BareLayerSource::describe(std::string_view layer,
                                                     std::string_view time) const {
  if (layer != kBareLayer) return inner_.describe(layer, time);
  DatasetSpec s;
  s.name = kBareLayer;
  s.server = "tellus";
  s.grid.levelZeroDeltaDeg = 36.0;
  s.grid.numLevels = 1;
  s.grid.tileWidth = s.grid.tileHeight = 512;
  s.mimeType = "image/jpeg";
  s.extension = "jpg";
  return s;
}

TileRequestId BareLayerSource::request(const TileAddress& address, double priority, Callback done) {
  if (address.layer != kBareLayer) return inner_.request(address, priority, std::move(done));
  TileResult r;
  r.status = TileStatus::Absent;
  done(std::move(r));
  return nextBare_++;
}

void BareLayerSource::reprioritize(TileRequestId id, double priority) {
  if (id < (TileRequestId{1} << 62)) inner_.reprioritize(id, priority);
}

bool BareLayerSource::cancel(TileRequestId id) {
  return id < (TileRequestId{1} << 62) ? inner_.cancel(id) : false;
}

} // namespace tellus::commands
