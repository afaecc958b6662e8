// The bodies section of the configuration (issue 26, ParseSections.hpp): bodies beside the
// built-in Earth, Moon and Mars, each a name, radii, the IAU rotation elements and an atmosphere
// or none. Checks of values (names, radii) are Validate.cpp's, so validate() makes them too.

#include "ParseSections.hpp"

#include <string>
#include <vector>

namespace tellus::detail::yaml {

namespace {

/** radii: a number (a sphere), [a, c] (biaxial) or [a, b, c] (triaxial). */
std::array<double, 3> readRadii(Reader& r, const YAML::Node& v, const std::string& path) {
  if (v.IsScalar()) {
    const double a = number(r, v, path);
    return {a, a, a};
  }
  const auto items = list(r, v, path);
  if (items.size() == 2) {
    const double a = number(r, items[0], indexPath(path, 0));
    return {a, a, number(r, items[1], indexPath(path, 1))};
  }
  if (items.size() == 3)
    return {number(r, items[0], indexPath(path, 0)),
            number(r, items[1], indexPath(path, 1)),
            number(r, items[2], indexPath(path, 2))};
  r.fail(v.Mark(),
         path,
         "expected a radius, [equatorial, polar] or [a, b, c] in metres, got " +
             std::to_string(items.size()) + " numbers");
  return {};
}

void readRotation(Reader& r, const Map& body, BodyConfig& b) {
  const auto [node, where] = body.child("rotation");
  const Map m(r,
              node,
              body.path("rotation"),
              where,
              {"pole_ra", "pole_ra_rate", "pole_dec", "pole_dec_rate", "prime_meridian", "rate"});
  const auto num = [&](const char* key, double& out) {
    if (auto v = m.get(key)) out = number(r, *v, m.path(key));
  };
  num("pole_ra", b.poleRa);
  num("pole_ra_rate", b.poleRaRate);
  num("pole_dec", b.poleDec);
  num("pole_dec_rate", b.poleDecRate);
  num("prime_meridian", b.primeMeridian);
  num("rate", b.rotationRate);
}

BodyConfig readBody(Reader& r, const YAML::Node& node, const std::string& path) {
  if (!node.IsMap())
    r.fail(node.Mark(), path, "expected a mapping (name, radii, rotation, atmosphere)");
  const Map m(r,
              node,
              path,
              node.Mark(),
              {"name", "radii", "rotation", "atmosphere", "iau_code", "relief_bound"});
  BodyConfig b;
  b.name = text(r, m.need("name"), m.path("name"));
  b.radii = readRadii(r, m.need("radii"), m.path("radii"));
  readRotation(r, m, b);
  if (auto v = m.get("atmosphere")) {
    if (v->IsScalar()) {
      const std::string t = text(r, *v, m.path("atmosphere"));
      if (t != "none")
        r.fail(v->Mark(),
               m.path("atmosphere"),
               "expected 'none' or a mapping of renderer.atmosphere's keys, got '" + t + "'");
    } else {
      AtmosphereSettings a;
      readAtmosphereMap(r, *v, m.path("atmosphere"), v->Mark(), a);
      if (a.enabled) b.atmosphere = a;
    }
  }
  if (auto v = m.get("iau_code"))
    b.iauCode = static_cast<int>(integer(r, *v, m.path("iau_code"), 0, 99999999));
  if (auto v = m.get("relief_bound")) b.reliefBound = number(r, *v, m.path("relief_bound"));
  return b;
}

} // namespace

void readBodies(Reader& r, const Map& root, std::vector<BodyConfig>& out) {
  const auto v = root.get("bodies");
  if (!v) return;
  const auto items = list(r, *v, "bodies");
  for (std::size_t i = 0; i < items.size(); ++i) {
    const std::string p = indexPath("bodies", i);
    r.remember(p, items[i].Mark());
    out.push_back(readBody(r, items[i], p));
  }
}

} // namespace tellus::detail::yaml
