// The renderer section of the configuration: LOD, terrain, layers, dome, stars (ParseSections.hpp).

#include "ParseSections.hpp"

#include <array>
#include <string>
#include <vector>

namespace tellus::detail::yaml {

namespace {

/** The strings of a list of names (null: none), appended to out. */
void readNames(Reader& r,
               const YAML::Node& node,
               const std::string& path,
               std::vector<std::string>& out) {
  const auto items = list(r, node, path);
  for (std::size_t i = 0; i < items.size(); ++i)
    out.push_back(text(r, items[i], indexPath(path, i)));
}

/** renderer.terrain: the elevation layer, its regional ones, exaggeration, sun. */
void readTerrain(Reader& r, const Map& renderer, TerrainSettings& ts) {
  const auto [tnode, twhere] = renderer.child("terrain");
  const Map t(
      r,
      tnode,
      renderer.path("terrain"),
      twhere,
      {"enabled", "layer", "exaggeration", "clearance", "sun", "regional", "min_relief_px"});
  if (auto v = t.get("enabled")) ts.enabled = boolean(r, *v, t.path("enabled"));
  if (auto v = t.get("layer")) ts.layer = text(r, *v, t.path("layer"));
  if (auto v = t.get("exaggeration")) ts.exaggeration = number(r, *v, t.path("exaggeration"));
  if (auto v = t.get("clearance")) ts.clearanceM = number(r, *v, t.path("clearance"));
  if (auto v = t.get("min_relief_px")) ts.minReliefPx = number(r, *v, t.path("min_relief_px"));
  if (auto v = t.get("sun")) {
    const std::string sp = t.path("sun");
    const auto items = list(r, *v, sp);
    if (items.size() != 2)
      r.fail(v->Mark(), sp, "expected 2 numbers [lat, lon], got " + std::to_string(items.size()));
    ts.sun = std::array<double, 2>{number(r, items[0], indexPath(sp, 0)),
                                   number(r, items[1], indexPath(sp, 1))};
  }
  if (auto v = t.get("regional")) readNames(r, *v, t.path("regional"), ts.regional);
}

/** One entry of renderer.layers, at path ip. */
RenderLayerSettings readRenderLayer(Reader& r, const YAML::Node& item, const std::string& ip) {
  const Map e(r,
              item,
              ip,
              item.Mark(),
              {"layer",
               "regional",
               "opacity",
               "visible",
               "max_level",
               "time",
               "night",
               "colour_map",
               "range"});
  RenderLayerSettings l;
  if (auto x = e.get("layer"))
    l.layer = text(r, *x, e.path("layer"));
  else
    r.fail(item.Mark(), ip, "needs 'layer' (an imagery layer's name)");
  if (auto x = e.get("regional")) readNames(r, *x, e.path("regional"), l.regional);
  if (auto x = e.get("opacity")) l.opacity = number(r, *x, e.path("opacity"));
  if (auto x = e.get("visible")) l.visible = boolean(r, *x, e.path("visible"));
  if (auto x = e.get("max_level")) l.maxLevel = int32(r, *x, e.path("max_level"));
  if (auto x = e.get("time")) l.time = text(r, *x, e.path("time"));
  if (auto x = e.get("night")) l.night = boolean(r, *x, e.path("night"));
  if (auto x = e.get("colour_map")) l.colourMap = text(r, *x, e.path("colour_map"));
  if (auto x = e.get("range")) {
    const auto items = list(r, *x, e.path("range"));
    if (items.size() != 2)
      r.fail(x->Mark(),
             e.path("range"),
             "expected [min, max], got " + std::to_string(items.size()) + " items");
    else
      l.range = std::array<double, 2>{number(r, items[0], indexPath(e.path("range"), 0)),
                                      number(r, items[1], indexPath(e.path("range"), 1))};
  }
  return l;
}

/** renderer.dome: the fisheye's angle, tilt and method. */
void readDome(Reader& r, const Map& renderer, DomeSettings& dome) {
  const auto [dnode, dwhere] = renderer.child("dome");
  const Map d(r,
              dnode,
              renderer.path("dome"),
              dwhere,
              {"enabled", "fov", "tilt", "face_scale", "method", "direct_max_error"});
  if (auto v = d.get("enabled")) dome.enabled = boolean(r, *v, d.path("enabled"));
  if (auto v = d.get("fov")) dome.fovDeg = number(r, *v, d.path("fov"));
  if (auto v = d.get("tilt")) dome.tiltDeg = number(r, *v, d.path("tilt"));
  if (auto v = d.get("face_scale")) dome.faceScale = number(r, *v, d.path("face_scale"));
  if (auto v = d.get("method"))
    dome.method = choice(r, *v, d.path("method"), {"direct", "cube"}) == 0
                      ? DomeSettings::Method::Direct
                      : DomeSettings::Method::Cube;
  if (auto v = d.get("direct_max_error"))
    dome.directMaxErrorPx = number(r, *v, d.path("direct_max_error"));
}

/** renderer.stars: the star background. */
void readStars(Reader& r, const Map& renderer, StarsSettings& stars) {
  const auto [snode, swhere] = renderer.child("stars");
  const Map s(
      r, snode, renderer.path("stars"), swhere, {"enabled", "magnitude_limit", "brightness"});
  if (auto v = s.get("enabled")) stars.enabled = boolean(r, *v, s.path("enabled"));
  if (auto v = s.get("magnitude_limit"))
    stars.magnitudeLimit = number(r, *v, s.path("magnitude_limit"));
  if (auto v = s.get("brightness")) stars.brightness = number(r, *v, s.path("brightness"));
}

/** Three numbers (R, G, B) at path. */
std::array<double, 3> triple(Reader& r, const YAML::Node& v, const std::string& path) {
  const auto items = list(r, v, path);
  if (items.size() != 3)
    r.fail(v.Mark(), path, "expected 3 numbers [r, g, b], got " + std::to_string(items.size()));
  std::array<double, 3> out{};
  for (std::size_t i = 0; i < 3 && i < items.size(); ++i)
    out[i] = number(r, items[i], indexPath(path, i));
  return out;
}

} // namespace

/** renderer.atmosphere (and bodies[i].atmosphere): on or off, the exposure, the resolution, the
 * physical parameters. */
void readAtmosphereMap(Reader& r,
                       const YAML::Node& anode,
                       const std::string& path,
                       const YAML::Mark& awhere,
                       AtmosphereSettings& a) {
  const Map m(r,
              anode,
              path,
              awhere,
              {"enabled",
               "exposure",
               "resolution",
               "bottom_radius",
               "top_altitude",
               "rayleigh_scattering",
               "rayleigh_scale_height",
               "mie_scattering",
               "mie_extinction",
               "mie_scale_height",
               "mie_g",
               "ozone_absorption",
               "ozone_centre",
               "ozone_half_width",
               "sun_angular_radius",
               "solar_irradiance",
               "ground_albedo",
               "min_sun_cosine"});
  const auto num = [&](const char* key, double& out) {
    if (auto v = m.get(key)) out = number(r, *v, m.path(key));
  };
  const auto rgb = [&](const char* key, std::array<double, 3>& out) {
    if (auto v = m.get(key)) out = triple(r, *v, m.path(key));
  };
  if (auto v = m.get("enabled")) a.enabled = boolean(r, *v, m.path("enabled"));
  num("exposure", a.exposure);
  if (auto v = m.get("resolution")) {
    const std::string res = text(r, *v, m.path("resolution"));
    const auto divisor = atmosphereResolutionDivisor(res);
    if (divisor)
      a.resolutionDivisor = *divisor;
    else
      r.fail(v->Mark(), m.path("resolution"), "must be full, half or quarter, got '" + res + "'");
  }
  num("bottom_radius", a.bottomRadius);
  num("top_altitude", a.topAltitude);
  rgb("rayleigh_scattering", a.rayleighScattering);
  num("rayleigh_scale_height", a.rayleighScaleHeight);
  num("mie_scattering", a.mieScattering);
  num("mie_extinction", a.mieExtinction);
  num("mie_scale_height", a.mieScaleHeight);
  num("mie_g", a.mieG);
  rgb("ozone_absorption", a.ozoneAbsorption);
  num("ozone_centre", a.ozoneCentre);
  num("ozone_half_width", a.ozoneHalfWidth);
  num("sun_angular_radius", a.sunAngularRadius);
  rgb("solar_irradiance", a.solarIrradiance);
  rgb("ground_albedo", a.groundAlbedo);
  num("min_sun_cosine", a.minSunCosine);
}

namespace {

void readAtmosphere(Reader& r, const Map& renderer, AtmosphereSettings& a) {
  const auto [anode, awhere] = renderer.child("atmosphere");
  readAtmosphereMap(r, anode, renderer.path("atmosphere"), awhere, a);
}

} // namespace

void readRenderer(Reader& r, const Map& root, RendererSettings& g) {
  const auto [node, where] = root.child("renderer");
  const Map m(r,
              node,
              root.path("renderer"),
              where,
              {"lod_threshold",
               "mesh_size",
               "fov",
               "texture_budget",
               "upload_per_frame",
               "max_in_flight",
               "max_splits_per_frame",
               "decode_threads",
               "terrain",
               "dome",
               "stars",
               "atmosphere",
               "earth",
               "body",
               "bodies",
               "geoid",
               "layers",
               "overlays_per_pass",
               "time",
               "sunlight",
               "night",
               "fade_in",
               "geomorph",
               "legend",
               "overview"});
  if (auto v = m.get("lod_threshold")) g.lodThreshold = number(r, *v, m.path("lod_threshold"));
  if (auto v = m.get("mesh_size")) g.meshSize = int32(r, *v, m.path("mesh_size"));
  if (auto v = m.get("fov")) g.fovDeg = number(r, *v, m.path("fov"));
  if (auto v = m.get("texture_budget")) g.textureBudget = size(r, *v, m.path("texture_budget"));
  if (auto v = m.get("upload_per_frame"))
    g.uploadPerFrame = size(r, *v, m.path("upload_per_frame"));
  if (auto v = m.get("max_in_flight")) g.maxInFlight = int32(r, *v, m.path("max_in_flight"));
  if (auto v = m.get("max_splits_per_frame"))
    g.maxSplitsPerFrame = int32(r, *v, m.path("max_splits_per_frame"));
  if (auto v = m.get("decode_threads")) g.decodeThreads = int32(r, *v, m.path("decode_threads"));
  readTerrain(r, m, g.terrain);
  if (auto v = m.get("layers")) {
    const std::string lp = m.path("layers");
    const auto items = list(r, *v, lp);
    for (std::size_t i = 0; i < items.size(); ++i)
      g.layers.push_back(readRenderLayer(r, items[i], indexPath(lp, i)));
  }
  readDome(r, m, g.dome);
  readStars(r, m, g.stars);
  readAtmosphere(r, m, g.atmosphere);
  if (auto v = m.get("earth"))
    g.earth = choice(r, *v, m.path("earth"), {"wgs84", "sphere"}) == 0 ? EarthShape::Wgs84
                                                                       : EarthShape::Sphere;
  if (auto v = m.get("body")) g.body = text(r, *v, m.path("body"));
  if (auto v = m.get("bodies")) readNames(r, *v, m.path("bodies"), g.bodies);
  if (auto v = m.get("overview")) g.overview = text(r, *v, m.path("overview"));
  if (auto v = m.get("geoid")) g.geoid = boolean(r, *v, m.path("geoid"));
  if (auto v = m.get("overlays_per_pass"))
    g.overlaysPerPass = int32(r, *v, m.path("overlays_per_pass"));
  if (auto v = m.get("time")) g.time = text(r, *v, m.path("time"));
  if (auto v = m.get("sunlight")) g.sunlight = boolean(r, *v, m.path("sunlight"));
  if (auto v = m.get("night")) g.night = boolean(r, *v, m.path("night"));
  if (auto v = m.get("fade_in")) g.fadeInS = number(r, *v, m.path("fade_in"));
  if (auto v = m.get("geomorph")) g.geomorph = boolean(r, *v, m.path("geomorph"));
  if (auto v = m.get("legend")) g.legend = boolean(r, *v, m.path("legend"));
}

} // namespace tellus::detail::yaml
