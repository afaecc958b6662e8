// The bodies of a configuration (issue 26): the bodies section, a layer's body and renderer.body,
// and their refusals with file, line and key.

#include <tellus/config/Config.hpp>

#include <gtest/gtest.h>

#include <string>

using namespace tellus;

namespace {

constexpr std::string_view kLayers = R"(upstreams:
  - name: up
    type: wms
    url: http://example.org/wms
layers:
  - name: a
    upstream: up
    format: image/jpeg
    grid:
      levels: 3
  - name: luna
    upstream: up
    format: image/jpeg
    body: moon
    grid:
      levels: 3
)";

std::expected<Config, ConfigError> parse(const std::string& yaml) {
  return parseConfig(yaml, "test.yaml", "/base");
}

ConfigError errorOf(const std::string& yaml) {
  auto c = parse(yaml);
  EXPECT_FALSE(c) << "parsed although it should not:\n" << yaml;
  return c ? ConfigError{} : c.error();
}

} // namespace

TEST(ConfigBodies, LayersSayTheirBodyAndTheRendererItsOwn) {
  const auto c = parse(std::string(kLayers) + "renderer:\n  body: moon\n");
  ASSERT_TRUE(c) << c.error().toString();
  EXPECT_EQ(c->layer("a")->dataset.body, "earth");
  EXPECT_EQ(c->layer("luna")->dataset.body, "moon");
  EXPECT_EQ(c->renderer.body, "moon");
  EXPECT_TRUE(c->knowsBody("mars"));
  EXPECT_FALSE(c->knowsBody("vesta"));
  const auto d = parse(std::string(kLayers));
  ASSERT_TRUE(d);
  EXPECT_EQ(d->renderer.body, "earth");
}

TEST(ConfigBodies, ConfiguredBodiesWithEveryShape) {
  const std::string yaml = std::string(kLayers) + R"(bodies:
  - name: vesta
    radii: [286300, 278600, 223200]
    rotation: {pole_ra: 309.031, pole_dec: 42.235, prime_meridian: 285.39, rate: 1617.3329428}
    iau_code: 200400
    relief_bound: 25000
  - name: ceres
    radii: [482100, 445900]
    atmosphere: none
  - name: titan
    radii: 2575000
    atmosphere:
      top_altitude: 600000
      rayleigh_scale_height: 40000
renderer:
  body: vesta
)";
  const auto c = parse(yaml);
  ASSERT_TRUE(c) << c.error().toString();
  ASSERT_EQ(c->bodies.size(), 3U);
  const BodyConfig* v = c->body("vesta");
  ASSERT_NE(v, nullptr);
  EXPECT_EQ(v->radii, (std::array<double, 3>{286300, 278600, 223200}));
  EXPECT_DOUBLE_EQ(v->poleRa, 309.031);
  EXPECT_DOUBLE_EQ(v->poleDec, 42.235);
  EXPECT_DOUBLE_EQ(v->rotationRate, 1617.3329428);
  EXPECT_EQ(v->iauCode, 200400);
  EXPECT_EQ(v->reliefBound, 25000.0);
  EXPECT_FALSE(v->atmosphere);
  EXPECT_EQ(c->body("ceres")->radii, (std::array<double, 3>{482100, 482100, 445900}));
  EXPECT_FALSE(c->body("ceres")->atmosphere);
  ASSERT_TRUE(c->body("titan")->atmosphere);
  EXPECT_EQ(c->body("titan")->atmosphere->topAltitude, 600000.0);
  EXPECT_EQ(c->renderer.body, "vesta");
}

TEST(ConfigBodies, UnknownBodiesAreRefusedWithFileLineAndKey) {
  std::string yaml(kLayers);
  yaml.replace(yaml.find("body: moon"), 10, "body: pluto");
  const ConfigError e = errorOf(yaml);
  EXPECT_EQ(e.file, "test.yaml");
  EXPECT_EQ(e.line, 14);
  EXPECT_EQ(e.key, "layers[1].body");
  EXPECT_NE(e.message.find("no body named 'pluto'"), std::string::npos) << e.message;
  EXPECT_NE(e.message.find("earth, moon, mars"), std::string::npos) << e.message;

  const ConfigError r = errorOf(std::string(kLayers) + "renderer:\n  body: vesta\n");
  EXPECT_EQ(r.key, "renderer.body");
  EXPECT_EQ(r.line, 18);
  EXPECT_NE(r.message.find("no body named 'vesta'"), std::string::npos) << r.message;
}

TEST(ConfigBodies, BadBodiesAreRefused) {
  const auto bad = [](const std::string& body) {
    return errorOf(std::string(kLayers) + "bodies:\n  - " + body + "\n");
  };
  EXPECT_EQ(bad("name: moon\n    radii: 1000").key, "bodies[0].name");
  EXPECT_NE(bad("name: moon\n    radii: 1000").message.find("built-in"), std::string::npos);
  EXPECT_EQ(bad("name: x\n    radii: [1000, 2000, 900]").key, "bodies[0].radii");
  EXPECT_EQ(bad("name: x\n    radii: -5").key, "bodies[0].radii");
  EXPECT_EQ(bad("name: x\n    radii: [1, 2, 3, 4]").key, "bodies[0].radii");
  EXPECT_EQ(bad("name: x").key, "bodies[0].radii");
  EXPECT_EQ(bad("name: x\n    radii: 1000\n    colour: red").key, "bodies[0].colour");
  EXPECT_EQ(bad("name: x\n    radii: 1000\n    rotation: {spin: 3}").key,
            "bodies[0].rotation.spin");
  EXPECT_EQ(bad("name: x\n    radii: 1000\n    rotation: {pole_dec: 91}").key,
            "bodies[0].rotation.pole_dec");
  EXPECT_EQ(bad("name: x\n    radii: 1000\n    atmosphere: thick").key, "bodies[0].atmosphere");
  EXPECT_EQ(bad("name: x\n    radii: 100000\n    atmosphere: {top_altitude: 200000}").key,
            "bodies[0].atmosphere.top_altitude");
  const ConfigError twice =
      errorOf(std::string(kLayers) + "bodies:\n  - name: x\n    radii: 1000\n  - name: x\n"
                                     "    radii: 1000\n");
  EXPECT_EQ(twice.key, "bodies[1].name");
  EXPECT_GT(twice.line, 0);
}

TEST(ConfigBodies, TheScenesOtherBodiesAreListedAndUnknownOnesRefused) {
  const auto c = parse(std::string(kLayers) + "renderer:\n  body: moon\n  bodies: [earth, moon]\n");
  ASSERT_TRUE(c) << c.error().toString();
  EXPECT_EQ(c->renderer.bodies, (std::vector<std::string>{"earth", "moon"}));
  EXPECT_TRUE(parse(std::string(kLayers))->renderer.bodies.empty());

  const ConfigError e = errorOf(std::string(kLayers) + "renderer:\n  bodies: [moon, pluto]\n");
  EXPECT_EQ(e.key, "renderer.bodies[1]");
  EXPECT_EQ(e.line, 18);
  EXPECT_NE(e.message.find("'pluto' cannot share a scene"), std::string::npos) << e.message;
  // A configured body has no orbit: it can neither join a scene nor be orbited in one.
  const std::string vesta = "bodies:\n  - name: vesta\n    radii: 262700\n";
  EXPECT_EQ(errorOf(std::string(kLayers) + vesta + "renderer:\n  bodies: [vesta]\n").key,
            "renderer.bodies[0]");
  const ConfigError o =
      errorOf(std::string(kLayers) + vesta + "renderer:\n  body: vesta\n  bodies: [moon]\n");
  EXPECT_EQ(o.key, "renderer.bodies");
  EXPECT_NE(o.message.find("no ephemeris"), std::string::npos) << o.message;
}
