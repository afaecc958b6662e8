#include <tellus/planet/Body.hpp>

#include <cmath>

namespace tellus::planet {

namespace {

bool positiveFinite(double v) {
  return std::isfinite(v) && v > 0.0;
}

} // namespace

std::string Body::validate() const {
  if (name.empty()) return "a body needs a name";
  if (!positiveFinite(radiusA) || !positiveFinite(radiusB) || !positiveFinite(radiusC))
    return "body '" + name + "': its radii must be finite and positive";
  if (!(reliefBoundM >= 0.0 && std::isfinite(reliefBoundM)))
    return "body '" + name + "': its relief bound must be finite and >= 0";
  if (radiusB > radiusA)
    return "body '" + name + "': radius b (" + std::to_string(radiusB) +
           " m) must not exceed radius a (" + std::to_string(radiusA) + " m)";
  if (atmosphere) {
    const std::string e = atmosphere->validate();
    if (!e.empty()) return "body '" + name + "': atmosphere: " + e;
  }
  return "";
}

Body earthBody() {
  Body b;
  b.name = "earth";
  b.radiusA = b.radiusB = 6378137.0;
  b.radiusC = 6378137.0 * (1.0 - 1.0 / 298.257223563);
  b.rotation = iauEarth();
  b.atmosphere = AtmosphereParameters{};
  b.atmosphere->bottomRadiusM = b.radiusA;
  return b;
}

Body earthSphereBody() {
  Body b = earthBody();
  b.radiusA = b.radiusB = b.radiusC = 6371008.8; // IUGG mean radius R1
  b.atmosphere->bottomRadiusM = b.radiusA;
  return b;
}

Body moonBody() {
  Body b;
  b.name = "moon";
  b.radiusA = b.radiusB = b.radiusC = 1737400.0;
  b.rotation = iauMoon();
  b.iauCrsCode = 30100;
  return b;
}

AtmosphereParameters marsAtmosphere() {
  AtmosphereParameters p;
  p.bottomRadiusM = 3396190.0;
  p.topAltitudeM = 3463174.95 - 3386190.0;                         // 76.98 km
  p.rayleighScattering = glm::dvec3{19.918e-6, 13.57e-6, 5.75e-6}; // 1/m at 680, 550, 440 nm
  p.rayleighScaleHeightM = 10439.85;
  p.mieScattering = 53.61771e-6;
  p.mieExtinction = 53.61771e-6 / 0.98979;
  p.mieScaleHeightM = 3099.55;
  p.miePhaseG = 0.85;
  p.ozoneAbsorption = glm::dvec3{0.0};
  constexpr double kInverseSquareAu = 1.0 / (1.524 * 1.524);
  p.solarIrradiance = AtmosphereParameters{}.solarIrradiance * kInverseSquareAu;
  p.sunAngularRadiusRad = AtmosphereParameters{}.sunAngularRadiusRad / 1.524;
  p.groundAlbedo = glm::dvec3{0.25, 0.15, 0.1};
  return p;
}

Body marsBody() {
  Body b;
  b.name = "mars";
  b.radiusA = b.radiusB = 3396190.0;
  b.radiusC = 3376200.0;
  b.rotation = iauMars();
  b.atmosphere = marsAtmosphere();
  b.iauCrsCode = 49900;
  b.reliefBoundM = 26000.0;
  return b;
}

std::optional<Body> builtinBody(std::string_view name) {
  if (name == "earth") return earthBody();
  if (name == "moon") return moonBody();
  if (name == "mars") return marsBody();
  return std::nullopt;
}

std::vector<std::string> builtinBodyNames() {
  return {"earth", "moon", "mars"};
}

} // namespace tellus::planet
